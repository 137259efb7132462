"""What a recording keeps that it once lost: the views as planned although the
caller changed its arrays, the merged points bit for bit on any machine, and a
changed byte of the recorded spec reported as corruption."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_record_fakes import box_scene, fake_gripper, fake_spec, plan_recorded

from wsgrasp.errors import RecordingError
from wsgrasp.record import RunRecorder, open_run, replay_run


def _cloud(path: Path, topic: str) -> np.ndarray:
    """The points (n, 3) float32 of the Foxglove cloud on ``topic``."""
    import foxglove.messages as fm
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

    pool = descriptor_pool.DescriptorPool()
    data = bytes(fm.PointCloud.get_schema().data)
    for f in descriptor_pb2.FileDescriptorSet.FromString(data).file:
        pool.Add(f)
    cls = message_factory.GetMessageClass(
        pool.FindMessageTypeByName("foxglove.PointCloud")
    )
    (msg,) = [
        cls.FromString(m.data) for m in open_run(path).messages if m.topic == topic
    ]
    rows = np.frombuffer(msg.data, dtype=np.uint8).reshape(-1, msg.point_stride)
    return rows[:, :12].copy().view("<f4")  # x, y, z of each row


def test_views_show_the_inputs_and_stages_as_handed_over(tmp_path: Path) -> None:
    """The caller zeroing its arrays after handing them over (the plan returned,
    the views not yet built) changes neither the records nor the views; stage
    arrays over 65,536 values included."""
    from wsgrasp.perception.io import scene_from_arrays

    rng = np.random.default_rng(0)
    scene = scene_from_arrays([(rng.normal(size=(25_000, 3)), np.eye(4))])
    view0 = scene.views[0].points.copy()  # 75,000 values
    big = rng.normal(size=(30_000, 3))  # 90,000 values
    path = tmp_path / "run.mcap"
    rec = RunRecorder(path)
    rec.on_start(fake_spec(), fake_gripper(), scene)
    rec.on_stage("preprocess", {"points": big.copy()})
    scene.views[0].points[:] = 0.0  # the caller reuses its buffers
    rec.on_stage("segmentation", {"object_points": big})
    expected = big.copy()
    big[:] = 0.0
    rec.on_error(RuntimeError("stopped"))
    rec.close()
    assert np.array_equal(_cloud(path, "/inputs/view0"), view0.astype("<f4"))
    assert np.array_equal(_cloud(path, "/scene/object"), expected.astype("<f4"))
    run = open_run(path)
    assert np.array_equal(run.scene.views[0].points, view0)
    assert np.array_equal(run.stages["segmentation"]["object_points"], expected)


def test_views_show_the_inputs_as_planned_after_plan_returned(tmp_path: Path) -> None:
    from wsgrasp import Pipeline
    from wsgrasp.perception.io import scene_from_arrays

    small = box_scene(views=1).views[0].points
    scene = scene_from_arrays([(np.repeat(small, 10, axis=0), np.eye(4))])
    view0 = scene.views[0].points.copy()  # 45,000 points
    path = tmp_path / "run.mcap"
    rec = RunRecorder(path)
    Pipeline(fake_spec(), gripper=fake_gripper()).plan(scene, observers=[rec])
    scene.views[0].points[:] = 0.0
    rec.close()
    assert np.array_equal(_cloud(path, "/inputs/view0"), view0[::2].astype("<f4"))


def test_the_merged_points_read_back_bit_for_bit_whatever_the_merge_gives_here(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """As if the run were read on a machine whose BLAS rounds the merge of the
    views otherwise: the recorded points are the planner's, not a new merge."""
    import wsgrasp.perception.io as pio

    scene = box_scene(views=3)
    path = tmp_path / "run.mcap"
    result = plan_recorded(path, scene=scene)
    real = pio._to_world

    def other_rounding(view: object) -> np.ndarray:
        out = np.array(real(view))  # type: ignore[arg-type]
        return np.nextafter(out, np.inf)  # one ulp up, every value

    monkeypatch.setattr(pio, "_to_world", other_rounding)
    run = open_run(path)
    assert run.scene.points.tobytes() == scene.points.tobytes()
    monkeypatch.undo()
    report = replay_run(run)
    assert report.identical, report.differences
    assert result.found == report.replayed["found"]


def _change_spec_digit(path: Path, out: Path) -> None:
    """``path`` with one digit of the spec in its ``spec`` metadata record
    changed (the record's length kept, so the file stays valid MCAP)."""
    from mcap.reader import make_reader

    open_run(path)  # waits until the recording is finished
    data = bytearray(path.read_bytes())
    with open(path, "rb") as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None
    (index,) = [m for m in summary.metadata_indexes if m.name == "spec"]
    record = data[index.offset : index.offset + index.length]
    at = record.index(b'"orientations":4')
    record[at : at + 16] = b'"orientations":5'
    data[index.offset : index.offset + index.length] = record
    out.write_bytes(bytes(data))


def test_a_changed_digit_of_the_recorded_spec_is_corruption(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "run.mcap"
    plan_recorded(path)
    bad = tmp_path / "bad.mcap"
    _change_spec_digit(path, bad)
    with pytest.raises(RecordingError, match="corrupt.*spec"):
        open_run(bad)
    with pytest.raises(RecordingError, match="corrupt"):
        replay_run(bad)
    from wsgrasp.cli import main

    assert main(["inspect", str(bad)]) != 0
    assert "corrupt" in capsys.readouterr().err
    assert open_run(path).spec == fake_spec()  # the original reads as it was
