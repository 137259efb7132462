"""``wsgrasp eval``: the command, its report and its specs."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

pytest.importorskip("mujoco")

from wsgrasp.cli import main  # noqa: E402
from wsgrasp.errors import InputError  # noqa: E402
from wsgrasp.sim import (  # noqa: E402
    OUTCOMES,
    build_report,
    report_markdown,
    spec_entries,
)


def test_eval_one_object_one_trial(tmp_path: Path, capsys: pytest.CaptureFixture):
    md = tmp_path / "table.md"
    rc = main(
        [
            "eval",
            "--gripper",
            "franka_hand",
            "--objects",
            "realsense_box",
            "--trials",
            "1",
            "--workers",
            "1",
            "--json",
            "--md-out",
            str(md),
        ]
    )
    assert rc == 0
    report = json.loads(capsys.readouterr().out)
    assert report["trials"] == 1
    assert 0.0 <= report["success_rate"] <= 1.0
    assert report["plan_ms_median"] > 0
    by_spec = {r["spec"]: r for r in report["results"]}
    assert set(by_spec) == {"default", "paper"}
    row = by_spec["default"]["objects"][0]
    assert row["object"] == "realsense_box"
    assert row["trials"] == 1
    assert row["paper"] == {"plan_s": 0.41, "success_rate": 0.9}
    (record,) = [r for r in report["trial_records"] if r["spec"] == "default"]
    assert record["outcome"] in OUTCOMES
    assert record["protocol"] == report["params"]["protocol"] == "strict"
    # the box settles on one of its faces: its height is one of its sides
    sides = (0.13, 0.07, 0.055)
    assert min(abs(record["object_height"] - s) for s in sides) < 0.005
    assert "| realsense_box |" in md.read_text()


def test_eval_refuses_an_open_mesh(tmp_path: Path, capsys: pytest.CaptureFixture):
    import numpy as np
    import trimesh

    mesh = trimesh.creation.box(extents=(0.05, 0.05, 0.1))
    mesh.update_faces(np.arange(len(mesh.faces)) > 1)
    mesh.export(tmp_path / "open.stl")
    rc = main(["eval", "--objects", str(tmp_path / "open.stl"), "--trials", "1"])
    assert rc == 2
    err = capsys.readouterr().err
    assert "not watertight" in err


def _rec(gripper: str, spec: str, obj: str, outcome: str, plan_ms: float) -> dict:
    return {
        "gripper": gripper,
        "spec": spec,
        "object": obj,
        "trial": 0,
        "outcome": outcome,
        "plan_ms": plan_ms,
    }


def test_report_counts_outcomes_per_object_and_gripper():
    records = [
        _rec("franka_hand", "default", "mug", "success", 100.0),
        _rec("franka_hand", "default", "mug", "slipped_lifting", 300.0),
        _rec("franka_hand", "default", "banana", "success", 200.0),
        _rec("franka_hand", "paper", "mug", "no_grasp", 50.0),
        _rec("allegro_right", "default", "mug", "dropped_holding", 400.0),
    ]
    report = build_report(records)
    # the top level is the primary ("default") spec over every gripper
    assert report["trials"] == 4
    assert report["success_rate"] == pytest.approx(0.5)
    assert report["plan_ms_median"] == pytest.approx(250.0)
    franka = next(
        r
        for r in report["results"]
        if r["gripper"] == "franka_hand" and r["spec"] == "default"
    )
    assert franka["success_rate"] == pytest.approx(2 / 3)
    mug = next(o for o in franka["objects"] if o["object"] == "mug")
    assert mug["failures"]["slipped_lifting"] == 1
    assert mug["success_rate"] == pytest.approx(0.5)
    md = report_markdown(report)
    assert "| mug | 0.20 s | 50 % | 0.05 s | 0 % | 0.23 s | 80 % |" in md
    assert "**allegro_right**" in md


def test_a_gripper_given_as_a_file_is_shown_by_its_stem():
    """Tables, titles and file names show a gripper given as a YAML path by the
    file's stem (a table column would cut a path to its first letters); the
    report keeps the path, which says which file ran."""
    from wsgrasp._names import gripper_label
    from wsgrasp.sim.report import report_table
    from wsgrasp.sim.runner import record_name

    path = "/tmp/pkgs/wsgrasp_my_hand/my_hand.yaml"
    assert gripper_label(path) == "my_hand" and gripper_label("franka_hand") == (
        "franka_hand"
    )
    assert record_name(path, "default", "mug", 3) == "my_hand-default-mug-003.mcap"
    report = build_report([_rec(path, "default", "mug", "success", 100.0)])
    assert report["results"][0]["gripper"] == path
    md = report_markdown(report)
    assert "**my_hand**" in md and "| my_hand | default |" in md and path not in md
    from rich.console import Console

    console = Console(width=200, record=True)
    for part in report_table(report):
        console.print(part)
    text = console.export_text()
    assert "my_hand: median plan time" in text and "/tmp/pkgs" not in text
    # two files of one stem stay apart, by their paths
    other = "/tmp/other/wsgrasp_my_hand/my_hand.yaml"
    both = build_report(
        [
            _rec(path, "default", "mug", "success", 100.0),
            _rec(other, "default", "mug", "no_grasp", 100.0),
        ]
    )
    md = report_markdown(both)
    assert f"**{path}**" in md and f"**{other}**" in md


def test_spec_entries_default_paper_and_files(tmp_path: Path):
    entries = spec_entries(["franka_hand", "allegro_right"])
    assert [(e.gripper, e.label) for e in entries] == [
        ("franka_hand", "default"),
        ("franka_hand", "paper"),
        ("allegro_right", "default"),
        ("allegro_right", "paper"),
    ]
    assert all(e.spec["gripper"] == e.gripper for e in entries)
    paper = entries[1].spec
    assert [s["name"] for s in paper["scorers"]] == ["centroid_distance"]

    spec = tmp_path / "mine.yaml"
    spec.write_text("version: 1\ngripper: franka_hand\n")
    (entry,) = spec_entries(["allegro_right"], [f"x={spec}"])
    assert entry.label == "x" and entry.spec["gripper"] == "allegro_right"
    with pytest.raises(InputError, match="labels repeat"):
        spec_entries(["franka_hand"], [str(spec), str(spec)])


def test_spec_entries_followup_sampling():
    """--followup adds the follow-up's xyz sampling beside default and paper, for
    a gripper with its own follow-up spec and for one that borrows Franka's."""
    barrett = str(
        Path(__file__).resolve().parent.parent
        / "examples/plugins/barrett_bh8_like/wsgrasp_barrett_bh8_like"
        / "barrett_bh8_like.yaml"
    )
    entries = spec_entries(["allegro_right", barrett], followup=True)
    assert [e.label for e in entries] == ["default", "paper", "followup"] * 2
    for e in entries:
        if e.label == "followup":
            assert e.spec["sampling"]["mode"] == "xyz"
            assert e.source.endswith("specs/followup.yaml")
        else:
            assert e.spec["sampling"].get("mode", "major_axis") != "xyz"


def test_report_records_the_libraries_it_ran_with():
    from importlib import metadata

    report = build_report([_rec("franka_hand", "default", "mug", "success", 100.0)])
    libs = report["libraries"]
    # the simulator's version as installed, and None for what is not installed
    assert libs["numpy"] == metadata.version("numpy")
    assert set(libs) >= {"python", "wsgrasp", "mujoco", "coacd", "open3d", "numba"}
    # and the processor's vector extension, which the libraries' kernels follow
    assert libs["cpu"].split()[0] == __import__("platform").machine()
    assert all(v is None or isinstance(v, str) for v in libs.values())


def test_report_gives_the_held_grasps_friction_use():
    """Per gripper and spec, the median friction use of the grasps that held
    (their trials' ``friction_use_held``), printed with the failures; a spec
    with no held grasp, or records without it, has none."""

    def rec(spec, outcome, use):
        r = _rec("franka_hand", spec, "mug", outcome, 10.0)
        r["metrics"] = {"friction_use_held": use}
        return r

    records = [
        rec("default", "success", 0.2),
        rec("default", "success", 0.6),
        rec("default", "slipped_in_grip", 0.9),  # not held: left out
        rec("default", "success", 0.4),
        rec("firm", "no_grasp", None),
    ]
    report = build_report(records)
    by_spec = {r["spec"]: r for r in report["results"]}
    assert by_spec["default"]["held_friction_use_median"] == pytest.approx(0.4)
    assert by_spec["firm"]["held_friction_use_median"] is None
    md = report_markdown(report)
    assert "held: friction use" in md
    assert "| 0.40 |" in md and "| – |" in md
