"""The structured-candidate kernels (``wsgrasp.planning.dense``) give the verdicts of
the loop-by-loop reference, in any frame, for any orientations, depths and spheres."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from conftest import box_object, make_jaw_gripper
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from wsgrasp.geometry import coordinates_in_superellipsoids, transform_points
from wsgrasp.planning import _dense_numba, dense
from wsgrasp.planning._dense_grid import (
    FingerDepth,
    NearestPoint,
    ObjectDistance,
    inscribed_balls,
)
from wsgrasp.planning.candidates import candidate_poses
from wsgrasp.planning.dense import (
    CandidateStructure,
    StructuredPoses,
    _body_hits,
    _boxes_clear,
    _count_depth,
    _count_every_point,
    _count_in_slab,
    _held_in_slab,
    _object_box_clear,
    _orientation_spans,
    _Slabs,
    hull_vertices,
    lowest_heights,
    table_bounds,
    table_exact,
)
from wsgrasp.planning.evaluate import FingerSpheres, TableSE, evaluate_candidates
from wsgrasp.planning.reference import reference_search

#: a scene frame: rotation vector and translation
ROTVEC = st.tuples(*[st.floats(-3.0, 3.0)] * 3)
SHIFT = st.tuples(*[st.floats(-2.0, 2.0)] * 3)
SETTINGS = settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)


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


class _Forced:
    """Every optional path on at any candidate count (the ball proofs start at
    ``dense._BALLS_FROM`` candidates, the compiled finger loop at
    ``dense._COMPILED_FROM`` pairs), and the compiled finger loop replaced by
    ``loop`` (its plain Python function, so that its logic is tested without
    numba) or left as installed."""

    def __init__(
        self, balls: bool, loop=None, counts: str = "keep", small: bool = False
    ) -> None:
        # loop: (body loop, finger loop), each a callable or None (no numba);
        # counts: "keep" (holdings computed and kept, the small-set path),
        # "count" (counts only, holdings built when read) or "depth" (counts
        # through the depth grid and its sphere lists at any chunk size);
        # small: the compiled loops as a small search runs them once loaded
        # (no hint grid, the points in their own order, one chunk's rows for
        # both tests) instead of as a dense one
        self.balls, self.loop, self.counts = balls, loop, counts
        self.small = small

    def __enter__(self):
        N = _dense_numba
        self.saved = (
            dense._BALLS_FROM,
            dense._COMPILED_FROM,
            dense._KEEP_ENTRIES,
            dense._DEPTH_FROM,
        )
        self.saved_loops = (N._compiled_body, N._compiled_count, N._AVAILABLE)
        if self.balls:
            dense._BALLS_FROM = 0
        dense._COMPILED_FROM = 2**62 if self.small else 0
        if self.counts != "keep":
            dense._KEEP_ENTRIES = -1
        if self.counts == "depth":
            dense._DEPTH_FROM = 0
        if self.loop is not None:  # (None, None): the numpy path
            N._compiled_body, N._compiled_count = self.loop
            N._AVAILABLE = self.loop[0] is not None
        return self

    def __exit__(self, *exc):
        (
            dense._BALLS_FROM,
            dense._COMPILED_FROM,
            dense._KEEP_ENTRIES,
            dense._DEPTH_FROM,
        ) = self.saved
        (
            _dense_numba._compiled_body,
            _dense_numba._compiled_count,
            _dense_numba._AVAILABLE,
        ) = self.saved_loops


def _frame(rotvec, shift) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(rotvec).as_matrix()
    T[:3, 3] = shift
    return T


def _scene(seed: int, T_world_scene: np.ndarray, n_orient: int, obstacles: bool):
    """A box on a table, samples in its box, random orientations and depths; the
    object sits low so that many candidates reach the table."""
    rng = np.random.default_rng(seed)
    size = rng.uniform([0.02, 0.02, 0.03], [0.09, 0.09, 0.2])
    obj = box_object(size, 300, seed)
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


def _table_verdicts(T_world_gripper, cloud, table):
    """Brute force: every cloud point of every candidate, eq. (1) as the reference
    writes it."""
    T = np.linalg.inv(table.T_world_table) @ T_world_gripper
    p = np.einsum("cij,nj->cni", T[:, :3, :3], cloud) + T[:, None, :3, 3]
    d = np.abs(p - table.center) / table.semi_axes
    v = d[..., 0] ** table.exponent + d[..., 1] ** table.exponent + d[..., 2] ** 2
    return (v < 1.0).any(axis=1)


@SETTINGS
@given(
    seed=st.integers(0, 10_000),
    rotvec=ROTVEC,
    shift=SHIFT,
    n_orient=st.integers(1, 40),
)
def test_table_bounds_never_contradict_the_cloud(seed, rotvec, shift, n_orient):
    """A bound's "hit" is a hit and its "clear" is clear, point by point."""
    g = make_jaw_gripper(spheres_per_finger=1 + seed % 12)
    obj, T_wo, samples, R, depth, _, table = _scene(
        seed, _frame(rotvec, shift), n_orient, False
    )
    _, T_wg, _, _ = candidate_poses(T_wo, samples, R, g.T_gripper_gwc, depth)
    poses = StructuredPoses.build(
        CandidateStructure(T_wo, samples, R, depth), g.T_gripper_gwc
    )
    np.testing.assert_allclose(
        poses.transforms(np.arange(len(T_wg))), T_wg, rtol=0, atol=1e-12
    )
    hit, unsure = table_bounds(poses, hull_vertices(g.cloud), table)
    truth = _table_verdicts(T_wg, g.cloud, table)
    assert not np.any(hit & unsure)
    np.testing.assert_array_equal(truth[~unsure], hit[~unsure])
    everything = np.arange(len(T_wg))
    np.testing.assert_array_equal(table_exact(poses, g.cloud, table, everything), truth)


@SETTINGS
@given(
    seed=st.integers(0, 10_000),
    rotvec=ROTVEC,
    shift=SHIFT,
    n_orient=st.integers(1, 12),
)
def test_structured_evaluation_matches_reference(seed, rotvec, shift, n_orient):
    """Reasons, contacts and the feasible set equal the reference's and the
    unstructured path's, for random frames, orientations, depths and spheres (the
    jaw's, or 2-4 fingers of random sizes), with and without the ball proofs."""
    g = (
        make_jaw_gripper(spheres_per_finger=1 + seed % 12)
        if seed % 4
        else _hand(seed, 2 + seed % 3, 1 + seed % 20)
    )
    obj, T_wo, samples, R, depth, obs, table = _scene(
        seed, _frame(rotvec, shift), n_orient, bool(seed % 3 == 0)
    )
    _, T_wg, _, _ = candidate_poses(T_wo, samples, R, g.T_gripper_gwc, depth)
    structure = CandidateStructure(T_wo, samples, R, depth)
    # with and without the ball proofs; holdings kept, or counts only (through
    # the depth grid's sphere lists, or as the chunk size chooses)
    mode = ("keep", "count", "depth")[seed % 3]
    with _Forced(balls=bool(seed % 2), counts=mode):
        fast = evaluate_candidates(T_wg, g, obj, obs, table, structure=structure)
        fast_holding = fast.holding  # a counting mode builds it when read
    plain = evaluate_candidates(T_wg, g, obj, obs, table)
    ref = reference_search(g, T_wo, samples, R, obj, obs, table, depth)
    np.testing.assert_array_equal(fast.reason, ref.reason)
    np.testing.assert_array_equal(fast.contacts, ref.contacts)
    np.testing.assert_array_equal(fast.feasible, plain.feasible)
    np.testing.assert_array_equal(fast_holding, plain.holding)
    np.testing.assert_array_equal(fast.holdings.counts, plain.contacts[plain.feasible])
    # a scoring input, not a verdict: equal to rounding (the matrix products
    # group candidates differently)
    np.testing.assert_allclose(
        fast.min_table_height, plain.min_table_height, rtol=0, atol=1e-12
    )


def test_structure_that_does_not_match_is_refused(jaw_gripper):
    obj, T_wo, samples, R, depth, obs, table = _scene(1, np.eye(4), 4, False)
    _, T_wg, _, _ = candidate_poses(T_wo, samples, R, jaw_gripper.T_gripper_gwc)
    wrong = CandidateStructure(T_wo, samples + 0.01, R, None)
    try:
        evaluate_candidates(T_wg, jaw_gripper, obj, obs, table, structure=wrong)
    except ValueError as err:
        assert "does not match" in str(err)
    else:  # pragma: no cover
        raise AssertionError("a mismatched structure was accepted")


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
    pair, j, r = _Slabs(Q).pairs(ol, u[:, k], k, lo, lo + width)
    assert np.all(r == ol[pair])
    got = np.zeros((len(ol), n), dtype=bool)
    got[pair, j] = True
    assert len(pair) == got.sum()  # no pair twice
    coord = Q[ol, k, :] - u[:, k, None]  # (m, n)
    inside = (coord >= lo) & (coord <= lo + width)
    assert np.all(got[inside])
    near = (coord >= lo - 2e-7) & (coord <= lo + width + 2e-7)
    assert np.all(near[got])


def _gripper_coordinates(Q, ol, u, cand):
    return [Q[ol[cand], i] - u[cand, i, None] for i in range(3)]  # 3 × (n, no)


@SETTINGS
@given(
    seed=st.integers(0, 10_000),
    q=st.integers(1, 5),
    n=st.integers(1, 200),
    spheres=st.integers(1, 12),
)
def test_slab_kernels_match_every_point(seed, q, n, spheres):
    """The superellipsoid and finger kernels on slabs give what testing every
    point gives."""
    g = make_jaw_gripper(spheres_per_finger=spheres, seed=seed)
    Q, ol, u = _rows(seed, q, n)
    Q *= 0.7  # points among the gripper's bodies and spheres
    Q[:, 2] += 0.06
    cand = np.arange(len(ol))
    slabs = _Slabs(Q)
    se = (g.se_centers, g.se_semi_axes, g.se_exponent)
    few = Q[:, :, : max(1, n // 10)]  # sparse enough that some bodies are clear
    every = coordinates_in_superellipsoids(*_gripper_coordinates(few, ol, u, cand), *se)
    np.testing.assert_array_equal(
        _body_hits(_Slabs(few), ol, u, cand, *se), every.any(axis=1)
    )
    sp = FingerSpheres(g)
    nf = g.num_fingers
    lo = np.stack(
        [
            (g.sphere_centers - g.sphere_radii[:, None])[g.sphere_finger == f].min(0)
            for f in range(nf)
        ]
    )
    hi = np.stack(
        [
            (g.sphere_centers + g.sphere_radii[:, None])[g.sphere_finger == f].max(0)
            for f in range(nf)
        ]
    )
    held = _held_in_slab(slabs, ol, u, cand, sp, lo, hi)
    truth = sp.holding_coordinates(*_gripper_coordinates(Q, ol, u, cand))
    np.testing.assert_array_equal(held, truth)


def test_memory_stays_bounded_for_a_million_candidates():
    """The table kernel's peak for 1,000 samples × 1,000 orientations: its
    chunks, not the candidate count, set it (two (C,) masks are the output)."""
    import tracemalloc

    g = make_jaw_gripper()
    obj, T_wo, _, _, _, _, table = _scene(3, np.eye(4), 1, False)
    rng = np.random.default_rng(0)
    samples = rng.uniform(-0.03, 0.03, (1000, 3))
    R = Rotation.random(1000, random_state=0).as_matrix()
    structure = CandidateStructure(T_wo, samples, R, rng.uniform(-0.02, 0.02, 1000))
    tracemalloc.start()
    try:
        poses = StructuredPoses.build(structure, g.T_gripper_gwc)
        hit, unsure = table_bounds(poses, hull_vertices(g.cloud), table)
        idx = np.flatnonzero(unsure)[:20_000]
        table_exact(poses, g.cloud, table, idx)
        peak = tracemalloc.get_traced_memory()[1] / 2**20
    finally:
        tracemalloc.stop()
    assert structure.num_candidates == len(hit) == 1_000_000
    # outputs: 2 MB of masks; a chunk of 262,144 candidates: about 45 MB
    assert peak < 80, f"peak {peak:.0f} MiB"


@pytest.mark.parametrize("spheres", [1, 4, 10], ids=lambda n: f"{n}spheres")
def test_finger_kernel_with_every_point_in_the_slab(spheres):
    """Points all within the fingers' box: the kernel takes every point as rows,
    with the same answer as the sphere grid point by point."""
    g = make_jaw_gripper(spheres_per_finger=spheres)
    sp = FingerSpheres(g)
    lo = (g.sphere_centers - g.sphere_radii[:, None]).min(axis=0)
    hi = (g.sphere_centers + g.sphere_radii[:, None]).max(axis=0)
    rng = np.random.default_rng(spheres)
    Q = rng.uniform(lo, hi, (3, 400, 3)).transpose(0, 2, 1)  # (q, 3, n)
    ol = rng.integers(0, 3, 50)
    u = rng.normal(0.0, 1e-3, (50, 3))
    cand = np.arange(50)
    f_lo = np.stack([lo, lo])
    f_hi = np.stack([hi, hi])
    held = _held_in_slab(_Slabs(Q), ol, u, cand, sp, f_lo, f_hi)
    truth = sp.holding_coordinates(*_gripper_coordinates(Q, ol, u, cand))
    assert truth.any() and not truth.all()
    np.testing.assert_array_equal(held, truth)


@pytest.mark.slow
def test_memory_bound_of_the_whole_evaluation_for_a_million_candidates():
    """Beyond its inputs and the feasible candidates' holdings (F × no × nf
    bools, part of the answer), the structured evaluation of a million candidates
    needs chunks only."""
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


@SETTINGS
@given(seed=st.integers(0, 10_000), n_orient=st.integers(1, 3))
def test_compiled_finger_loop_gives_the_numpy_paths_answers(seed, n_orient):
    """The finger and body loops numba compiles, run as plain Python (and
    compiled, where numba is installed), give the numpy path's verdicts, contacts
    and holdings."""
    g = _hand(seed, 2 + seed % 3, 1 + seed % 12) if seed % 2 else make_jaw_gripper()
    obj, T_wo, samples, R, depth, obs, table = _scene(
        seed, _frame((0.3, -0.2, 0.1), (0.1, 0.0, 0.2)), n_orient, False
    )
    obj, samples = obj[::4], samples[:6]  # plain Python: a few thousand pairs
    _, T_wg, _, _ = candidate_poses(T_wo, samples, R, g.T_gripper_gwc, depth)
    structure = CandidateStructure(T_wo, samples, R, depth)
    sp = FingerSpheres(g)

    def run(loop, counts, small=False):
        with _Forced(balls=bool(seed % 3), loop=loop, counts=counts, small=small):
            ev = evaluate_candidates(T_wg, g, obj, obs, table, sp, structure=structure)
            return ev, ev.holding  # the holdings from the kernel under test

    numpy_path, numpy_holding = run((None, None), "keep")  # the numpy path
    N = _dense_numba
    loops = [(N._body_loop, N._count_loop)]
    if N.available():
        count_loop, body_loop = N.load()
        loops.append((body_loop, count_loop))
    for loop, counts, small in itertools.product(
        loops, ("keep", "count"), (False, True)
    ):
        got, holding = run(loop, counts, small)
        np.testing.assert_array_equal(got.reason, numpy_path.reason)
        np.testing.assert_array_equal(got.contacts, numpy_path.contacts)
        np.testing.assert_array_equal(holding, numpy_holding)


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
    saved = dense._SPAN_CANDIDATES
    dense._SPAN_CANDIDATES = span
    try:
        spans = _orientation_spans(o, n_points)
    finally:
        dense._SPAN_CANDIDATES = saved
    ends = [a for a, _ in spans] + [len(o)]
    assert [b for _, b in spans] == ends[1:] and ends[0] == 0
    for a, b in spans:
        assert 0 < b - a <= span
        rows = len(np.unique(o[a:b]))
        assert rows == 1 or rows * 3 * n_points <= dense._SPAN_POINTS


@SETTINGS
@given(seed=st.integers(0, 10_000), bodies=st.integers(1, 6), hinted=st.booleans())
def test_body_loop_finds_exactly_the_candidates_with_a_point_inside(
    seed, bodies, hinted
):
    """The body loop (plain Python, and compiled where numba is installed), with
    its probes (the nearest-point hints, or only the last hit) and its per-body
    box counts, against eq. (1) at every point."""
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
    loops = [_dense_numba._body_loop]
    if _dense_numba.available():
        loops.append(_dense_numba.load()[1])
    for loop in loops:
        got = _dense_numba.body_hits(
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
    fingers=st.integers(1, 4),
    spheres=st.integers(1, 40),
    spread=st.floats(0.01, 0.1),
    ordered=st.booleans(),
)
def test_compiled_count_gives_the_spheres_counts(
    seed, fingers, spheres, spread, ordered
):
    """The count loop (plain Python, and compiled where numba is installed)
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
    loops = [_dense_numba._count_loop]
    if _dense_numba.available():
        loops.append(_dense_numba.load()[0])
    for loop in loops:
        got = _dense_numba.count_by_fingers(depth, Q, ol, u, loop=loop)
        np.testing.assert_array_equal(got, truth)
        out = np.ones((m + 2, n, fingers), dtype=bool)
        got = _dense_numba.count_by_fingers(
            depth, Q[:, :, order], ol, u, loop, order, out, dest
        )
        np.testing.assert_array_equal(got, truth)
        np.testing.assert_array_equal(out[dest], held)


@SETTINGS
@given(
    seed=st.integers(0, 10_000),
    fingers=st.integers(1, 4),
    spheres=st.integers(1, 40),
    spread=st.floats(0.01, 0.1),
)
def test_finger_depth_decides_only_what_the_spheres_decide(
    seed, fingers, spheres, spread
):
    """A point the depth grid calls held is inside one of the finger's spheres;
    one it calls not held is outside all of them; only the unsure are left."""
    g = _hand(seed, fingers, spheres)
    depth = FingerDepth(g.sphere_centers, g.sphere_radii, g.sphere_finger, fingers)
    rng = np.random.default_rng(seed)
    q, n, m = 3, 200, 20
    Q = rng.normal([0.0, 0.0, 0.1], spread, (q, n, 3)).transpose(0, 2, 1)
    ol = np.sort(rng.integers(0, q, m))
    u = rng.normal(0.0, 0.3 * spread, (m, 3))
    held, unsure = depth.held_points(Q, ol, u)
    p = Q[ol].transpose(0, 2, 1) - u[:, None, :]  # (m, n, 3) gripper frame
    d2 = ((p[:, :, None, :] - g.sphere_centers) ** 2).sum(-1)  # (m, n, s)
    inside = d2 < g.sphere_radii**2
    truth = np.stack(
        [inside[..., g.sphere_finger == f].any(-1) for f in range(fingers)], -1
    )
    assert np.all(truth[held])
    np.testing.assert_array_equal(held[~unsure], truth[~unsure])


@SETTINGS
@given(
    seed=st.integers(0, 10_000),
    n=st.integers(1, 300),
    radius=st.floats(0.001, 0.03),
    cell=st.sampled_from([0.002, 0.003, 0.006]),
)
def test_object_distance_proves_only_true_neighbours(seed, n, radius, cell):
    """Where the grid proves an object point within ``radius`` of a query, there
    is one; queries far outside the grid are never proven."""
    rng = np.random.default_rng(seed)
    pts = rng.normal(0.0, 0.02, (n, 3)) + rng.uniform(-1, 1, 3)
    grid = ObjectDistance(pts, np.array([radius]), cell)
    x = pts[rng.integers(0, n, 400)] + rng.normal(0.0, radius, (400, 3))
    x = np.concatenate([x, pts[:1] + 10.0])
    got = grid.within(x, radius)
    nearest = np.sqrt(((x[:, None, :] - pts[None]) ** 2).sum(-1)).min(axis=1)
    assert np.all(nearest[got] < radius)
    assert not got[-1]


@SETTINGS
@given(
    axes=st.lists(st.tuples(*[st.floats(0.003, 0.2)] * 3), min_size=1, max_size=6),
    exponent=st.sampled_from([2.0, 4.0, 10.0]),
    seed=st.integers(0, 10_000),
)
def test_inscribed_balls_lie_inside_their_superellipsoids(axes, exponent, seed):
    """Points of every ball, its surface included, are inside its body."""
    rng = np.random.default_rng(seed)
    semi = np.asarray(axes)
    centers = rng.uniform(-0.1, 0.1, semi.shape)
    c, r, body = inscribed_balls(centers, semi, exponent)
    assert len(c) >= 1
    d = rng.normal(size=(len(c), 64, 3))
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    p = c[:, None, :] + r[:, None, None] * d  # (b, 64, 3) on each ball's surface
    for e in np.unique(body):
        mine = p[body == e].reshape(-1, 3)
        assert coordinates_in_superellipsoids(
            mine[:, 0],
            mine[:, 1],
            mine[:, 2],
            centers[e : e + 1],
            semi[e : e + 1],
            exponent,
        ).all()


def _finger_boxes(g):
    nf = g.num_fingers
    mine = [g.sphere_finger == f for f in range(nf)]
    lo = np.stack(
        [(g.sphere_centers - g.sphere_radii[:, None])[m].min(0) for m in mine]
    )
    hi = np.stack(
        [(g.sphere_centers + g.sphere_radii[:, None])[m].max(0) for m in mine]
    )
    return lo, hi


@SETTINGS
@given(
    seed=st.integers(0, 10_000),
    fingers=st.integers(1, 4),
    spheres=st.integers(1, 40),
    spread=st.floats(0.01, 0.1),
    k=st.integers(0, 2),
)
def test_counting_kernels_match_every_point(seed, fingers, spheres, spread, k):
    """Points held per finger, counted through the depth grid and its sphere
    lists, through a slab, or point by point, are the counts of the exact test
    of every point against every sphere, for random sphere sets (3-30 mm) and
    translations."""
    g = _hand(seed, fingers, spheres)
    sp = FingerSpheres(g)
    depth = FingerDepth(g.sphere_centers, g.sphere_radii, g.sphere_finger, fingers)
    rng = np.random.default_rng(seed)
    q, n, m = 3, 150, 24
    Q = rng.normal([0.0, 0.0, 0.1], spread, (q, n, 3)).transpose(0, 2, 1)
    ol = np.sort(rng.integers(0, q, m))
    u = rng.normal(0.0, 0.3 * spread, (m, 3))
    p = Q[ol].transpose(0, 2, 1) - u[:, None, :]  # (m, n, 3) gripper frame
    d2 = ((p[:, :, None, :] - g.sphere_centers) ** 2).sum(-1)  # (m, n, s)
    inside = d2 < g.sphere_radii**2
    truth = np.stack(
        [inside[..., g.sphere_finger == f].any(-1) for f in range(fingers)], -1
    ).sum(axis=1)  # (m, nf)
    cand = np.arange(m)
    np.testing.assert_array_equal(_count_depth(depth, sp, Q, ol, u, cand), truth)
    np.testing.assert_array_equal(_count_every_point(sp, Q, ol, u, cand), truth)
    lo, hi = _finger_boxes(g)
    got = _count_in_slab(_Slabs(Q), ol, u, cand, sp, k, lo, hi)
    np.testing.assert_array_equal(got, truth)
    # a subset of the candidates, in any order
    some = rng.permutation(m)[: m // 2]
    np.testing.assert_array_equal(_count_depth(depth, sp, Q, ol, u, some), truth[some])


@SETTINGS
@given(
    seed=st.integers(0, 10_000),
    fingers=st.integers(1, 4),
    spheres=st.integers(1, 40),
)
def test_sphere_lists_hold_every_sphere_that_can_hold_a_point(seed, fingers, spheres):
    """At a point whose nearest node the depth grid leaves unsure for a finger,
    every sphere of that finger holding the point is in the node's list."""
    g = _hand(seed, fingers, spheres)
    depth = FingerDepth(g.sphere_centers, g.sphere_radii, g.sphere_finger, fingers)
    node_id, lists, centers, radii = depth.sphere_lists()
    rng = np.random.default_rng(seed)
    # points near the spheres' surfaces, where nodes are unsure
    s = rng.integers(0, len(g.sphere_radii), 4000)
    v = rng.normal(size=(4000, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    r = g.sphere_radii[s] * rng.uniform(0.9, 1.1, 4000)
    pts = g.sphere_centers[s] + v * r[:, None]  # (n, 3)
    Q, ol, u = pts.T[None], np.zeros(1, dtype=np.int64), np.zeros((1, 3))
    flat = depth.nodes_at(Q, ol, u)[0]  # (n,)
    code = depth.codes[flat]
    open_f = depth.unsure_fingers[code]  # (n, nf)
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


@SETTINGS
@given(
    seed=st.integers(0, 10_000),
    rotvec=ROTVEC,
    shift=SHIFT,
    n_orient=st.integers(1, 30),
)
def test_lowest_heights_are_the_clouds_lowest_points(seed, rotvec, shift, n_orient):
    """The lowest gripper-cloud point above the table from the per-orientation
    support vertex is the lowest of every cloud point, to rounding."""
    g = make_jaw_gripper(seed=seed)
    obj, T_wo, samples, R, depth, _, table = _scene(
        seed, _frame(rotvec, shift), n_orient, False
    )
    _, T_wg, _, _ = candidate_poses(T_wo, samples, R, g.T_gripper_gwc, depth)
    poses = StructuredPoses.build(
        CandidateStructure(T_wo, samples, R, depth), g.T_gripper_gwc
    )
    rng = np.random.default_rng(seed)
    index = np.sort(rng.choice(len(T_wg), min(len(T_wg), 50), replace=False))
    got = lowest_heights(poses, hull_vertices(g.cloud), table, index)
    T = np.linalg.inv(table.T_world_table) @ T_wg[index]
    z = np.einsum("cj,nj->cn", T[:, 2, :3], g.cloud) + T[:, 2, 3][:, None]
    np.testing.assert_allclose(got, z.min(axis=1), rtol=0, atol=1e-12)


@SETTINGS
@given(seed=st.integers(0, 10_000), n_orient=st.integers(1, 30))
def test_box_separation_per_orientation_matches_per_candidate(seed, n_orient):
    """The object-box test from per-orientation products gives the verdicts of
    the per-candidate boxes."""
    g = make_jaw_gripper(seed=seed)
    obj, T_wo, samples, R, depth, _, _ = _scene(seed, np.eye(4), n_orient, False)
    poses = StructuredPoses.build(
        CandidateStructure(T_wo, samples, R, depth), g.T_gripper_gwc
    )
    C = len(samples) * len(R)
    s, o = np.divmod(np.arange(C), len(R))
    Q = np.matmul(poses.R.transpose(0, 2, 1), obj.T)  # (O, 3, no)
    lo, hi = Q.min(axis=2), Q.max(axis=2)
    u = np.matmul((poses.A[s] + poses.B[o])[:, None, :], poses.R[o])[:, 0]
    se_lo, se_hi = g.se_centers - g.se_semi_axes, g.se_centers + g.se_semi_axes
    want = _object_box_clear(lo[o], hi[o], u, se_lo, se_hi)
    got = _boxes_clear(poses, s, o, lo, hi, se_lo, se_hi)
    np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize(
    ("spec", "sampling"),
    [
        ("allegro.yaml", None),  # its 1,200 candidates: the slab and grid paths
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
    """With numba installed, a test of many pairs runs the compiled loops at
    once; a small one runs numpy's until a process has done
    ``_SMALL_BEFORE_LOADING`` of them, or the loops are loaded, and a tiny one
    (below ``_SMALL_FROM`` pairs) until they are loaded; without numba, numpy's
    always."""
    N = _dense_numba
    monkeypatch.setattr(N, "_AVAILABLE", True)
    monkeypatch.setattr(N, "_compiled_body", None)
    monkeypatch.setattr(N, "_compiled_count", None)
    monkeypatch.setattr(dense, "_small_searches", 0)
    small = dense._COMPILED_FROM - 1
    before = dense._SMALL_BEFORE_LOADING
    tiny = dense._SMALL_FROM - 1  # never worth loading for, never counted
    assert not any(dense._use_compiled(t) for t in [0, tiny] * (before + 1))
    assert [dense._use_compiled(small) for _ in range(before + 2)] == (
        [False] * before + [True, True]
    )
    monkeypatch.setattr(dense, "_small_searches", 0)
    assert dense._use_compiled(dense._COMPILED_FROM)  # many: at once
    assert dense._small_searches == 0  # and not counted as a small one
    assert not dense._use_compiled(small)
    # loaded (here as the plain Python loops): every test from then on
    monkeypatch.setattr(N, "_compiled_body", N._body_loop)
    monkeypatch.setattr(N, "_compiled_count", N._count_loop)
    assert N.loaded() and dense._use_compiled(0)
    monkeypatch.setattr(N, "_AVAILABLE", False)
    assert not dense._use_compiled(dense._COMPILED_FROM)


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
        "from wsgrasp.planning import _dense_numba as N; "
        "print(N.available(), 'numba' in sys.modules)"
    )
    env = {k: v for k, v in os.environ.items() if k != "WSGRASP_NUMBA"}
    env["PYTHONPATH"] = str(tmp_path)
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["True", "False"]
