"""The clutter-removal benchmark in MuJoCo: scenes set up, steps run until the
table is clear, results counted, every step recorded and replayable."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("mujoco")

from wsgrasp.sim.clutter import (  # noqa: E402
    ClutterWorld,
    clutter_summary,
    place_objects,
    run_clutter_scene,
)
from wsgrasp.sim.objects import Part, SimObject  # noqa: E402
from wsgrasp.sim.params import SimParams  # noqa: E402


def _boxes(n):
    sizes = [(0.05, 0.05, 0.08), (0.04, 0.06, 0.07), (0.05, 0.04, 0.09)]
    return [
        SimObject(f"box{k}", [Part("box", sizes[k % 3])], mass=0.15) for k in range(n)
    ]


@pytest.mark.parametrize("kind", ["pile", "packed"])
def test_a_scene_settles_on_the_table(kind):
    p = SimParams.for_protocol("lift")
    world = ClutterWorld.build(_boxes(3), p)
    place_objects(world, kind, np.random.default_rng(0), p)
    assert world.present.all()
    com = world.data.xipos[world.bodies]  # (3, 3)
    assert (com[:, 2] > 0.0).all() and (np.abs(com[:, :2]) < 0.2).all()
    speeds = [np.linalg.norm(world.data.qvel[d][:3]) for d in world.dof]
    assert max(speeds) < 0.01


def test_an_unknown_scene_kind_is_refused():
    from wsgrasp.errors import InputError

    p = SimParams.for_protocol("lift")
    world = ClutterWorld.build(_boxes(2), p)
    with pytest.raises(InputError, match="clutter scene 'heap' is unknown"):
        place_objects(world, "heap", np.random.default_rng(0), p)


@pytest.fixture(scope="module")
def franka_clutter():
    import wsgrasp
    from wsgrasp.cli._clutter import clutter_spec
    from wsgrasp.sim.gripper import load_sim_gripper
    from wsgrasp.spec import load_spec

    p = SimParams.for_protocol("lift")
    pipeline = wsgrasp.Pipeline(load_spec(clutter_spec("franka_hand")))
    return pipeline, load_sim_gripper("franka_hand", p), p


def test_a_packed_scene_is_cleared_and_every_step_recorded(franka_clutter, tmp_path):
    pipeline, gripper, p = franka_clutter
    out = run_clutter_scene(
        _boxes(2), "packed", pipeline, gripper, p, seed=1, record_dir=tmp_path
    )
    assert out["objects"] == ["box0", "box1"]
    assert out["end"] in ("clear", "two_failures", "step_limit")
    assert out["attempts"] == len(out["steps"]) >= 1
    assert out["removed"] == len({n for st in out["steps"] for n in st["lifted"]})
    if out["end"] == "clear":
        assert out["removed"] + len(out["fell_off"]) == 2
    listed = json.loads((tmp_path / "clutter.json").read_text())
    assert listed["steps"] == out["steps"]
    for step in out["steps"]:
        assert step["records"] and all(
            (tmp_path / r).is_file() for r in step["records"]
        )
        # the neighbours moved before the lift, and those the gripper touched:
        # never the target
        others = {"box0", "box1"} - {step["target"]}
        assert set(step["pushed"]) <= others and set(step["touched"]) <= others
        if step["kind"] == "neighbour_collision":
            assert step["touched"] or step["outcome"] == "approach_collision"
    s = clutter_summary([out])
    assert s["attempts"] == out["attempts"]
    assert 0.0 <= s["grasp_success_rate"] <= 1.0
    assert s["declutter_rate"] == out["removed"] / 2


def _eval_packed(tmp_path, *extra: str) -> dict:
    """``wsgrasp eval --scene packed`` on one scene of two paper13 boxes under
    the lift protocol, with ``extra`` options; its JSON report."""
    from wsgrasp.cli import main

    out = tmp_path / "clutter.json"
    args = ["eval", "--scene", "packed", "--objects", "realsense_box"]
    args += ["--objects", "cookies_package", "--objects-per-scene", "2"]
    args += ["--scenes", "1", "--protocol", "lift", *extra]
    assert main([*args, "--json-out", str(out), "--quiet"]) == 0
    return json.loads(out.read_text())


def test_eval_scene_packed_writes_rates_per_gripper(tmp_path, capsys):
    """The rates per gripper; with ``--film``, each attempt drawn step by step
    (a folder per scene, a PNG per step, which the step names)."""
    films = tmp_path / "films"
    report = _eval_packed(tmp_path, "--film", str(films))
    s = report["grippers"]["franka_hand"]["summary"]
    assert report["scene"] == "packed" and s["scenes"] == 1 and s["objects"] == 2
    assert s["attempts"] >= 1 and 0.0 <= s["declutter_rate"] <= 1.0
    assert report["grippers"]["franka_hand"]["spec"]["segmenter"]["name"] == "clutter"
    assert report["libraries"]["mujoco"] == __import__("mujoco").__version__
    assert "clutter removal: packed" in capsys.readouterr().out
    steps = report["grippers"]["franka_hand"]["scenes"][0]["steps"]
    executed = [st for st in steps if st["found"]]
    assert executed
    for st in executed:
        png = films / "franka_hand" / "packed-000" / f"step-{st['step']:02d}.png"
        assert st["film"] == str(png) and png.stat().st_size > 0


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--scene", "heap"], "--scene 'heap' is unknown"),
        (["--scene", "pile", "--objects-per-scene", "3"], "needs at least that many"),
    ],
    ids=["unknown scene", "too few objects"],
)
def test_eval_scene_refuses_bad_input(args, message, capsys):
    from wsgrasp.cli import main

    rc = main(["eval", "--objects", "realsense_box", *args])
    assert rc != 0
    assert message in capsys.readouterr().err


def test_a_recorded_clutter_run_replays_and_is_drawn_step_by_step(
    franka_clutter, tmp_path, capsys
):
    from wsgrasp.cli import main

    pipeline, gripper, p = franka_clutter
    out = run_clutter_scene(
        _boxes(2), "pile", pipeline, gripper, p, seed=2, record_dir=tmp_path
    )
    capsys.readouterr()
    assert main(["replay", str(tmp_path)]) == 0
    text = capsys.readouterr().out
    assert text.count("identical") == len(out["steps"])
    assert "step 0: 2 objects left" in text
    assert main(["view", str(tmp_path)]) == 0
    for step in out["steps"]:
        for rec in step["records"]:
            assert (tmp_path / rec).with_suffix(".png").stat().st_size > 0


def test_a_folder_that_is_no_clutter_run_is_refused(tmp_path, capsys):
    from wsgrasp.cli import main

    assert main(["replay", str(tmp_path)]) != 0
    assert (
        "no clutter.json, so it is no recorded clutter run" in capsys.readouterr().err
    )


def _step(target, outcome, lifted, kind=None):
    return {
        "target": target,
        "outcome": outcome,
        "success": outcome == "success",
        "lifted": lifted,
        "kind": kind,
        "plan_ms": 50.0,
    }


def test_a_target_lifted_but_slipping_in_the_grip_counts_as_lifted_not_held():
    scene = {
        "objects": ["a", "b", "c"],
        "attempts": 4,
        "successes": 1,
        "removed": 3,
        "steps": [
            _step("a", "success", ["a"]),
            _step("b", "slipped_in_grip", ["b"], "slip"),  # came up, moved in the grip
            _step("c", "slipped_lifting", [], "slip"),  # stayed on the table
            _step("c", "approach_collision", ["b2"], "neighbour_collision"),
        ],
    }
    scene["steps"][0]["touched"] = ["c"]  # a success that brushed a neighbour
    scene["steps"][3]["touched"] = scene["steps"][3]["touched_first"] = ["b"]
    s = clutter_summary([scene])
    assert s["touched_neighbour"] == 2 and s["touched_neighbour_first"] == 1
    assert s["successes"] == 1 and s["grasp_success_rate"] == 0.25
    # the other object that came up with the last attempt is not its target
    assert s["target_lifted"] == 2 and s["lift_rate"] == 0.5
    assert s["failure_kinds"] == {"slip": 2, "neighbour_collision": 1}


def test_a_scene_ends_after_two_steps_in_a_row_that_lifted_nothing():
    from wsgrasp.sim.clutter import Step, _two_failures

    held = Step(step=0, objects_left=3, found=True, success=True, lifted=["a"])
    slipped = Step(step=1, objects_left=2, found=True, lifted=["b"])  # came up
    missed = Step(step=2, objects_left=1, found=True, lifted=[])
    none = Step(step=3, objects_left=1, found=False)
    assert not _two_failures([held, slipped])
    assert not _two_failures([slipped, slipped])  # each cleared an object
    assert not _two_failures([missed])
    assert not _two_failures([missed, slipped])
    assert _two_failures([slipped, missed, none])


def test_chance_clears_the_same_scene_with_random_feasible_candidates(franka_clutter):
    """``pick="random"`` plans each step as the pipeline does and executes a
    random feasible candidate of the plan, finished as the choice is: the
    step names it, the plan that takes it (``plan_choices``) is the one
    executed, and a seed gives the same draws; the choice's run names none.
    An unknown pick is refused."""
    from wsgrasp.errors import InputError
    from wsgrasp.sim import clutter

    pipeline, gripper, p = franka_clutter
    taken = []
    real = clutter._random_choice

    def spy(pipe, scene, result, draws, step):
        plan = real(pipe, scene, result, draws, step)
        taken.append((step.candidate, result.candidates.reason, plan))
        return plan

    clutter._random_choice = spy
    try:
        runs = [
            run_clutter_scene(
                _boxes(2), "packed", pipeline, gripper, p, 1, pick="random"
            )
            for _ in range(2)
        ]
    finally:
        clutter._random_choice = real
    assert runs[0]["pick"] == "random"
    assert [s["candidate"] for s in runs[0]["steps"]] == [
        s["candidate"] for s in runs[1]["steps"]
    ]
    found = [s for s in runs[0]["steps"] if s["found"]]
    assert found and all(isinstance(s["candidate"], int) for s in found)
    for index, reason, plan in taken:
        if index is not None:
            assert reason[index] == 0 and plan.found  # a feasible candidate
    chosen = run_clutter_scene(_boxes(2), "packed", pipeline, gripper, p, 1)
    assert chosen["pick"] == "plan"
    assert all(s["candidate"] is None for s in chosen["steps"])
    with pytest.raises(InputError, match="clutter pick 'best' is unknown"):
        run_clutter_scene(_boxes(2), "packed", pipeline, gripper, p, 1, pick="best")


def test_the_choice_is_compared_with_chance_over_the_same_scenes():
    from wsgrasp.cli._clutter import baseline_pairs

    def scene(successes, attempts, removed, objects=2):
        steps = [_step("a", "success", ["a"])] * successes + [
            _step("b", "slipped_lifting", [], "slip")
        ] * (attempts - successes)
        return {
            "objects": ["a", "b"][:objects],
            "attempts": attempts,
            "successes": successes,
            "removed": removed,
            "steps": steps,
        }

    chosen = [scene(2, 2, 2), scene(1, 2, 1), scene(0, 0, 0)]
    random = [scene(1, 2, 1), scene(1, 2, 1), scene(1, 1, 1)]
    out = baseline_pairs(chosen, random)
    g = out["grasp_success"]
    assert g["scenes"] == 2  # the scene without an attempt of the choice is left out
    assert g["chosen"] == pytest.approx(0.75) and g["random"] == pytest.approx(0.5)
    assert g["difference"] == pytest.approx(0.25)
    lo, hi = g["ci95"]
    assert lo < 0.25 < hi
    assert out["target_lifted"]["difference"] == pytest.approx(0.25)
    d = out["declutter"]
    assert d["scenes"] == 3 and d["difference"] == pytest.approx((0.5 + 0 - 0.5) / 3)


def test_eval_clutter_with_a_random_baseline_reports_both(tmp_path, capsys):
    report = _eval_packed(tmp_path, "--baseline", "random")
    assert report["baseline"] == "random"
    r = report["grippers"]["franka_hand"]
    assert r["baseline"]["summary"]["scenes"] == 1
    assert r["baseline"]["scenes"][0]["pick"] == "random"
    assert set(r["baseline"]["paired"]) >= {"grasp_success", "declutter", "interval"}
    text = capsys.readouterr().out
    assert "choice less random feasible" in text


def test_a_replayed_step_names_the_random_candidate_it_executed():
    from wsgrasp.record._sequence import SequenceStep

    info = {
        "step": 1,
        "objects_left": 2,
        "segments": 2,
        "tries": 1,
        "target": "box0",
        "outcome": "success",
        "lifted": ["box0"],
    }
    assert "candidate" not in SequenceStep(info, []).line()
    line = SequenceStep({**info, "candidate": 7}, []).line()
    assert "target box0 (random feasible candidate 7): success" in line
    assert "touched" not in line
    touches = {
        "touched": ["box1", "box2"],
        "touched_first": ["box2"],
        "touched_by": {"box1": ["link_11.0_tip"], "box2": ["palm", "link_3.0"]},
    }
    line = SequenceStep({**info, **touches}, []).line()
    assert line.endswith(
        "; touched box1 by link_11.0_tip; box2 by palm, link_3.0 before the target"
    )


def test_a_grasp_that_lands_on_a_neighbour_touches_it(franka_clutter):
    """Execution names the neighbours the gripper touched while it approached
    and closed: a hand brought down onto the other box of a packed pair touches
    that box, one brought down beside both touches neither."""
    from wsgrasp.sim.clutter import _target_scene
    from wsgrasp.sim.trial import execute_grasp

    _, gripper, p = franka_clutter
    settle = ClutterWorld.build(_boxes(2), p)
    place_objects(settle, "packed", np.random.default_rng(0), p)
    poses = settle.poses()
    world = ClutterWorld.build(_boxes(2), p, gripper)
    R_down = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])

    def touched_at(xy) -> list[int]:
        world.set_poses(poses, np.ones(2, dtype=bool))
        scene = _target_scene(world, 0)
        T = np.eye(4)
        T[:3, :3] = R_down
        T[:3, 3] = (*xy, 0.12)  # the base 12 cm up: the fingertips near the table
        ex = execute_grasp(scene, poses[0], T, p)
        return [world.bodies.index(int(b)) for b in ex.touched]

    assert touched_at(poses[1][:2, 3]) == [1]
    assert touched_at((0.5, 0.5)) == []


def test_a_neighbour_touched_before_the_target_is_in_the_way(franka_clutter):
    """Execution tells the neighbours the gripper touched before it touched the
    target (``touched_first``) and names the gripper's links that touched
    each: a hand brought down onto the other box of a pair moved apart meets
    that box, and never the target."""
    from wsgrasp.sim.clutter import _target_scene, _touched_by
    from wsgrasp.sim.trial import execute_grasp

    _, gripper, p = franka_clutter
    settle = ClutterWorld.build(_boxes(2), p)
    place_objects(settle, "packed", np.random.default_rng(0), p)
    poses = settle.poses()
    poses[0][1, 3] += 0.2  # the target well away from the hand
    world = ClutterWorld.build(_boxes(2), p, gripper)
    world.set_poses(poses, np.ones(2, dtype=bool))
    T = np.eye(4)
    T[:3, :3] = [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]
    T[:3, 3] = (*poses[1][:2, 3], 0.12)
    ex = execute_grasp(_target_scene(world, 0), poses[0], T, p)
    assert ex.touched.tolist() == ex.touched_first.tolist() == [world.bodies[1]]
    by = _touched_by(world, ["box0", "box1"], ex.touched_by)
    assert list(by) == ["box1"] and by["box1"]
    assert all(not name.startswith("g/") for name in by["box1"])


@pytest.mark.parametrize(
    ("outcome", "in_the_way", "kind"),
    [
        ("slipped_lifting", True, "neighbour_collision"),
        ("slipped_lifting", False, "slip"),  # neighbours met around the target
        ("approach_collision", False, "neighbour_collision"),
        ("success", True, None),
    ],
)
def test_only_a_neighbour_in_the_way_makes_a_failure_a_collision(
    outcome, in_the_way, kind
):
    from wsgrasp.sim.clutter import _kind

    assert _kind(outcome, 0.0, 1, in_the_way) == kind
