"""The fingers' closing sweeps stay out of the table until they reach the object.

The gripper here is a two-finger claw written by the test: each finger hangs from
a hinge at the palm's side and swings from pointing outwards (pre-grasp) down
through pointing along the approach to pointing inwards (closed), like the
D'Claw's; its tip lies 3 cm beyond the pad centre, so that the tips sweep
3 cm deeper than the pads do.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from wsgrasp.api import Pipeline, as_scene
from wsgrasp.gripper import load_gripper
from wsgrasp.gripper.check import check_gripper
from wsgrasp.gripper.model import GripperModel
from wsgrasp.planning.candidates import candidate_poses
from wsgrasp.planning.closing import (
    BACK_OFF_STEPS,
    closing_paths,
    finger_sweep,
)
from wsgrasp.planning.result import REASONS
from wsgrasp.planning.sweeps import GRAZE_SLACK, SWEEP_SLACK, slides, sweep_back_offs
from wsgrasp.spec import load_spec

#: hinge offset from the palm's axis and above its base; finger length; pad
#: centre's distance from the hinge (m)
HINGE_X, HINGE_Z, LENGTH, PAD_AT = 0.035, 0.02, 0.08, 0.05
TABLE = np.eye(4)  # surface z = 0, normal +z
SWEPT = REASONS.index("finger_sweeps_table")
#: a finger this near (m) an object point has reached it, for the loop-by-loop
#: checks of plans (above the planner's own reach, its points' spacing)
NEAR = 0.015


def _box_link(name: str, length: float) -> str:
    return (
        f'<link name="{name}"><collision><origin xyz="{length / 2} 0 0" rpy="0 0 0"/>'
        f'<geometry><box size="{length} 0.02 0.012"/></geometry></collision></link>'
    )


def _finger(i: int, side: float, knuckle: bool) -> str:
    yaw = 0.0 if side > 0 else np.pi  # the -x finger: the +x one turned about z
    hinge = f"""<joint name="j{i}" type="revolute">
    <parent link="palm"/><child link="f{i}"/>
    <origin xyz="{side * HINGE_X} 0 {HINGE_Z}" rpy="0 0 {yaw:.12f}"/>
    <axis xyz="0 -1 0"/>
    <limit lower="0" upper="2.6" effort="5" velocity="1"/>
  </joint>"""
    if not knuckle:
        return f"{_box_link(f'f{i}', LENGTH)}\n  {hinge}"
    # the same finger in two links, the outer one on a joint of its own at the pad
    return f"""{_box_link(f"f{i}", PAD_AT)}
  {hinge}
  {_box_link(f"t{i}", LENGTH - PAD_AT)}
  <joint name="k{i}" type="revolute">
    <parent link="f{i}"/><child link="t{i}"/>
    <origin xyz="{PAD_AT} 0 0" rpy="0 0 0"/><axis xyz="0 -1 0"/>
    <limit lower="0" upper="0.5" effort="5" velocity="1"/>
  </joint>"""


def write_claw(
    folder: Path, knuckles: bool = False, on_table: str | None = None
) -> Path:
    """Write the claw's URDF and gripper YAML into ``folder``; the YAML's path.

    Approach +z; at joint angle 0 a finger points outwards along x, at pi/2
    along the approach, at 2.6 inwards and back up; the pad is the inner face
    of the finger ``PAD_AT`` from the hinge. With ``knuckles`` each finger is
    two links, the outer one on a second joint at the pad (held straight while
    the finger closes): the same sweeps, from fingers that two joints drive.
    ``on_table`` is written into each finger's description where given."""
    folder.mkdir(parents=True, exist_ok=True)
    palm = (
        '<collision><origin xyz="0 0 0.01" rpy="0 0 0"/>'
        '<geometry><box size="0.08 0.04 0.02"/></geometry></collision>'
    )
    (folder / "claw.urdf").write_text(
        '<?xml version="1.0"?>\n<robot name="claw">\n'
        f'  <link name="palm">{palm}</link>\n'
        f"  {_finger(0, 1.0, knuckles)}\n  {_finger(1, -1.0, knuckles)}\n"
        "</robot>\n"
    )
    if knuckles:
        pads = [(f"t{i}", 0.0) for i in range(2)]
        joints = [f"[j{i}, k{i}]" for i in range(2)]
        posture = "j0: {a}, j1: {a}, k0: 0.0, k1: 0.0"
    else:
        pads = [(f"f{i}", PAD_AT) for i in range(2)]
        joints = [f"[j{i}]" for i in range(2)]
        posture = "j0: {a}, j1: {a}"
    fingers = "".join(
        f"  - name: f{i}\n    joints: {joints[i]}\n    pad: {{link: {link}, center: "
        f"[{x}, 0.0, 0.006], size: [0.02, 0.016, 0.0], samples: 5}}\n"
        + (f"    on_table: {on_table}\n" if on_table else "")
        for i, (link, x) in enumerate(pads)
    )
    path = folder / "claw.yaml"
    path.write_text(
        "version: 1\nname: claw\nurdf: claw.urdf\nbase_link: palm\n"
        "tool_frame: {link: palm, xyz: [0.0, 0.0, 0.08]}\n"
        "approach_axis: [0.0, 0.0, 1.0]\nclosing_axis: [1.0, 0.0, 0.0]\n"
        "fingers:\n" + fingers + "joint_samples: 24\nspheres_per_finger: 10\n"
        "workspace_voxel: 0.003\nmin_sphere_radius: 0.003\n"
        "ellipsoids: {count: 3, exponent: 10.0}\ncloud_points: 300\n"
        f"pregrasp: {{{posture.format(a=0.2)}}}\nclosed: {{{posture.format(a=2.6)}}}\n"
    )
    return path


@pytest.fixture(scope="module")
def claw_yaml(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_claw(tmp_path_factory.mktemp("claw"))


@pytest.fixture(scope="module")
def claw(claw_yaml: Path) -> GripperModel:
    return load_gripper(claw_yaml, cache_dir=claw_yaml.parent / "cache")


def _top_down(height: float) -> np.ndarray:
    """Approaching straight down (gripper z to world -z), the palm's base
    ``height`` above the table."""
    T = np.diag([1.0, -1.0, -1.0, 1.0])
    T[2, 3] = height
    return T


def _slab(top: float, half: float) -> np.ndarray:
    """Points on the top and sides of a slab ``2 half`` wide along x, 6 cm along
    y, ``top`` tall, on the table, 3 mm apart: (n, 3)."""
    u = np.arange(-half, half + 1e-9, 0.003)
    v = np.arange(-0.03, 0.03 + 1e-9, 0.003)
    w = np.arange(0.0, top + 1e-9, 0.003)
    U, V = np.meshgrid(u, v)
    top_face = np.column_stack([U.ravel(), V.ravel(), np.full(U.size, top)])
    Vs, Ws = np.meshgrid(v, w)
    sides = [
        np.column_stack([np.full(Vs.size, s * half), Vs.ravel(), Ws.ravel()])
        for s in (-1.0, 1.0)
    ]
    return np.concatenate([top_face, *sides])


def _column(top: float) -> np.ndarray:
    """A block 2 cm wide along x, ``top`` tall, under the palm's middle: the
    fingers reach it only as they swing back inwards, after their lowest point."""
    return _slab(top, 0.01)


def _enters_before_reaching(
    g: GripperModel, T: np.ndarray, object_points: np.ndarray, reach: float
) -> list[bool]:
    """Loop by loop, per finger: whether its sweep, posed at ``T``, dips more
    than ``SWEEP_SLACK`` below the table before (or at the posture where) any
    of its points first comes within ``reach`` of an object point."""
    sweep = finger_sweep(g)
    tree = cKDTree(object_points) if len(object_points) else None
    out = []
    for f in range(sweep.shape[0]):
        entered = reached = None
        for k in range(sweep.shape[1]):
            p = sweep[f, k] @ T[:3, :3].T + T[:3, 3]
            if reached is None and tree is not None:
                if tree.query(p)[0].min() <= reach:
                    reached = k
            if entered is None and p[:, 2].min() < -SWEEP_SLACK:
                entered = k
        out.append(entered is not None and (reached is None or entered <= reached))
    return out


def _lowest(g: GripperModel, T: np.ndarray) -> float:
    """The lowest height any finger's sweep reaches at ``T``."""
    sweep = finger_sweep(g).reshape(-1, 3)
    return float((sweep @ T[:3, :3].T + T[:3, 3])[:, 2].min())


# ------------------------------------------------------------------------------
# the model keeps the sweeps
# ------------------------------------------------------------------------------
def test_the_model_keeps_each_fingers_sweep_from_pregrasp_to_closed(claw):
    sweep = finger_sweep(claw)
    nf, K, P, _ = sweep.shape
    assert (nf, P) == (2, claw.finger_sweep.shape[2]) and K >= 16 and P >= 64
    # the pad centre's path is among the points, from pre-grasp to closed
    paths = closing_paths(claw)  # (nf, K, 3)
    np.testing.assert_allclose(sweep[:, :, 0], paths, atol=2e-4)  # paths interpolate
    # the tips swing 3 cm deeper along the approach than the pads
    depth = sweep @ claw.approach_axis  # (nf, K, P)
    pad_depth = paths @ claw.approach_axis  # (nf, K)
    beyond = depth.max(axis=(1, 2)) - pad_depth.max(axis=1)
    np.testing.assert_allclose(beyond, LENGTH - PAD_AT, atol=0.004)
    # the file keeps them exactly (float32 values, as built)
    again = GripperModel.from_bytes(claw.to_bytes())
    np.testing.assert_array_equal(again.finger_sweep, claw.finger_sweep)


def test_a_model_without_sweeps_uses_its_pad_centres(claw):
    from dataclasses import replace

    old = GripperModel.from_bytes(
        replace(claw, finger_sweep=np.zeros((0, 0, 0, 3))).to_bytes()
    )
    assert not old.has_sweeps
    assert finger_sweep(old).shape == (2, closing_paths(old).shape[1], 1, 3)
    # its pads stay above the table where the claw's tips do not
    T = _top_down(0.09)
    assert sweep_back_offs(old, T[None], TABLE, _column(0.06))[0] == 0.0
    assert sweep_back_offs(claw, T[None], TABLE, _column(0.06))[0] > 0.0


# ------------------------------------------------------------------------------
# one pose at a time
# ------------------------------------------------------------------------------
def test_sweeps_that_clear_the_table_are_untouched(claw):
    T = _top_down(0.15)
    assert _lowest(claw, T) > 0.0
    assert sweep_back_offs(claw, T[None], TABLE, _column(0.12))[0] == 0.0


def test_tips_beyond_the_pads_back_off_where_the_pads_alone_would_not(claw):
    T = _top_down(0.09)
    # the pads' paths stay above the table, the tips' do not
    pads = closing_paths(claw).reshape(-1, 3) @ T[:3, :3].T + T[:3, 3]
    assert pads[:, 2].min() >= 0.0
    assert _lowest(claw, T) < -SWEEP_SLACK
    d = sweep_back_offs(claw, T[None], TABLE, _column(0.06))[0]
    assert d in BACK_OFF_STEPS and d > 0.0
    back = T.copy()
    back[2, 3] += d  # backed off along the approach: up
    assert _lowest(claw, back) >= -SWEEP_SLACK
    less = T.copy()
    less[2, 3] += d - 0.005  # the step before does not clear
    assert _lowest(claw, less) < -SWEEP_SLACK


def test_fingers_that_several_joints_drive_may_graze_the_table(tmp_path):
    # the same claw with a second joint in each finger: where the table pushes
    # on a tip its joints give way and it slides, so a graze needs no back-off
    knuckled = load_gripper(
        write_claw(tmp_path, knuckles=True), cache_dir=tmp_path / "cache"
    )
    assert [len(j) for j in knuckled.finger_joints] == [2, 2]
    column = _column(0.05)
    T = _top_down(0.095)
    assert -GRAZE_SLACK < _lowest(knuckled, T) < -SWEEP_SLACK
    assert sweep_back_offs(knuckled, T[None], TABLE, column)[0] == 0.0
    # deeper than a graze: backed off until it is one
    T = _top_down(0.07)
    d = sweep_back_offs(knuckled, T[None], TABLE, column)[0]
    assert d > 0.0
    back = T.copy()
    back[2, 3] += d
    assert _lowest(knuckled, back) >= -GRAZE_SLACK
    back[2, 3] -= 0.005
    assert _lowest(knuckled, back) < -GRAZE_SLACK


def test_a_finger_whose_tip_sticks_on_the_table_is_kept_off_it(tmp_path):
    # the knuckled claw described as sticking: the graze that needed no
    # back-off is backed off as a one-joint finger's would be, and a
    # one-joint finger described as sliding may graze
    sticking = load_gripper(
        write_claw(tmp_path / "s", knuckles=True, on_table="sticks"),
        cache_dir=tmp_path / "cache",
    )
    assert slides(sticking) == [False, False]
    column = _column(0.05)
    T = _top_down(0.095)
    assert -GRAZE_SLACK < _lowest(sticking, T) < -SWEEP_SLACK
    d = sweep_back_offs(sticking, T[None], TABLE, column)[0]
    assert d > 0.0
    back = T.copy()
    back[2, 3] += d
    assert _lowest(sticking, back) >= -SWEEP_SLACK
    sliding = load_gripper(
        write_claw(tmp_path / "g", on_table="slides"), cache_dir=tmp_path / "cache"
    )
    assert slides(sliding) == [True, True]
    T = _top_down(0.095)
    assert -GRAZE_SLACK < _lowest(sliding, T) < -SWEEP_SLACK
    assert sweep_back_offs(sliding, T[None], TABLE, column)[0] == 0.0


def _two_joint_claw(folder: Path, pregrasp: tuple, closed: tuple) -> Path:
    """The knuckled claw with its pads at the fingertips and the outer joint
    free to turn both ways, closing from ``pregrasp`` to ``closed`` (each
    ``(inner, outer)`` joint angle)."""
    path = write_claw(folder, knuckles=True)
    urdf = folder / "claw.urdf"
    urdf.write_text(
        urdf.read_text().replace('lower="0" upper="0.5"', 'lower="-0.6" upper="0.6"')
    )
    text = path.read_text().replace(
        "center: [0.0, 0.0, 0.006]", f"center: [{LENGTH - PAD_AT - 0.005}, 0.0, 0.006]"
    )
    lines = [
        f"pregrasp: {{j0: {pregrasp[0]}, j1: {pregrasp[0]}, k0: {pregrasp[1]}, "
        f"k1: {pregrasp[1]}}}\n"
        if ln.startswith("pregrasp:")
        else f"closed: {{j0: {closed[0]}, j1: {closed[0]}, k0: {closed[1]}, "
        f"k1: {closed[1]}}}\n"
        if ln.startswith("closed:")
        else ln
        for ln in text.splitlines(keepends=True)
    ]
    path.write_text("".join(lines))
    return path


def test_whether_a_tip_slides_on_the_table_is_guessed_from_its_joints(tmp_path):
    # two-joint fingers coming down onto the table from above: one that curls
    # as it closes pushes its tip along the table and slides; one whose outer
    # joint straightens against the inner one (a D'Claw's) pushes it into the
    # table, inside the friction cone, and sticks
    curling = load_gripper(
        _two_joint_claw(tmp_path / "curl", (0.2, 0.0), (2.0, 0.5)),
        cache_dir=tmp_path / "cache",
    )
    assert slides(curling) == [True, True]
    straightening = _two_joint_claw(tmp_path / "straight", (0.2, 0.5), (2.0, -0.5))
    sticking = load_gripper(straightening, cache_dir=tmp_path / "cache")
    assert slides(sticking) == [False, False]
    report = check_gripper(straightening, cache_dir=tmp_path / "cache")
    assert [f["on_table"] for f in report.fingers] == ["sticks", "sticks"]
    assert "tip sticks on the table (guessed)" in report.format()
    # the description overrules the guess
    said = straightening.read_text().replace(
        "samples: 5}\n", "samples: 5}\n    on_table: slides\n"
    )
    straightening.write_text(said)
    overruled = load_gripper(straightening, cache_dir=tmp_path / "cache")
    assert slides(overruled) == [True, True]
    report = check_gripper(straightening, cache_dir=tmp_path / "cache")
    assert report.format().count("tip slides on the table") == 2
    assert "(guessed)" not in report.format()


def test_sweeps_that_no_back_off_clears_are_rejected(claw):
    T = _top_down(0.06)
    assert _lowest(claw, T) + BACK_OFF_STEPS[-1] < -SWEEP_SLACK
    assert np.isnan(sweep_back_offs(claw, T[None], TABLE, _column(0.04))[0])


def test_a_finger_the_object_stops_first_may_sweep_on_below(claw):
    # the tips swing down onto a wide, low slab before they would reach the table
    T = _top_down(0.065)
    slab = _slab(0.015, 0.1)
    assert _lowest(claw, T) + BACK_OFF_STEPS[-1] < -SWEEP_SLACK
    assert not any(_enters_before_reaching(claw, T, slab, 0.003))
    assert sweep_back_offs(claw, T[None], TABLE, slab)[0] == 0.0
    # a slab too narrow to stop them: the tips pass 9 mm beside it and enter the
    # table
    narrow = _slab(0.015, 0.02)
    assert all(_enters_before_reaching(claw, T, narrow, 0.005))
    assert np.isnan(sweep_back_offs(claw, T[None], TABLE, narrow)[0])


def test_many_poses_at_once_as_one_at_a_time(claw):
    # poses at several heights, turned about the table's normal by several angles
    heights = np.linspace(0.05, 0.16, 12)
    T = np.stack([_top_down(h) for h in heights])
    for i, yaw in enumerate(np.resize([0.0, 0.4, 1.1], len(T))):
        c, s = np.cos(yaw), np.sin(yaw)
        T[i, :3, :3] = (
            np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ T[i, :3, :3]
        )
    column = _column(0.13)
    together = sweep_back_offs(claw, T, TABLE, column)
    alone = [sweep_back_offs(claw, t[None], TABLE, column)[0] for t in T]
    np.testing.assert_array_equal(together, alone)
    # the lowest poses cannot be cleared, the highest need no back-off, and
    # some between are backed off
    assert np.isnan(together[0]) and together[-1] == 0.0
    assert ((together > 0.0) & (together <= BACK_OFF_STEPS[-1])).any()


# ------------------------------------------------------------------------------
# planning
# ------------------------------------------------------------------------------
def _scene(size: tuple[float, float, float], seed: int = 0) -> np.ndarray:
    """A box of ``size`` standing on a 40 cm table at z = 0: (n, 3)."""
    rng = np.random.default_rng(seed)
    u = np.arange(-0.2, 0.2, 0.004)
    X, Y = np.meshgrid(u, u)
    table = np.column_stack([X.ravel(), Y.ravel(), np.zeros(X.size)])
    box = rng.uniform(-0.5, 0.5, size=(1500, 3))
    axis = rng.integers(0, 3, size=1500)
    box[np.arange(1500), axis] = np.sign(box[np.arange(1500), axis]) * 0.5
    box = box * size + [0.0, 0.0, size[2] / 2]
    world = np.concatenate([table, box[box[:, 2] > 0.001]])
    return world + rng.normal(0.0, 0.0003, size=world.shape)


def _pipeline(claw: GripperModel, claw_yaml: Path) -> Pipeline:
    spec = load_spec(
        {
            "gripper": str(claw_yaml),
            "segmenter": {"name": "ransac_dbscan"},
            "sampling": {
                "mode": "approach_sphere",
                "grid": [3, 3, 3],
                "directions": 4,
                "orientations": 4,
                "depths": 3,
            },
            "approach": {"squeeze": 0.03, "close_to": "closed"},
            "scorers": [{"name": "centroid_distance", "weight": 1.0}],
        }
    )
    return Pipeline(spec, gripper=claw)


@pytest.fixture(scope="module")
def planned(claw, claw_yaml):
    pipe = _pipeline(claw, claw_yaml)
    scene = as_scene(_scene((0.04, 0.04, 0.05)))
    return pipe, scene, pipe.prepare(scene), pipe.plan(scene)


def _generated(prep, claw) -> np.ndarray:
    """Every candidate's pose as the search generated it: (C, 4, 4)."""
    inp = prep.search_input
    o = inp.orientations
    return candidate_poses(
        inp.T_world_object,
        inp.samples_object,
        o.R_object_gwc,
        claw.T_gripper_gwc,
        o.depth,
    )[1]


def test_the_plan_rejects_what_no_back_off_clears_and_keeps_what_clears(planned, claw):
    pipe, scene, prep, result = planned
    assert result.found, result.hint
    cands = result.candidates
    assert result.rejections["finger_sweeps_table"] == int(
        (cands.reason == SWEPT).sum()
    )
    assert result.rejections["finger_sweeps_table"] > 0
    T_gen = _generated(prep, claw)
    table = prep.search_input.table.T_world_table
    obj = prep.search_input.object_points
    for i in np.flatnonzero(cands.reason == SWEPT):
        # at its pose as generated some finger dips below the table
        assert _lowest_in(claw, T_gen[i], table) < -SWEEP_SLACK
    untouched = 0
    for i in np.flatnonzero(cands.reason == 0):
        if _lowest_in(claw, T_gen[i], table) >= -SWEEP_SLACK:
            # clear as generated: feasible, and taken as generated
            np.testing.assert_array_equal(cands.T_world_ee[i], T_gen[i])
            untouched += 1
    assert untouched > 0
    # the chosen grasp: no finger enters the table before it comes near the
    # object
    T = _in_table_frame(result.T_world_ee, table)
    assert not any(
        _enters_before_reaching(claw, T, _in_table_frame_points(obj, table), NEAR)
    )


def test_a_candidate_whose_sweep_enters_the_table_is_taken_backed_off(planned, claw):
    pipe, scene, prep, result = planned
    cands = result.candidates
    T_gen = _generated(prep, claw)
    table = prep.search_input.table.T_world_table
    obj = prep.search_input.object_points
    # feasible candidates whose fingers enter the table, as generated, before
    # they come near the object
    dipping = [
        int(i)
        for i in np.flatnonzero(cands.reason == 0)
        if any(
            _enters_before_reaching(
                claw,
                _in_table_frame(T_gen[i], table),
                _in_table_frame_points(obj, table),
                NEAR,
            )
        )
    ]
    assert dipping, "the scene has feasible candidates that need backing off"
    for i in dipping:  # the first whose pre-grasp pose is clear of the table
        taken = pipe.plan(scene, choose=i)
        if taken.found:
            break
    assert taken.found, taken.hint
    a = T_gen[i][:3, :3] @ claw.approach_axis
    moved = T_gen[i][:3, 3] - taken.T_world_ee[:3, 3]
    d = float(moved @ a)
    np.testing.assert_allclose(moved, d * a, atol=1e-12)  # along its approach
    assert 0.0 < d <= BACK_OFF_STEPS[-1] + 1e-12
    assert np.isclose(d / 0.005, round(d / 0.005))
    T = _in_table_frame(taken.T_world_ee, table)
    assert not any(
        _enters_before_reaching(claw, T, _in_table_frame_points(obj, table), NEAR)
    )


def test_a_rejected_candidate_is_refused_with_its_reason(planned):
    from wsgrasp.errors import InputError

    pipe, scene, _, result = planned
    i = int(np.flatnonzero(result.candidates.reason == SWEPT)[0])
    with pytest.raises(InputError, match="finger_sweeps_table"):
        pipe.plan(scene, choose=i)


def test_no_grasp_says_the_fingers_would_sweep_through_the_table(
    claw, claw_yaml, tmp_path
):
    from typer.testing import CliRunner

    from wsgrasp.cli import app
    from wsgrasp.record import RunRecorder, open_run
    from wsgrasp.record._summary import summarize_run
    from wsgrasp.view._run import REASON_COLOURS, run_layers

    path = tmp_path / "flat.mcap"
    result = _pipeline(claw, claw_yaml).plan(
        _scene((0.05, 0.05, 0.015)), observers=[RunRecorder(path)]
    )
    assert not result.found
    assert result.rejections["finger_sweeps_table"] > 0
    assert "sweep through the table" in result.hint
    # inspect's histogram, the view's rejected poses and its colours
    run = open_run(path)
    assert summarize_run(run)["rejections"]["finger_sweeps_table"] > 0
    layers = run_layers(run)
    assert "finger_sweeps_table" in [reason for reason, _ in layers.rejected]
    assert set(REASONS) <= set(REASON_COLOURS)
    shown = CliRunner().invoke(app, ["inspect", str(path)])
    assert shown.exit_code == 0 and "finger sweeps table" in shown.stdout
    png = tmp_path / "flat.png"
    drawn = CliRunner().invoke(app, ["view", str(path), "-o", str(png)])
    assert drawn.exit_code == 0, drawn.stdout
    assert png.read_bytes()[:4] == b"\x89PNG"


def _in_table_frame(T: np.ndarray, T_world_table: np.ndarray) -> np.ndarray:
    return np.linalg.inv(T_world_table) @ T


def _in_table_frame_points(p: np.ndarray, T_world_table: np.ndarray) -> np.ndarray:
    T = np.linalg.inv(T_world_table)
    return p @ T[:3, :3].T + T[:3, 3]


def _lowest_in(g: GripperModel, T: np.ndarray, T_world_table: np.ndarray) -> float:
    return _lowest(g, _in_table_frame(T, T_world_table))
