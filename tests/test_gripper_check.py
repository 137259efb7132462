"""`wsgrasp gripper check`: a sound gripper passes; each kind of mistake in a
gripper YAML or URDF is reported with the field to change."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
import yaml
from urdf_factory import jaw_urdf, swing_jaw_urdf

from wsgrasp.cli import main
from wsgrasp.gripper.check import check_gripper

ROOT = Path(__file__).resolve().parents[1]
FRANKA = ROOT / "plugins" / "grippers" / "wsgrasp_grippers" / "franka_hand"


@pytest.fixture(autouse=True)
def _cache(tmp_path_factory, monkeypatch):
    cache = tmp_path_factory.getbasetemp() / "gripper-cache"
    monkeypatch.setenv("WSGRASP_CACHE_DIR", str(cache))


def _franka_variant(tmp_path, edit) -> Path:
    """A copy of the Franka hand's YAML and URDF with ``edit(data)`` applied."""
    shutil.copy(FRANKA / "franka_hand.urdf", tmp_path / "franka_hand.urdf")
    data = yaml.safe_load((FRANKA / "franka_hand.yaml").read_text())
    data["name"] = "franka_variant"
    data["joint_samples"] = 11
    edit(data)
    path = tmp_path / "variant.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _fields(report, severity=None):
    return {p.field for p in report.problems if severity in (None, p.severity)}


def test_franka_hand_passes():
    report = check_gripper("franka_hand")
    assert not report.problems, report.format()
    for f in report.fingers:
        assert f["pad_closes_mm"] == pytest.approx(80.0, abs=1.0)
        assert f["pad_facing_deg"] < 10.0
        assert f["covered_fraction"] > 0.3 and f["workspace_volume_m3"] > 0
    assert report.cloud_inside_se == 1.0
    assert 0.15 < report.size_m < 0.3
    text = report.format()
    assert "finger left" in text and "no problems found" in text


def test_swapped_postures_are_an_error_on_closed(tmp_path):
    def swap(d):
        d["pregrasp"], d["closed"] = d["closed"], d["pregrasp"]

    report = check_gripper(_franka_variant(tmp_path, swap))
    errors = [p for p in report.errors if p.field == "closed"]
    assert len(errors) == 2 and "does not get nearer" in errors[0].message
    assert "swap the values of pregrasp and closed" in errors[0].fix


def test_pad_on_the_outer_face_is_reported(tmp_path):
    def outer(d):
        # the left finger's box spans y 0..18 mm: put the pad on its +y (outer) face
        d["fingers"][0]["pad"]["center"] = [0.0, 0.018, 0.045]

    report = check_gripper(_franka_variant(tmp_path, outer))
    assert "fingers[left].pad" in _fields(report, "warning")
    assert "fingers[right].pad" not in _fields(report)


def test_given_ellipsoids_that_miss_the_body(tmp_path):
    def tiny(d):
        d["ellipsoids"] = {
            "count": 1,
            "given": [{"center": [0, 0, 0.03], "semi_axes": [0.02, 0.02, 0.02]}],
        }

    report = check_gripper(_franka_variant(tmp_path, tiny))
    assert "ellipsoids" in _fields(report, "error")
    assert report.cloud_inside_se < 0.5


def test_ellipsoid_in_a_finger_workspace(tmp_path):
    def block(d):
        d["ellipsoids"] = {
            "count": 1,
            "given": [{"center": [0, 0, 0.06], "semi_axes": [0.04, 0.11, 0.06]}],
        }

    report = check_gripper(_franka_variant(tmp_path, block))
    assert any(i["fraction"] > 0.9 for i in report.intrusions)
    msgs = [p.message for p in report.errors if p.field == "ellipsoids"]
    assert any("of finger left's workspace" in m for m in msgs)


def test_fingers_that_never_meet(tmp_path):
    """Fingers mounted 60 mm apart: neither reaches the other's workspace."""
    urdf = tmp_path / "jaw.urdf"
    urdf.write_text(jaw_urdf(mimic=False, apart=True))
    pad = {"center": [0, 0, 0.045], "size": [0.01, 0.0, 0.01], "samples": 5}
    data = {
        "name": "apart",
        "urdf": "jaw.urdf",
        "base_link": "palm",
        "tool_frame": {"link": "palm", "xyz": [0, 0, 0.1]},
        "approach_axis": [0, 0, 1],
        "closing_axis": [0, 1, 0],
        "fingers": [
            {"name": "a", "joints": ["left_joint"], "pad": {"link": "left_finger"}},
            {"name": "b", "joints": ["right_joint"], "pad": {"link": "right_finger"}},
        ],
        "joint_samples": 9,
        "workspace_voxel": 0.002,
        "spheres_per_finger": 3,
        "pregrasp": {"left_joint": 0.04, "right_joint": 0.04},
        "closed": {"left_joint": 0.0, "right_joint": 0.0},
    }
    for f in data["fingers"]:
        f["pad"].update(pad)
    path = tmp_path / "apart.yaml"
    path.write_text(yaml.safe_dump(data))
    report = check_gripper(path)
    touch = [p for p in report.problems if "cannot touch" in p.message]
    assert touch and "'left_finger'" in touch[0].message
    assert touch[0].field == "fingers[a]"


def test_joint_that_moves_nothing(tmp_path):
    """An actuated joint whose child link has no geometry."""
    text = jaw_urdf().replace(
        "</robot>",
        """  <link name="dial"/>
  <joint name="dial_joint" type="revolute">
    <parent link="palm"/><child link="dial"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>""",
    )
    (tmp_path / "jaw.urdf").write_text(text)
    from wsgrasp.gripper.scaffold import guess_description, render_yaml

    sc = guess_description(tmp_path / "jaw.urdf", "dial_jaw")
    sc.data["joint_samples"] = 9
    path = tmp_path / "dial_jaw.yaml"
    path.write_text(render_yaml(sc))
    report = check_gripper(path)
    assert report.idle_joints == ["dial_joint"]
    idle = [p for p in report.problems if "'dial_joint' moves nothing" in p.message]
    assert idle and "'dial'" in idle[0].fix


def test_cli_check_json_picture_and_exit_codes(tmp_path, capsys):
    png = tmp_path / "franka.png"
    assert main(["gripper", "check", "franka_hand", "-o", str(png), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["name"] == "franka_hand" and out["problems"] == []
    assert png.stat().st_size > 10_000

    def swap(d):
        d["pregrasp"], d["closed"] = d["closed"], d["pregrasp"]

    bad = _franka_variant(tmp_path, swap)
    assert main(["gripper", "check", str(bad)]) == 1
    text = capsys.readouterr().out
    assert "error:" in text and "[field: closed]" in text


def test_a_collision_envelope_round_the_fingers_is_named(tmp_path):
    """A palm whose collision geometry is an envelope drawn round the fingers
    (as for arm motion planning): the check names the link and says to give it
    its own shape, not to add superellipsoids; the same jaw without the
    envelope has no such finding."""
    from wsgrasp.gripper.scaffold import scaffold_plugin

    envelope = (
        '<collision><origin xyz="0 0 0.08"/><geometry>'
        '<box size="0.06 0.2 0.08"/></geometry></collision></link>'
    )
    urdf = jaw_urdf().replace("</link>", envelope, 1)  # the palm is the first link
    (tmp_path / "env.urdf").write_text(urdf)
    yaml_path, _ = scaffold_plugin("env", tmp_path / "env.urdf", tmp_path / "pkg")
    report = check_gripper(yaml_path, cache_dir=tmp_path / "cache")
    found = [p for p in report.errors if p.field == "urdf"]
    assert len(found) == 2 and all(
        "link 'palm' itself holds" in p.message for p in found
    )
    assert "<collision> shapes of its own form" in found[0].fix
    assert not [p for p in report.problems if p.field == "ellipsoids"]
    (tmp_path / "plain.urdf").write_text(jaw_urdf())
    plain, _ = scaffold_plugin("plain", tmp_path / "plain.urdf", tmp_path / "plain")
    assert not [
        p
        for p in check_gripper(plain, cache_dir=tmp_path / "cache").problems
        if p.field == "urdf"
    ]


@pytest.mark.parametrize("opening", [0.8, 0.96], ids=["46deg", "55deg"])
def test_jaws_that_swing_open_leave_their_workspace_free(tmp_path, opening):
    """Jaws hinged on a palm and tilted open in the pre-grasp posture: the box
    round a tilted jaw holds the air it closes through, so the superellipsoids
    beyond the palm's go to the jaws; the default five then leave most of each
    jaw's workspace free, and the ones round a jaw's own link (its pad centre
    inside or not) are expected there, not reported."""
    from wsgrasp.gripper.scaffold import scaffold_plugin

    (tmp_path / "swing.urdf").write_text(swing_jaw_urdf(opening))
    yaml_path, sc = scaffold_plugin("swing", tmp_path / "swing.urdf", tmp_path / "pkg")
    assert sc.data["pregrasp"] == {"left_hinge": opening}
    report = check_gripper(yaml_path, cache_dir=tmp_path / "cache")
    assert not report.errors, report.format()
    assert not [p for p in report.problems if p.field == "ellipsoids"]
    assert sc.data["ellipsoids"]["count"] == 5
    for f in report.model.stats["fingers"]:
        assert f["workspace_inside_se"] < 0.35, f


def test_one_superellipsoid_round_a_jaw_swung_open_is_an_error(tmp_path):
    """The same jaws with one superellipsoid per link: the box round each
    tilted jaw swallows most of its workspace, an error naming the finger's
    own links and the count to raise."""
    from wsgrasp.gripper.scaffold import scaffold_plugin

    (tmp_path / "swing.urdf").write_text(swing_jaw_urdf(0.96))
    yaml_path, _ = scaffold_plugin(
        "swing", tmp_path / "swing.urdf", tmp_path / "pkg", check=False
    )
    data = yaml.safe_load(yaml_path.read_text())
    data["ellipsoids"]["count"] = 3
    yaml_path.write_text(yaml.safe_dump(data))
    report = check_gripper(yaml_path, cache_dir=tmp_path / "cache")
    found = [p for p in report.errors if p.field == "ellipsoids"]
    assert len(found) == 2, report.format()
    for p, finger in zip(found, ("left", "right"), strict=True):
        assert f"fitted round finger {finger}'s own links open" in p.message
        assert "raise ellipsoids.count" in p.fix
