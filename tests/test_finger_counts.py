"""Grippers with any number of fingers. Synthetic hands of 2, 3, 5 and 6 fingers
(``hand_factory``) get the loop-by-loop reference's verdicts from every search
kernel, small and dense, numpy and compiled; five- and six-finger hands plan,
record and draw end to end; a one-finger description is refused."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from hand_factory import hand_yaml, write_hand
from search_kernels import KERNELS, force, loops
from typer.testing import CliRunner
from wsgrasp_scorers import CentroidDistanceScorer

from wsgrasp.api import Pipeline
from wsgrasp.cli import app
from wsgrasp.errors import SpecError, WsgraspError
from wsgrasp.gripper import load_gripper
from wsgrasp.gripper.model import GripperModel
from wsgrasp.perception.types import Scene, View
from wsgrasp.planning import _compiled
from wsgrasp.planning._grids import FingerDepth
from wsgrasp.planning.candidates import candidate_poses, orientation_set
from wsgrasp.planning.evaluate import CandidateStructure, TableSE, evaluate_candidates
from wsgrasp.planning.reference import reference_search
from wsgrasp.planning.search import SearchInput, run_search
from wsgrasp.record import RunRecorder, compare_results, open_run
from wsgrasp.spec import (
    GripperDescription,
    Sampling,
    load_gripper_description,
    load_spec,
)
from wsgrasp.view._gripper import finger_colour, render_gripper

FINGERS = (2, 3, 5, 6)
#: a few candidates and more (more approach directions over the half-sphere,
#: two depths, an obstacle beside the object)
SAMPLINGS = {
    "small": {"mode": "approach_sphere", "directions": 3, "orientations": 2},
    "dense": {
        "mode": "approach_sphere",
        "directions": 6,
        "orientations": 4,
        "depths": 2,
    },
}


@pytest.fixture(scope="module")
def hands(
    tmp_path_factory: pytest.TempPathFactory,
) -> dict[int, tuple[Path, GripperModel]]:
    """Each hand's YAML and model, built once into a fresh cache."""
    root = tmp_path_factory.mktemp("hands")
    out = {}
    for n in FINGERS:
        path = write_hand(root / f"hand{n}", n)
        out[n] = (path, load_gripper(path, cache_dir=root / "cache"))
    return out


def _cylinder(radius: float, height: float, n: int, seed: int) -> np.ndarray:
    """Surface points of an upright cylinder standing on z = 0, with its top: (n, 3)."""
    rng = np.random.default_rng(seed)
    k = n // 5
    a = rng.uniform(0.0, 2.0 * np.pi, n - k)
    side = np.c_[radius * np.cos(a), radius * np.sin(a), rng.uniform(0, height, n - k)]
    r, b = radius * np.sqrt(rng.uniform(0.0, 1.0, k)), rng.uniform(0.0, 2.0 * np.pi, k)
    top = np.c_[r * np.cos(b), r * np.sin(b), np.full(k, height)]
    return np.vstack([side, top])


def _held_truth(g: GripperModel, T_world_gripper: np.ndarray, points: np.ndarray):
    """Every point against every sphere, per candidate: (C, no, nf) bool."""
    out = np.zeros((len(T_world_gripper), len(points), g.num_fingers), dtype=bool)
    for c, T in enumerate(T_world_gripper):
        p = (points - T[:3, 3]) @ T[:3, :3]  # (no, 3) gripper frame
        d2 = ((p[:, None, :] - g.sphere_centers[None]) ** 2).sum(-1)  # (no, S)
        inside = d2 < g.sphere_radii**2
        for f in range(g.num_fingers):
            out[c, :, f] = inside[:, g.sphere_finger == f].any(axis=1)
    return out


def _cylinder_case(g: GripperModel, n: int, sampling: str):
    """A search of ``g`` around a 4.4 cm x 15 cm cylinder: its points, frame,
    the table, 40 random samples, the orientations of ``SAMPLINGS[sampling]``
    and the candidates' poses."""
    obj = _cylinder(0.022, 0.15, 200, seed=n)
    T_world_object = np.eye(4)
    T_world_object[:3, 3] = obj.mean(axis=0)
    table = TableSE(
        np.eye(4), np.array([0, 0, -0.05]), np.array([0.35] * 2 + [0.05]), 10.0
    )
    rng = np.random.default_rng(n)
    samples = rng.uniform([-0.02, -0.02, -0.07], [0.02, 0.02, 0.07], (40, 3))
    o = orientation_set(
        Sampling(**SAMPLINGS[sampling]),
        T_world_object,
        np.array([0, 0, 1.0]),
        (-0.03, 0.02),
    )
    _, T_wg, _, _ = candidate_poses(
        T_world_object, samples, o.R_object_gwc, g.T_gripper_gwc, o.depth
    )
    return obj, T_world_object, table, samples, o, T_wg


def _check_kernel(g, case, obs, ref, monkeypatch: pytest.MonkeyPatch, kernel: str):
    """``kernel``'s verdicts on ``case`` (:func:`_cylinder_case`) with obstacle
    points ``obs``: the reference's ``ref`` reasons, contacts, feasible set and
    choice, and the holdings every point against every sphere gives."""
    obj, T_world_object, table, samples, o, T_wg = case
    force(monkeypatch, kernel)
    structure = CandidateStructure(T_world_object, samples, o.R_object_gwc, o.depth)
    ev = evaluate_candidates(T_wg, g, obj, obs, table, structure=structure)
    np.testing.assert_array_equal(ev.reason, ref.reason)
    np.testing.assert_array_equal(ev.contacts, ref.contacts)
    np.testing.assert_array_equal(ev.feasible, np.flatnonzero(ref.reason == 0))
    np.testing.assert_array_equal(ev.holding, _held_truth(g, T_wg[ev.feasible], obj))
    out = run_search(
        SearchInput(
            g, T_world_object, np.ptp(obj, axis=0), samples, o, obj, obs, table
        ),
        [("centroid_distance", CentroidDistanceScorer(), None, 1.0)],
    )
    assert out.best == ref.best


@pytest.mark.parametrize("kernel", KERNELS)
@pytest.mark.parametrize("sampling", list(SAMPLINGS))
@pytest.mark.parametrize("n", FINGERS, ids=lambda n: f"{n}fingers")
def test_search_verdicts_equal_the_reference(
    hands, monkeypatch: pytest.MonkeyPatch, n: int, sampling: str, kernel: str
) -> None:
    """Rejection reasons, contacts, the feasible set, the holdings and the
    chosen candidate are the loop-by-loop reference's, for every kernel."""
    g = hands[n][1]
    case = _cylinder_case(g, n, sampling)
    obj, T_world_object, table, samples, o, _ = case
    obs = (
        _cylinder(0.02, 0.1, 80, seed=n + 1) + [0.075, 0.0, 0.0]
        if sampling == "dense"
        else np.zeros((0, 3))
    )
    ref = reference_search(
        g, T_world_object, samples, o.R_object_gwc, obj, obs, table, o.depth
    )
    assert (ref.reason == 0).any() and (ref.reason == 2).any(), "a scene that decides"
    _check_kernel(g, case, obs, ref, monkeypatch, kernel)


@pytest.fixture(scope="module")
def rigid_jaw(tmp_path_factory: pytest.TempPathFactory) -> GripperModel:
    """A moving jaw and a rigid one (``urdf_factory.rigid_jaw_urdf``),
    scaffolded, built into a fresh cache."""
    from urdf_factory import rigid_jaw_urdf

    from wsgrasp.gripper.scaffold import scaffold_plugin

    root = tmp_path_factory.mktemp("rigid")
    (root / "rj.urdf").write_text(rigid_jaw_urdf())
    yaml_path, _ = scaffold_plugin("rj", root / "rj.urdf", root / "pkg")
    return load_gripper(str(yaml_path), cache_dir=root / "cache")


@pytest.mark.parametrize("kernel", KERNELS)
@pytest.mark.parametrize("sampling", list(SAMPLINGS))
def test_rigid_jaw_verdicts_equal_the_reference(
    rigid_jaw: GripperModel, monkeypatch: pytest.MonkeyPatch, sampling: str, kernel: str
) -> None:
    """A finger with no joints (a rigid jaw, its spheres filling its pad box)
    gets the loop-by-loop reference's verdicts from every kernel."""
    g = rigid_jaw
    case = _cylinder_case(g, 2, sampling)
    obj, T_world_object, table, samples, o, _ = case
    obs = np.zeros((0, 3))
    ref = reference_search(
        g, T_world_object, samples, o.R_object_gwc, obj, obs, table, o.depth
    )
    assert (ref.reason == 0).any() and (ref.reason == 2).any(), "a scene that decides"
    _check_kernel(g, case, obs, ref, monkeypatch, kernel)


@pytest.mark.parametrize("nf", [1, 5, 6, 12])
def test_depth_grid_counts_any_number_of_fingers(nf: int) -> None:
    """The depth grid and the count loop give each finger's exact holdings for
    random overlapping spheres of up to 12 fingers (3**12 combinations of
    states: the grid renumbers them as it goes)."""
    rng = np.random.default_rng(nf)
    s = 8
    centers = rng.uniform([-0.03, -0.03, 0.0], [0.03, 0.03, 0.04], (nf * s, 3))
    radii = rng.uniform(0.004, 0.02, nf * s)
    finger = np.repeat(np.arange(nf), s)
    depth = FingerDepth(centers, radii, finger, nf)
    q, n, m = 3, 300, 15
    Q = rng.normal([0.0, 0.0, 0.02], 0.03, (q, n, 3)).transpose(0, 2, 1).copy()
    ol = np.sort(rng.integers(0, q, m))
    u = rng.normal(0.0, 0.005, (m, 3))
    p = Q[ol].transpose(0, 2, 1) - u[:, None, :]  # (m, n, 3) gripper frame
    inside = ((p[:, :, None, :] - centers) ** 2).sum(-1) < radii**2  # (m, n, S)
    held = np.stack([inside[..., finger == f].any(-1) for f in range(nf)], -1)
    for loop, _ in loops():
        out = np.ones((m, n, nf), dtype=bool)
        counts = _compiled.count_by_fingers(depth, Q, ol, u, loop, None, out, None)
        np.testing.assert_array_equal(counts, held.sum(axis=1))
        np.testing.assert_array_equal(out, held)


def test_one_finger_is_refused(tmp_path: Path) -> None:
    """A one-finger description fails validation with one message naming the
    gripper, the finger found and the fix: from its YAML (with the file and
    line), as a plan loads it, and built in code."""
    path = write_hand(tmp_path, 1, name="pointer")
    for load in (
        load_gripper_description,
        lambda p: load_gripper(p, cache_dir=tmp_path),
    ):
        with pytest.raises(SpecError) as err:
            load(path)
        assert isinstance(err.value, WsgraspError)
        text = str(err.value)
        assert "'pointer'" in text and "1 finger ('f0')" in text
        assert "a grasp needs at least two opposing fingers" in text
        assert str(path) in text  # the file, with the line of `fingers:`
    data = yaml.safe_load(path.read_text())
    with pytest.raises(SpecError, match="'pointer' describes 1 finger"):
        GripperDescription.model_validate(data)  # built in code, not from a file
    text = hand_yaml(2, "hand1.urdf", "none")
    head, tail = text.split("fingers:\n")[0], text.split("joint_samples:")[1]
    empty = f"{head}fingers: []\njoint_samples:{tail}"
    (tmp_path / "none.yaml").write_text(empty)
    with pytest.raises(SpecError, match="describes 0 fingers"):
        load_gripper_description(tmp_path / "none.yaml")


def _scene(seed: int = 0, radius: float = 0.022, height: float = 0.15) -> Scene:
    """An upright cylinder (4.4 cm x 15 cm unless given) on a 40 cm table, one
    camera's view."""
    rng = np.random.default_rng(seed)
    table = np.c_[rng.uniform(-0.2, 0.2, (3000, 2)), np.zeros(3000)]
    points = np.vstack([table, _cylinder(radius, height, 1800, seed)])
    points += rng.normal(0.0, 0.0005, points.shape)
    return Scene(
        views=[View(points=points, T_world_camera=np.eye(4), name="cam")],
        points=points,
        dropped_nonfinite=0,
    )


#: the built-in scorers that read the fingers' contacts
CONTACT_SCORERS = [
    "contact_balance",
    "antipodal",
    "joint_margin",
    "mass_center",
    "wrench_balance",
    "contact_depth",
    "squeeze_inward",
]


def _hand_spec(path: Path, weights: dict[str, float], **fields: object):
    """A spec for the hand at ``path``: approach directions over the
    half-sphere on a 3 x 3 x 3 grid, the scorers ``weights``, and ``fields``."""
    return load_spec(
        {
            "gripper": str(path),
            "segmenter": {"name": "ransac_dbscan"},
            "sampling": {
                "mode": "approach_sphere",
                "grid": [3, 3, 3],
                "directions": 6,
                "orientations": 4,
            },
            "scorers": [{"name": s, "weight": w} for s, w in weights.items()],
            **fields,
        }
    )


@pytest.mark.parametrize("n", [5, 6], ids=lambda n: f"{n}fingers")
def test_plan_records_and_draws(hands, tmp_path: Path, n: int) -> None:
    """A five- or six-finger hand plans a grasp (approach directions over the
    half-sphere, every built-in scorer) with a contact and joint targets per
    finger; the run's recording reads back the same result and draws as a PNG,
    and the hand's own picture gives each finger a colour of its own."""
    path, g = hands[n]
    scorers = ["centroid_distance", *CONTACT_SCORERS, "table_clearance"]
    spec = _hand_spec(path, {s: 1.0 for s in [*scorers, "approach_direction"]})
    run = tmp_path / "run.mcap"
    result = Pipeline(spec, gripper=g).plan(_scene(), observers=[RunRecorder(run)])
    assert result.found, result.hint
    assert sorted(c.finger for c in result.contacts) == sorted(g.finger_names)
    assert all(len(c.points) > 0 for c in result.contacts)
    assert len(result.finger_targets) == n
    assert set(result.joints_grasp) == {
        f"f{i}_{j}" for i in range(n) for j in ("base", "tip")
    }
    back = open_run(run)
    assert back.status == "ok" and back.result is not None
    assert compare_results(result, back.result) == []
    png = tmp_path / "run.png"
    res = CliRunner().invoke(app, ["view", str(run), "-o", str(png)])
    assert res.exit_code == 0, res.stdout
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    picture = render_gripper(g, tmp_path / "hand.png")
    assert Path(picture).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert len({finger_colour(f) for f in range(max(n, 12))}) == max(n, 12)


#: per hand, the fingers a grasp needs in the tests of ``contact_fingers``
CONTACT = {5: ["f0", "f2", "f3"], 6: ["f0", "f3"]}


@pytest.fixture(scope="module")
def tripods(
    tmp_path_factory: pytest.TempPathFactory,
) -> dict[int, tuple[Path, GripperModel]]:
    """The five- and six-finger hands with ``contact_fingers`` (:data:`CONTACT`)."""
    root = tmp_path_factory.mktemp("tripods")
    out = {}
    for n, names in CONTACT.items():
        path = write_hand(root / f"hand{n}", n, name=f"tripod{n}")
        path.write_text(path.read_text() + f"contact_fingers: [{', '.join(names)}]\n")
        out[n] = (path, load_gripper(path, cache_dir=root / "cache"))
    return out


@pytest.mark.parametrize("kernel", KERNELS)
@pytest.mark.parametrize("n", sorted(CONTACT), ids=lambda n: f"{n}fingers")
def test_contact_fingers_verdicts_equal_the_reference(
    hands, tripods, monkeypatch: pytest.MonkeyPatch, n: int, kernel: str
) -> None:
    """With ``contact_fingers``, a candidate is feasible when those fingers hold
    object points, whatever the others hold: every kernel gives the reference's
    verdicts and choice; the feasible set holds every candidate the hand that
    needs all its fingers finds, and more, some with a finger holding none."""
    g, g_all = tripods[n][1], hands[n][1]
    np.testing.assert_array_equal(
        g.contact_fingers, [f in CONTACT[n] for f in g.finger_names]
    )
    case = _cylinder_case(g, n, "dense")
    obj, T_world_object, table, samples, o, _ = case
    obs = np.zeros((0, 3))
    ref = reference_search(
        g, T_world_object, samples, o.R_object_gwc, obj, obs, table, o.depth
    )
    ref_all = reference_search(
        g_all, T_world_object, samples, o.R_object_gwc, obj, obs, table, o.depth
    )
    np.testing.assert_array_equal(ref.contacts, ref_all.contacts)
    feasible, feasible_all = ref.reason == 0, ref_all.reason == 0
    assert feasible_all.any() and not (feasible_all & ~feasible).any()
    extra = feasible & ~feasible_all
    assert extra.any(), "a scene where the rule decides"
    assert (ref.contacts[extra] == 0).any(axis=1).all()
    assert (ref.contacts[feasible][:, g.contact_fingers] > 0).all()
    _check_kernel(g, case, obs, ref, monkeypatch, kernel)


def test_a_finger_that_holds_nothing_closes_to_closed(tripods, tmp_path) -> None:
    """A plan whose chosen grasp leaves a finger outside ``contact_fingers``
    without a contact: every scorer gives finite scores in [0, 1] (the
    contact terms over the fingers that hold points), that finger's target has
    no contact posture and closes to its ``closed`` posture, the others have
    theirs; the result's JSON carries it, and its recording reads back the
    same result and draws."""
    path, g = tripods[5]
    scorers = ["centroid_distance", *CONTACT_SCORERS]
    weights = {"centroid_distance": 1.0, **{s: 0.0 for s in CONTACT_SCORERS}}
    spec = _hand_spec(path, weights, approach={"close_to": "contacts"})
    pipe = Pipeline(spec, gripper=g)
    thin = _scene(radius=0.012, height=0.06)  # narrower than the hand's fingers
    result = pipe.plan(thin)
    assert result.found, result.hint
    cands = result.candidates
    feasible = cands.reason == 0
    for name in scorers:
        v = cands.terms[name][feasible]
        assert np.isfinite(v).all() and (v >= 0).all() and (v <= 1).all(), name
    # a grasp with a free finger: plan it
    free = np.flatnonzero(feasible & (cands.contacts == 0).any(axis=1))
    assert len(free), "a scene with grasps that leave a finger free"
    run = tmp_path / "free.mcap"
    choice = pipe.plan(thin, choose=int(free[0]), observers=[RunRecorder(run)])
    back = open_run(run)
    assert back.status == "ok" and back.result is not None
    assert compare_results(choice, back.result) == []
    png = tmp_path / "free.png"
    res = CliRunner().invoke(app, ["view", str(run), "-o", str(png)])
    assert res.exit_code == 0, res.stdout
    targets = {t["finger"]: t for t in choice.finger_targets}
    missing = [c.finger for c in choice.contacts if len(c.points) == 0]
    assert missing and not set(missing) & set(CONTACT[5])
    for name in missing:
        t = targets[name]
        assert t["contact"] == {} and t["gap"] is None
        f = g.finger_names.index(name)
        for j in g.finger_joints[f]:
            assert t["grasp"][j] == pytest.approx(g.closed[j])
            assert choice.joints_grasp[j] == pytest.approx(g.closed[j])
    for name in CONTACT[5]:
        assert targets[name]["contact"] and targets[name]["gap"] is not None
    assert json.loads(json.dumps(choice.to_json()))["finger_targets"]


def test_contact_fingers_must_name_fingers(tmp_path: Path) -> None:
    """``contact_fingers`` naming no finger, one twice, or fewer than two is
    refused with the field and the fingers."""
    path = write_hand(tmp_path, 5)
    base = yaml.safe_load(path.read_text())
    for value, words in (
        (["f0", "thumb"], "thumb"),
        (["f0", "f0"], "twice"),
        (["f0"], "at least 2"),
    ):
        bad = tmp_path / "bad.yaml"
        bad.write_text(yaml.safe_dump({**base, "contact_fingers": value}))
        with pytest.raises(SpecError) as err:
            load_gripper_description(bad)
        assert "contact_fingers" in str(err.value) and words in str(err.value)
