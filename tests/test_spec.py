"""Pipeline specs: examples load, errors name file, line and key, schemas fresh."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from wsgrasp.cli import main
from wsgrasp.errors import SpecError
from wsgrasp.spec import json_schemas, load_spec

ROOT = Path(__file__).resolve().parents[1]
SPECS = sorted((ROOT / "examples" / "specs").glob("*.yaml"))


@pytest.mark.parametrize("path", SPECS, ids=lambda p: p.name)
def test_example_specs_load(path):
    spec = load_spec(path)
    assert f"gripper: {spec.gripper}\n" in path.read_text()
    if path.stem.endswith("_paper"):  # the paper's Table I setting
        s = spec.sampling
        assert (s.mode, s.points, s.orientations) == ("major_axis", 147, 4)
    if path.stem.endswith("_followup"):  # the follow-up's sampling
        assert spec.sampling.mode == "xyz"


def _write(tmp_path, text, name="spec.yaml"):
    p = tmp_path / name
    p.write_text(text)
    return p


BASE = "version: 1\ngripper: franka_hand\n"


@pytest.mark.parametrize(
    ("body", "line", "fragment"),
    [
        (
            "sampling:\n  points: 147\n  orientatons: 4\n",
            5,
            "unknown key 'sampling.orientatons'",
        ),
        ("sampling:\n  points: many\n", 4, "sampling.points"),
        ("preprocess:\n  voxel_size: -1\n", 4, "greater than 0"),
        (
            "scorers:\n  - name: centroid_distanse\n",
            4,
            "did you mean 'centroid_distance'",
        ),
        (
            "segmenter:\n  name: ransac_dbscan\n  options: {plane_distanse: 1}\n",
            5,
            "plane_distanse",
        ),
    ],
    ids=["typo-key", "wrong-type", "out-of-range", "unknown-scorer", "plugin-option"],
)
def test_spec_errors_name_file_line_and_key(tmp_path, body, line, fragment):
    p = _write(tmp_path, BASE + body)
    with pytest.raises(SpecError) as info:
        load_spec(p)
    msg = str(info.value)
    assert f"{p}:{line}:" in msg, msg
    assert fragment in msg


def test_unknown_gripper_suggests_close_names(tmp_path):
    p = _write(tmp_path, "gripper: franka_hnd\n")
    with pytest.raises(SpecError, match="did you mean 'franka_hand'"):
        load_spec(p)


def test_toml_and_json_specs(tmp_path):
    t = _write(tmp_path, 'gripper = "franka_hand"\n[sampling]\npoints = 60\n', "s.toml")
    assert load_spec(t).sampling.points == 60
    j = _write(tmp_path, json.dumps({"gripper": "allegro_right"}), "s.json")
    assert load_spec(j).gripper == "allegro_right"
    bad = _write(
        tmp_path, 'gripper = "franka_hand"\n[sampling]\npointz = 60\n', "b.toml"
    )
    with pytest.raises(SpecError, match=r"b\.toml:3: unknown key 'sampling.pointz'"):
        load_spec(bad)


def test_syntax_error_has_line(tmp_path):
    p = _write(tmp_path, "gripper: franka_hand\nsampling: {points: [1,\n")
    with pytest.raises(SpecError, match=r"spec\.yaml:\d+: cannot parse"):
        load_spec(p)


def test_committed_schemas_are_fresh():
    for name, schema in json_schemas().items():
        committed = json.loads((ROOT / "schemas" / name).read_text())
        assert committed == json.loads(json.dumps(schema)), (
            f"schemas/{name} is stale: run `wsgrasp schema`"
        )


def test_cli_spec_check_and_error_exit(tmp_path, capsys):
    assert main(["spec", "check", str(SPECS[0])]) == 0
    bad = _write(tmp_path, BASE + "sampling: {pionts: 3}\n")
    assert main(["spec", "check", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "unknown key 'sampling.pionts'" in err
    assert "Traceback" not in err
    assert len(err.strip().splitlines()) <= 3  # one message, wrapped at most
