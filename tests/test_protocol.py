"""The trial protocols (strict and lift), object masses, and chance as a column:
what a strict trial fails that a lift trial holds, seeded disturbances and
execution errors, the report's parameters against what MuJoCo was given, masses
from density or masses.json, and random candidates finished as the choice is."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco")

from test_sim import _T, JAW_URDF, R_DOWN, jaw_description  # noqa: E402

from wsgrasp.cli import main  # noqa: E402
from wsgrasp.errors import InputError, SimulationError  # noqa: E402
from wsgrasp.sim import (  # noqa: E402
    SimParams,
    build_report,
    build_scene,
    execute_grasp,
    report_markdown,
    sim_gripper_from_files,
)
from wsgrasp.sim.objects import (  # noqa: E402
    Part,
    SimObject,
    mesh_folder,
    mesh_source,
    resolve_objects,
    trial_mass,
)
from wsgrasp.sim.report import LOW_OBJECT, paired_difference  # noqa: E402
from wsgrasp.sim.trial import (  # noqa: E402
    DISTURBANCE_DIRECTIONS,
    ExecutionError,
    execution_error,
)

ROOT = Path(__file__).resolve().parents[1]
#: the YCB development set (../shared/objects/ycb), read from where it lies
YCB = ROOT.parent / "shared" / "objects" / "ycb"


@pytest.fixture
def jaw_dir(tmp_path: Path) -> Path:
    (tmp_path / "jaw.urdf").write_text(JAW_URDF)
    return tmp_path


def _tall_box(mass: float) -> SimObject:
    """4 × 6 × 12 cm, standing on z = 0."""
    return SimObject(
        "tall_box", [Part("box", (0.04, 0.06, 0.12), _T((0, 0, 0.06)))], mass
    )


def _grasp(jaw_dir: Path, obj: SimObject, depth: float, p: SimParams, **kw):
    """The test jaw pointing down, its fingertips ``depth`` below the top of
    ``obj`` (12 cm tall), closing 1 cm past the 4 cm faces."""
    scene = build_scene(obj, sim_gripper_from_files(jaw_description(), jaw_dir), p)
    T_world_base = _T((0.0, 0.0, 0.12 + 0.10 - depth), R_DOWN)
    return execute_grasp(
        scene, _T(), T_world_base, p, joints_grasp={"j_left": 0.01}, **kw
    )


# --------------------------------------------------------------------------------
# the protocol
# --------------------------------------------------------------------------------
def test_a_shallow_pinch_that_lift_holds_fails_under_strict(jaw_dir: Path):
    """A 1.2 kg box pinched by the top centimetre hangs still in the jaw for the
    lift protocol's 10 s hold, and is wrenched out by the strict protocol's first
    tug (its weight, sideways, 5 cm under the pads), with the lift protocol's
    friction too: the disturbance fails it, not the lower friction. Pinched by
    5 cm it holds through all six."""
    box = _tall_box(1.2)
    lift = _grasp(jaw_dir, box, 0.01, SimParams.for_protocol("lift"))
    assert lift.outcome == "success", lift.metrics
    assert lift.metrics["slip_distance"] < 1e-3  # it hung still
    error = execution_error([0, 1, 2], SimParams())
    for friction in (0.5, 0.8):
        p = SimParams.for_protocol("strict", friction=friction)
        strict = _grasp(jaw_dir, box, 0.01, p, error=error)
        assert strict.outcome == "dropped_disturbed", strict.metrics
        assert strict.metrics["disturbances_held"] == 0
        assert strict.metrics["sim_s"] < 8.0  # stopped once the box was lost
    deep = _grasp(jaw_dir, box, 0.05, SimParams(), error=error)
    assert deep.outcome == "success", deep.metrics
    assert deep.metrics["disturbances_held"] == 6
    assert deep.metrics["slip_distance"] < SimParams().slip_distance


def test_slip_in_the_grip_fails_a_strict_trial(jaw_dir: Path):
    """A grasp that stays held but moves in the grip past the limits is
    ``slipped_in_grip``; with the limits off (the lift protocol's) it holds."""
    box = _tall_box(0.6)
    tight = SimParams(slip_distance=1e-5, slip_angle_deg=0.01)
    ex = _grasp(jaw_dir, box, 0.03, tight)
    assert ex.outcome == "slipped_in_grip", ex.metrics
    assert ex.metrics["disturbances_held"] == 6
    loose = SimParams(slip_distance=0.0, slip_angle_deg=0.0)
    assert _grasp(jaw_dir, box, 0.03, loose).outcome == "success"


def test_execution_error_is_seeded_and_sized():
    p = SimParams()
    a, b = execution_error([0, 7, 1], p), execution_error([0, 7, 1], p)
    np.testing.assert_array_equal(a.offset, b.offset)
    np.testing.assert_array_equal(a.rotvec, b.rotvec)
    c = execution_error([0, 7, 2], p)
    assert not np.allclose(a.offset, c.offset)
    assert np.linalg.norm(a.offset) == pytest.approx(p.execution_offset, rel=1e-12)
    assert np.degrees(np.linalg.norm(a.rotvec)) == pytest.approx(1.5, rel=1e-12)
    # a rigid motion about the centre of mass: the centre moves by the offset
    center = np.array([0.01, -0.02, 0.05])
    E = a.transform(center)
    np.testing.assert_allclose(E[:3, :3] @ center + E[:3, 3], center + a.offset)
    lift = execution_error([0, 7, 1], SimParams.for_protocol("lift"))
    assert not lift.offset.any() and not lift.rotvec.any()


def test_disturbances_and_execution_error_reproduce_for_a_seed(jaw_dir: Path):
    """The same trial seed gives the same error and the same trial, step for
    step; the error moves the executed grasp."""
    box = _tall_box(0.3)
    p = SimParams()
    runs = [
        _grasp(jaw_dir, box, 0.03, p, error=execution_error([3, 4, 5], p))
        for _ in range(2)
    ]
    assert runs[0].metrics == runs[1].metrics
    m = runs[0].metrics
    assert m["disturbance_force"] == pytest.approx(0.3 * 9.81 * p.disturbance_weights)
    assert m["execution_offset"] == pytest.approx(0.003)
    assert m["execution_angle_deg"] == pytest.approx(1.5)
    other = _grasp(
        jaw_dir, box, 0.03, p, error=ExecutionError(np.zeros(3), np.zeros(3))
    )
    assert other.metrics["slip_distance"] != m["slip_distance"]
    assert DISTURBANCE_DIRECTIONS.shape == (6, 3)
    np.testing.assert_array_equal(np.abs(DISTURBANCE_DIRECTIONS).sum(axis=0), [2, 2, 2])


def test_protocols_and_their_parameters():
    strict, lift = SimParams(), SimParams.for_protocol("lift")
    assert strict.protocol == "strict" and lift.protocol == "lift"
    assert (strict.friction, lift.friction) == (0.5, 0.8)
    assert lift.disturbance_weights == 0 and lift.hold_time == 10.0
    assert SimParams.for_protocol("lift", friction=0.3).friction == 0.3
    with pytest.raises(InputError, match="protocol 'shake' is unknown"):
        SimParams.for_protocol("shake")


def test_report_params_are_what_mujoco_was_given(capsys: pytest.CaptureFixture):
    """``--friction``, ``--mass`` (and the disturbance they make) in the report's
    ``params`` and in each trial's metrics, which are read back from MuJoCo."""
    rc = main(
        ["eval", "-g", "franka_hand", "--objects", "realsense_box", "-n", "1"]
        + ["-j", "1", "--no-paper", "--friction", "0.65", "--mass", "0.45", "--json"]
        + ["--sim", "kp_prismatic=4000", "--sim", "noslip_iterations=12"]
    )
    assert rc == 0
    report = json.loads(capsys.readouterr().out)
    params = report["params"]
    assert params["protocol"] == "strict"
    assert params["friction"] == 0.65 and params["object_mass"] == 0.45
    assert params["kp_prismatic"] == 4000.0 and params["noslip_iterations"] == 12
    assert report["object_masses"] == {"realsense_box": {"kg": 0.45, "from": "forced"}}
    (rec,) = report["trial_records"]
    m = rec["metrics"]
    assert m["object_friction"] == pytest.approx(0.65)
    assert m["object_mass"] == pytest.approx(0.45)
    assert m["disturbance_force"] == pytest.approx(
        params["disturbance_weights"] * 0.45 * 9.81
    )
    assert m["execution_offset"] == pytest.approx(params["execution_offset"])
    assert "protocol: strict (friction 0.65, mass 0.45 kg" in report_markdown(report)


def test_sim_settings_reach_the_model_and_bad_ones_are_named():
    from wsgrasp.sim.gripper import load_sim_gripper
    from wsgrasp.sim.params import parse_overrides

    over = parse_overrides(["kp_revolute=10", " views = 2 ", "kp_revolute=12.5"])
    assert over == {"kp_revolute": 12.5, "views": 2}
    assert isinstance(over["views"], int)
    p = SimParams.for_protocol("lift", **over)
    # a hand whose YAML gives no drive of its own
    yaml = "examples/plugins/robotiq_2f85_like/wsgrasp_robotiq_2f85_like"
    g = load_sim_gripper(str(ROOT / yaml / "robotiq_2f85_like.yaml"), p)
    gains = {float(k) for k in re.findall(r'kp="([^"]+)"', g.actuator_xml)}
    assert gains == {12.5}
    for item, message, fix in [
        ("kp_revolute", "is not KEY=VALUE", "kp_revolute=10"),
        ("kp_revolut=3", "is not a simulation parameter", "did you mean kp_revolute"),
        ("friction=0.3", "option of its own", "--friction"),
        ("views=2.5", "is not an integer", "views=3"),
        ("kp_revolute=nan", "out of range", "the default is 2.0"),
        ("hold_time=-1", "zero or more", "the default"),
        ("timestep=0", "above zero", "the default"),
        ("mimic_impedance=1.5", "must be below 1", "the default is 0.99"),
        ("mimic_timeconst=0", "above zero", "the default is 0.005"),
        ("camera_elevation_deg=95", "must be at most 90", "the default is 45.0"),
        ("camera_elevation_deg=0", "above zero", "the default is 45.0"),
    ]:
        with pytest.raises(InputError, match=message) as info:
            parse_overrides([item])
        assert fix in info.value.hint


def test_a_grippers_drive_sets_its_gains_and_leaves_its_model_alone():
    from pydantic import ValidationError

    from wsgrasp.gripper._cache import source_hash
    from wsgrasp.sim.gripper import sim_gripper_from_files
    from wsgrasp.spec import DriveSettings, load_gripper_description

    path = ROOT / "plugins/grippers/wsgrasp_grippers/allegro_right/allegro_right.yaml"
    desc, base = load_gripper_description(path)
    desc = desc.model_copy(update={"drive": DriveSettings()})  # no drive of its own
    p = SimParams.for_protocol("lift", kp_revolute=3.0)
    plain = sim_gripper_from_files(desc.model_dump(), base, p)
    assert plain.gains["revolute"] == (3.0, "params")
    assert plain.notes_json()["gains"]["revolute"] == {"kp": 3.0, "source": "params"}
    own = desc.model_copy(update={"drive": DriveSettings(kp_revolute=7.5)})
    g = sim_gripper_from_files(own.model_dump(), base, p)
    assert g.gains["revolute"] == (7.5, "gripper")
    assert {float(k) for k in re.findall(r'kp="([^"]+)"', g.actuator_xml)} == {7.5}
    assert source_hash(own, base) == source_hash(desc, base)  # no model rebuild
    # `eval --sim kp_revolute=...` on a gripper whose YAML sets it: said, not
    # silently ignored; on one without, nothing to say
    from wsgrasp.cli._eval import gains_not_applied

    sim = ["kp_revolute=3"]
    (line,) = gains_not_applied(sim, "hand", g.notes_json()["gains"])
    assert "--sim kp_revolute=3 does not apply to hand" in line
    assert "drive sets kp_revolute 7.5 N·m/rad" in line
    assert gains_not_applied(sim, "hand", plain.notes_json()["gains"]) == []
    assert gains_not_applied(["views=2"], "hand", g.notes_json()["gains"]) == []
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(ValidationError):
            DriveSettings(kp_revolute=bad)


def test_single_joints_take_the_gains_the_drive_gives_them():
    """``drive.joints`` sets the gains of the joints it names (the Allegro
    hand's thumb at three times its fingers'); the others keep their kind's.
    A name that is no actuated joint is one error naming it and the fix."""
    from wsgrasp.sim.gripper import sim_gripper_from_files
    from wsgrasp.sim.report import _repair_markdown
    from wsgrasp.spec import DriveSettings, load_gripper_description

    path = ROOT / "plugins/grippers/wsgrasp_grippers/allegro_right/allegro_right.yaml"
    desc, base = load_gripper_description(path)
    thumb = ["joint_12.0", "joint_13.0", "joint_14.0", "joint_15.0"]
    assert desc.drive.joints == dict.fromkeys(thumb, 6.0)
    g = sim_gripper_from_files(desc.model_dump(), base, SimParams())
    kp = dict(re.findall(r'joint="g/([^"]+)" kp="([^"]+)"', g.actuator_xml))
    assert len(kp) == 16
    assert {j: float(v) for j, v in kp.items() if j in thumb} == dict.fromkeys(
        thumb, 6.0
    )
    assert {float(v) for j, v in kp.items() if j not in thumb} == {2.0}
    notes = g.notes_json()
    assert notes["joint_gains"] == {j: {"kp": 6.0} for j in thumb}
    text = "\n".join(_repair_markdown({"sim_grippers": {"allegro_right": notes}}))
    assert "drive.joints: joint_12.0 6" in text
    for name, what in (("joint_99", "not a movable joint"), ("joint_13", "not a")):
        bad = desc.model_copy(update={"drive": DriveSettings(joints={name: 3.0})})
        with pytest.raises(SimulationError, match=what) as info:
            sim_gripper_from_files(bad.model_dump(), base, SimParams())
        assert "drive.joints" in str(info.value) and "joint_0.0" in info.value.hint


def test_a_bad_sim_setting_is_one_clear_error_from_the_cli(capsys):
    rc = main(["eval", "--objects", "realsense_box", "--sim", "kp_revolut=3"])
    text = capsys.readouterr()
    out = text.out + text.err
    assert rc == 2, out
    assert "did you mean kp_revolute" in out and "Traceback" not in out


# --------------------------------------------------------------------------------
# masses
# --------------------------------------------------------------------------------
def _cube(path: Path, side: float) -> None:
    import trimesh

    trimesh.creation.box(extents=(side, side, side)).export(path)


def test_mass_from_density_masses_json_or_forced(tmp_path: Path):
    _cube(tmp_path / "a.stl", 0.05)
    _cube(tmp_path / "b.stl", 0.04)
    (tmp_path / "masses.json").write_text(json.dumps({"b": 0.3}))
    (tmp_path / "notes.txt").write_text("not a mesh")
    objs = {o.name: o for o in resolve_objects([str(tmp_path)]).objects}
    assert list(objs) == ["a", "b"]
    p = SimParams()
    assert not objs["a"].mass_given and objs["b"].mass_given
    assert trial_mass(objs["a"], p) == pytest.approx(1200 * 0.05**3, rel=1e-6)
    assert trial_mass(objs["a"], SimParams(density=500)) == pytest.approx(
        500 * 0.05**3, rel=1e-6
    )
    assert trial_mass(objs["b"], p) == 0.3
    assert trial_mass(objs["b"], SimParams(object_mass=0.1)) == 0.1
    # a file named alone finds masses.json beside it
    assert mesh_source(tmp_path / "b.stl").mass == 0.3
    # the random set's URDF mass (0.1 kg for all) is a placeholder
    (random_obj,) = resolve_objects(["random:000"]).objects
    assert not random_obj.mass_given


def test_bad_masses_json_and_empty_folder_are_named(tmp_path: Path):
    _cube(tmp_path / "a.stl", 0.05)
    (tmp_path / "masses.json").write_text(json.dumps({"a": -1}))
    with pytest.raises(InputError, match=r"masses in kg above 0; found a: -1"):
        resolve_objects([str(tmp_path)])
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(InputError, match="holds no mesh file"):
        resolve_objects([str(empty)])


def test_ycb_development_set_masses():
    if not YCB.is_dir():
        pytest.skip(f"the YCB development set is not at {YCB} (../shared/objects/ycb)")
    files = mesh_folder(YCB)
    masses = json.loads((YCB / "masses.json").read_text())
    assert sorted(f.stem for f in files) == sorted(masses)
    hammer = mesh_source(YCB / "hammer.obj")
    assert hammer.mass_given and hammer.mass == masses["hammer"]


# --------------------------------------------------------------------------------
# chance as a column
# --------------------------------------------------------------------------------
def _rec(spec: str, obj: str, outcome: str, pick: str = "plan", draw: int = 0) -> dict:
    return {
        "gripper": "franka_hand",
        "spec": spec,
        "object": obj,
        "trial": 0,
        "outcome": outcome,
        "plan_ms": 10.0,
        "pick": pick,
        "draw": draw,
    }


def test_report_pairs_the_choice_with_random_candidates_per_scene():
    records = [
        _rec("default", "a", "success"),
        _rec("default", "a", "success", "random", 0),
        _rec("default", "a", "slipped_in_grip", "random", 1),
        _rec("default", "b", "success"),
        _rec("default", "b", "dropped_disturbed", "random", 0),
        _rec("default", "b", "no_grasp", "random", 1),
        _rec("default", "c", "no_grasp"),
        _rec("default", "c", "no_grasp", "random", 0),
        _rec("default", "c", "no_grasp", "random", 1),
    ]
    report = build_report(records)
    assert report["trials"] == 3  # the random candidates are not trials of the plan
    assert report["success_rate"] == pytest.approx(2 / 3)
    (b,) = report["baseline"]
    assert (b["scenes"], b["random_per_scene"], b["random_trials"]) == (3, 2, 6)
    assert b["chosen_rate"] == pytest.approx(2 / 3)
    assert b["random_rate"] == pytest.approx(0.5 / 3)
    diffs = [0.5, 1.0, 0.0]
    mean, low, high = paired_difference(diffs)
    assert b["difference"] == pytest.approx(mean) == pytest.approx(0.5)
    half = 1.96 * np.std(diffs, ddof=1) / np.sqrt(3)
    assert b["ci95"] == pytest.approx([mean - half, mean + half])
    assert (low, high) == pytest.approx((mean - half, mean + half))
    md = report_markdown(report)
    assert "| franka_hand | default | 3 × 2 random | 67 % | 17 % | +50.0 pts" in md


def test_report_splits_low_objects_from_tall_ones():
    # a: low, held by the choice, one of two random candidates; b: low, lost by
    # both; c: tall, held by the choice and both random candidates; d: never
    # settled (no height): in neither band
    heights = {"a": 0.021, "b": 0.029, "c": 0.06}
    records = [
        _rec("default", "a", "success"),
        _rec("default", "a", "success", "random", 0),
        _rec("default", "a", "slipped_lifting", "random", 1),
        _rec("default", "b", "slipped_lifting"),
        _rec("default", "b", "slipped_lifting", "random", 0),
        _rec("default", "b", "slipped_lifting", "random", 1),
        _rec("default", "c", "success"),
        _rec("default", "c", "success", "random", 0),
        _rec("default", "c", "success", "random", 1),
        _rec("default", "d", "no_grasp"),
    ]
    for r in records:
        if r["object"] in heights:
            r["object_height"] = heights[r["object"]]
    report = build_report(records)
    (res,) = report["results"]
    split = res["by_height"]
    assert split["low_below_m"] == LOW_OBJECT == 0.03
    assert (split["low"]["trials"], split["low"]["successes"]) == (2, 1)
    assert (split["tall"]["trials"], split["tall"]["successes"]) == (1, 1)
    assert split["low"]["success_rate"] == pytest.approx(0.5)
    (b,) = report["baseline"]
    low, tall = b["by_height"]["low"], b["by_height"]["tall"]
    assert (low["scenes"], tall["scenes"]) == (2, 1)
    assert low["chosen_rate"] == pytest.approx(0.5)
    assert low["random_rate"] == pytest.approx(0.25)
    assert (tall["chosen_rate"], tall["random_rate"]) == (1.0, 1.0)
    md = report_markdown(report)
    assert (
        "| franka_hand | default | 50 % of 2 (random 25 %) "
        "| 100 % of 1 (random 100 %) |" in md
    )
    # no trial in a band: no rate, not a division by zero
    only_tall = build_report([r for r in records if r["object"] == "c"])
    assert only_tall["results"][0]["by_height"]["low"]["success_rate"] is None


def test_report_pairs_each_spec_with_the_primary_over_the_same_scenes():
    outcomes = {  # object: (default, other)
        "a": ("success", "success"),
        "b": ("success", "slipped_in_grip"),
        "c": ("no_grasp", "success"),
        "d": ("dropped_disturbed", "success"),
        "e": ("success", "success"),
    }
    records = [_rec("default", o, a) for o, (a, _) in outcomes.items()]
    records += [_rec("other", o, b) for o, (_, b) in outcomes.items() if o != "e"]
    records.append(_rec("other", "a", "no_grasp", "random", 0))  # not a scene's plan
    report = build_report(records)
    (p,) = report["specs_paired"]
    assert (p["spec"], p["against"], p["scenes"]) == ("other", "default", 4)
    assert (p["gained"], p["lost"]) == (2, 1)
    assert p["rate"] == pytest.approx(3 / 4)
    assert p["against_rate"] == pytest.approx(2 / 4)
    mean, low, high = paired_difference([0.0, -1.0, 1.0, 1.0])
    assert p["difference"] == pytest.approx(mean) == pytest.approx(0.25)
    assert p["ci95"] == pytest.approx([low, high])
    md = report_markdown(report)
    assert (
        "| franka_hand | other | default | 4 | 75 % vs 50 % | 2 | 1 | +25.0 pts" in md
    )
    # one spec: nothing to pair
    assert "specs_paired" not in build_report(records[:5])


@pytest.mark.parametrize(("views", "elevation"), [(3, 45.0), (1, 85.0)])
def test_the_cameras_look_down_from_the_elevation_asked_for(views, elevation):
    from wsgrasp.sim.trial import render_views

    (obj,) = resolve_objects(["realsense_box"]).objects
    p = SimParams(views=views, camera_elevation_deg=elevation)
    rendered = render_views(obj, np.eye(4), np.random.default_rng(3), p)
    assert len(rendered) == views
    for view in rendered:
        # the camera's viewing axis (its z) points down at the table
        down = -view.T_world_camera[2, 2]
        assert np.degrees(np.arcsin(down)) == pytest.approx(elevation, abs=5.0 + 1e-9)
        assert view.T_world_camera[2, 3] > 0.3


def test_random_candidates_are_finished_and_executed_as_the_choice():
    """Each random candidate of ``--baseline random`` is the plan
    ``Pipeline.plan(scene, choose=i)`` gives (its pose, pre-grasp pose and joint
    targets), executed with the trial's execution error like the choice: the
    same outcome and metrics as executing that plan directly."""
    from wsgrasp.api import Pipeline
    from wsgrasp.perception.io import scene_from_arrays
    from wsgrasp.sim import load_sim_gripper, spec_entries
    from wsgrasp.sim.runner import Task, run_task, task_seed
    from wsgrasp.sim.trial import render_views, settle_object
    from wsgrasp.spec import load_spec

    (obj,) = resolve_objects(["realsense_box"]).objects
    (entry,) = spec_entries(["franka_hand"], None, paper=False)
    p = SimParams(hold_time=0.2, disturbance_time=0.3)
    task = Task(obj, trial=0, seed=5, specs=[entry], params=p, baseline=2)
    records = run_task(task)
    assert [r["pick"] for r in records] == ["plan", "random", "random"]
    # the scene again, from the trial's seed
    seed = task_seed(5, obj.name, 0)
    rng = np.random.default_rng(seed)
    bare = build_scene(obj, None, p)
    settled = settle_object(bare, obj, rng, p)
    views = render_views(obj, settled.T_world_object, rng, p)
    scene = scene_from_arrays([(v.points, v.T_world_camera) for v in views])
    pipeline = Pipeline(load_spec(entry.spec))
    world = build_scene(obj, load_sim_gripper("franka_hand", p), p)
    error = execution_error(seed, p)
    for rec in records:
        choose = rec.get("candidate")  # None: the plan's own choice
        plan = pipeline.plan(scene, choose=choose)
        assert rec["found"] and plan.found
        np.testing.assert_allclose(rec["T_world_ee"], plan.T_world_ee, atol=1e-12)
        assert rec["joints_grasp"] == pytest.approx(dict(plan.joints_grasp))
        assert rec["execution_error"] == error.to_json()
        ex = execute_grasp(
            world,
            settled.T_world_object,
            np.asarray(plan.T_world_ee),
            p,
            T_world_pregrasp=np.asarray(plan.T_world_pregrasp),
            joints_pregrasp=dict(plan.joints_pregrasp),
            joints_grasp=dict(plan.joints_grasp),
            error=error,
        )
        assert ex.outcome == rec["outcome"]
        got = {k: v for k, v in rec["metrics"].items() if k != "cpu_s"}
        assert ex.metrics == got


def test_random_draws_follow_the_grippers_name_not_its_folder(tmp_path):
    """The same gripper YAML in two folders draws the same random candidates
    (the draws are keyed by the gripper's name and the spec's label), so a
    run reproduces wherever its packages lie."""
    import shutil

    from wsgrasp.sim import spec_entries
    from wsgrasp.sim.runner import Task, run_task

    src = Path(__file__).resolve().parents[1] / "plugins" / "grippers"
    src = src / "wsgrasp_grippers" / "franka_hand"
    yamls = []
    for folder in ("a", "b"):
        shutil.copytree(src, tmp_path / folder)
        yamls.append(str(tmp_path / folder / "franka_hand.yaml"))
    (obj,) = resolve_objects(["realsense_box"]).objects
    entries = spec_entries(yamls, None, paper=False)
    p = SimParams(hold_time=0.2, disturbance_time=0.3)
    records = run_task(Task(obj, trial=0, seed=5, specs=entries, params=p, baseline=2))
    drawn = {
        g: [
            r["candidate"]
            for r in records
            if r["gripper"] == g and r["pick"] == "random"
        ]
        for g in yamls
    }
    assert len(drawn[yamls[0]]) == 2
    assert drawn[yamls[0]] == drawn[yamls[1]]


def test_a_long_random_selection_resolves():
    """A selection longer than a file name may be (a comma list of 300 objects)
    is read as the set's selection, not tried as a path."""
    pytest.importorskip("pybullet_data")
    names = ",".join(f"{i:03d}" for i in range(300))
    resolved = resolve_objects([f"random:{names}"])
    assert len(resolved.objects) + len(resolved.skipped) == 300
