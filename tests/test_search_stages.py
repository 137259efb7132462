"""Each stage of the search (``table``, ``body``, ``fingers``, ``holdings``) and the
pipeline of them give the loop-by-loop reference's verdicts, for hands of 1 to 6
fingers, random frames, orientations, depths, object sizes and sphere sets, with
every kernel; and the kernels' parts (slabs, the compiled loops, their grids,
chunking) hold to what they promise."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import box_object, make_jaw_gripper
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation
from search_kernels import KERNELS, force, loops

from wsgrasp.geometry import coordinates_in_superellipsoids, transform_points
from wsgrasp.planning import _compiled, kernels, poses
from wsgrasp.planning._grids import FingerDepth, NearestPoint
from wsgrasp.planning.body import Slabs, _slab_hits, body_verdicts
from wsgrasp.planning.candidates import candidate_poses
from wsgrasp.planning.evaluate import FingerSpheres, TableSE, evaluate_candidates
from wsgrasp.planning.fingers import _Fingers, finger_verdicts
from wsgrasp.planning.holdings import feasible_holdings
from wsgrasp.planning.kernels import Kernels
from wsgrasp.planning.poses import (
    CandidateStructure,
    StructuredPoses,
    orientation_spans,
)
from wsgrasp.planning.reference import reference_search
from wsgrasp.planning.table import _bounds, _cloud_hull, _exact, table_verdicts

#: a scene frame: rotation vector and translation
ROTVEC = st.tuples(*[st.floats(-3.0, 3.0)] * 3)
SHIFT = st.tuples(*[st.floats(-2.0, 2.0)] * 3)
SETTINGS = settings(
    max_examples=25,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
#: a stage's kernels: numpy's, and the compiled loops as a small and a dense
#: search run them
STAGE_KERNELS = {
    "numpy": Kernels(False, False),
    "compiled": Kernels(True, False),
    "compiled_dense": Kernels(True, True),
}


def _hand(seed: int, fingers: int = 2, spheres: int = 10):
    """The jaw gripper with ``fingers`` fingers of ``spheres`` random spheres each,
    3-30 mm, around the fingertips: small jaw pads to Allegro-sized workspaces."""
    from dataclasses import replace

    g = make_jaw_gripper(seed=seed)
    rng = np.random.default_rng(seed)
    n = fingers * spheres
    centers = rng.uniform([-0.03, -0.06, 0.05], [0.03, 0.06, 0.14], (n, 3))
    radii = rng.uniform(0.003, 0.03, n)
    finger = np.repeat(np.arange(fingers), spheres).astype(np.int64)
    return replace(
        g,
        sphere_centers=centers,
        sphere_radii=radii,
        sphere_finger=finger,
        finger_names=[f"f{i}" for i in range(fingers)],
    )


def _frame(rotvec, shift) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(rotvec).as_matrix()
    T[:3, 3] = shift
    return T


def _scene(
    seed: int, T_world_scene: np.ndarray, n_orient: int, obstacles: bool, n: int = 300
):
    """A box on a table, samples in its box, random orientations and depths; the
    object sits low so that many candidates reach the table."""
    rng = np.random.default_rng(seed)
    size = rng.uniform([0.02, 0.02, 0.03], [0.09, 0.09, 0.2])
    obj = box_object(size, n, seed)
    obj[:, 2] -= obj[:, 2].min() - rng.uniform(0.0, 0.02)
    T_scene_object = np.eye(4)
    T_scene_object[:3, :3] = Rotation.from_rotvec(rng.normal(0, 0.3, 3)).as_matrix()
    T_scene_object[:3, 3] = obj.mean(axis=0)
    samples = rng.uniform(-size / 2, size / 2, (int(rng.integers(1, 25)), 3))
    R = Rotation.random(n_orient, random_state=seed).as_matrix().reshape(-1, 3, 3)
    depth = rng.uniform(-0.04, 0.03, len(R)) if seed % 2 else None
    obs = (
        box_object([0.04, 0.04, 0.1], 120, seed + 1) + [size[0] / 2 + 0.05, 0, 0.05]
        if obstacles
        else np.zeros((0, 3))
    )
    table = TableSE(
        T_world_scene,
        np.array([0.0, 0.0, -0.05]),
        np.array([0.35, 0.35, 0.05]) * rng.uniform(0.2, 1.0),
        10.0,
    )
    return (
        transform_points(T_world_scene, obj),
        T_world_scene @ T_scene_object,
        samples,
        R,
        depth,
        transform_points(T_world_scene, obs),
        table,
    )


def _case(seed, rotvec, shift, n_orient, fingers, spheres, n_points):
    """A hand of ``fingers`` fingers, a scene in a random frame, the reference's
    verdicts and the poses: what the stage tests compare."""
    g = _hand(seed, fingers, spheres)
    obj, T_wo, samples, R, depth, obs, table = _scene(
        seed, _frame(rotvec, shift), n_orient, bool(seed % 3 == 0), n_points
    )
    ref = reference_search(g, T_wo, samples, R, obj, obs, table, depth)
    p = StructuredPoses.build(
        CandidateStructure(T_wo, samples, R, depth), g.T_gripper_gwc
    )
    return g, obj, obs, table, ref, p


def _held_truth(g, T_world_gripper, points):
    """Every point against every sphere, per candidate: (C, no, nf) bool."""
    out = np.zeros((len(T_world_gripper), len(points), g.num_fingers), dtype=bool)
    for c, T in enumerate(T_world_gripper):
        p = (points - T[:3, 3]) @ T[:3, :3]  # (no, 3) gripper frame
        d2 = ((p[:, None, :] - g.sphere_centers[None]) ** 2).sum(-1)  # (no, S)
        inside = d2 < g.sphere_radii**2
        for f in range(g.num_fingers):
            out[c, :, f] = inside[:, g.sphere_finger == f].any(axis=1)
    return out


@pytest.fixture
def compiled_loops(monkeypatch):
    """The compiled loops as :func:`search_kernels.loops` gives them."""
    count, body = loops()[-1]
    monkeypatch.setattr(_compiled, "_AVAILABLE", True)
    monkeypatch.setattr(_compiled, "_compiled_count", count)
    monkeypatch.setattr(_compiled, "_compiled_body", body)


STAGE_CASE = {
    "seed": st.integers(0, 10_000),
    "rotvec": ROTVEC,
    "shift": SHIFT,
    "n_orient": st.integers(1, 8),
    "fingers": st.integers(1, 6),
    "spheres": st.integers(1, 20),
    "n_points": st.integers(20, 400),
}


@SETTINGS
@given(**STAGE_CASE)
def test_table_stage_is_the_reference(
    seed, rotvec, shift, n_orient, fingers, spheres, n_points
):
    g, _, _, table, ref, p = _case(
        seed, rotvec, shift, n_orient, fingers, spheres, n_points
    )
    np.testing.assert_array_equal(table_verdicts(p, g, table).hit, ref.reason == 1)


@pytest.mark.usefixtures("compiled_loops")
@pytest.mark.parametrize("kernel", list(STAGE_KERNELS))
@SETTINGS
@given(**STAGE_CASE)
def test_body_stage_is_the_reference(
    kernel, seed, rotvec, shift, n_orient, fingers, spheres, n_points
):
    g, obj, obs, table, ref, p = _case(
        seed, rotvec, shift, n_orient, fingers, spheres, n_points
    )
    alive = np.flatnonzero(ref.reason != 1)
    got = body_verdicts(p, alive, g, obj, obs, STAGE_KERNELS[kernel])
    want = np.where(np.isin(ref.reason[alive], [2, 3]), ref.reason[alive], 0)
    np.testing.assert_array_equal(got, want)


@pytest.mark.usefixtures("compiled_loops")
@pytest.mark.parametrize("kernel", list(STAGE_KERNELS))
@SETTINGS
@given(**STAGE_CASE)
def test_finger_and_holdings_stages_are_the_reference(
    kernel, seed, rotvec, shift, n_orient, fingers, spheres, n_points
):
    """Counts per finger, and the holdings of the feasible ones: kept, or
    computed when read."""
    g, obj, _, _, ref, p = _case(
        seed, rotvec, shift, n_orient, fingers, spheres, n_points
    )
    live = np.flatnonzero(np.isin(ref.reason, [0, 4]))
    v = finger_verdicts(p, live, g, FingerSpheres(g), obj, STAGE_KERNELS[kernel])
    np.testing.assert_array_equal(v.counts, ref.contacts[live])
    ok = np.flatnonzero(ref.reason[live] == 0)
    truth = _held_truth(g, p.transforms(live[ok]), obj)
    np.testing.assert_array_equal(feasible_holdings(v, ok).dense(), truth)
    v.held = None  # as when too many to keep: computed when read
    np.testing.assert_array_equal(feasible_holdings(v, ok).dense(), truth)


@pytest.mark.parametrize("kernel", KERNELS)
@SETTINGS
@given(
    seed=st.integers(0, 10_000),
    rotvec=ROTVEC,
    shift=SHIFT,
    n_orient=st.integers(1, 12),
    fingers=st.integers(1, 6),
)
def test_pipeline_is_the_reference(kernel, seed, rotvec, shift, n_orient, fingers):
    """Reasons, contacts, the feasible set and their holdings, through the
    whole evaluation, and for the same poses given one by one."""
    with pytest.MonkeyPatch.context() as mp:
        force(mp, kernel)
        g = _hand(seed, fingers, 1 + seed % 20) if seed % 4 else make_jaw_gripper()
        obj, T_wo, samples, R, depth, obs, table = _scene(
            seed, _frame(rotvec, shift), n_orient, bool(seed % 3 == 0)
        )
        _, T_wg, _, _ = candidate_poses(T_wo, samples, R, g.T_gripper_gwc, depth)
        structure = CandidateStructure(T_wo, samples, R, depth)
        ev = evaluate_candidates(T_wg, g, obj, obs, table, structure=structure)
        one_by_one = evaluate_candidates(T_wg, g, obj, obs, table)
        holding = ev.holding
    ref = reference_search(g, T_wo, samples, R, obj, obs, table, depth)
    for got in (ev, one_by_one):
        np.testing.assert_array_equal(got.reason, ref.reason)
        np.testing.assert_array_equal(got.contacts, ref.contacts)
        np.testing.assert_array_equal(got.feasible, np.flatnonzero(ref.reason == 0))
    np.testing.assert_array_equal(holding, _held_truth(g, T_wg[ev.feasible], obj))
    np.testing.assert_array_equal(one_by_one.holding, holding)


def test_structure_that_does_not_match_is_refused(jaw_gripper):
    obj, T_wo, samples, R, depth, obs, table = _scene(1, np.eye(4), 4, False)
    _, T_wg, _, _ = candidate_poses(T_wo, samples, R, jaw_gripper.T_gripper_gwc)
    wrong = CandidateStructure(T_wo, samples + 0.01, R, None)
    with pytest.raises(ValueError, match="does not match"):
        evaluate_candidates(T_wg, jaw_gripper, obj, obs, table, structure=wrong)


@pytest.mark.parametrize("ns, n_orient", [(0, 4), (5, 0), (0, 0)], ids=str)
def test_no_candidates(jaw_gripper, ns, n_orient):
    obj, T_wo, samples, R, _, obs, table = _scene(2, np.eye(4), max(n_orient, 1), False)
    samples, R = samples[:ns] if ns else samples[:0], R[:n_orient]
    _, T_wg, _, _ = candidate_poses(T_wo, samples, R, jaw_gripper.T_gripper_gwc)
    ev = evaluate_candidates(
        T_wg,
        jaw_gripper,
        obj,
        obs,
        table,
        structure=CandidateStructure(T_wo, samples, R, None),
    )
    assert ev.reason.shape == (0,) and ev.feasible.shape == (0,)


def _table_truth(T_world_gripper, cloud, table):
    """Brute force: every cloud point of every candidate, eq. (1)."""
    T = np.linalg.inv(table.T_world_table) @ T_world_gripper
    p = np.einsum("cij,nj->cni", T[:, :3, :3], cloud) + T[:, None, :3, 3]
    d = np.abs(p - table.center) / table.semi_axes
    v = d[..., 0] ** table.exponent + d[..., 1] ** table.exponent + d[..., 2] ** 2
    return (v < 1.0).any(axis=1)


@SETTINGS
@given(seed=st.integers(0, 10_000), rotvec=ROTVEC, shift=SHIFT, n=st.integers(1, 40))
def test_table_bounds_never_contradict_the_cloud(seed, rotvec, shift, n):
    """A bound's "hit" is a hit and its "clear" is clear, point by point; the
    lowest heights are the cloud's lowest points, to rounding."""
    g = make_jaw_gripper(spheres_per_finger=1 + seed % 12)
    obj, T_wo, samples, R, depth, _, table = _scene(seed, _frame(rotvec, shift), n, 0)
    _, T_wg, _, _ = candidate_poses(T_wo, samples, R, g.T_gripper_gwc, depth)
    p = StructuredPoses.build(
        CandidateStructure(T_wo, samples, R, depth), g.T_gripper_gwc
    )
    np.testing.assert_allclose(p.transforms(np.arange(len(T_wg))), T_wg, atol=1e-12)
    hit, unsure = _bounds(p, _cloud_hull(g), table)
    truth = _table_truth(T_wg, g.cloud, table)
    assert not np.any(hit & unsure)
    np.testing.assert_array_equal(truth[~unsure], hit[~unsure])
    everything = np.arange(len(T_wg))
    np.testing.assert_array_equal(_exact(p, g.cloud, table, everything), truth)
    low = table_verdicts(p, g, table).lowest_heights(everything)
    T = np.linalg.inv(table.T_world_table) @ T_wg
    z = np.einsum("cj,nj->cn", T[:, 2, :3], g.cloud) + T[:, 2, 3][:, None]
    np.testing.assert_allclose(low, z.min(axis=1), rtol=0, atol=1e-12)


def test_table_memory_stays_bounded_for_a_million_candidates():
    """The table stage's peak for 1,000 samples × 1,000 orientations: its chunks,
    not the candidate count, set it (two (C,) masks are the output)."""
    import tracemalloc

    g = make_jaw_gripper()
    obj, T_wo, _, _, _, _, table = _scene(3, np.eye(4), 1, False)
    rng = np.random.default_rng(0)
    samples = rng.uniform(-0.03, 0.03, (1000, 3))
    R = Rotation.random(1000, random_state=0).as_matrix()
    structure = CandidateStructure(T_wo, samples, R, rng.uniform(-0.02, 0.02, 1000))
    tracemalloc.start()
    try:
        p = StructuredPoses.build(structure, g.T_gripper_gwc)
        hit, unsure = _bounds(p, _cloud_hull(g), table)
        _exact(p, g.cloud, table, np.flatnonzero(unsure)[:20_000])
        peak = tracemalloc.get_traced_memory()[1] / 2**20
    finally:
        tracemalloc.stop()
    assert structure.num_candidates == len(hit) == 1_000_000
    # outputs: 2 MB of masks; a chunk of 262,144 candidates: about 45 MB
    assert peak < 80, f"peak {peak:.0f} MiB"


@pytest.mark.slow
def test_memory_bound_of_the_whole_evaluation_for_a_million_candidates():
    """Beyond its inputs and the feasible candidates' holdings (F × no × nf
    bools, part of the answer), the evaluation of a million candidates needs
    chunks only."""
    import tracemalloc

    g = make_jaw_gripper()
    obj, T_wo, _, _, _, _, table = _scene(5, np.eye(4), 1, False)
    rng = np.random.default_rng(1)
    samples = rng.uniform(-0.03, 0.03, (1000, 3))
    R = Rotation.random(1000, random_state=1).as_matrix()
    _, T_wg, _, _ = candidate_poses(T_wo, samples, R, g.T_gripper_gwc)
    structure = CandidateStructure(T_wo, samples, R, None)
    tracemalloc.start()
    try:
        ev = evaluate_candidates(
            T_wg, g, obj, np.zeros((0, 3)), table, structure=structure
        )
        peak = tracemalloc.get_traced_memory()[1] / 2**20
    finally:
        tracemalloc.stop()
    assert len(ev.reason) == 1_000_000
    answer = (ev.holding.nbytes + ev.reason.nbytes + ev.contacts.nbytes) / 2**20
    assert peak - answer < 200, f"peak {peak:.0f} MiB, answer {answer:.0f} MiB"


def _rows(seed: int, q: int, n: int):
    """Points per orientation in gripper axes (q, 3, n) and candidates: a row of
    them each and a translation."""
    rng = np.random.default_rng(seed)
    Q = rng.uniform(-0.12, 0.12, (q, 3, n))
    m = int(rng.integers(1, 40))
    ol = rng.integers(0, q, m)
    u = rng.uniform(-0.08, 0.08, (m, 3))
    return Q, ol, u


@SETTINGS
@given(
    seed=st.integers(0, 10_000),
    q=st.integers(1, 6),
    n=st.integers(0, 300),
    k=st.integers(0, 2),
    lo=st.floats(-0.1, 0.1),
    width=st.floats(0.0, 0.1),
    offset=st.sampled_from([0.0, 0.0, 1.5, -3.0, 10.0]),
)
def test_slab_pairs_are_exactly_the_points_in_the_slab(
    seed, q, n, k, lo, width, offset
):
    """Every point in the slab comes back once; a point outside it only within
    the 1e-7 m widening. Also with the points and the candidates far from the
    origin of the gripper axes (an object metres from the world origin)."""
    Q, ol, u = _rows(seed, q, n)
    Q, u = Q + offset, u + offset
    pair, j, r = Slabs(Q).pairs(ol, u[:, k], k, lo, lo + width)
    assert np.all(r == ol[pair])
    got = np.zeros((len(ol), n), dtype=bool)
    got[pair, j] = True
    assert len(pair) == got.sum()  # no pair twice
    coord = Q[ol, k, :] - u[:, k, None]  # (m, n)
    inside = (coord >= lo) & (coord <= lo + width)
    assert np.all(got[inside])
    near = (coord >= lo - 2e-7) & (coord <= lo + width + 2e-7)
    assert np.all(near[got])


@SETTINGS
@given(
    seed=st.integers(0, 10_000),
    q=st.integers(1, 5),
    n=st.integers(1, 200),
    spheres=st.integers(1, 12),
    fingers=st.integers(1, 6),
)
def test_numpy_slab_kernels_match_every_point(seed, q, n, spheres, fingers):
    """numpy's body kernel on slabs, and its finger kernel in chunks, give what
    testing every point at once gives."""
    g = _hand(seed, fingers, spheres)
    Q, ol, u = _rows(seed, q, n)
    Q *= 0.7  # points among the gripper's bodies and spheres
    Q[:, 2] += 0.06
    cand = np.arange(len(ol))
    xyz = [Q[ol, i] - u[:, i, None] for i in range(3)]  # 3 × (m, n)
    se = (g.se_centers, g.se_semi_axes, g.se_exponent)
    few = Q[:, :, : max(1, n // 10)]  # sparse enough that some bodies are clear
    every = coordinates_in_superellipsoids(*(c[:, : few.shape[2]] for c in xyz), *se)
    np.testing.assert_array_equal(
        _slab_hits(Slabs(few), ol, u, cand, *se), every.any(axis=1)
    )
    sp = FingerSpheres(g)
    dummy = StructuredPoses(np.eye(3)[None], np.zeros((1, 3)), np.zeros((1, 3)))
    f = _Fingers(dummy, np.zeros((n, 3)), sp, Kernels(False, False))
    truth = sp.holding_coordinates(*xyz)
    np.testing.assert_array_equal(f._numpy_held(Q, ol, u, cand), truth)


@SETTINGS
@given(
    seed=st.integers(0, 10_000),
    n_points=st.integers(1, 3_000_000),
    span=st.integers(1, 50),
)
def test_orientation_spans_cover_every_candidate_within_their_bounds(
    seed, n_points, span
):
    """The compiled body test's chunks: consecutive, covering every candidate
    once, none over the candidate bound or over the point bound (except a
    single orientation whose points alone exceed it)."""
    rng = np.random.default_rng(seed)
    o = np.sort(rng.integers(0, 1 + seed % 40, int(rng.integers(0, 400))))
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(poses, "_SPAN_CANDIDATES", span)
        spans = orientation_spans(o, n_points)
    ends = [a for a, _ in spans] + [len(o)]
    assert [b for _, b in spans] == ends[1:] and ends[0] == 0
    for a, b in spans:
        assert 0 < b - a <= span
        rows = len(np.unique(o[a:b]))
        assert rows == 1 or rows * 3 * n_points <= poses._SPAN_POINTS


@SETTINGS
@given(seed=st.integers(0, 10_000), bodies=st.integers(1, 6), hinted=st.booleans())
def test_body_loop_finds_exactly_the_candidates_with_a_point_inside(
    seed, bodies, hinted
):
    """The body loop (plain Python, and compiled where numba can be imported),
    with its probes (the nearest-point hints, or only the last hit) and its
    per-body box counts, against eq. (1) at every point."""
    rng = np.random.default_rng(seed)
    q, n, m = 3, 60, 40
    R = Rotation.random(q, random_state=seed).as_matrix()
    P = rng.normal(0.0, 0.05, (n, 3))
    Q = np.matmul(R.transpose(0, 2, 1), P.T)  # (q, 3, n)
    ol = np.sort(rng.integers(0, q, m))
    u = rng.normal(0.0, 0.06, (m, 3))
    centers = rng.normal(0.0, 0.03, (bodies, 3))
    semi = rng.uniform(0.005, 0.06, (bodies, 3))
    exponent = float(rng.choice([2.0, 4.0, 10.0]))
    x, y, z = (Q[ol, i] - u[:, i, None] for i in range(3))
    truth = coordinates_in_superellipsoids(x, y, z, centers, semi, exponent).any(1)
    hints = NearestPoint(P) if hinted else None
    for _, loop in loops():
        got = _compiled.body_hits(
            Q, ol, u, centers, semi, exponent, R=R, hints=hints, loop=loop
        )
        np.testing.assert_array_equal(got, truth)


def test_nearest_point_names_a_point_of_the_nearest_occupied_voxel():
    """Every voxel's hint is an object point, in a voxel at the least distance
    from it among the occupied ones."""
    rng = np.random.default_rng(3)
    P = rng.uniform(-0.05, 0.05, (200, 3)) * [1.0, 0.5, 2.0]
    grid = NearestPoint(P, cell=0.01)
    shape = tuple(grid.shape)
    owner_voxel = np.floor((P - grid.origin) / grid.cell).astype(int)
    occupied = np.unique(owner_voxel, axis=0)
    voxels = np.stack(np.unravel_index(np.arange(np.prod(shape)), shape), axis=1)
    d2 = ((voxels[:, None, :] - occupied[None]) ** 2).sum(-1).min(axis=1)
    hint = grid.point
    assert hint.min() >= 0 and hint.max() < len(P)
    got = ((voxels - owner_voxel[hint]) ** 2).sum(-1)
    np.testing.assert_array_equal(got, d2)


@SETTINGS
@given(
    seed=st.integers(0, 10_000),
    fingers=st.integers(1, 6),
    spheres=st.integers(1, 40),
    spread=st.floats(0.01, 0.1),
    ordered=st.booleans(),
)
def test_count_loop_gives_the_spheres_counts(seed, fingers, spheres, spread, ordered):
    """The count loop (plain Python, and compiled where numba can be imported)
    counts exactly the points inside each finger's spheres, with the candidates'
    rows in order or not, and writes exactly those holdings, with the points in
    another order and the candidates to other rows."""
    g = _hand(seed, fingers, spheres)
    depth = FingerDepth(g.sphere_centers, g.sphere_radii, g.sphere_finger, fingers)
    rng = np.random.default_rng(seed)
    q, n, m = 3, 120, 12
    Q = rng.normal([0.0, 0.0, 0.1], spread, (q, n, 3)).transpose(0, 2, 1)
    ol = rng.integers(0, q, m)
    if ordered:
        ol = np.sort(ol)
    u = rng.normal(0.0, 0.3 * spread, (m, 3))
    p = Q[ol].transpose(0, 2, 1) - u[:, None, :]  # (m, n, 3) gripper frame
    d2 = ((p[:, :, None, :] - g.sphere_centers) ** 2).sum(-1)  # (m, n, s)
    inside = d2 < g.sphere_radii**2
    held = np.stack(
        [inside[..., g.sphere_finger == f].any(-1) for f in range(fingers)], -1
    )  # (m, n, nf)
    truth = held.sum(axis=1)  # (m, nf)
    order = rng.permutation(n)  # column j of the loop's points: point order[j]
    dest = rng.permutation(m + 2)[:m]
    for loop, _ in loops():
        got = _compiled.count_by_fingers(depth, Q, ol, u, loop=loop)
        np.testing.assert_array_equal(got, truth)
        out = np.ones((m + 2, n, fingers), dtype=bool)
        got = _compiled.count_by_fingers(
            depth, Q[:, :, order], ol, u, loop, order, out, dest
        )
        np.testing.assert_array_equal(got, truth)
        np.testing.assert_array_equal(out[dest], held)


@SETTINGS
@given(
    seed=st.integers(0, 10_000), fingers=st.integers(1, 6), spheres=st.integers(1, 40)
)
def test_sphere_lists_hold_every_sphere_that_can_hold_a_point(seed, fingers, spheres):
    """At a point whose nearest node the depth grid leaves unsure for a finger,
    every sphere of that finger holding the point is in the node's list."""
    g = _hand(seed, fingers, spheres)
    depth = FingerDepth(g.sphere_centers, g.sphere_radii, g.sphere_finger, fingers)
    node_id, lists, centers, radii = depth.sphere_lists
    rng = np.random.default_rng(seed)
    # points near the spheres' surfaces, where nodes are unsure
    s = rng.integers(0, len(g.sphere_radii), 4000)
    v = rng.normal(size=(4000, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    r = g.sphere_radii[s] * rng.uniform(0.9, 1.1, 4000)
    pts = g.sphere_centers[s] + v * r[:, None]  # (n, 3)
    ijk = np.clip(
        np.floor((pts - depth.origin) / depth.cell + 0.5), 0, depth.shape - 1
    ).astype(np.int64)  # (n, 3) each point's nearest node
    flat = ijk @ depth.strides
    open_f = depth.unsure_fingers[depth.codes[flat]]  # (n, nf)
    assert open_f.any()
    inside = ((pts[:, None, :] - g.sphere_centers) ** 2).sum(-1) < g.sphere_radii**2
    for f in range(fingers):
        at = np.flatnonzero(open_f[:, f])
        listed = lists[node_id[flat[at]], f]  # (k, K)
        assert np.all(node_id[flat[at]] >= 0)
        for sphere in np.flatnonzero(g.sphere_finger == f):
            holds = inside[at, sphere]
            assert np.all((listed[holds] == sphere).any(axis=1))
    assert radii[-1] == 0.0 and len(centers) == len(radii) == len(g.sphere_radii) + 1


@pytest.mark.parametrize(
    ("spec", "sampling"),
    [
        ("allegro.yaml", None),
        ("franka.yaml", {"mode": "major_axis", "points": 147, "orientations": 4}),
    ],
)
def test_search_of_a_scene_metres_from_the_origin(spec: str, sampling):  # type: ignore[no-untyped-def]
    """A camera-frame scene can lie metres from the world origin: the search of
    the bundled scene's prepared input, moved 12 m away and turned, gives every
    candidate the same verdict and contact counts, and the same choice."""
    import dataclasses
    from pathlib import Path

    from wsgrasp.api import Pipeline, _normals, as_scene
    from wsgrasp.planning.search import run_search
    from wsgrasp.spec import load_spec

    root = Path(__file__).resolve().parent.parent
    s = load_spec(root / "examples" / "specs" / spec)
    if sampling:
        s.sampling = s.sampling.model_validate({**s.sampling.model_dump(), **sampling})
    pipe = Pipeline(s)
    prep = pipe.prepare(as_scene(root / "examples" / "scenes" / "box_upright.npz"))
    inp = prep.search_input
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec([0.3, -0.7, 1.1]).as_matrix()
    T[:3, 3] = [7.0, -9.0, 4.0]  # 12.1 m away

    def moved(P: np.ndarray) -> np.ndarray:
        return transform_points(T, P) if len(P) else P

    far = dataclasses.replace(
        inp,
        T_world_object=T @ inp.T_world_object,
        object_points=moved(inp.object_points),
        obstacle_points=moved(inp.obstacle_points),
        table=dataclasses.replace(inp.table, T_world_table=T @ inp.table.T_world_table),
    )
    centre = far.T_world_object[:3, 3]
    out = run_search(
        far,
        pipe._scorers,
        top_k=pipe.spec.top_k,
        spheres=pipe._spheres,
        normals_fn=lambda p: _normals(p, centre),
        normals_of=lambda p, rows: _normals(p, centre, rows),
    )
    ref = pipe.search(prep)
    np.testing.assert_array_equal(out.candidates.reason, ref.candidates.reason)
    np.testing.assert_array_equal(out.candidates.contacts, ref.candidates.contacts)
    assert (ref.candidates.reason == 0).sum() > 0
    assert out.best == ref.best


def test_small_searches_load_the_compiled_loops_from_the_fourth_on(monkeypatch):
    """With numba, a search of many pairs runs the compiled loops at once; a
    small one runs numpy's until a process has done ``SMALL_BEFORE_LOADING`` of
    them, or the loops are loaded, and a tiny one (below ``SMALL_FROM`` pairs),
    or poses checked again (not a search), until they are loaded; without
    numba, numpy's always."""
    monkeypatch.setattr(_compiled, "_AVAILABLE", True)
    monkeypatch.setattr(_compiled, "_compiled_body", None)
    monkeypatch.setattr(_compiled, "_compiled_count", None)
    monkeypatch.setattr(kernels, "_small_searches", 0)

    def compiled(pairs: int, search: bool = True) -> bool:
        return kernels.choose_kernels(pairs, search).compiled

    small = kernels.COMPILED_FROM - 1
    before = kernels.SMALL_BEFORE_LOADING
    tiny = kernels.SMALL_FROM - 1  # never worth loading for, never counted
    assert not any(compiled(t) for t in [0, tiny] * (before + 1))
    assert not any(compiled(small, search=False) for _ in range(before + 1))
    assert [compiled(small) for _ in range(before + 2)] == (
        [False] * before + [True, True]
    )
    monkeypatch.setattr(kernels, "_small_searches", 0)
    assert compiled(kernels.COMPILED_FROM)  # many: at once
    assert kernels.choose_kernels(kernels.COMPILED_FROM).dense
    assert kernels._small_searches == 0  # and not counted as a small one
    assert not compiled(small)
    # loaded (here as the plain Python loops): every evaluation from then on
    monkeypatch.setattr(_compiled, "_compiled_body", _compiled._body_loop)
    monkeypatch.setattr(_compiled, "_compiled_count", _compiled._count_loop)
    assert _compiled.loaded() and compiled(0) and compiled(0, search=False)
    monkeypatch.setattr(_compiled, "_AVAILABLE", False)
    assert not compiled(kernels.COMPILED_FROM)


def test_importing_wsgrasp_leaves_numba_unimported(tmp_path):
    """numba is imported when a search first runs the compiled loops, not when
    wsgrasp is: here a ``numba`` that fails on import stands in for it, so the
    import of the planner must not touch it, while ``available`` finds it."""
    import os
    import subprocess
    import sys

    (tmp_path / "numba.py").write_text("raise RuntimeError('numba imported')\n")
    code = (
        "import sys; import wsgrasp.api, wsgrasp.planning.evaluate; "
        "from wsgrasp.planning import _compiled as N; "
        "print(N.available(), 'numba' in sys.modules)"
    )
    env = {k: v for k, v in os.environ.items() if k != "WSGRASP_NUMBA"}
    env["PYTHONPATH"] = str(tmp_path)
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["True", "False"]


def test_a_single_plan_does_not_import_numba(tmp_path):
    """A process that plans one scene, as ``wsgrasp plan`` does, runs numpy's
    kernels and never imports numba (its import alone costs more than the
    plan): a ``numba`` that fails on import stands in for it."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    (tmp_path / "numba.py").write_text("raise RuntimeError('numba imported')\n")
    code = (
        "import sys; from wsgrasp.api import plan; "
        f"r = plan({str(root / 'examples/scenes/box_upright.npz')!r}, "
        f"{str(root / 'examples/specs/allegro.yaml')!r}); "
        "print(r.found, 'numba' in sys.modules)"
    )
    env = {k: v for k, v in os.environ.items() if k != "WSGRASP_NUMBA"}
    env["PYTHONPATH"] = str(tmp_path)
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.split()[-2:] == ["True", "False"]


@SETTINGS
@given(seed=st.integers(0, 10_000), distinct=st.integers(1, 60), C=st.integers(0, 500))
def test_sweeps_group_rotations_as_numpy_unique_does(seed, distinct, C):
    """The closing sweeps take each distinct rotation once: the same rotations,
    in the same order, and the same index per candidate as ``np.unique`` over
    rows, also where rows differ only in the sign of a zero."""
    from wsgrasp.planning.poses import distinct_rotations

    rng = np.random.default_rng(seed)
    R = Rotation.random(distinct, random_state=seed).as_matrix().reshape(-1, 3, 3)
    R[0] = np.eye(3)
    if distinct > 1:
        R[1] = np.eye(3) * np.array([1.0, 1.0, 1.0])[:, None]
        R[1][0, 1] = -0.0
    T = R[rng.integers(0, distinct, C)]
    got, of = distinct_rotations(T)
    want, want_of = np.unique(T.reshape(-1, 9), axis=0, return_inverse=True)
    np.testing.assert_array_equal(got.reshape(-1, 9), want)
    np.testing.assert_array_equal(of, want_of.reshape(-1))
    np.testing.assert_array_equal(got[of], T)


@SETTINGS
@given(
    seed=st.integers(0, 10_000),
    nf=st.integers(1, 6),
    H=st.integers(1, 40),
    U=st.integers(0, 300),
    block=st.integers(1, 5000),
)
def test_sweeps_lowest_heights_do_not_depend_on_blocking(seed, nf, H, U, block):
    """The fingers' lowest sweep heights per rotation: the same bits whatever
    block of directions is computed at once, and each the least of the
    corners' heights."""
    from wsgrasp.planning import sweeps

    rng = np.random.default_rng(seed)
    hull = rng.normal(0.0, 0.05, (nf, 4, H, 3))
    u = rng.normal(size=(U, 3))
    whole = sweeps._lowest(hull, u)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(sweeps, "_LOWEST_ENTRIES", block)
        blocked = sweeps._lowest(hull, u)
    np.testing.assert_array_equal(blocked.view(np.uint64), whole.view(np.uint64))
    heights = np.einsum("fkhi,ui->fkuh", hull, u)  # (nf, 4, U, H)
    np.testing.assert_allclose(whole, heights.min(axis=3), rtol=0, atol=1e-15)


@pytest.mark.skipif(not _compiled.available(), reason="numba cannot be imported")
@SETTINGS
@given(
    seed=st.integers(0, 10_000),
    nf=st.integers(1, 6),
    n=st.integers(1, 60),
    x=st.integers(0, 40),
    halves=st.booleans(),
)
def test_sweeps_reach_test_is_numpys_in_every_kernel(seed, nf, n, x, halves):
    """Whether each finger reaches an object point before it enters the table:
    the same answer from numpy's lookups, the loop as written and the loop
    compiled, with points outside the grids and on voxel halves (rounded to
    even)."""
    from types import SimpleNamespace

    from wsgrasp.planning import _loops, sweeps

    rng = np.random.default_rng(seed)
    K = 8
    reach = [
        rng.integers(0, K + 1, rng.integers(2, 9, 3)).astype(np.uint8)
        for _ in range(nf)
    ]
    index = SimpleNamespace(
        hull=np.zeros((nf, K, 1, 3)),
        origin=rng.normal(0.0, 0.004, (nf, 3)),
        reach=reach,
    )
    p_rot = rng.uniform(-2.0, 10.0, (3, n, 3)).astype(np.float32)
    rotation = rng.integers(0, 3, x)
    shift = rng.uniform(-1.0, 1.0, (x, 3))
    if halves:  # points half-way between voxels
        p_rot = np.floor(p_rot) + np.float32(0.5)
        shift = np.round(shift)
        index.origin[:] = 0.0
    limit = rng.integers(0, K + 1, (nf, x))
    got = {}
    for name, loop in (
        ("numpy", None),
        ("loop", _loops._reach_loop),
        ("compiled", _compiled.load() and _compiled.reach_loop()),
    ):
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(_compiled, "reach_loop", lambda loop=loop: loop)
            got[name] = sweeps._reached_first(index, p_rot, rotation, shift, limit)
    np.testing.assert_array_equal(got["loop"], got["numpy"])
    np.testing.assert_array_equal(got["compiled"], got["numpy"])


@SETTINGS
@given(
    seed=st.integers(0, 2**16),
    ns=st.integers(1, 9),
    n_orient=st.integers(1, 7),
    depths=st.booleans(),
)
def test_pose_array_reads_the_structures_poses_bit_for_bit(seed, ns, n_orient, depths):
    """Any subset of a ``PoseArray``'s poses, read from the structure, is the
    same bits as the whole array ``candidate_poses`` builds, for integer,
    negative, array and mask indices, and split into rotations and
    translations; a pose set on it overrides the
    structure's wherever read, and a copy keeps its own."""
    from wsgrasp.planning.poses import PoseArray

    rng = np.random.default_rng(seed)
    T_wo = np.eye(4)
    T_wo[:3, :3] = Rotation.from_rotvec(rng.normal(size=3)).as_matrix()
    T_wo[:3, 3] = rng.uniform(-2, 2, 3)
    samples = rng.uniform(-0.1, 0.1, (ns, 3))
    R = Rotation.random(n_orient, random_state=seed).as_matrix()
    depth = rng.uniform(-0.02, 0.02, n_orient) if depths else None
    T_gg = np.eye(4)
    T_gg[:3, 3] = rng.uniform(-0.1, 0.1, 3)
    _, T_wg, _, _ = candidate_poses(T_wo, samples, R, T_gg, depth)
    structure = CandidateStructure(T_wo, samples, R, depth)
    lazy = PoseArray(StructuredPoses.build(structure, T_gg))
    C = ns * n_orient
    assert len(lazy) == C
    index = rng.integers(-C, C, 5)
    mask = rng.random(C) < 0.5
    for i in (0, C - 1, -1, index, mask, np.array([], dtype=np.int64)):
        assert np.array_equal(lazy.at(i), T_wg[i])
    with pytest.raises(IndexError):
        lazy.at(C)
    some = np.flatnonzero(mask)
    for kept in (lazy, PoseArray(T_wg)):  # split: rotations once, translations
        R_u, of, t = kept.split(some, some % n_orient)
        assert np.array_equal(R_u[of], T_wg[some, :3, :3])
        assert np.array_equal(t, T_wg[some, :3, 3])
        assert len(R_u) == len(np.unique(some % n_orient))
    assert not lazy.built
    edit = np.eye(4)
    edit[:3, 3] = [1.0, 2.0, 3.0]
    copy = lazy.copy()
    lazy.set(C - 1, edit)
    assert np.array_equal(lazy.at(-1), edit)
    assert np.array_equal(lazy.at(np.arange(C))[-1], edit)
    assert np.array_equal(copy.at(-1), T_wg[-1])  # the copy keeps its own
    whole = lazy.whole()
    assert lazy.built and np.array_equal(whole[:-1], T_wg[:-1])
    assert np.array_equal(whole[-1], edit)


def test_a_search_builds_no_pose_array_of_every_candidate():
    """The search keeps its candidates' poses as the structure gives them: a
    plan without a recording reads those of the feasible and chosen ones, and
    the candidate set still gives every pose, as ``candidate_poses`` lays them
    out, when read whole."""
    from pathlib import Path

    from wsgrasp.api import Pipeline, as_scene
    from wsgrasp.spec import load_spec

    root = Path(__file__).resolve().parent.parent
    s = load_spec(root / "examples" / "specs" / "allegro.yaml")
    pipe = Pipeline(s)
    prep = pipe.prepare(as_scene(root / "examples" / "scenes" / "box_upright.npz"))
    out = pipe.search(prep)
    ee, gwc = out.candidates.poses()
    assert not ee.built and not gwc.built
    inp = prep.search_input
    o = inp.orientations
    T_gwc, T_ee, sample, orientation = candidate_poses(
        inp.T_world_object,
        inp.samples_object,
        o.R_object_gwc,
        inp.gripper.T_gripper_gwc,
        o.depth,
    )
    moved = np.flatnonzero(
        np.any(T_ee != out.candidates.ee_at(np.arange(len(T_ee))), axis=(1, 2))
    )
    assert set(moved) <= {out.best}  # the choice, where backed off
    np.testing.assert_array_equal(
        np.delete(out.candidates.T_world_ee, moved, 0), np.delete(T_ee, moved, 0)
    )
    np.testing.assert_array_equal(
        np.delete(out.candidates.T_world_gwc, moved, 0), np.delete(T_gwc, moved, 0)
    )
    np.testing.assert_array_equal(out.candidates.sample, sample)
    np.testing.assert_array_equal(out.candidates.orientation, orientation)


@SETTINGS
@given(seed=st.integers(0, 10_000), q=st.integers(0, 90), n=st.integers(0, 3000))
def test_points_in_each_rotations_axes_are_a_batched_products_bits(seed, q, n):
    """``in_axes``, a matrix product per block of rotations small enough for one
    BLAS thread: the bits of numpy's batched product per rotation."""
    rng = np.random.default_rng(seed)
    P = rng.normal(0.0, 0.1, (n, 3))
    R = Rotation.random(q, random_state=seed).as_matrix().reshape(-1, 3, 3)
    got = poses.in_axes(P, R)
    assert got.shape == (q, 3, n)
    np.testing.assert_array_equal(got, np.matmul(R.transpose(0, 2, 1), P.T))


def test_a_batch_reads_its_poses_axes_without_building_them():
    """A scorers' batch given ``PoseRows``: its approach, closing and GWC
    origins are the bits of the poses' own columns, read without building the
    poses; reading the poses whole builds them once."""
    from dataclasses import replace

    from wsgrasp.planning.poses import PoseArray, PoseRows
    from wsgrasp.planning.scoring import CandidateBatch

    rng = np.random.default_rng(3)
    T_wo = np.eye(4)
    T_wo[:3, :3] = Rotation.from_rotvec(rng.normal(size=3)).as_matrix()
    structure = CandidateStructure(
        T_wo,
        rng.uniform(-0.1, 0.1, (6, 3)),
        Rotation.random(5, random_state=3).as_matrix(),
    )
    poses = PoseArray(StructuredPoses.build(structure))
    f = np.array([1, 4, 7, 22, 29])
    T = poses.at(f)
    kept = dict(
        gripper=make_jaw_gripper(),
        theta=np.zeros(len(f)),
        holding=np.zeros((len(f), 1, 2), dtype=bool),
        object_points=np.zeros((1, 3)),
        T_world_object=T_wo,
        extents=np.ones(3),
        table_normal=np.array([0.0, 0.0, 1.0]),
        min_table_height=np.zeros(len(f)),
    )
    lazy = CandidateBatch(
        T_world_gwc=PoseRows(poses, f), T_world_gripper=PoseRows(poses, f), **kept
    )
    whole = CandidateBatch(T_world_gwc=T, T_world_gripper=T, **kept)
    assert len(lazy) == len(f)
    for name in ("approach", "closing", "gwc_origins"):
        np.testing.assert_array_equal(getattr(lazy, name), getattr(whole, name))
    assert isinstance(type(lazy).__dict__["T_world_gwc"].stored(lazy), PoseRows)
    np.testing.assert_array_equal(lazy.T_world_gwc, T)
    assert lazy.T_world_gwc is lazy.T_world_gwc  # built once, then kept
    np.testing.assert_array_equal(replace(lazy).T_world_gripper, T)
