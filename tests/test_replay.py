"""Replaying recorded runs: identical with the recorded spec, a difference with
another one, the gripper model taken from the file."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from test_record_fakes import box_scene, fake_gripper, fake_spec, plan_recorded
from typer.testing import CliRunner

from wsgrasp.cli import app, main
from wsgrasp.errors import RecordingError
from wsgrasp.record import open_run, replay_run


@pytest.fixture(scope="module")
def run_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("replay") / "run.mcap"
    plan_recorded(path)
    return path


def test_replay_is_identical_without_the_gripper_plugin(run_path: Path) -> None:
    # "fake_franka" is registered by no plugin: the model comes from the file
    report = replay_run(run_path)
    assert report.identical and report.same_spec and report.differences == []
    assert report.recorded == report.replayed


def test_replay_cli_json_exit_codes(run_path: Path, capsys) -> None:
    assert main(["replay", str(run_path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["identical"] is True


def _cli(*args: str) -> tuple[int, str]:
    res = CliRunner().invoke(app, list(args))
    return res.exit_code, res.stdout


def test_replay_with_another_spec_shows_the_difference(
    run_path: Path, tmp_path: Path
) -> None:
    other = tmp_path / "other.yaml"
    other.write_text(
        "version: 1\ngripper: fake_franka\nsegmenter: {name: ransac_dbscan}\n"
        "sampling: {points: 60, orientations: 3, angle_range_deg: 180}\n"
        "scorers: [{name: centroid_distance, weight: 1.0}]\n"
    )
    new = tmp_path / "replayed.mcap"
    code, text = _cli(
        "replay", str(run_path), "--spec", str(other), "--json", "--record", str(new)
    )
    out = json.loads(text)
    assert code == 0, "with --spec, a difference is the replay's result"
    assert out["identical"] is False and out["same_spec"] is False
    assert "candidates.reason" in out["differences"]
    assert out["recorded"]["candidates"] == 588
    assert out["replayed"]["candidates"] == 180
    assert set(out["histogram"]["feasible"]) == {"recorded", "replayed"}
    if out["recorded"]["found"] and out["replayed"]["found"]:
        assert out["pose_delta"]["translation_m"] >= 0.0
        assert 0.0 <= out["pose_delta"]["angle_deg"] <= 180.0
    assert open_run(new).status == "ok"
    # the table view of the same comparison
    code, text = _cli("replay", str(run_path), "--spec", str(other))
    assert code == 0
    assert "different" in text and "feasible" in text


def test_replay_never_overwrites(run_path: Path) -> None:
    before = run_path.read_bytes()
    with pytest.raises(RecordingError, match="never (overwrites|records over)"):
        replay_run(run_path, record=run_path, force=True)
    with pytest.raises(RecordingError, match="input of this run"):
        replay_run(run_path, record=run_path)
    other = run_path.with_name("other.mcap")
    other.write_bytes(before)
    with pytest.raises(RecordingError, match="--force"):
        replay_run(run_path, record=other)
    assert run_path.read_bytes() == before


def test_replay_detects_a_changed_result(run_path: Path, tmp_path: Path) -> None:
    """Flip the recorded seed-independent input: the replay must notice."""
    from wsgrasp.api import Pipeline
    from wsgrasp.record import RunRecorder

    scene = box_scene(seed=1)
    path = tmp_path / "other_scene.mcap"
    Pipeline(fake_spec(), gripper=fake_gripper()).plan(
        scene, observers=[RunRecorder(path)]
    )
    run = open_run(path)
    # swap in the first run's inputs: same spec, different result
    run.inputs = open_run(run_path).inputs
    run.__dict__.pop("scene", None)
    report = replay_run(run)
    assert not report.identical and report.differences


def _real_gripper(name: str):
    from wsgrasp.gripper import load_gripper

    return load_gripper(name)


@pytest.mark.parametrize("gripper", ["franka_hand", "allegro_right"])
def test_record_replay_identical_for_the_real_grippers(
    gripper: str, tmp_path: Path, monkeypatch
) -> None:
    model = _real_gripper(gripper)
    spec = fake_spec(gripper=gripper)
    path = tmp_path / f"{gripper}.mcap"
    plan_recorded(path, spec=spec, gripper=model)
    # replay with the plugin's gripper unavailable: the model comes from the file
    import wsgrasp.gripper as g

    def no_plugin(*a, **k):
        raise AssertionError("replay must not build or load the gripper")

    monkeypatch.setattr(g, "load_gripper", no_plugin)
    report = replay_run(path)
    assert report.identical, report.differences


def test_a_run_recorded_before_angles_from_replays_with_the_papers_angles(
    tmp_path: Path,
) -> None:
    """Recorded specs hold every field; one recorded before
    ``sampling.angles_from`` existed was planned with the object frame's angles,
    and replays with them, not with today's default (``table``)."""
    sampling = {"points": 147, "orientations": 4, "angle_range_deg": 360}
    path = tmp_path / "old.mcap"
    plan_recorded(path, spec=fake_spec(sampling={**sampling, "angles_from": "object"}))
    run = open_run(path)
    assert run.spec_data is not None
    assert run.spec_data["sampling"]["angles_from"] == "object"
    old = {k: v for k, v in run.spec_data["sampling"].items() if k != "angles_from"}
    run.__dict__["spec_data"] = {**run.spec_data, "sampling": old}  # as recorded then
    assert run.spec.sampling.angles_from == "object"
    assert replay_run(run).identical
    # a field the run did record is kept as recorded
    new = open_run(path)
    assert new.spec_data is not None
    new.spec_data["sampling"]["angles_from"] = "table"  # the cached data
    assert new.spec.sampling.angles_from == "table"


def test_a_run_recorded_before_across_narrowest_replays_with_the_frames_angles(
    tmp_path: Path,
) -> None:
    """A spec recorded before ``sampling.across_narrowest`` existed turned no
    angles on upright objects, and replays so."""
    path = tmp_path / "old.mcap"
    plan_recorded(path, spec=fake_spec(sampling={"across_narrowest": False}))
    run = open_run(path)
    assert run.spec_data is not None
    old = {
        k: v for k, v in run.spec_data["sampling"].items() if k != "across_narrowest"
    }
    run.__dict__["spec_data"] = {**run.spec_data, "sampling": old}  # as recorded then
    assert run.spec.sampling.across_narrowest is False
    assert replay_run(run).identical
