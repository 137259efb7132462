"""``wsgrasp batch`` and ``dataset``: the same rows locally and on Ray, a run killed
and resumed without a duplicate or a lost row, a killed worker costing one task."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pyarrow")
import pyarrow.parquet as pq  # noqa: E402

from wsgrasp.batch import LocalEngine, PartSink, scene_paths  # noqa: E402
from wsgrasp.cli import main  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "examples" / "scenes"
SPECS = ROOT / "examples" / "specs"
#: columns that differ between runs of the same plans
TIMINGS = ["plan_ms", "load_ms", "cpu_ms", "timing_ms", "worker"]


def _rows(folder: Path, drop: list[str] = TIMINGS) -> list[dict]:
    rows = pq.read_table(folder).drop_columns(drop).to_pylist()
    return sorted(rows, key=lambda r: (r["scene"], r["spec"]))


def _batch(out: Path, *extra: str) -> int:
    return main(
        [
            "batch",
            str(SCENES / "box_upright.npz"),
            str(SCENES / "mug.npz"),
            str(SCENES / "cone_views"),
            "-s",
            str(SPECS / "franka.yaml"),
            "-s",
            f"paper={SPECS / 'franka_paper.yaml'}",
            "-o",
            str(out),
            "-q",
            *extra,
        ]
    )


@pytest.fixture(scope="module")
def ray_engine():
    pytest.importorskip("ray")
    from wsgrasp.batch import RayEngine

    engine = RayEngine(2)
    yield engine
    engine.close()


def test_batch_rows_are_the_same_in_one_process_and_two(tmp_path: Path):
    assert _batch(tmp_path / "one", "-j", "1") == 0
    assert _batch(tmp_path / "two", "-j", "2") == 0
    one = _rows(tmp_path / "one" / "plans")
    assert len(one) == 3 * 2  # scenes x specs
    assert {r["spec"] for r in one} == {"franka", "paper"}
    assert all(r["found"] for r in one)
    assert one == _rows(tmp_path / "two" / "plans")


def test_batch_on_ray_gives_the_local_rows(tmp_path: Path, ray_engine, monkeypatch):
    from wsgrasp.batch import engine as engines

    class Kept:  # the module's Ray instance, not closed by the command
        name, workers = ray_engine.name, ray_engine.workers
        run = ray_engine.run

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            pass

    monkeypatch.setattr(engines, "RayEngine", lambda *a, **k: Kept())
    assert _batch(tmp_path / "local", "-j", "1") == 0
    assert _batch(tmp_path / "ray", "--engine", "ray") == 0
    assert _rows(tmp_path / "ray" / "plans") == _rows(tmp_path / "local" / "plans")


def _suicide(i: int, marker: str) -> int:
    """Kills its own process the first time it runs job 2."""
    flag = Path(marker) / "killed"
    if i == 2 and not flag.exists():
        flag.touch()
        os.kill(os.getpid(), signal.SIGKILL)
    return i * i


def test_a_ray_worker_killed_costs_only_its_task(tmp_path: Path, ray_engine):
    from ray import cloudpickle

    # this test module is not importable in Ray's workers: its job goes by value
    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    done: dict[int, int] = {}
    jobs = [(i, str(tmp_path)) for i in range(5)]
    ray_engine.run(_suicide, jobs, done.__setitem__)
    assert (tmp_path / "killed").exists()
    assert done == {i: i * i for i in range(5)}  # job 2 retried, none lost


def test_a_killed_run_resumes_without_duplicates_or_lost_rows(tmp_path: Path):
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    for i in range(60):
        shutil.copy(SCENES / "box_camera_frame.npz", scenes / f"s{i:02d}.npz")
    out = tmp_path / "out"
    cmd = [
        sys.executable,
        "-c",
        "import sys; from wsgrasp.cli import main; sys.exit(main(sys.argv[1:]))",
        "batch",
        str(scenes),
        "-g",
        "franka_hand",
        "-o",
        str(out),
        "-j",
        "1",
        "--row-group",
        "1",
        "-q",
    ]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if len(list((out / "plans").glob("part-*.parquet"))) >= 3:
            break
        time.sleep(0.02)
    proc.send_signal(signal.SIGKILL)
    assert proc.wait() == -signal.SIGKILL, "the run ended before it was killed"
    before = {p.name: p.stat().st_mtime_ns for p in (out / "plans").glob("part-*")}
    assert 3 <= len(before) < 60
    # without --resume the folder is refused (a usage error)
    assert main(["batch", str(scenes), "-g", "franka_hand", "-o", str(out)]) == 2
    args = ["batch", str(scenes), "-g", "franka_hand", "-o", str(out), "-q"]
    assert main([*args, "-j", "1", "--resume"]) == 0
    rows = pq.read_table(out / "plans").to_pylist()
    keys = [(r["scene"], r["spec"]) for r in rows]
    assert len(keys) == len(set(keys)) == 60
    assert {k[0] for k in keys} == {str(p) for p in sorted(scenes.iterdir())}
    assert all(r["found"] for r in rows)
    for name, mtime in before.items():  # what the killed run wrote is kept
        assert (out / "plans" / name).stat().st_mtime_ns == mtime
    # a second resume has nothing left to do
    assert main([*args, "--resume", "--json"]) == 0


def test_resume_refuses_a_changed_spec(tmp_path: Path, capsys):
    out = tmp_path / "out"
    scene = str(SCENES / "box_upright.npz")
    spec = tmp_path / "mine.yaml"
    spec.write_text((SPECS / "franka.yaml").read_text())
    assert main(["batch", scene, "-s", str(spec), "-o", str(out), "-q"]) == 0
    text = spec.read_text().replace("orientations: 4", "orientations: 3")
    assert text != spec.read_text()
    spec.write_text(text)
    capsys.readouterr()
    code = main(["batch", scene, "-s", str(spec), "-o", str(out), "--resume"])
    assert code == 2
    assert "differs from the one" in capsys.readouterr().err


def test_a_part_some_table_lacks_is_dropped_on_resume(tmp_path: Path):
    import pyarrow as pa

    schemas = {
        "scenes": pa.schema([("object", pa.string())]),
        "candidates": pa.schema([("object", pa.string()), ("i", pa.int32())]),
    }
    sink = PartSink(tmp_path, schemas, "scenes", ("object",), row_group=1)
    sink.add({"scenes": [{"object": "a"}], "candidates": [{"object": "a", "i": 0}]})
    sink.add({"scenes": [{"object": "b"}], "candidates": [{"object": "b", "i": 0}]})
    # a crash between the renames of part 1: its scenes part never arrived
    (tmp_path / "scenes" / "part-00001.parquet").unlink()
    (tmp_path / "candidates" / ".part-00002.parquet.123").write_bytes(b"torn")
    again = PartSink(tmp_path, schemas, "scenes", ("object",), resume=True)
    assert again.done == {("a",)}
    assert sorted(p.name for p in (tmp_path / "candidates").iterdir()) == [
        "part-00000.parquet"
    ]


def test_resume_refuses_parts_with_other_columns(tmp_path: Path):
    """Parts written with other columns (another wsgrasp version's tables)
    would not read back as one table with the new ones: resuming them is
    refused, naming the columns."""
    import pyarrow as pa

    from wsgrasp.errors import InputError

    old = {"scenes": pa.schema([("object", pa.string())])}
    sink = PartSink(tmp_path, old, "scenes", ("object",), row_group=1)
    sink.add({"scenes": [{"object": "a"}]})
    new = {"scenes": pa.schema([("object", pa.string()), ("use", pa.float64())])}
    with pytest.raises(InputError, match="without use") as err:
        PartSink(tmp_path, new, "scenes", ("object",), resume=True)
    assert "new output folder" in err.value.hint
    assert PartSink(tmp_path, old, "scenes", ("object",), resume=True).done == {("a",)}


def test_scene_folders_and_repeats(tmp_path: Path):
    from wsgrasp.errors import InputError

    got = scene_paths([SCENES, SCENES / "cone_views"])
    assert [p.name for p in got] == [
        "bottle_lying.npz",
        "box_camera_frame.npz",
        "box_upright.npz",
        "mug.npz",
        "scene.yaml",  # a folder with a scene YAML: its views are not scenes
    ]
    with pytest.raises(InputError, match="given twice"):
        scene_paths([SCENES / "mug.npz", SCENES / "mug.npz"])
    with pytest.raises(InputError, match="does not exist"):
        scene_paths([tmp_path / "nothing.npz"])
    images = tmp_path / "images"
    images.mkdir()
    (images / "depth.png").write_bytes(b"")
    with pytest.raises(InputError, match="depth images need their intrinsics"):
        scene_paths([images])


def test_local_engine_shares_one_payload(tmp_path: Path):
    from wsgrasp.batch import shared

    got: dict[int, object] = {}
    LocalEngine(1).run(lambda i: (i, shared()), [(0,), (1,)], got.__setitem__, shared=7)
    assert got == {0: (0, 7), 1: (1, 7)}
    assert shared() is None  # restored after the run


def _sim_records(records: list[dict]) -> list[dict]:
    """Eval records without their wall-clock times."""
    times = {"scene_s", "plan_ms", "exec_s"}
    return [{k: v for k, v in r.items() if k not in times} for r in records]


@pytest.mark.slow
def test_eval_on_ray_gives_the_local_outcomes_trial_for_trial(ray_engine):
    pytest.importorskip("mujoco")
    from wsgrasp.sim import EvalConfig, SimParams, run_eval, spec_entries
    from wsgrasp.sim.objects import resolve_objects

    config = EvalConfig(
        objects=resolve_objects(["realsense_box", "plastic_cup"]).objects,
        specs=spec_entries(["franka_hand"], None, paper=False),
        trials=2,
        seed=3,
        params=SimParams(),
        workers=2,
    )
    local, _ = run_eval(config, progress=False)
    ray, _ = run_eval(config, progress=False, engine=ray_engine)
    assert len(local) == 4
    assert _sim_records(ray) == _sim_records(local)


def _dataset(out: Path, *extra: str) -> int:
    return main(
        ["dataset", "random:000", "-g", "franka_hand", "-o", str(out), "-k", "2"]
        + ["-q", "--json", *extra]
    )


def test_dataset_rows_labels_and_resume(tmp_path: Path, capsys):
    pytest.importorskip("mujoco")
    import json

    assert _dataset(tmp_path / "d", "-j", "1") == 0
    summary = json.loads(capsys.readouterr().out)
    scenes = pq.read_table(tmp_path / "d" / "scenes").to_pylist()
    cands = pq.read_table(tmp_path / "d" / "candidates").to_pylist()
    assert [(s["object"], s["trial"]) for s in scenes] == [("random_000", 0)]
    assert len(scenes[0]["views"]) == 3
    assert scenes[0]["feasible"] == len(cands) == summary["candidates"] > 2
    assert [c["rank"] for c in cands] == list(range(len(cands)))
    scores = [c["score"] for c in cands]
    assert scores == sorted(scores, reverse=True)
    labelled = [c for c in cands if c["label"] is not None]
    assert [c["rank"] for c in labelled] == [0, 1] and summary["labels"] == 2
    assert all(c["success"] == (c["label"] == "success") for c in labelled)
    # a label that held says how near its grip came to sliding; the rest none
    assert any(c["success"] for c in labelled)
    for c in cands:
        if c["success"]:
            assert 0.0 <= c["friction_use"] <= 1.0 + 1e-6
        else:
            assert c["friction_use"] is None
    # each executed as the plan that takes it: its pre-grasp pose and targets
    assert {c["label_targets"] for c in labelled} == {"plan"}
    assert {"centroid_distance", "antipodal"} <= set(dict(cands[0]["score_terms"]))
    # resumed: nothing left to do, nothing written twice
    assert _dataset(tmp_path / "d", "--resume") == 0
    assert json.loads(capsys.readouterr().out)["resumed"] == 1
    assert pq.read_table(tmp_path / "d" / "scenes").num_rows == 1


def test_dataset_labels_random_feasible_candidates_beside_the_choice(
    tmp_path: Path, capsys
):
    pytest.importorskip("mujoco")
    import json

    assert _dataset(tmp_path / "d", "-j", "1", "-k", "1", "--random", "3") == 0
    summary = json.loads(capsys.readouterr().out)
    (scene,) = pq.read_table(tmp_path / "d" / "scenes").to_pylist()
    cands = pq.read_table(tmp_path / "d" / "candidates").to_pylist()
    drawn = [c for c in cands if c["random_pick"]]
    assert len(drawn) == scene["random_labels"] == summary["random_labels"] == 3
    # every draw is labelled, as is the choice; nothing else
    labelled = [c for c in cands if c["label"] is not None]
    assert {c["candidate"] for c in labelled} == {
        c["candidate"] for c in cands if c["random_pick"] or c["rank"] == 0
    }
    assert scene["random_successes"] == sum(c["success"] for c in drawn)
    assert scene["chosen_success"] == next(c["success"] for c in cands if c["chosen"])
    assert summary["chosen"] == 1


def test_random_feasible_draws_are_seeded_distinct_and_feasible():
    from types import SimpleNamespace

    from wsgrasp.batch.dataset import random_feasible

    reason = np.array([0, 3, 0, 0, 1, 0, 0, 2])  # feasible: 0, 2, 3, 5, 6
    C = SimpleNamespace(reason=reason)
    a = random_feasible(C, [0, 1, 2], 3)
    assert a == random_feasible(C, [0, 1, 2], 3)  # the trial's seed alone
    assert len(set(a)) == 3 and set(a) <= {0, 2, 3, 5, 6}
    assert sorted(random_feasible(C, [0, 1, 2], 10)) == [0, 2, 3, 5, 6]
    assert random_feasible(C, [0, 1, 2], 0) == []
    draws = {tuple(random_feasible(C, [0, 1, t], 2)) for t in range(20)}
    assert len(draws) > 1  # other trials draw others


@pytest.mark.slow
def test_dataset_on_ray_gives_the_local_rows(tmp_path: Path, ray_engine):
    pytest.importorskip("mujoco")
    from wsgrasp.batch import LocalEngine, run_dataset
    from wsgrasp.cli._plan import plan_spec
    from wsgrasp.sim.objects import resolve_objects

    objs = resolve_objects(["random:000-001"]).objects
    spec = plan_spec(None, "franka_hand")
    for name, engine in (("local", LocalEngine(2)), ("ray", ray_engine)):
        run_dataset(objs, spec, "franka_hand", tmp_path / name, engine, top_k=2)
    times = ["scene_s", "plan_ms", "sim_s", "cpu_s", "worker"]
    for table, drop in (("candidates", []), ("scenes", times)):
        key = lambda r: (r["object"], r["trial"], r.get("rank", 0))  # noqa: E731
        a = sorted(_rows_of(tmp_path / "local" / table, drop), key=key)
        b = sorted(_rows_of(tmp_path / "ray" / table, drop), key=key)
        assert a == b


def _rows_of(folder: Path, drop: list[str]) -> list[dict]:
    return pq.read_table(folder).drop_columns(drop).to_pylist()


@pytest.mark.parametrize(
    "args, says",
    [
        (["--engine", "spark"], "--engine 'spark' is unknown"),
        (["--address", "ray://head:10001"], "--engine is local"),
        (["--simulate"], "needs the grippers"),
    ],
    ids=["unknown-engine", "address-without-ray", "simulate-without-gripper"],
)
def test_batch_usage_errors_exit_2(tmp_path: Path, capsys, args, says):
    scene = str(SCENES / "mug.npz")
    spec = str(SPECS / "franka.yaml")
    code = main(["batch", scene, "-s", spec, "-o", str(tmp_path / "o"), *args])
    assert code == 2
    assert says in capsys.readouterr().err


@pytest.mark.slow
def test_batch_simulate_rows_are_eval_trials(tmp_path: Path):
    pytest.importorskip("mujoco")
    from wsgrasp.sim import EvalConfig, SimParams, run_eval, spec_entries
    from wsgrasp.sim.objects import resolve_objects

    args = ["batch", "--simulate", "realsense_box", "-g", "franka_hand"]
    assert main([*args, "-n", "2", "--seed", "1", "-o", str(tmp_path), "-q"]) == 0
    rows = pq.read_table(tmp_path / "trials").to_pylist()
    config = EvalConfig(
        objects=resolve_objects(["realsense_box"]).objects,
        specs=spec_entries(["franka_hand"], None, paper=False),
        trials=2,
        seed=1,
        params=SimParams(),
        workers=1,
    )
    records, _ = run_eval(config, progress=False)
    got = sorted((r["trial"], r["outcome"], r["T_world_ee"]) for r in rows)
    want = sorted((r["trial"], r["outcome"], sum(r["T_world_ee"], [])) for r in records)
    assert got == want


def test_engine_ray_without_ray_says_how_to_install_it(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # `import ray` fails
    scene, spec = str(SCENES / "mug.npz"), str(SPECS / "franka.yaml")
    args = ["batch", scene, "-s", spec, "-o", str(tmp_path), "--engine", "ray"]
    assert main(args) == 2
    assert "pip install 'wsgrasp[ray]'" in capsys.readouterr().err


def test_batch_record_writes_one_mcap_per_plan(tmp_path: Path):
    from wsgrasp.record import open_run

    scene = str(SCENES / "mug.npz")
    assert (
        main(
            ["batch", scene, "-g", "franka_hand", "-o", str(tmp_path), "-q"]
            + ["--record", "-j", "1"]
        )
        == 0
    )
    (row,) = pq.read_table(tmp_path / "plans").to_pylist()
    assert Path(row["record"]).parent == tmp_path / "runs" / "franka_hand"
    run = open_run(row["record"])
    assert run.status == "ok" and not run.truncated
    assert run.result_data["found"] == row["found"]


def test_a_manifest_lists_scenes_specs_and_grippers(tmp_path: Path):
    shutil.copy(SCENES / "mug.npz", tmp_path / "mug.npz")
    shutil.copy(SPECS / "franka_paper.yaml", tmp_path / "paper.yaml")
    manifest = tmp_path / "manifest.yaml"
    manifest.write_text(
        "scenes: [mug.npz]\nspecs: [p=paper.yaml]\ngrippers: [franka_hand]\n"
    )
    out = tmp_path / "out"
    assert main(["batch", "--manifest", str(manifest), "-o", str(out), "-q"]) == 0
    (row,) = pq.read_table(out / "plans").to_pylist()
    assert (row["scene"], row["spec"], row["gripper"]) == (
        str(tmp_path / "mug.npz"),
        "p@franka_hand",
        "franka_hand",
    )


def test_a_plans_warnings_are_a_column(tmp_path: Path):
    """A scene whose one view was given camera_link's pose plans with a
    warning, and its row keeps it; a scene without one has none."""
    from conftest_perception import small_scene

    from wsgrasp.geometry import transform_from
    from wsgrasp.perception.io import write_scene_yaml
    from wsgrasp.perception.types import View

    view = small_scene("box", "upright", 0).views[0]
    link = transform_from([[0, 0, 1], [-1, 0, 0], [0, -1, 0]])
    T = view.T_world_camera @ np.linalg.inv(link)
    wrong = write_scene_yaml(tmp_path / "wrong", [View(view.points, T, "v")])
    right = write_scene_yaml(tmp_path / "right", [view])
    args = ["batch", str(wrong), str(right), "-g", "franka_hand", "-q", "-j", "1"]
    assert main([*args, "-o", str(tmp_path / "out")]) == 0
    rows = {
        r["scene"]: r for r in pq.read_table(tmp_path / "out" / "plans").to_pylist()
    }
    assert "camera_link" in rows[str(wrong)]["warnings"][0]
    assert rows[str(right)]["warnings"] == []
