"""Recording a run to MCAP and reading it back: round trip, truncation, bad files."""

from __future__ import annotations

import json
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import pytest
from test_record_fakes import box_scene, fake_gripper, fake_spec, plan_recorded

from wsgrasp.errors import RecordingError
from wsgrasp.record import (
    FORMAT_VERSION,
    PARTS,
    RunRecorder,
    compare_results,
    default_run_path,
    open_run,
    summarize_run,
)

FOXGLOVE_SCHEMAS = {
    "foxglove.PointCloud",
    "foxglove.FrameTransform",
    "foxglove.PosesInFrame",
    "foxglove.PoseInFrame",
    "foxglove.SceneUpdate",
}


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object]:
    path = tmp_path_factory.mktemp("runs") / "run.mcap"
    result = plan_recorded(path)
    return path, result


def test_round_trip_gives_back_inputs_and_result_bit_for_bit(recorded) -> None:
    path, result = recorded
    run = open_run(path)
    scene = box_scene()
    assert not run.truncated and run.missing == [] and run.status == "ok"
    assert len(run.scene.views) == len(scene.views)
    for got, want in zip(run.scene.views, scene.views, strict=True):
        assert got.points.tobytes() == want.points.tobytes()
        assert got.T_world_camera.tobytes() == want.T_world_camera.tobytes()
        assert got.name == want.name
    assert run.scene.points.tobytes() == scene.points.tobytes()
    assert run.result is not None
    assert compare_results(result, run.result) == []
    assert run.spec == fake_spec()
    g = run.gripper
    assert g.name == "fake_franka"
    assert g.sphere_centers.tobytes() == fake_gripper().sphere_centers.tobytes()
    assert run.timing_ms["recorder"] > 0 and run.timing_ms["views"] > 0


def test_metadata_has_versions_plugins_spec_and_seed(recorded) -> None:
    run = open_run(recorded[0])
    meta = run.metadata["wsgrasp"]
    assert meta["format_version"] == str(FORMAT_VERSION) and meta["seed"] == "0"
    assert {"wsgrasp_version", "python", "platform", "numpy"} <= set(meta)
    assert json.loads(run.metadata["spec"]["json"])["gripper"] == "fake_franka"
    assert all({"distribution", "version"} <= set(p) for p in run.plugins)
    assert run.plugins, "every loaded plugin is listed"


def test_inspect_summary_counts_add_up(recorded) -> None:
    path, result = recorded
    s = summarize_run(open_run(path))
    assert s["found"] is True and s["truncated"] is False
    assert s["candidates"] == len(result.candidates)
    assert s["feasible"] + sum(s["rejections"].values()) == s["candidates"]
    assert "feasible" not in s["rejections"]
    assert s["top"][0]["score"] == pytest.approx(result.score)
    json.dumps(s)  # JSON-ready


def test_every_channel_decodes_with_its_declared_schema(recorded) -> None:
    pytest.importorskip("mcap_protobuf")
    from mcap.reader import make_reader
    from mcap_protobuf.decoder import DecoderFactory

    with open(recorded[0], "rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        names = {summary.schemas[c.schema_id].name for c in summary.channels.values()}
        decoded = list(reader.iter_decoded_messages())
    assert len(decoded) == summary.statistics.message_count > 0
    assert names - {"wsgrasp.Record"} <= FOXGLOVE_SCHEMAS
    assert FOXGLOVE_SCHEMAS <= names, "all well-known schemas are used"
    by_topic = {ch.topic: msg for _, ch, _, msg in decoded}
    assert by_topic["/wsgrasp/inputs"].format_version == FORMAT_VERSION
    assert len(by_topic["/inputs/view0"].data) == 12 * 2250
    for _, ch, _, _ in decoded:
        assert ch.message_encoding == "protobuf"


def test_clouds_are_stored_uncompressed_and_structured_records_with_zstd(
    recorded,
) -> None:
    from mcap.reader import make_reader

    with open(recorded[0], "rb") as fh:
        reader = make_reader(fh)
        summary = reader.get_summary()
        assert summary is not None and summary.chunk_indexes
        kinds: dict[str, set[str]] = {}
        for c in summary.chunk_indexes:
            topics = {summary.channels[i].topic for i in c.message_index_offsets}
            for topic in topics:
                kinds.setdefault(topic, set()).add(c.compression)
    assert kinds["/wsgrasp/inputs"] == {""} and kinds["/inputs/view0"] == {""}
    assert kinds["/scene/object"] == {""}
    assert kinds["/wsgrasp/stage/candidates"] == {"zstd"}
    assert kinds["/wsgrasp/run"] == {"zstd"} and kinds["/grasp/gripper"] == {"zstd"}
    # one chunk per stage: run, inputs, preprocess, segmentation, frame,
    # candidates, result
    assert len(summary.chunk_indexes) >= 7


def test_every_message_reads_with_mcaps_stock_reader(recorded) -> None:
    from mcap.reader import make_reader

    run = open_run(recorded[0])
    with open(recorded[0], "rb") as fh:
        stock = [(c.topic, m.data) for _, c, m in make_reader(fh).iter_messages()]
    assert sorted(stock) == sorted((m.topic, m.data) for m in run.messages)


def test_mcaps_stock_reader_fails_on_a_cut_file_and_open_run_does_not(
    recorded, tmp_path: Path
) -> None:
    """The case the reader's own failure handling is for: ``make_reader`` needs
    the summary, which a cut file lacks."""
    from mcap.reader import make_reader

    data = recorded[0].read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: int(len(data) * 0.9)])
    with open(cut, "rb") as fh, pytest.raises(Exception):  # noqa: B017, PT011
        list(make_reader(fh).iter_messages())
    run = open_run(cut)
    assert run.truncated and run.result is not None
    assert run.scene.points.tobytes() == box_scene().points.tobytes()


def test_record_refuses_an_existing_file_without_force(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    path.write_bytes(b"precious")
    with pytest.raises(RecordingError, match="--force"):
        RunRecorder(path)
    assert path.read_bytes() == b"precious"
    # --force replaces recordings only, never another file
    with pytest.raises(RecordingError, match="not an MCAP recording"):
        RunRecorder(path, force=True)
    assert path.read_bytes() == b"precious"
    from wsgrasp.api import Pipeline

    path.unlink()
    for _ in range(2):  # a recording, then the same path replaced with --force
        Pipeline(fake_spec(), gripper=fake_gripper()).plan(
            box_scene(), observers=[RunRecorder(path, force=True)]
        )
        assert open_run(path).status == "ok"


def test_record_never_writes_through_a_link_or_over_an_input(tmp_path: Path) -> None:
    from wsgrasp.record._writer import check_record_path

    target = tmp_path / "target.txt"
    target.write_text("keep")
    link = tmp_path / "run.mcap"
    link.symlink_to(target)
    with pytest.raises(RecordingError, match="symbolic link"):
        check_record_path(link, force=True)
    cloud = tmp_path / "cloud.npy"
    cloud.write_bytes(b"\x93NUMPY")
    with pytest.raises(RecordingError, match="input of this run"):
        check_record_path(cloud, force=True, inputs=[cloud])
    assert target.read_text() == "keep"


def test_default_run_path_is_utc_time_and_gripper() -> None:
    spec = fake_spec(record={"dir": "some/runs"})
    now = datetime(2024, 5, 6, 7, 8, 9, 123456, tzinfo=timezone.utc)
    p = default_run_path(spec, "franka hand", now=now)
    assert p == Path("some/runs/20240506T070809.123456Z-franka_hand.mcap")


@pytest.mark.parametrize("fraction", [0.02, 0.2, 0.5, 0.8, 0.97, 0.999])
def test_a_cut_file_still_inspects_and_says_what_is_missing(
    recorded, tmp_path: Path, fraction: float
) -> None:
    data = recorded[0].read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: int(len(data) * fraction)])
    try:
        run = open_run(cut)
    except RecordingError as exc:  # cut inside the very first records
        assert fraction < 0.05, exc
        return
    assert run.truncated
    s = summarize_run(run)
    assert s["truncated"] is True
    assert s["feasible"] + sum(s["rejections"].values()) == s["candidates"]
    assert set(run.missing) <= set(PARTS)
    if run.result_data is None:
        assert "result" in run.missing


def test_truncation_point_is_reported_per_stage(recorded, tmp_path: Path) -> None:
    """Cutting just after each chunk keeps every stage before it."""
    from mcap.reader import make_reader

    data = recorded[0].read_bytes()
    with open(recorded[0], "rb") as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None
    chunks = summary.chunk_indexes
    seen = []
    for c in sorted(chunks, key=lambda c: c.chunk_start_offset):
        end = c.chunk_start_offset + c.chunk_length
        cut = tmp_path / f"cut{end}.mcap"
        cut.write_bytes(data[:end])
        run = open_run(cut)
        assert run.truncated
        seen.append(len(run.missing))
    assert seen == sorted(seen, reverse=True), "each chunk adds parts"
    assert seen[-1] == 0


def test_crash_mid_plan_leaves_a_file_with_the_finished_stages(tmp_path: Path) -> None:
    path = tmp_path / "crash.mcap"
    rec = RunRecorder(path)
    rec.on_start(fake_spec(), fake_gripper(), box_scene())
    rec.on_stage("preprocess", {"points": box_scene().points[::3]})
    # the process dies here: no on_result, no close
    run = open_run(path)
    assert run.truncated
    assert run.missing == ["segmentation", "object_frame", "candidates", "result"]
    assert run.scene.points.tobytes() == box_scene().points.tobytes()
    assert summarize_run(run)["candidates"] == 0
    rec.close()


def test_a_failed_plan_is_recorded_with_its_error(tmp_path: Path) -> None:
    from wsgrasp.api import Pipeline
    from wsgrasp.errors import WsgraspError
    from wsgrasp.perception.types import Scene, View

    table_only = np.random.default_rng(0).uniform(-0.2, 0.2, (2000, 3)) * [1, 1, 0]
    scene = Scene(views=[View(points=table_only)], points=table_only)
    path = tmp_path / "failed.mcap"
    with pytest.raises(WsgraspError):
        Pipeline(fake_spec(), gripper=fake_gripper()).plan(
            scene, observers=[RunRecorder(path)]
        )
    run = open_run(path)
    assert run.status == "error" and not run.truncated and run.error is not None
    assert run.error["type"] == "InputError" and run.error["message"]
    assert summarize_run(run)["error"]["type"] == "InputError"


def test_missing_and_non_mcap_files(tmp_path: Path) -> None:
    with pytest.raises(RecordingError, match="no such run file"):
        open_run(tmp_path / "nope.mcap")
    text = tmp_path / "cloud.mcap"
    text.write_text("0 0 0\n1 1 1\n")
    with pytest.raises(RecordingError, match="not an MCAP file"):
        open_run(text)
    empty = tmp_path / "empty.mcap"
    empty.write_bytes(b"")
    with pytest.raises(RecordingError, match="empty"):
        open_run(empty)


def test_corrupt_chunk_is_one_clear_error(recorded, tmp_path: Path) -> None:
    from mcap.reader import make_reader

    data = bytearray(recorded[0].read_bytes())
    with open(recorded[0], "rb") as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None
    chunk = summary.chunk_indexes[1]
    mid = chunk.chunk_start_offset + chunk.chunk_length // 2
    data[mid : mid + 16] = bytes(16)  # zeros over compressed data
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data))
    with pytest.raises(RecordingError, match="corrupt"):
        open_run(bad)


@pytest.mark.parametrize("name", ["gripper/model.npz", "gripper/description.json"])
def test_a_changed_byte_of_an_attachment_is_corruption(
    recorded, tmp_path: Path, name: str
) -> None:
    from mcap.reader import make_reader

    open_run(recorded[0])  # waits until the recording is finished
    data = bytearray(recorded[0].read_bytes())
    with open(recorded[0], "rb") as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None
    (index,) = [a for a in summary.attachment_indexes if a.name == name]
    at = index.offset + index.length - 4 - index.data_size // 2  # inside its data
    data[at] ^= 0x01
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data))
    with pytest.raises(RecordingError, match=f"corrupt.*attachment '{name}'"):
        open_run(bad)


def test_an_mcap_that_is_not_a_run(tmp_path: Path) -> None:
    from bag_factory import write_cloud_bag

    bag = write_cloud_bag(
        tmp_path / "bag.mcap", [("/camera/points", "cam", np.zeros((5, 3)), 1)]
    )
    with pytest.raises(RecordingError, match="not a wsgrasp run.*camera/points"):
        open_run(bag)


def test_a_newer_format_names_the_version(tmp_path: Path) -> None:
    path = tmp_path / "future.mcap"
    from mcap.writer import Writer

    with open(path, "wb") as fh:
        w = Writer(fh)
        w.start("wsgrasp", "wsgrasp 9.0")
        w.add_metadata("wsgrasp", {"format_version": "7", "wsgrasp_version": "9.0"})
        w.finish()
    with pytest.raises(
        RecordingError, match=rf"wsgrasp 9\.0 in run format 7.*up to {FORMAT_VERSION}"
    ):
        open_run(path)
