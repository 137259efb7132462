"""What keeps recording cheap, without losing a bit: float64 arrays stored as
float32 when that is exact, clouds stored uncompressed, the Foxglove views built by
the writer thread after the plan (and still there when a plan fails)."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from test_record_fakes import box_scene, fake_gripper, fake_spec

from wsgrasp.errors import RecordingError
from wsgrasp.record import RunRecorder, open_run
from wsgrasp.record._codec import Array, Record, as_float32_exact, encode, loads

ROOT = Path(__file__).resolve().parents[1]


def _bits(a: np.ndarray) -> bytes:
    return np.ascontiguousarray(a).tobytes()


def _record_json(data: bytes) -> dict:
    return json.loads(Record.FromString(data).json)


# -- float32 when exact ---------------------------------------------------------------
def test_float32_exact_arrays_are_stored_as_float32_and_read_back_bit_for_bit() -> None:
    rng = np.random.default_rng(0)
    a = rng.normal(size=(500, 3)).astype(np.float32).astype(np.float64)
    a[0] = [-0.0, 0.0, np.inf]
    a[1] = [-np.inf, np.nan, -np.nan]  # the standard NaNs, both signs
    a[2] = [float(np.float32(1e-45)), -float(np.float32(3.4e38)), 0.5]  # extremes
    data = encode({"a": a})[0]
    ref = _record_json(data)["a"]
    assert ref["$as"] == "<f8"
    arrays = Record.FromString(data).arrays
    assert arrays[0].dtype == "<f4" and len(arrays[0].data) == a.size * 4
    back = loads(data)["a"]
    assert back.dtype == np.float64 and back.shape == a.shape
    assert _bits(back) == _bits(a)  # -0.0, infinities and NaN signs included
    assert np.signbit(back[0, 0]) and not np.signbit(back[0, 1])


@pytest.mark.parametrize(
    "spoil",
    [
        lambda a: a.__setitem__((7, 1), 0.1),  # not a float32
        lambda a: a.__setitem__((499, 2), 1e-300),  # below float32's range
        lambda a: a.__setitem__((250, 0), 1e39),  # above it
        # a NaN with a payload float32 cannot hold
        lambda a: a.reshape(-1).view(np.uint64).__setitem__(9, 0x7FF8000000000001),
        # a signalling NaN (float32 would quiet it)
        lambda a: a.reshape(-1).view(np.uint64).__setitem__(5, 0x7FF0000000000001),
    ],
)
def test_an_array_that_is_not_float32_exact_stays_float64(spoil) -> None:
    a = np.arange(1500, dtype=np.float64).reshape(500, 3) / 8.0
    assert as_float32_exact(a) is not None
    spoil(a)
    assert as_float32_exact(a) is None
    data = encode({"a": a})[0]
    assert "$as" not in _record_json(data)["a"]
    assert _bits(loads(data)["a"]) == _bits(a)


def test_small_and_non_float_arrays_are_stored_as_they_are() -> None:
    value = {
        "small": np.array([0.5, 1.0, -0.0]),
        "ints": np.arange(100, dtype=np.int64),
        "f32": np.arange(100, dtype=np.float32),
        "empty": np.zeros((0, 3)),
    }
    data = encode(value)[0]
    text = _record_json(data)
    assert all("$as" not in text[k] for k in value)
    back = loads(data)
    for k, v in value.items():
        assert back[k].dtype == v.dtype and _bits(back[k]) == _bits(v)


def test_a_reader_refuses_an_unknown_cast() -> None:
    from wsgrasp.record._codec import decode_value

    arrays = [Array(dtype="<i4", shape=(2,), data=np.arange(2, dtype="<i4").tobytes())]
    with pytest.raises(ValueError, match="cannot read"):
        decode_value({"$array": 0, "$as": "<f8"}, arrays)


# -- views and failures ----------------------------------------------------------------
def _topics(path: Path) -> dict[str, int]:
    run = open_run(path)
    out: dict[str, int] = {}
    for m in run.messages:
        out[m.topic] = out.get(m.topic, 0) + 1
    return out


def test_a_failed_plan_still_has_every_view_written_before_the_error(
    tmp_path: Path,
) -> None:
    scene = box_scene()
    path = tmp_path / "failed.mcap"
    rec = RunRecorder(path)
    rec.on_start(fake_spec(), fake_gripper(), scene)
    rec.on_stage("preprocess", {"points": scene.points[::3]})
    rec.on_stage(
        "segmentation",
        {
            "table_normal": np.array([0.0, 0.0, 1.0]),
            "table_offset": 0.0,
            "table_points": scene.points[:100],
            "object_points": scene.points[100:200],
            "obstacles": [],
        },
    )
    rec.on_error(RuntimeError("the segmenter gave up"))
    run = open_run(path)
    assert not run.truncated and run.status == "error" and run.error is not None
    assert run.error["message"] == "the segmenter gave up"
    assert run.metadata["run_end"]["status"] == "error"
    topics = _topics(path)
    for topic in ("/inputs/view0", "/inputs/view1", "/scene/downsampled"):
        assert topics.get(topic) == 1, topic
    assert topics.get("/scene/table_points") == 1 and topics.get("/scene/object") == 1
    assert "/wsgrasp/stage/segmentation" in topics


def test_a_view_that_fails_to_build_is_a_warning_not_a_failure(tmp_path: Path) -> None:
    scene = box_scene()
    path = tmp_path / "run.mcap"
    rec = RunRecorder(path)
    rec.on_start(fake_spec(), fake_gripper(), scene)
    rec.on_stage("segmentation", {"obstacles": ["not an array"]})
    rec.close()
    run = open_run(path)
    assert not run.truncated
    warnings = [m for m in run.messages if m.topic == "/wsgrasp/warnings"]
    assert len(warnings) == 1
    assert "segmentation" in loads(warnings[0].data)["stage"]


def test_a_failed_write_is_one_error_and_the_file_keeps_the_stages_before(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from mcap.writer import Writer

    scene = box_scene()
    path = tmp_path / "run.mcap"
    rec = RunRecorder(path)
    rec.on_start(fake_spec(), fake_gripper(), scene)
    rec.on_stage("preprocess", {"points": scene.points[::3]})

    def full(*args: object, **kwargs: object) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(Writer, "flush", full)
    with pytest.raises(RecordingError, match="No space left") as info:
        rec.on_stage("segmentation", {"table_points": scene.points[:10]})
    assert "--no-record" in (info.value.hint or "")
    rec.on_error(info.value)  # what the planner does next: nothing more is written
    rec.close()
    monkeypatch.undo()
    run = open_run(path)
    assert run.truncated
    assert run.stages["preprocess"]["points"].shape == scene.points[::3].shape
    assert "segmentation" not in run.stages


def _record_preprocess_then(path: Path, ending: str) -> int:
    """In another process: start recording to ``path``, record the preprocess
    stage, then run the statement ``ending`` (how the process stops); its exit
    code."""
    code = textwrap.dedent(
        f"""
        import os, sys
        sys.path.insert(0, {str(ROOT / "tests")!r})
        from test_record_fakes import box_scene, fake_gripper, fake_spec
        from wsgrasp.record import RunRecorder

        scene = box_scene()
        rec = RunRecorder({str(path)!r})
        rec.on_start(fake_spec(), fake_gripper(), scene)
        rec.on_stage("preprocess", {{"points": scene.points[::3]}})
        """
    )
    done = subprocess.run(
        [sys.executable, "-c", code + ending],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert "Traceback" not in done.stderr, done.stderr
    return done.returncode


def test_a_recorder_left_open_is_finished_at_exit(tmp_path: Path) -> None:
    path = tmp_path / "left_open.mcap"
    # no on_result, no close
    assert _record_preprocess_then(path, "raise SystemExit(3)") == 3
    run = open_run(path)
    assert not run.truncated and run.metadata["run_end"]["status"] == "closed"
    assert "/scene/downsampled" in _topics(path)


def _gate_views(monkeypatch: pytest.MonkeyPatch) -> Any:
    """Make the writer thread wait, before building the views, until the
    returned event is set."""
    import threading

    from wsgrasp.record import _writer

    gate = threading.Event()
    real = _writer.RunRecorder._write_views

    def gated(self: Any, *args: Any) -> None:
        gate.wait(10)
        real(self, *args)

    monkeypatch.setattr(_writer.RunRecorder, "_write_views", gated)
    return gate


def test_views_are_built_after_the_plan_and_a_new_recording_waits_for_them(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import threading
    import time

    gate = _gate_views(monkeypatch)
    scene = box_scene()
    first = RunRecorder(tmp_path / "first.mcap")
    first.on_start(fake_spec(), fake_gripper(), scene)
    first.on_error(RuntimeError("stopped early"))  # hands the views over
    assert first._done is not None and not first._done.is_set()
    assert first.overhead_ms > 0  # returned: the views wait for the gate
    threading.Timer(0.2, gate.set).start()
    t0 = time.perf_counter()
    second = RunRecorder(tmp_path / "second.mcap")
    second.on_start(fake_spec(), fake_gripper(), scene)  # waits for the first
    assert first._done.is_set() and time.perf_counter() - t0 > 0.1
    second.close()
    first.close()
    for name in ("first", "second"):
        run = open_run(tmp_path / f"{name}.mcap")
        assert not run.truncated
        assert _topics(tmp_path / f"{name}.mcap").get("/inputs/view0") == 1


def test_the_views_show_the_result_as_planned_even_if_the_caller_changes_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from wsgrasp import Pipeline

    gate = _gate_views(monkeypatch)

    scene = box_scene()
    pipe = Pipeline(fake_spec(), gripper=fake_gripper())
    path = tmp_path / "run.mcap"
    rec = RunRecorder(path)
    result = pipe.plan(scene, observers=[rec])
    assert result.found
    planned = np.array(result.T_world_ee)
    result.T_world_ee[:3, 3] += 1.0  # the caller moves on with the pose
    gate.set()
    rec.close()
    run = open_run(path)
    assert np.array_equal(run.result.T_world_ee, planned)
    pose = [m for m in run.messages if m.topic == "/grasp/pose"]
    assert len(pose) == 1
    msg = _schema_class("foxglove.PoseInFrame").FromString(pose[0].data)
    got = [msg.pose.position.x, msg.pose.position.y, msg.pose.position.z]
    assert np.allclose(got, planned[:3, 3])
    from scipy.spatial.transform import Rotation

    q = msg.pose.orientation  # x, y, z, w
    R = Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix()
    assert np.allclose(R, planned[:3, :3], atol=1e-12)


def test_a_failure_finishing_the_file_is_raised_by_close_and_the_run_is_kept(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from mcap.writer import Writer

    def full(self: Any) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(Writer, "finish", full)
    scene = box_scene()
    path = tmp_path / "run.mcap"
    rec = RunRecorder(path)
    rec.on_start(fake_spec(), fake_gripper(), scene)
    rec.on_stage("preprocess", {"points": scene.points[::3]})
    rec.on_error(RuntimeError("the segmenter gave up"))
    with pytest.raises(RecordingError, match="No space left"):
        rec.close()
    rec.close()  # reported once
    monkeypatch.undo()
    run = open_run(path)
    assert run.truncated  # no summary
    assert run.error is not None and run.error["message"] == "the segmenter gave up"
    assert run.stages["preprocess"]["points"].shape == scene.points[::3].shape


def test_a_process_killed_after_the_plan_keeps_inputs_stages_and_result(
    tmp_path: Path,
) -> None:
    path = tmp_path / "killed.mcap"
    code = textwrap.dedent(
        f"""
        import os, sys, time
        sys.path.insert(0, {str(ROOT / "tests")!r})
        from test_record_fakes import box_scene, fake_gripper, fake_spec
        from wsgrasp import Pipeline
        from wsgrasp.record import RunRecorder, _writer

        _writer.RunRecorder._write_views = lambda *a: time.sleep(30)
        rec = RunRecorder({str(path)!r})
        pipe = Pipeline(fake_spec(), gripper=fake_gripper())
        result = pipe.plan(box_scene(), observers=[rec])
        os._exit(0 if result.found else 4)  # no close, no exit handlers
        """
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr
    run = open_run(path)
    assert run.truncated and run.missing == []  # only views and the summary lack
    assert run.result is not None and run.result.found
    assert run.scene.points.shape[0] > 0
    assert set(run.stages) >= {"preprocess", "segmentation", "candidates"}


# -- Foxglove messages -------------------------------------------------------------
def _schema_class(name: str):  # noqa: ANN202 - a generated protobuf class
    import foxglove.messages as fm
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

    data = getattr(fm, name.removeprefix("foxglove.")).get_schema().data
    pool = descriptor_pool.DescriptorPool()
    for f in descriptor_pb2.FileDescriptorSet.FromString(bytes(data)).file:
        pool.Add(f)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(name))


@pytest.mark.parametrize("colour", ["none", "one", "each"])
def test_point_clouds_hold_float32_points_and_byte_colours(colour: str) -> None:
    rng = np.random.default_rng(3)
    p = rng.normal(size=(50, 3))
    rgba = {
        "none": None,
        "one": (0.2, 0.4, 1.0, 1.0),
        "each": rng.uniform(size=(50, 4)),
    }
    from wsgrasp.record._views import point_cloud

    sdk = point_cloud(p, "world", 5, rgba=rgba[colour])
    msg = _schema_class("foxglove.PointCloud").FromString(sdk.encode())
    assert msg.frame_id == "world"
    if rgba[colour] is None:
        assert msg.point_stride == 12 and msg.data == p.astype("<f4").tobytes()
        return
    rec = np.empty(50, dtype=[("xyz", "<f4", 3), ("rgba", "u1", 4)])
    rec["xyz"] = p
    rec["rgba"] = np.clip(np.round(np.asarray(rgba[colour]) * 255), 0, 255)
    assert msg.point_stride == 16 and msg.data == rec.tobytes()
    assert [f.name for f in msg.fields][3:] == ["red", "green", "blue", "alpha"]


def test_input_views_shown_in_foxglove_are_thinned_to_the_cap(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from wsgrasp.record import _views

    monkeypatch.setattr(_views, "FOXGLOVE_MAX_POINTS", 1000)
    scene = box_scene(views=3)  # 4500 points
    path = tmp_path / "run.mcap"
    with RunRecorder(path) as rec:
        rec.on_start(fake_spec(), fake_gripper(), scene)
    run = open_run(path)
    cls = _schema_class("foxglove.PointCloud")
    clouds = [
        cls.FromString(m.data) for m in run.messages if m.topic.startswith("/inputs/")
    ]
    assert len(clouds) == 3
    shown = sum(len(c.data) // c.point_stride for c in clouds)
    assert shown == 900  # every 5th point of each view
    assert _bits(run.scene.views[2].points) == _bits(scene.views[2].points)


def test_the_overhead_benchmark_runs(tmp_path: Path) -> None:
    """A smoke test of benchmarks/record_overhead.py (no timing is asserted)."""
    done = subprocess.run(
        [
            sys.executable,
            str(ROOT / "benchmarks" / "record_overhead.py"),
            "--runs",
            "1",
            "--spec",
            "examples/specs/franka.yaml",
            "--scene",
            "examples/scenes/mug.npz",
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=ROOT,
    )
    assert done.returncode == 0, done.stderr
    (row,) = json.loads(done.stdout)
    assert row["gripper"] == "franka_hand" and row["file_mb"] > 0


def test_clouds_are_stored_raw_and_structured_records_compressed(
    tmp_path: Path,
) -> None:
    from mcap.reader import make_reader

    path = tmp_path / "run.mcap"
    rec = RunRecorder(path)
    scene = box_scene()
    rec.on_start(fake_spec(), fake_gripper(), scene)
    rec.on_stage("preprocess", {"points": np.repeat(scene.points, 20, axis=0)})
    rec.on_stage("object_frame", {"labels": np.zeros(50_000, dtype=np.int64)})
    rec.close()
    with open(path, "rb") as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None
    ratios = sorted(
        c.compressed_size / c.uncompressed_size for c in summary.chunk_indexes
    )
    assert {c.compression for c in summary.chunk_indexes} == {"", "zstd"}
    assert ratios[0] < 0.1  # the zeros: compressed
    assert ratios[-1] == 1.0  # a cloud: stored as it is
    run = open_run(path)
    assert _bits(run.stages["preprocess"]["points"]) == _bits(
        np.repeat(scene.points, 20, axis=0)
    )


@pytest.mark.skipif(not hasattr(__import__("os"), "fork"), reason="needs os.fork")
def test_a_forked_child_leaves_the_parents_recordings_alone(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import os

    from wsgrasp.record import _worker

    gate = _gate_views(monkeypatch)
    path = tmp_path / "parent.mcap"
    rec = RunRecorder(path)
    rec.on_start(fake_spec(), fake_gripper(), box_scene())
    rec.on_error(RuntimeError("stop"))  # the views wait for the gate
    size_before = path.stat().st_size
    pid = os.fork()
    if pid == 0:  # the child: nothing of the parent's to wait for or finish
        code = 0
        try:
            _worker.wait_for_recorders()
            _worker._close_open_recorders()
            if path.stat().st_size != size_before:
                code = 5
        except BaseException:  # noqa: BLE001 - reported by the exit code
            code = 6
        os._exit(code)
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0
    gate.set()
    rec.close()
    run = open_run(path)
    assert not run.truncated and _topics(path).get("/inputs/view0") == 1


# -- a copy with the views built again -------------------------------------------------
def test_a_copy_of_a_run_has_the_same_records_and_views(tmp_path: Path) -> None:
    from test_record_fakes import plan_recorded

    from wsgrasp.record import copy_with_views, replay_run

    path = tmp_path / "run.mcap"
    plan_recorded(path)
    run = open_run(path)
    copy = open_run(copy_with_views(run, tmp_path / "copy.mcap"))
    assert not copy.truncated and copy.status == "ok" and copy.missing == []
    assert {t: s for t, (s, _) in copy.topics().items()} == {
        t: s for t, (s, _) in run.topics().items()
    }
    assert _bits(copy.scene.points) == _bits(run.scene.points)
    assert _bits(copy.candidates.T_world_ee) == _bits(run.candidates.T_world_ee)
    assert copy.metadata["copy_of"]["path"] == str(path)
    assert replay_run(copy).identical
    with pytest.raises(RecordingError, match="is the run being copied"):
        copy_with_views(run, path, force=True)
    with pytest.raises(RecordingError, match="already exists"):
        copy_with_views(run, tmp_path / "copy.mcap")


def test_a_run_killed_before_its_views_gets_them_in_a_copy(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from wsgrasp.cli import app

    path = tmp_path / "killed.mcap"
    # killed in the segmentation: no exit handler runs
    assert _record_preprocess_then(path, "os._exit(0)") == 0
    assert "/scene/downsampled" not in _topics(path)
    out = tmp_path / "views.mcap"
    result = CliRunner().invoke(app, ["view", str(path), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert "copied up to where it stops" in result.output
    copy = open_run(out)
    assert not copy.truncated and copy.status == "truncated"
    assert "segmentation" in copy.missing and "result" in copy.missing
    topics = _topics(out)
    assert topics.get("/scene/downsampled") == 1 and topics.get("/inputs/view0") == 1


def test_a_copy_keeps_the_recorded_error(tmp_path: Path) -> None:
    from wsgrasp.errors import InputError
    from wsgrasp.record import copy_with_views

    path = tmp_path / "failed.mcap"
    rec = RunRecorder(path)
    rec.on_start(fake_spec(), fake_gripper(), box_scene())
    rec.on_error(InputError("no object on the table", hint="move the camera"))
    rec.close()
    copy = open_run(copy_with_views(open_run(path), tmp_path / "copy.mcap"))
    assert copy.status == "error" and copy.error is not None
    assert copy.error["type"] == "InputError"
    assert copy.error["message"] == "no object on the table"
    assert copy.error["hint"] == "move the camera"
