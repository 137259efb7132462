"""Physics trials: the simulated gripper, objects, settling and grasp execution."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco")

from wsgrasp.errors import InputError, SimulationError  # noqa: E402
from wsgrasp.sim import (  # noqa: E402
    PAPER13,
    SimParams,
    build_scene,
    execute_grasp,
    object_from_mesh,
    paper13,
    require_mujoco,
    settle_object,
    sim_gripper_from_files,
)
from wsgrasp.sim.objects import Part, SimObject  # noqa: E402

JAW_URDF = """<?xml version="1.0"?>
<robot name="jaw">
  <link name="palm">
    <collision>
      <origin xyz="0 0 0.02"/><geometry><box size="0.04 0.16 0.04"/></geometry>
    </collision>
  </link>
  <link name="left">
    <collision>
      <origin xyz="0 0.005 0.03"/><geometry><box size="0.02 0.01 0.06"/></geometry>
    </collision>
  </link>
  <link name="right">
    <collision>
      <origin xyz="0 0.005 0.03"/><geometry><box size="0.02 0.01 0.06"/></geometry>
    </collision>
  </link>
  <joint name="j_left" type="prismatic">
    <parent link="palm"/><child link="left"/>
    <origin xyz="0 0 0.04"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="0.05" effort="60" velocity="0.2"/>
  </joint>
  <joint name="j_right" type="prismatic">
    <parent link="palm"/><child link="right"/>
    <origin xyz="0 0 0.04" rpy="0 0 3.141592653589793"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="0.05" effort="60" velocity="0.2"/>
    <mimic joint="j_left" multiplier="1" offset="0"/>
  </joint>
</robot>
"""


def jaw_description(**over: object) -> dict:
    desc = {
        "name": "jaw",
        "urdf": "jaw.urdf",
        "base_link": "palm",
        "approach_axis": (0.0, 0.0, 1.0),
        "closing_axis": (0.0, 1.0, 0.0),
        "pregrasp": {"j_left": 0.05},
        "closed": {"j_left": 0.0},
    }
    desc.update(over)
    return desc


@pytest.fixture
def jaw_dir(tmp_path: Path) -> Path:
    (tmp_path / "jaw.urdf").write_text(JAW_URDF)
    return tmp_path


@pytest.fixture
def box_object() -> SimObject:
    # 4 x 6 x 8 cm box, base on z = 0
    return SimObject("box", [Part("box", (0.04, 0.06, 0.08), _T((0, 0, 0.04)))], 0.2)


def _T(xyz=(0.0, 0.0, 0.0), R=None) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = xyz
    if R is not None:
        T[:3, :3] = R
    return T


#: the gripper pointing down (its z along world -z), closing along world x
R_DOWN = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def test_mimic_joint_follows_its_master(jaw_dir: Path, box_object: SimObject):
    mujoco = require_mujoco()
    g = sim_gripper_from_files(jaw_description(), jaw_dir)
    assert g.actuated == ["j_left"]
    scene = build_scene(box_object, g)
    m, d = scene.model, scene.data
    d.qpos[scene.gripper_qpos][2] = d.ctrl[2] = 0.5  # the gripper in the air
    for target in (0.04, 0.01, 0.03):
        d.ctrl[6:] = target
        mujoco.mj_step(m, d, nstep=500)
        q_left = d.qpos[scene.joint_qpos["j_left"]]
        q_right = d.qpos[scene.joint_qpos["j_right"]]
        assert q_left == pytest.approx(target, abs=2e-3)
        assert q_right == pytest.approx(q_left, abs=1e-3)


@pytest.mark.parametrize(
    "closed, match",
    [({}, "no closed configuration"), ({"j_left": 0.05}, "equals the pregrasp")],
    ids=["missing", "same-as-pregrasp"],
)
def test_gripper_without_closed_configuration_is_refused(
    jaw_dir: Path, closed: dict, match: str
):
    with pytest.raises(SimulationError, match=match):
        sim_gripper_from_files(jaw_description(closed=closed), jaw_dir)


def test_unknown_joint_in_posture_is_named(jaw_dir: Path):
    with pytest.raises(SimulationError, match="j_middle"):
        sim_gripper_from_files(jaw_description(closed={"j_middle": 0.0}), jaw_dir)


def test_missing_mujoco_says_how_to_install(monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setitem(sys.modules, "mujoco", None)
    with pytest.raises(SimulationError, match=r"pip install 'wsgrasp\[sim\]'"):
        require_mujoco()


def test_paper13_objects_are_plausible():
    objs = paper13()
    assert [o.name for o in objs] == list(PAPER13)
    for o in objs:
        ext = o.size()
        assert 0.03 <= ext.max() <= 0.25, o.name
        assert ext.min() >= 0.01, o.name
        assert 0.01 <= o.mass <= 1.0, o.name
        com, inertia = o.inertial()
        assert np.all(np.linalg.eigvalsh(inertia) > 0), o.name
        for part in o.parts:
            assert part.to_trimesh().is_watertight, o.name


def test_mesh_object_checks(tmp_path: Path):
    import trimesh

    good = trimesh.creation.box(extents=(0.05, 0.05, 0.1))
    good.export(tmp_path / "good.stl")
    obj = object_from_mesh(tmp_path / "good.stl", mass=0.3, friction=0.5)
    assert obj.mass == 0.3 and obj.friction == 0.5
    assert np.asarray(obj.mesh().bounds)[0, 2] == pytest.approx(0.0, abs=1e-9)

    open_mesh = good.copy()
    open_mesh.update_faces(np.arange(len(open_mesh.faces)) > 1)  # drop a side
    open_mesh.export(tmp_path / "open.stl")
    with pytest.raises(InputError, match="not watertight"):
        object_from_mesh(tmp_path / "open.stl")

    trimesh.creation.box(extents=(50, 50, 100)).export(tmp_path / "mm.stl")
    with pytest.raises(InputError, match="millimetres"):
        object_from_mesh(tmp_path / "mm.stl")

    with pytest.raises(InputError, match="does not exist"):
        object_from_mesh(tmp_path / "nope.obj")


def test_dropped_object_comes_to_rest_on_the_table(box_object: SimObject):
    p = SimParams()
    scene = build_scene(box_object, None, p)
    settled = settle_object(scene, box_object, np.random.default_rng(3), p)
    verts = np.asarray(box_object.mesh().vertices)
    lowest = (verts @ settled.T_world_object[:3, :3].T)[:, 2].min()
    assert lowest + settled.T_world_object[2, 3] == pytest.approx(0.0, abs=3e-3)
    assert np.abs(settled.T_world_object[:2, 3]).max() < p.table_size / 2


@pytest.mark.parametrize(
    "offset, expected",
    [
        # fingertips 2 cm below the box top, straddling its 4 cm side
        ((0.0, 0.0, 0.08 + 0.10 - 0.02), "success"),
        # 10 cm to the side: the fingers close on air
        ((0.10, 0.0, 0.08 + 0.10 - 0.02), "slipped_lifting"),
        # fingers nearly closed before the approach: they land on the top
        ("turned", "approach_collision"),
    ],
    ids=["straddling", "beside", "fingers-on-top"],
)
def test_grasp_execution_outcomes(
    jaw_dir: Path, box_object: SimObject, offset, expected: str
):
    p = SimParams(hold_time=2.0)
    g = sim_gripper_from_files(jaw_description(), jaw_dir)
    scene = build_scene(box_object, g, p)
    T_world_object = _T((0.0, 0.0, 0.0))
    if offset == "turned":
        Rz = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
        T_world_base = _T((0.0, 0.0, 0.16), Rz @ R_DOWN)
        # a narrow opening: both fingers land on the box's top
        g.pregrasp[:] = 0.005
        g.qpos_pregrasp.update({"j_left": 0.005, "j_right": 0.005})
    else:
        T_world_base = _T(offset, R_DOWN)
    ex = execute_grasp(scene, T_world_object, T_world_base, p)
    assert ex.outcome == expected, ex.metrics
    if expected == "success":
        assert ex.metrics["rise_after_hold"] > 0.15
        # where the bodies were once the fingers had closed: the box still on
        # the table, before the lift took it up
        assert ex.xipos_closed is not None
        assert ex.xipos_closed.shape == (scene.model.nbody, 3)
        box_z = ex.xipos_closed[scene.object_body, 2]
        assert box_z < scene.data.xipos[scene.object_body, 2] - 0.15


def test_fingers_are_driven_to_the_plans_joint_targets(jaw_dir: Path):
    """In the air: the fingers start in ``joints_pregrasp`` and end in
    ``joints_grasp`` (the mimic following); the approach starts at the plan's
    pre-grasp pose."""
    p = SimParams(hold_time=0.5)
    g = sim_gripper_from_files(jaw_description(), jaw_dir)
    far = SimObject("box", [Part("box", (0.04, 0.06, 0.08), _T((0.2, 0.2, 0.04)))], 0.2)
    scene = build_scene(far, g, p)
    T_world_base = _T((0.0, 0.0, 0.3), R_DOWN)
    T_pre = T_world_base.copy()
    T_pre[2, 3] += 0.05  # 5 cm back along the approach axis (world -z)
    ex = execute_grasp(
        scene,
        _T(),
        T_world_base,
        p,
        T_world_pregrasp=T_pre,
        joints_pregrasp={"j_left": 0.045},
        joints_grasp={"j_left": 0.015},
    )
    closed = ex.metrics["joints_closed"]
    assert closed["j_left"] == pytest.approx(0.015, abs=5e-4)
    default = execute_grasp(scene, _T(), T_world_base, p)
    assert default.metrics["joints_closed"]["j_left"] == pytest.approx(0.0, abs=5e-4)
    # the approach from 5 cm instead of the 10 cm standoff takes 0.5 s less
    assert default.metrics["sim_s"] - ex.metrics["sim_s"] == pytest.approx(
        0.5, abs=0.01
    )
    with pytest.raises(SimulationError, match="j_right"):
        execute_grasp(scene, _T(), T_world_base, p, joints_grasp={"j_right": 0.0})


def test_squeeze_past_the_surface_becomes_a_grip(jaw_dir: Path, box_object: SimObject):
    """Position-controlled fingers whose targets stop at the box's faces barely
    press on it; 10 mm past them (the planner's default squeeze) they grip."""
    p = SimParams(hold_time=2.0)
    g = sim_gripper_from_files(jaw_description(), jaw_dir)
    scene = build_scene(box_object, g, p)
    T_world_base = _T((0.0, 0.0, 0.08 + 0.10 - 0.02), R_DOWN)
    surface = 0.02  # each finger's inner face touches the 4 cm box at q = 2 cm
    forces = {}
    for squeeze in (0.0, 0.01):
        target = surface - squeeze
        ex = execute_grasp(
            scene, _T(), T_world_base, p, joints_grasp={"j_left": target}
        )
        forces[squeeze] = ex.metrics["grip_force"]
        # the box stops the fingers short of a target inside it (contacts give
        # way a few mm)
        reached = ex.metrics["joints_closed"]["j_left"]
        assert target - 1e-3 < reached < surface + 1e-3
    assert forces[0.0] < 2.0
    assert forces[0.01] > 20.0  # both fingers together; the box weighs 2 N
    assert ex.outcome == "success", ex.metrics


def test_object_contacts_are_stiff(jaw_dir: Path, box_object: SimObject):
    """A grip of tens of newtons sinks a fraction of a millimetre into the
    object with the default ``contact_timeconst``, several times less than with
    MuJoCo's default 20 ms, under which pads sank millimetres into held objects
    and the collision normals deep inside flipped them out of the grip."""
    sinks = {}
    for tc in (0.005, 0.02):
        p = SimParams(hold_time=0.5, contact_timeconst=tc)
        scene = build_scene(
            box_object, sim_gripper_from_files(jaw_description(), jaw_dir), p
        )
        T_world_base = _T((0.0, 0.0, 0.08 + 0.10 - 0.02), R_DOWN)
        ex = execute_grasp(scene, _T(), T_world_base, p, joints_grasp={"j_left": 0.01})
        assert ex.outcome == "success", ex.metrics
        assert ex.metrics["grip_force"] > 20.0
        m, d = scene.model, scene.data
        bodies = m.geom_bodyid[np.asarray(d.contact.geom[: d.ncon])]
        held = np.isin(bodies, scene.gripper_bodies).any(axis=1)
        assert held.any()
        sinks[tc] = -float(np.asarray(d.contact.dist[: d.ncon])[held].min())
    assert SimParams().contact_timeconst == 0.005
    assert 0.0 < sinks[0.005] < 0.3e-3
    assert sinks[0.02] > 3 * sinks[0.005]


def test_grip_inside_its_friction_cone_does_not_creep(jaw_dir: Path):
    """A box whose weight needs 0.6 of the grip's friction stays put in the jaw
    with the default noslip pass, and creeps down through it without one
    (MuJoCo's soft friction); a box beyond the friction limit slips out either
    way, so the pass adds no stickiness beyond Coulomb friction."""

    def hold(mass: float, noslip: int) -> tuple[float, float, str]:
        box = SimObject(
            "box", [Part("box", (0.04, 0.06, 0.08), _T((0, 0, 0.04)))], mass
        )
        # the lift protocol: friction 0.8, no disturbance, a plain hold
        p = SimParams.for_protocol("lift", hold_time=3.0, noslip_iterations=noslip)
        scene = build_scene(box, sim_gripper_from_files(jaw_description(), jaw_dir), p)
        T_world_base = _T((0.0, 0.0, 0.08 + 0.10 - 0.02), R_DOWN)
        ex = execute_grasp(scene, _T(), T_world_base, p, joints_grasp={"j_left": 0.01})
        m = ex.metrics
        need = mass * 9.81 / (p.friction * m["grip_force"])  # share of the limit
        return need, m["rise_after_lift"] - m["rise_after_hold"], ex.outcome

    assert SimParams().noslip_iterations == 10
    need, slid, outcome = hold(2.4, 10)
    assert 0.5 < need < 0.7 and outcome == "success"
    assert abs(slid) < 0.2e-3
    need, slid, outcome = hold(2.4, 0)
    assert 0.5 < need < 0.7 and outcome == "success"
    assert slid > 0.5e-3  # the creep the pass removes
    need, _, outcome = hold(4.8, 10)
    assert need > 1.1 and outcome == "slipped_lifting"


def test_eval_uses_the_plans_targets_and_records_which(monkeypatch):
    """A plan with joint targets closes to them (``finger_targets: plan``), one
    without them to the YAML's ``closed`` posture (``closed``); plans with the
    same pose but other targets are executed apart."""
    from types import SimpleNamespace

    from wsgrasp.sim import runner
    from wsgrasp.sim.runner import SpecEntry, Task
    from wsgrasp.sim.trial import Settled

    T = _T((0.0, 0.0, 0.3), R_DOWN)  # in the air, above a box out of reach

    def result(**targets: float) -> SimpleNamespace:
        return SimpleNamespace(
            found=True,
            T_world_ee=T,
            timing_ms={"total": 1.0},
            hint="",
            T_world_pregrasp=None,
            joints_pregrasp={},
            joints_grasp=dict(targets),
        )

    results = {
        "yaml": result(),
        "plan": result(panda_finger_joint1=0.01),
        "plan_again": result(panda_finger_joint1=0.01),
        "wider": result(panda_finger_joint1=0.03),
    }

    class FakePipeline:
        def __init__(self, r: SimpleNamespace) -> None:
            self.r = r

        def plan(self, scene: object, observers: object = ()) -> SimpleNamespace:
            return self.r

    monkeypatch.setattr(runner, "_pipeline", lambda e: FakePipeline(results[e.label]))
    far = SimObject("box", [Part("box", (0.04, 0.06, 0.08), _T((0.2, 0.2, 0.04)))], 0.2)
    task = Task(
        object=far,
        trial=0,
        seed=0,
        specs=[SpecEntry("franka_hand", label, {}) for label in results],
        params=SimParams(hold_time=0.2),
    )
    records: list[dict] = []
    executed: dict = {}
    runner._run_specs(task, None, 0.0, Settled(_T(), 1, 0.0), records, executed, [])
    by = {r["spec"]: r for r in records}
    assert {k: r["finger_targets"] for k, r in by.items()} == {
        "yaml": "closed",
        "plan": "plan",
        "plan_again": "plan",
        "wider": "plan",
    }
    assert len(executed) == 3  # plan and plan_again share one execution
    closed = {
        k: r["metrics"]["joints_closed"]["panda_finger_joint1"] for k, r in by.items()
    }
    assert closed == pytest.approx(
        {"yaml": 0.0, "plan": 0.01, "plan_again": 0.01, "wider": 0.03}, abs=5e-4
    )


def test_eval_records_how_high_the_object_settled():
    from wsgrasp.sim.runner import _height

    box = SimObject("box", [Part("box", (0.05, 0.06, 0.08))], mass=0.1)
    T = np.eye(4)
    T[2, 3] = 0.04  # standing on its 5 x 6 cm face
    assert _height(box, T) == pytest.approx(0.08)
    lying = np.eye(4)
    lying[:3, :3] = [[1, 0, 0], [0, 0, -1], [0, 1, 0]]  # its 8 cm side along y
    assert _height(box, lying) == pytest.approx(0.06)


def test_closing_push_is_how_far_the_fingers_moved_the_object(
    jaw_dir: Path, box_object: SimObject
):
    """A jaw centred on the box closes on it where it stands, its mimic finger in
    step with its master under the grip's load (a linkage does not give way);
    one set 15 mm off centre along its closing direction reaches the box with
    one finger first and pushes (and tips) it until the other arrives:
    ``closing_push`` measures that, most of the offset."""
    p = SimParams(hold_time=0.2)
    scene = build_scene(
        box_object, sim_gripper_from_files(jaw_description(), jaw_dir, p), p
    )
    pushes = {}
    for offset in (0.0, 0.015):
        T_world_base = _T((offset, 0.0, 0.08 + 0.10 - 0.02), R_DOWN)
        ex = execute_grasp(scene, _T(), T_world_base, p, joints_grasp={"j_left": 0.01})
        pushes[offset] = ex.metrics["closing_push"]
        if offset == 0.0:
            assert ex.outcome == "success", ex.metrics
            q = scene.data.qpos
            step = q[scene.joint_qpos["j_left"]] - q[scene.joint_qpos["j_right"]]
            assert abs(step) < 1e-3  # still gripping at the end of the hold
    assert pushes[0.0] < 1e-3
    assert 0.005 < pushes[0.015] < 0.015


def test_friction_use_says_how_near_the_grip_is_to_sliding(
    jaw_dir: Path, box_object: SimObject
):
    """A jaw centred on the box holds it by friction alone once lifted: its
    contacts use part of their friction cones, more with less friction (the
    same squeeze, a smaller cone), none of them past the cone; before the
    lift the table carries the box, and the jaw squeezes straight."""
    uses = {}
    for mu in (0.8, 0.4):
        p = SimParams(hold_time=0.2, gripper_friction=mu, friction=mu)
        scene = build_scene(
            box_object, sim_gripper_from_files(jaw_description(), jaw_dir, p), p
        )
        T_world_base = _T((0.0, 0.0, 0.08 + 0.10 - 0.02), R_DOWN)
        ex = execute_grasp(scene, _T(), T_world_base, p, joints_grasp={"j_left": 0.01})
        assert ex.outcome == "success", ex.metrics
        m = ex.metrics
        assert m["friction_use_closed"] is not None
        assert m["friction_use_closed"] < m["friction_use_lifted"] <= 1.0 + 1e-6
        assert 0.0 < m["friction_use_held"] <= 1.0 + 1e-6
        uses[mu] = m["friction_use_lifted"]
    assert uses[0.4] > uses[0.8]


def test_a_filmed_execution_keeps_each_step_and_is_drawn(
    jaw_dir: Path, box_object: SimObject, tmp_path: Path
):
    """``film=True`` keeps the world at each step of the protocol without
    changing what happens; the frames show the box lifted with the jaw, and
    ``draw_film`` draws them as a column each."""
    from PIL import Image

    from wsgrasp.sim.film import OBJECT_COLOUR, draw_film

    p = SimParams(hold_time=0.5, disturbance_time=0.2, rest_time=0.1)
    g = sim_gripper_from_files(jaw_description(), jaw_dir)
    scene = build_scene(box_object, g, p)
    T_world_base = _T((0.0, 0.0, 0.16), R_DOWN)
    plain = execute_grasp(scene, _T(), T_world_base, p)
    ex = execute_grasp(scene, _T(), T_world_base, p, film=True)
    assert plain.film is None and ex.film is not None
    assert ex.outcome == plain.outcome == "success"
    assert ex.metrics == plain.metrics  # filming changes nothing
    frames = ex.film.frames
    labels = [f.label for f in frames]
    pulls = [f"pulled {s}{a}" for a in "xyz" for s in "-+"]
    assert labels == [
        "pre-grasp",
        "grasp pose",
        "closing 33 %",
        "closing 67 %",
        "closed",
        "lifted",
        "held",
        *pulls,
        "rested",
    ]
    geometry = ex.film.geometry
    box = [i for i, c in enumerate(geometry.colours) if c == OBJECT_COLOUR]
    assert len(box) == len(box_object.parts) and box == list(geometry.target)
    assert len(geometry.geoms) > len(box)  # the jaw's geoms too, not the table
    at = {f.label: f for f in frames}
    rise = at["lifted"].xpos[box, 2] - at["closed"].xpos[box, 2]
    assert (rise > 0.15).all()
    times = [f.time for f in frames]
    assert times == sorted(times) and times[0] == 0.0
    # the views turn with the closing direction: the jaw's y axis, world x
    np.testing.assert_allclose(ex.film.closing, R_DOWN @ [0.0, 1.0, 0.0], atol=0.05)
    png = draw_film(ex.film, tmp_path / "film.png", title="jaw on box")
    width, height = Image.open(png).size
    assert width > height * len(frames) / 3  # a column per frame, two rows


def test_eval_film_draws_each_executed_grasp(tmp_path: Path):
    """``wsgrasp eval --film DIR``: a PNG per executed grasp, named as its
    plan's recording, and each trial record names it."""
    import json

    from PIL import Image

    from wsgrasp.cli import main

    out = tmp_path / "films"
    argv = ["eval", "-g", "franka_hand", "--objects", "realsense_box", "-n", "1"]
    argv += ["-j", "1", "--no-paper", "--protocol", "lift", "--quiet"]
    argv += ["--film", str(out), "--json-out", str(tmp_path / "r.json")]
    assert main(argv) == 0
    (rec,) = json.loads((tmp_path / "r.json").read_text())["trial_records"]
    assert rec["film"] == str(out / "franka_hand-default-realsense_box-000.png")
    assert Image.open(rec["film"]).size[0] > 0
