"""`wsgrasp gripper new`: what the scaffolder guesses from a URDF, the package it
writes, and the clear errors on bad URDFs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from numpy.testing import assert_allclose
from urdf_factory import jaw_urdf, rigid_jaw_urdf, write_claw

from wsgrasp.errors import GripperError
from wsgrasp.gripper.scaffold import copy_urdf, guess_description, scaffold_plugin
from wsgrasp.spec import GripperDescription


@pytest.fixture(autouse=True)
def _cache(tmp_path_factory, monkeypatch):
    cache = tmp_path_factory.getbasetemp() / "gripper-cache"
    monkeypatch.setenv("WSGRASP_CACHE_DIR", str(cache))


def _write(tmp_path, text, name="g.urdf"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_jaw_guesses_base_fingers_axes_and_postures(tmp_path):
    sc = guess_description(_write(tmp_path, jaw_urdf()), "jaw")
    d = sc.data
    GripperDescription.model_validate(d)
    assert d["base_link"] == "palm"
    assert [f["pad"]["link"] for f in d["fingers"]] == ["left_finger", "right_finger"]
    # the mimic follows its master: both fingers are driven by left_joint
    assert [f["joints"] for f in d["fingers"]] == [["left_joint"], ["left_joint"]]
    assert d["approach_axis"] == [0.0, 0.0, 1.0]
    assert d["closing_axis"] == [0.0, 1.0, 0.0]
    assert d["pregrasp"] == {"left_joint": 0.04}
    assert d["closed"] == {"left_joint": 0.0}
    # pads on the inner faces: the left finger's box spans y 0..15 mm, its inner
    # face is its -y side; the right finger's is its +y side
    left, right = (np.array(f["pad"]["center"]) for f in d["fingers"])
    assert left[1] < 0.0075 - 0.005 and right[1] > -0.0075 + 0.005
    # the TCP between the fingertips, in front of the palm
    tcp = np.array(d["tool_frame"]["xyz"])
    assert abs(tcp[1]) < 1e-6 and 0.05 < tcp[2] < 0.11
    for field in ("base_link", "approach_axis", "closing_axis", "pregrasp", "pad"):
        assert sc.notes[field], field


def _arm_with_jaw(
    joints: int,
    prefix: str = "",
    parent: str = "arm_base",
    length: float = 0.3,
    gripper: str | None = None,
) -> str:
    """An arm of ``joints`` revolute joints (box links ``length`` long) hanging
    from link ``parent``, ``gripper``'s URDF (``jaw_urdf``'s jaw by default; its
    root link named ``palm``) bolted to its last link (a fixed joint); every
    name but ``parent`` starts with ``prefix``."""
    import re

    jaw = gripper or jaw_urdf()
    body = jaw[jaw.index("<link") : jaw.index("</robot>")]
    body = re.sub(r'((?:name|link|joint)=")', rf"\g<1>{prefix}", body)
    arm = []
    up = parent
    for i in range(1, joints + 1):
        arm.append(
            f'<link name="{prefix}arm_{i}"><collision><origin xyz="0 0 '
            f'{length / 2:g}"/><geometry><box size="0.06 0.06 {length:g}"/>'
            "</geometry></collision></link>"
            f'<joint name="{prefix}arm_joint_{i}" type="revolute"><parent '
            f'link="{up}"/><child link="{prefix}arm_{i}"/><origin xyz="0 0 '
            f'{length:g}"/>'
            '<axis xyz="0 1 0"/><limit lower="-2.9" upper="2.9" effort="80" '
            'velocity="2"/></joint>'
        )
        up = f"{prefix}arm_{i}"
    arm.append(
        f'<joint name="{prefix}flange" type="fixed"><parent link="{up}"/>'
        f'<child link="{prefix}palm"/><origin xyz="0 0 {length:g}"/></joint>'
    )
    return "".join(arm) + body


def _on_arm(joints: int, gripper: str | None = None) -> str:
    """``gripper``'s URDF (``jaw_urdf``'s jaw by default) on an arm of ``joints``
    joints: the URDF of a robot."""
    base = (
        '<link name="arm_base"><collision><geometry><box size="0.1 0.1 0.1"/>'
        "</geometry></collision></link>"
    )
    arm = _arm_with_jaw(joints, gripper=gripper)
    return f'<?xml version="1.0"?>\n<robot name="robot">{base}{arm}</robot>'


def test_a_gripper_on_an_arm_starts_where_the_fingers_part(tmp_path):
    """A robot's URDF (an arm of six joints, then the jaw): the arm is left out,
    the base is the jaw's palm, as if the jaw's own URDF had been given; the note
    names the arm. With ``--base-link`` the given link stays the base."""
    alone = guess_description(_write(tmp_path, jaw_urdf()), "jaw").data
    sc = guess_description(_write(tmp_path, _on_arm(6), "robot.urdf"), "jaw")
    assert sc.data["base_link"] == "palm"
    assert "arm of 6 joints" in sc.notes["base_link"]
    assert "arm_joint_1" in sc.notes["base_link"]
    assert any("arm_base" in w and "ignored" in w for w in sc.warnings)
    for key in ("fingers", "approach_axis", "closing_axis", "pregrasp", "closed"):
        assert sc.data[key] == alone[key], key
    given = guess_description(tmp_path / "robot.urdf", "jaw", base_link="arm_6")
    assert given.data["base_link"] == "arm_6"
    # two joints above the fingers are a wrist, held, not an arm
    wrist = guess_description(_write(tmp_path, _on_arm(2), "wrist.urdf"), "jaw")
    assert wrist.data["base_link"] == "arm_base"


def test_a_plugin_from_a_robots_urdf_carries_the_gripper_alone(tmp_path):
    """The package scaffolded from a robot's URDF holds the links below the
    gripper's base and nothing of the arm; it builds and checks."""
    from wsgrasp.gripper import load_gripper
    from wsgrasp.gripper._urdf import load_kinematics

    urdf = _write(tmp_path, _on_arm(6), "robot.urdf")
    yaml_path, sc = scaffold_plugin("armjaw", urdf, tmp_path / "out")
    copy = yaml_path.parent / "armjaw.urdf"
    kin = load_kinematics(copy, "armjaw")
    assert set(kin.links) == {"palm", "left_finger", "right_finger"}
    assert "arm_joint_1" not in copy.read_text()
    text = yaml_path.read_text()
    assert "left out of the copied URDF, above base link palm" in text
    assert "are ignored" not in text
    assert not [w for w in sc.warnings if "error" in w]
    assert load_gripper(str(yaml_path)).num_fingers == 2


def test_the_arm_left_out_keeps_simulator_elements_whole(tmp_path):
    """A robot's URDF with Gazebo elements named like URDF tags
    (``<joint:hinge>`` between two arm links, as in the PR2's URDF): leaving the
    arm out removes the URDF joints and links only, and the copy stays valid
    XML."""
    import xml.etree.ElementTree as ET

    gazebo = (
        '<gazebo reference="arm_2"><joint:hinge name="arm_tip_hinge">'
        "<body1>arm_1</body1><body2>arm_2</body2><axis>0 0 1</axis>"
        "</joint:hinge><linkName>arm_2</linkName></gazebo>"
    )
    robot = _on_arm(6).replace(
        '<robot name="robot">',
        '<robot name="robot" xmlns:joint="http://example.org/joint">' + gazebo,
    )
    urdf = _write(tmp_path, robot, "robot.urdf")
    yaml_path, _ = scaffold_plugin("armjaw", urdf, tmp_path / "out")
    copy = (yaml_path.parent / "armjaw.urdf").read_text()
    ET.fromstring(copy)
    assert "<joint:hinge" in copy and "arm_joint_1" not in copy


def test_a_robot_with_two_grippers_or_a_rigid_tool_is_refused_clearly(tmp_path):
    """Two jaws on two arms of one torso: one message naming both; an arm whose
    tool has no finger joints: one message saying so."""
    base = (
        '<link name="arm_base"><collision><geometry><box size="0.1 0.1 0.1"/>'
        "</geometry></collision></link>"
    )
    both = (
        f'<?xml version="1.0"?>\n<robot name="two">{base}'
        f"{_arm_with_jaw(3, 'l_')}{_arm_with_jaw(3, 'r_')}</robot>"
    )
    with pytest.raises(GripperError, match="holds 2 grippers") as info:
        guess_description(_write(tmp_path, both, "two.urdf"), "jaw")
    assert "'l_palm'" in str(info.value) and "'r_palm'" in str(info.value)
    assert "--base-link" in info.value.hint
    # a robot so small that its arms and hands span less than a hand may
    short = (
        f'<?xml version="1.0"?>\n<robot name="two">{base}'
        f"{_arm_with_jaw(3, 'l_', length=0.02)}{_arm_with_jaw(3, 'r_', length=0.02)}"
        "</robot>"
    )
    with pytest.raises(GripperError, match="holds 2 grippers"):
        guess_description(_write(tmp_path, short, "small.urdf"), "jaw")
    one = guess_description(tmp_path / "two.urdf", "jaw", base_link="r_palm")
    assert one.data["base_link"] == "r_palm"
    rigid = _on_arm(6).replace('type="prismatic"', 'type="fixed"')
    with pytest.raises(GripperError, match="no finger joints"):
        guess_description(_write(tmp_path, rigid, "rigid.urdf"), "jaw")


def test_a_jaw_closing_on_a_rigid_one_gets_the_rigid_jaw_as_a_finger(tmp_path):
    """One moving jaw and a jaw plate on the palm: the plate is a second finger
    with no joints, its pad a box on the plate's inner face as deep as the
    moving finger may push the object; the moving jaw closes to where the two
    meet (its limit narrowed there), not through the plate to its limit. On a
    robot's URDF (an arm of six joints above it), the arm is left out and the
    guess is the same."""
    sc = guess_description(_write(tmp_path, rigid_jaw_urdf()), "rj")
    d = sc.data
    moving, rigid = d["fingers"]
    assert moving["joints"] == ["jaw_joint"] and rigid["joints"] == []
    assert rigid["name"] == "rigid_jaw" and rigid["pad"]["link"] == "palm"
    # the plate's inner face is at y = -20 mm; the pad box starts there and
    # reaches 10 mm towards the moving jaw, along the plate's height
    lo = np.array(rigid["pad"]["center"]) - np.array(rigid["pad"]["size"]) / 2
    hi = np.array(rigid["pad"]["center"]) + np.array(rigid["pad"]["size"]) / 2
    assert lo[1] == pytest.approx(-0.02, abs=1e-3)
    assert hi[1] == pytest.approx(-0.01, abs=1e-3)
    assert 0.04 <= lo[2] < hi[2] <= 0.1
    # the jaws meet near 0.68 rad: closed stops within 5 mm of that, the limit
    # narrowed to it; pregrasp is the other limit
    assert d["pregrasp"] == {"jaw_joint": -0.6}
    assert 0.55 < d["closed"]["jaw_joint"] < 0.68
    assert sc.limits == {"jaw_joint": (-0.6, d["closed"]["jaw_joint"])}
    assert d["approach_axis"] == [0.0, 0.0, 1.0]
    assert d["closing_axis"] == [0.0, 1.0, 0.0]
    assert "rigid jaw" in sc.notes["fingers"] and "rigid jaw" in sc.notes["pad"]
    on_arm = guess_description(
        _write(tmp_path, _on_arm(6, rigid_jaw_urdf()), "robot.urdf"), "rj"
    )
    assert on_arm.data["base_link"] == "palm"
    assert "joint 'jaw_joint' of the only moving finger" in on_arm.notes["base_link"]
    for key in ("fingers", "approach_axis", "closing_axis", "pregrasp", "closed"):
        assert on_arm.data[key] == d[key], key


def test_a_placeholder_on_an_actuators_link_is_no_finger(tmp_path):
    """A hand's URDF may give the link an actuator turns a placeholder box of a
    millimetre or two (the fingers follow through joints of their own): that
    link is no finger, the note says so, and its joint, moving no finger, is
    held."""
    motor = (
        '<link name="motor"><collision><geometry><box size="0.0016 0.0016 0.0016"/>'
        '</geometry></collision></link><joint name="motor_joint" type="revolute">'
        '<parent link="palm"/><child link="motor"/><origin xyz="0 0 0.02"/>'
        '<axis xyz="1 0 0"/><limit lower="0" upper="1" effort="1" velocity="1"/>'
        "</joint></robot>"
    )
    urdf = jaw_urdf().replace("</robot>", motor)
    sc = guess_description(_write(tmp_path, urdf), "jaw")
    assert [f["pad"]["link"] for f in sc.data["fingers"]] == [
        "left_finger",
        "right_finger",
    ]
    assert (
        "placeholders on an actuator's or a sensor's link): motor"
        in sc.notes["fingers"]
    )
    assert sc.data["pregrasp"]["motor_joint"] == sc.data["closed"]["motor_joint"]


def test_an_arm_without_its_gripper_is_refused_clearly(tmp_path):
    """An arm of six joints and nothing mounted on it: its last link is the one
    moving "finger", and it closes against no rigid jaw; one message says so
    and names the link and its joint."""
    bare = '<?xml version="1.0"?>\n<robot name="jaw"><link name="palm"/></robot>'
    urdf = _write(tmp_path, _on_arm(6, bare), "arm.urdf")
    with pytest.raises(GripperError, match="closes against no still geometry") as err:
        guess_description(urdf, "arm")
    assert "'arm_6'" in str(err.value) and "arm_joint_6" in str(err.value)
    assert "an arm without its gripper" in str(err.value)


def test_a_finger_that_hardly_opens_from_still_geometry_is_no_jaw(tmp_path):
    """The rigid-jaw gripper with its jaw's range cut to open only 9 mm from the
    plate (a wrist turning beside its arm's last link opens no more): no rigid
    jaw is guessed, and the one-finger message says why."""
    urdf = rigid_jaw_urdf().replace('lower="-0.6"', 'lower="0.55"')
    with pytest.raises(GripperError, match="closes against no still geometry"):
        guess_description(_write(tmp_path, urdf), "rj")
    wide = rigid_jaw_urdf().replace('lower="-0.6"', 'lower="0.4"')  # 18 mm
    assert (
        guess_description(_write(tmp_path, wide), "rj").data["fingers"][1]["joints"]
        == []
    )


def test_a_rigid_jaw_gripper_builds_checks_and_plans(tmp_path):
    """The scaffolded rigid-jaw gripper builds into a model with two fingers
    (the rigid one's spheres fill its pad box), `gripper check` finds no error,
    and its default spec grasps an upright box and a cube."""
    import wsgrasp
    from wsgrasp.gripper import load_gripper
    from wsgrasp.gripper.check import check_gripper
    from wsgrasp.perception.synth import synth_scene
    from wsgrasp.spec import load_spec

    urdf = _write(tmp_path, rigid_jaw_urdf())
    yaml_path, _ = scaffold_plugin("rj", urdf, tmp_path / "pkg")
    g = load_gripper(str(yaml_path), cache_dir=tmp_path / "cache")
    assert g.num_fingers == 2 and (g.sphere_finger == 1).any()
    # the rigid jaw reaches what lies in its pad box from the first step of
    # the closing, and nothing a few centimetres from it
    from wsgrasp.planning.sweeps import reach_steps, sweep_steps

    pad = yaml.safe_load(yaml_path.read_text())["fingers"][1]["pad"]
    inside = np.array(pad["center"]) + [0.0, 0.004, 0.0]
    away = np.array(pad["center"]) + [0.0, 0.03, 0.0]
    steps = reach_steps(g, np.stack([inside, away]), finger=1)[:, 0]
    assert steps[0] == 0 and steps[1] == sweep_steps(g)
    report = check_gripper(yaml_path, cache_dir=tmp_path / "cache")
    assert not report.errors, report.format()
    # the rigid pad faces the moving jaw, though the palm's centre lies
    # beyond it (the pad's face is told from the jaw's surface behind it)
    assert not [p for p in report.warnings if "inner face" in p.message]
    assert report.fingers[1]["pad_facing_deg"] < 45
    spec_path = yaml_path.parent / "specs" / "default.yaml"
    spec = load_spec(
        {**yaml.safe_load(spec_path.read_text()), "gripper": str(yaml_path)}
    )
    pipe = wsgrasp.Pipeline(spec, gripper=g)
    for size in ((0.04, 0.03, 0.08), (0.03, 0.03, 0.03)):
        result = pipe.plan(synth_scene("box", size=size, seed=1).points)
        assert result.found, (size, result.hint)


def test_a_description_of_rigid_jaws_alone_is_refused(tmp_path):
    """Every finger a rigid jaw: nothing closes, refused naming the field; a
    rigid jaw whose pad link another finger's joint moves: refused naming both."""
    from wsgrasp.errors import SpecError
    from wsgrasp.gripper import load_gripper

    sc = guess_description(_write(tmp_path, rigid_jaw_urdf()), "rj")
    data = yaml.safe_load(yaml.safe_dump(sc.data))
    data["fingers"][0]["joints"] = []
    with pytest.raises((SpecError, ValueError), match="every finger is a rigid jaw"):
        GripperDescription.model_validate(data)
    data = yaml.safe_load(yaml.safe_dump(sc.data))
    data["fingers"][1]["pad"]["link"] = "jaw"
    (tmp_path / "moved.yaml").write_text(yaml.safe_dump(data))
    with pytest.raises(GripperError, match="rigid jaw .*jaw_joint"):
        load_gripper(str(tmp_path / "moved.yaml"), cache_dir=tmp_path / "cache")


def test_two_actuated_fingers_each_get_their_joint(tmp_path):
    sc = guess_description(_write(tmp_path, jaw_urdf(mimic=False)), "jaw")
    assert [f["joints"] for f in sc.data["fingers"]] == [
        ["left_joint"],
        ["right_joint"],
    ]
    assert sc.data["closed"] == {"left_joint": 0.0, "right_joint": 0.0}


def test_claw_with_odd_conventions(tmp_path):
    """Approach along x, revolute two-link fingers with a mimic distal joint,
    meshes under package:// paths."""
    urdf = write_claw(tmp_path / "src")
    copy, notes = copy_urdf(urdf, tmp_path / "pkg", "claw")
    assert len(notes) == 4 and (tmp_path / "pkg" / "meshes" / "palm.stl").is_file()
    assert "package://" not in copy.read_text()
    d = guess_description(copy, "claw").data
    assert d["approach_axis"] == [1.0, 0.0, 0.0]
    assert d["closing_axis"] == [0.0, 1.0, 0.0]
    assert [f["pad"]["link"] for f in d["fingers"]] == ["upper_distal", "lower_distal"]
    assert [f["joints"] for f in d["fingers"]] == [["upper_knuckle"], ["lower_knuckle"]]
    # fingers open outwards at the lower limit, close at the upper one
    assert d["pregrasp"] == {"upper_knuckle": -0.3, "lower_knuckle": -0.3}
    # ... and their pads meet 70 % of the way there: past it the fingers cross,
    # so the closing path stops where they meet (they do meet: no advice to
    # close further)
    assert "without meeting" not in guess_description(copy, "claw").notes["closed"]
    assert d["closed"] == pytest.approx(
        {"upper_knuckle": 0.403, "lower_knuckle": 0.403}, abs=0.01
    )
    # the upper finger (y > 0) closes towards -y: its pad is on its -y face
    assert d["fingers"][0]["pad"]["center"][1] < 0 < d["fingers"][1]["pad"]["center"][1]


def test_scaffolded_package_is_complete_and_its_yaml_validates(tmp_path):
    urdf = _write(tmp_path, jaw_urdf(), "jaw.urdf")
    yaml_path, sc = scaffold_plugin("my-jaw", urdf, tmp_path / "out")
    out = tmp_path / "out"
    pkg = out / "wsgrasp_my_jaw"
    assert yaml_path == pkg / "my-jaw.yaml"
    for rel in ("pyproject.toml", "README.md", "tests/test_wsgrasp_my_jaw.py"):
        assert (out / rel).is_file(), rel
    assert (pkg / "__init__.py").is_file() and (pkg / "my-jaw.urdf").is_file()
    pyproject = (out / "pyproject.toml").read_text()
    assert '[project.entry-points.wsgrasp]\nmy-jaw = "wsgrasp_my_jaw"' in pyproject
    text = yaml_path.read_text()
    assert "# the root link of the URDF tree" in text
    assert "`wsgrasp gripper check` on this guess" in text
    GripperDescription.model_validate(yaml.safe_load(text))
    # the drive is not guessed: it ends the YAML commented out, at the
    # simulator's defaults, and uncommented it is a valid drive
    from wsgrasp.sim.params import SimParams

    last = text.rstrip("\n").splitlines()[-1]
    assert last.startswith("# drive: ")
    assert "drive" not in yaml.safe_load(text)
    on = GripperDescription.model_validate(yaml.safe_load(text + last[2:] + "\n"))
    assert on.drive.kp_revolute == SimParams().kp_revolute
    assert on.drive.kp_prismatic == SimParams().kp_prismatic
    # the package ships the default spec that plan --gripper and eval use
    from wsgrasp.default_specs import default_spec

    assert "specs/*.yaml" in pyproject
    data, source = default_spec(str(yaml_path))
    assert source == str(pkg / "specs" / "default.yaml")
    assert data["sampling"]["mode"] == "approach_sphere"
    # a second scaffold into the same folder needs --force
    with pytest.raises(GripperError, match="--force"):
        scaffold_plugin("my-jaw", urdf, out)
    scaffold_plugin("my-jaw", urdf, out, force=True)


# -- bad input: one clear error (or warning) naming the link/joint and the fix ----
def test_no_actuated_joint(tmp_path):
    with pytest.raises(GripperError) as err:
        guess_description(_write(tmp_path, jaw_urdf(actuated=False)), "jaw")
    msg = str(err.value)
    assert "no actuated joint" in msg and "left_joint (fixed)" in msg
    assert "revolute or prismatic" in msg


def test_disconnected_trees(tmp_path):
    path = _write(tmp_path, jaw_urdf(stray_tree=True))
    with pytest.raises(GripperError) as err:
        guess_description(path, "jaw")
    msg = str(err.value)
    assert "2 disconnected trees" in msg and "'stray_camera'" in msg
    assert "--base-link" in msg
    sc = guess_description(path, "jaw", base_link="palm")
    assert any("stray_camera" in w for w in sc.warnings)


def test_continuous_joint_without_limits_on_a_finger(tmp_path):
    with pytest.raises(GripperError) as err:
        guess_description(_write(tmp_path, jaw_urdf(continuous=True)), "jaw")
    msg = str(err.value)
    assert "'swivel_joint'" in msg and "<limit lower" in msg


def test_urdf_in_millimetres(tmp_path):
    with pytest.raises(GripperError, match="millimetres"):
        guess_description(_write(tmp_path, jaw_urdf(scale=1000.0)), "jaw")


def test_meshes_in_millimetres(tmp_path):
    urdf = write_claw(tmp_path / "src", mesh_scale=1000.0)
    with pytest.raises(GripperError) as err:
        copy_urdf(urdf, tmp_path / "a", "claw")
    msg = str(err.value)
    assert "millimetres" in msg and "--mesh-units mm" in msg and "link " in msg
    copy, _ = copy_urdf(urdf, tmp_path / "b", "claw", mesh_units="mm")
    assert copy.read_text().count('scale="0.001 0.001 0.001"') == 6
    d = guess_description(copy, "claw").data
    assert d["approach_axis"] == [1.0, 0.0, 0.0]


def test_a_marker_drawn_at_the_tool_frame_is_not_solid(tmp_path):
    """A URDF that gives its links collision geometry and draws a marker sphere
    at its tool frame, between the jaws, with a visual alone: the marker is no
    body (a solid there would meet every object the jaws close on); in a URDF
    without any collision element, visuals are the shapes."""
    from wsgrasp.gripper._urdf import load_kinematics

    marker = (
        '<link name="tool0"><visual><geometry><sphere radius="0.005"/></geometry>'
        '</visual></link><joint name="tool0_joint" type="fixed"><parent '
        'link="palm"/><child link="tool0"/><origin xyz="0 0 0.09"/></joint>\n</robot>'
    )
    urdf = _write(tmp_path, jaw_urdf().replace("</robot>", marker))
    kin = load_kinematics(urdf, "jaw")
    assert kin.shapes["tool0"] == [] and kin.drawn_only == ["tool0"]
    assert kin.shapes["palm"]
    yaml_path, _ = scaffold_plugin("jaw", urdf, tmp_path / "o")
    header = yaml_path.read_text()
    assert "drawn but not solid" in header and "tool0" in header
    drawn = urdf.read_text().replace("<collision>", "<visual>")
    drawn = drawn.replace("</collision>", "</visual>")
    kin = load_kinematics(_write(tmp_path, drawn, "drawn.urdf"), "jaw")
    assert kin.shapes["tool0"] and kin.shapes["palm"] and not kin.drawn_only


def test_a_finger_joint_whose_limits_are_equal_is_named(tmp_path):
    """A jaw's joint written with ``lower = upper`` (Hello Robot's SG3 gripper,
    whose second jaw follows the first by a transmission the URDF leaves
    out): the error names the joint and its limits, and the <mimic> fix."""
    text = jaw_urdf(mimic=False)
    right = text.index('<joint name="right_joint"')
    text = text[:right] + text[right:].replace('upper="0.04"', 'upper="0"', 1)
    with pytest.raises(GripperError) as err:
        scaffold_plugin("jaw", _write(tmp_path, text), tmp_path / "o")
    msg = str(err.value)
    assert "right_joint (lower = upper = 0) spans nothing" in msg
    assert "<mimic" in msg


def test_a_sphere_of_radius_zero_is_no_shape(tmp_path):
    """A frame link written with ``<sphere radius="0.00"/>`` (ARMAR-4's) is no
    solid: no shape, and no division by zero in the mesh library."""
    import warnings

    from wsgrasp.gripper._urdf import load_kinematics

    frame = (
        '<link name="frame"><collision><geometry><sphere radius="0.00"/></geometry>'
        '</collision></link><joint name="frame_joint" type="fixed"><parent '
        'link="palm"/><child link="frame"/></joint>\n</robot>'
    )
    urdf = _write(tmp_path, jaw_urdf().replace("</robot>", frame))
    assert load_kinematics(urdf, "jaw").shapes["frame"] == []
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scaffold_plugin("jaw", urdf, tmp_path / "o")


def test_a_long_mesh_above_the_base_link_is_no_unit_error(tmp_path):
    """A robot's URDF may hold a part truly over a metre long above the gripper
    (a mobile manipulator's mast): that is no mesh in millimetres, and with
    ``--base-link`` naming the gripper it is left out of the copy; a gripper
    link's own mesh that long is still refused."""
    import trimesh

    urdf = write_claw(tmp_path / "src")
    trimesh.creation.box(extents=(0.05, 0.05, 1.3)).export(
        tmp_path / "src" / "meshes" / "mast.stl"
    )
    text = urdf.read_text().replace(
        '<robot name="claw">',
        '<robot name="claw">\n  <link name="mast"><collision><geometry><mesh '
        'filename="package://claw_description/meshes/mast.stl"/></geometry>'
        '</collision></link>\n  <joint name="lift" type="fixed"><parent '
        'link="mast"/><child link="claw_base"/><origin xyz="0.1 0 0.5"/></joint>',
    )
    urdf.write_text(text)
    yaml_path, sc = scaffold_plugin("claw", urdf, tmp_path / "o", base_link="claw_base")
    assert sc.data["base_link"] == "claw_base"
    assert list(yaml_path.parent.rglob("palm.stl"))
    assert not list(yaml_path.parent.rglob("mast.stl"))
    with pytest.raises(GripperError) as err:
        scaffold_plugin("claw", urdf, tmp_path / "p", base_link="mast")
    assert "'mast.stl' of link mast" in str(err.value) and "millimetres" in str(
        err.value
    )


def test_missing_mesh_names_link_and_fix(tmp_path):
    urdf = write_claw(tmp_path / "src")
    moved = tmp_path / "elsewhere"
    (tmp_path / "src" / "meshes").rename(moved)
    with pytest.raises(GripperError) as err:
        copy_urdf(urdf, tmp_path / "a", "claw")
    msg = str(err.value)
    assert "palm.stl" in msg and "link claw_base" in msg and "--mesh-dir" in msg
    copy, _ = copy_urdf(urdf, tmp_path / "b", "claw", mesh_dirs=[moved])
    assert (copy.parent / "meshes" / "distal.stl").is_file()


def test_bad_names(tmp_path):
    urdf = _write(tmp_path, jaw_urdf())
    with pytest.raises(GripperError, match="package name"):
        scaffold_plugin("9 lives", urdf, tmp_path / "o")
    with pytest.raises(GripperError, match="does not exist"):
        scaffold_plugin("jaw", tmp_path / "nope.urdf", tmp_path / "o")
    with pytest.raises(GripperError, match="mesh-units"):
        scaffold_plugin("jaw", urdf, tmp_path / "o", mesh_units="inch")


@pytest.mark.parametrize(
    "text, kind",
    [
        ('<sdf version="1.6"><model name="g"/></sdf>', "an SDFormat"),
        ('<mujoco model="g"><worldbody/></mujoco>', "a MuJoCo"),
        ("solid cube\nendsolid cube\n", "not valid XML"),
    ],
    ids=["sdf", "mjcf", "not xml"],
)
def test_a_description_that_is_no_urdf_is_named_and_refused(tmp_path, text, kind):
    """An SDFormat or MJCF description, or no XML at all, passed as the URDF is
    refused before anything is written, naming the file the user passed."""
    src = tmp_path / "gripper.xml"
    src.write_text(text)
    with pytest.raises(GripperError) as err:
        scaffold_plugin("g", src, tmp_path / "out")
    msg = str(err.value)
    assert kind in msg and str(src) in msg and "URDF" in msg
    assert not (tmp_path / "out").exists()


def test_failed_scaffold_leaves_no_folder(tmp_path):
    urdf = _write(tmp_path, jaw_urdf(stray_tree=True))
    with pytest.raises(GripperError, match="disconnected"):
        scaffold_plugin("jaw", urdf, tmp_path / "out")
    assert not (tmp_path / "out").exists()


def _pad_speeds(urdf_path, d):
    """Per finger, the sum over its joints of the squared distance from the
    joint's axis to the pad centre, half closed, by yourdfpy's kinematics: the
    squared speed (m²/rad²) at which each of the hand's parallel-axis revolute
    joints moves the pad."""
    import yourdfpy

    u = yourdfpy.URDF.load(str(urdf_path), load_meshes=False)
    mid = {
        j: 0.5 * (d["pregrasp"].get(j, 0.0) + d["closed"].get(j, 0.0))
        for j in u.actuated_joint_names
    }
    u.update_cfg(mid)
    out = []
    for f in d["fingers"]:
        T = u.get_transform(f["pad"]["link"], d["base_link"])
        p = T[:3, :3] @ np.asarray(f["pad"]["center"]) + T[:3, 3]
        total = 0.0
        for jn in f["joints"]:
            joint = u.joint_map[jn]
            Tj = u.get_transform(joint.child, d["base_link"])
            a, o = Tj[:3, :3] @ np.asarray(joint.axis), Tj[:3, 3]
            v = p - o
            total += float(np.sum((v - a * (v @ a)) ** 2))
        out.append(total)
    return out


def test_a_gripper_gets_a_drive_for_its_size_a_prismatic_jaw_none(
    tmp_path, monkeypatch
):
    import hand_factory

    from wsgrasp.gripper._guess import PAD_STIFFNESS, PAD_STIFFNESS_THREE

    path = _write(tmp_path, hand_factory.hand_urdf(3), "hand.urdf")
    d = guess_description(path, "hand").data
    kp = d["drive"]["kp_revolute"]
    want = PAD_STIFFNESS_THREE * float(np.median(_pad_speeds(path, d)))
    assert kp == pytest.approx(want, rel=0.03)  # two significant digits
    GripperDescription.model_validate(d)
    # a fourth finger of the same size: the softer pads of a hand of more fingers
    path4 = _write(tmp_path, hand_factory.hand_urdf(4), "hand4.urdf")
    d4 = guess_description(path4, "hand4").data
    want4 = PAD_STIFFNESS * float(np.median(_pad_speeds(path4, d4)))
    assert d4["drive"]["kp_revolute"] == pytest.approx(want4, rel=0.03)
    assert PAD_STIFFNESS < PAD_STIFFNESS_THREE
    # the same hand twice as large: four times the gain for the same pad stiffness
    for name in ("PALM_RADIUS", "PALM_THICKNESS", "BASE_RADIUS", "PROXIMAL", "DISTAL"):
        monkeypatch.setattr(hand_factory, name, 2 * getattr(hand_factory, name))
    big = _write(tmp_path, hand_factory.hand_urdf(3), "big.urdf")
    assert guess_description(big, "big").data["drive"]["kp_revolute"] == (
        pytest.approx(4 * kp, rel=0.06)
    )
    # a prismatic jaw keeps the simulator's default; revolute jaws (the same
    # hand with two fingers) get their pads the stiffness of three fingers'
    assert "drive" not in guess_description(_write(tmp_path, jaw_urdf()), "jaw").data
    path2 = _write(tmp_path, hand_factory.hand_urdf(2), "hand2.urdf")
    d2 = guess_description(path2, "hand2").data
    want2 = PAD_STIFFNESS_THREE * float(np.median(_pad_speeds(path2, d2)))
    assert d2["drive"]["kp_revolute"] == pytest.approx(want2, rel=0.03)


def test_a_hands_prismatic_finger_leaves_the_drive_to_its_revolute_ones(tmp_path):
    import re

    import hand_factory

    from wsgrasp.gripper._guess import pad_stiffness

    text = hand_factory.hand_urdf(3)
    for joint in ("f0_base", "f0_tip", "f1_base", "f1_tip"):  # two fingers slide
        text = re.sub(rf'(<joint name="{joint}" type=")revolute', r"\1prismatic", text)
    for _ in range(2):
        text = text.replace('lower="-0.3" upper="1.0"', 'lower="0" upper="0.02"', 1)
        text = text.replace('lower="0" upper="1.2"', 'lower="0" upper="0.02"', 1)
    path = _write(tmp_path, text, "mixed.urdf")
    d = guess_description(path, "mixed").data
    revolute = [f for f in d["fingers"] if f["joints"][0].startswith("f2")]
    assert len(revolute) == 1
    speeds = _pad_speeds(path, {**d, "fingers": revolute})
    want = pad_stiffness(3) * float(np.median(speeds))
    assert d["drive"]["kp_revolute"] == pytest.approx(want, rel=0.03)


def test_gripper_new_names_a_hands_guessed_drive(tmp_path, capsys):
    """`wsgrasp gripper new` says which finger drive it guessed for a hand, and
    says nothing of one for a jaw."""
    import hand_factory

    from wsgrasp.cli import main

    hand = _write(tmp_path, hand_factory.hand_urdf(3), "hand.urdf")
    assert (
        main(["gripper", "new", "hand", "--urdf", str(hand), "-o", str(tmp_path / "h")])
        == 0
    )
    out = " ".join(capsys.readouterr().out.split())  # unwrapped
    kp = yaml.safe_load((tmp_path / "h" / "wsgrasp_hand" / "hand.yaml").read_text())
    assert f"finger drive in simulation {kp['drive']['kp_revolute']:g} N·m/rad" in out
    jaw = _write(tmp_path, jaw_urdf(), "jaw.urdf")
    assert (
        main(["gripper", "new", "jaw", "--urdf", str(jaw), "-o", str(tmp_path / "j")])
        == 0
    )
    assert "finger drive" not in capsys.readouterr().out


def test_a_wide_pad_is_sampled_a_voxel_apart_along_each_edge(tmp_path):
    """A jaw 5 cm wide: twelve points per edge leave its sweep a lattice of
    separate points that no sphere fits in; the scaffolder then samples the pad
    about a voxel apart along each edge (one count per edge), and its spheres
    cover the workspace."""
    from wsgrasp.gripper.check import MIN_COVERAGE, check_gripper

    urdf = _write(tmp_path, rigid_jaw_urdf(0.05))
    yaml_path, _ = scaffold_plugin("rj", urdf, tmp_path / "pkg")
    data = yaml.safe_load(yaml_path.read_text())
    moving = data["fingers"][0]["pad"]
    voxel = data["workspace_voxel"]
    assert isinstance(moving["samples"], list) and len(moving["samples"]) == 3
    pairs = zip(moving["size"], moving["samples"], strict=True)
    spacing = [s / (k - 1) for s, k in pairs if k > 1]
    assert max(spacing) <= voxel * 1.001
    report = check_gripper(yaml_path, cache_dir=tmp_path / "cache")
    assert not report.problems, report.format()
    assert min(f["covered_fraction"] for f in report.fingers) >= MIN_COVERAGE
    comments = " ".join(yaml_path.read_text().replace("#", " ").split())
    assert "a voxel apart along each edge" in comments


def test_a_rigid_pad_inside_the_body_superellipsoid_moves_out(tmp_path):
    """A rigid pad whose box the superellipsoid round its jaw swallows (object
    points there reject every grasp) slides out along its face's normal until
    the superellipsoids hold little of it."""
    from wsgrasp.geometry import box_grid_points, points_in_superellipsoids
    from wsgrasp.gripper import load_gripper
    from wsgrasp.gripper._guess import clear_rigid_pads
    from wsgrasp.gripper.check import INTRUSION_WARN
    from wsgrasp.gripper.scaffold import render_yaml

    urdf = _write(tmp_path, rigid_jaw_urdf())
    yaml_path, sc = scaffold_plugin("rj", urdf, tmp_path / "pkg")
    pad = sc.data["fingers"][1]["pad"]
    assert not clear_rigid_pads(sc, yaml_path)  # the guess lies clear already
    # push the box 6 mm into the jaw plate (its face looks along +y)
    pad["center"] = [pad["center"][0], pad["center"][1] - 0.006, pad["center"][2]]
    yaml_path.write_text(render_yaml(sc, []))
    pushed = pad["center"][1]
    assert clear_rigid_pads(sc, yaml_path)
    assert 0.003 <= pad["center"][1] - pushed <= 0.0105  # out along +y
    yaml_path.write_text(render_yaml(sc, []))
    g = load_gripper(str(yaml_path), cache_dir=tmp_path / "cache")
    box = box_grid_points(pad["center"], pad["size"], 5)  # palm frame = base frame
    inside = points_in_superellipsoids(box, g.se_centers, g.se_semi_axes, g.se_exponent)
    assert inside.mean() <= INTRUSION_WARN
    assert "the rigid pad moved" in sc.notes["pad"]


def test_pad_samples_per_edge_validate_and_match_one_count(tmp_path):
    """``pad.samples`` is one count (at most 12) or three, one per edge (at most
    64 each); three equal counts sample the workspace exactly as one does."""
    from wsgrasp.errors import SpecError
    from wsgrasp.gripper._urdf import load_kinematics
    from wsgrasp.gripper._workspace import sample_workspace

    urdf = _write(tmp_path, rigid_jaw_urdf())
    sc = guess_description(urdf, "rj")
    data = yaml.safe_load(yaml.safe_dump(sc.data))
    kin = load_kinematics(urdf, "rj")
    spaces = []
    for samples in (7, [7, 7, 7]):
        data["fingers"][0]["pad"]["samples"] = samples
        desc = GripperDescription.model_validate(data)
        spaces.append(sample_workspace(kin, desc, desc.fingers[0]))
    assert np.array_equal(spaces[0].occupied, spaces[1].occupied)
    assert spaces[0].closing == spaces[1].closing
    for bad in (13, [65, 2, 2], [4, 4]):
        data["fingers"][0]["pad"]["samples"] = bad
        with pytest.raises((SpecError, ValueError)):
            GripperDescription.model_validate(data)


def test_finger_names_come_from_the_words_the_link_names_do_not_share():
    """Finger names are the words of each distal link's name that the others
    lack; where a differing word appears in every name at another place (a
    right gripper's left and right fingertips), the words that differ at their
    place."""
    from wsgrasp.gripper._guess import _finger_names

    assert _finger_names(["rh_ffdistal", "rh_thdistal"]) == ["ffdistal", "thdistal"]
    assert _finger_names(["finger_1_link_3", "finger_middle_link_3"]) == [
        "finger1",
        "middle",
    ]
    assert _finger_names(
        ["gripper_right_fingertip_left_link", "gripper_right_fingertip_right_link"]
    ) == ["left", "right"]
    assert _finger_names(["r_gripper_l_finger_tip", "r_gripper_r_finger_tip"]) == [
        "l",
        "r",
    ]
    assert _finger_names(["/left_finger_link", "/right_finger_link"]) == [
        "left",
        "right",
    ]
    assert _finger_names(["tip", "tip"]) == ["finger1", "finger2"]


def test_a_urdf_with_undeclared_namespace_prefixes_is_read(tmp_path):
    """A Drake URDF's ``<drake:collision_filter_group>`` without an ``xmlns:drake``
    declaration (which ROS's and Drake's parsers accept): it scaffolds and
    builds; a URDF that is not XML is still refused naming the file."""
    from wsgrasp.gripper import load_gripper
    from wsgrasp.gripper._urdf import load_kinematics

    drake = (
        '<drake:collision_filter_group name="fingers">'
        '<drake:member link="left_finger"/><drake:member link="right_finger"/>'
        "</drake:collision_filter_group></robot>"
    )
    urdf = _write(tmp_path, jaw_urdf().replace("</robot>", drake), "drake.urdf")
    assert set(load_kinematics(urdf, "jaw").links) >= {"left_finger", "right_finger"}
    yaml_path, _ = scaffold_plugin("drakejaw", urdf, tmp_path / "pkg")
    assert load_gripper(str(yaml_path)).num_fingers == 2
    broken = _write(tmp_path, jaw_urdf().replace("</robot>", "<link>"), "bad.urdf")
    with pytest.raises(GripperError, match="not valid XML"):
        load_kinematics(broken, "jaw")


def test_a_link_turned_only_by_an_unlimited_continuous_joint_is_no_finger(tmp_path):
    """A motor's horn on a continuous joint without limits beside a jaw's two
    fingers (Interbotix arms' grippers): not a finger, its joint held at 0 with
    a warning; a finger that such a joint moves is still refused."""
    horn = (
        '<link name="horn"><collision><geometry><box size="0.02 0.02 0.01"/>'
        "</geometry></collision></link>"
        '<joint name="horn_joint" type="continuous"><parent link="palm"/>'
        '<child link="horn"/><origin xyz="0 0 -0.01"/><axis xyz="0 0 1"/></joint>'
        "</robot>"
    )
    urdf = _write(tmp_path, jaw_urdf().replace("</robot>", horn), "horn.urdf")
    sc = guess_description(urdf, "jaw")
    assert [f["pad"]["link"] for f in sc.data["fingers"]] == [
        "left_finger",
        "right_finger",
    ]
    assert "horn" in sc.notes["fingers"] and "without limits" in sc.notes["fingers"]
    assert any("horn_joint" in w and "held at 0" in w for w in sc.warnings)
    with pytest.raises(GripperError, match="moves a finger"):
        guess_description(_write(tmp_path, jaw_urdf(continuous=True)), "jaw")


def _xacro_package(root):
    """A ROS description package holding a jaw as xacro: a macro for the
    fingers in a file it includes, an argument for the finger length, a palm
    mesh named by ``package://`` and a finger mesh by ``$(find ...)``."""
    import trimesh

    pkg = root / "jaw_description"
    (pkg / "urdf").mkdir(parents=True)
    (pkg / "meshes").mkdir()
    (pkg / "package.xml").write_text(
        "<package format='2'><name>jaw_description</name></package>"
    )
    trimesh.creation.box(extents=(0.04, 0.16, 0.05)).export(pkg / "meshes/palm.stl")
    trimesh.creation.box(extents=(0.02, 0.015, 0.05)).export(pkg / "meshes/finger.stl")
    (pkg / "urdf" / "finger.xacro").write_text(
        """<?xml version="1.0"?>
<robot xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:macro name="finger" params="side sign length">
    <link name="${side}_finger"><collision>
      <origin xyz="0 ${sign * 0.0075} ${length / 2}"/>
      <geometry><mesh filename="$(find jaw_description)/meshes/finger.stl"
        scale="1 1 ${length / 0.05}"/></geometry>
    </collision></link>
    <joint name="${side}_joint" type="prismatic">
      <parent link="palm"/><child link="${side}_finger"/>
      <origin xyz="0 ${sign * 0.005} 0.05"/><axis xyz="0 ${sign} 0"/>
      <limit lower="0" upper="0.04" effort="1" velocity="1"/>
      <xacro:if value="${sign &lt; 0}"><mimic joint="left_joint"/></xacro:if>
    </joint>
  </xacro:macro>
</robot>
"""
    )
    (pkg / "urdf" / "jaw.urdf.xacro").write_text(
        """<?xml version="1.0"?>
<robot name="jaw" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:arg name="finger_length" default="0.05"/>
  <xacro:include filename="finger.xacro"/>
  <link name="palm"><collision><origin xyz="0 0 0.025"/>
    <geometry><mesh filename="package://jaw_description/meshes/palm.stl"/></geometry>
  </collision></link>
  <xacro:finger side="left" sign="1" length="$(arg finger_length)"/>
  <xacro:finger side="right" sign="-1" length="$(arg finger_length)"/>
</robot>
"""
    )
    return pkg / "urdf" / "jaw.urdf.xacro"


def test_a_xacro_file_is_expanded_with_its_arguments(tmp_path):
    """`gripper new` on a ROS package's .urdf.xacro: expanded (includes, macros,
    ``$(find)``, ``package://``), its ``--xacro-arg`` applied, the meshes copied
    into the package, and a model that builds; the expansion is named in the
    YAML. A bad argument, or an argument for a plain URDF, is refused."""
    pytest.importorskip("xacrodoc")
    from wsgrasp.gripper import load_gripper
    from wsgrasp.gripper._scaffold_urdf import xacro_args

    source = _xacro_package(tmp_path / "src")
    yaml_path, sc = scaffold_plugin(
        "xjaw",
        source,
        tmp_path / "pkg",
        xacro_args=xacro_args(["finger_length:=0.06"]),
    )
    copy = (yaml_path.parent / "xjaw.urdf").read_text()
    assert "xacro" not in copy and "$(find" not in copy
    assert sorted(p.name for p in (yaml_path.parent / "meshes").iterdir()) == [
        "finger.stl",
        "palm.stl",
    ]
    assert 'scale="1 1 1.2' in copy  # the argument reached the macro
    assert "expanded from jaw.urdf.xacro by xacro with finger_length:=0.06" in (
        " ".join(yaml_path.read_text().replace("#", " ").split())
    )
    assert [f["joints"] for f in sc.data["fingers"]] == [["left_joint"]] * 2
    assert load_gripper(str(yaml_path)).num_fingers == 2
    with pytest.raises(GripperError, match="NAME:=VALUE"):
        xacro_args(["finger_length=0.06"])
    with pytest.raises(GripperError, match="no xacro file"):
        scaffold_plugin(
            "plain",
            _write(tmp_path, jaw_urdf()),
            tmp_path / "plain",
            xacro_args={"a": "1"},
        )
    broken = source.parent / "broken.urdf.xacro"
    broken.write_text(source.read_text().replace("finger.xacro", "missing.xacro"))
    with pytest.raises(GripperError, match="does not expand"):
        scaffold_plugin("broken", broken, tmp_path / "broken")
    assert not (tmp_path / "broken").exists()


def test_a_xacro_file_without_xacrodoc_names_the_extra(tmp_path, monkeypatch):
    """Without xacrodoc installed, a xacro file is refused with the extra that
    installs it, and no package is left behind."""
    import sys

    monkeypatch.setitem(sys.modules, "xacrodoc", None)
    source = _xacro_package(tmp_path / "src")
    with pytest.raises(GripperError, match="needs xacrodoc") as info:
        scaffold_plugin("xjaw", source, tmp_path / "pkg")
    assert "wsgrasp[xacro]" in info.value.hint
    assert not (tmp_path / "pkg").exists()
    # a URDF that xacro wrote keeps the namespace, and needs no expanding
    written = jaw_urdf().replace(
        '<robot name="jaw">',
        '<robot name="jaw" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<!-- <xacro:include filename="jaw.xacro"/> -->',
    )
    plain = _write(tmp_path, written, "written.urdf")
    yaml_path, _ = scaffold_plugin("written", plain, tmp_path / "written")
    assert yaml_path.is_file()


def test_a_xacro_file_given_by_a_relative_path_expands(tmp_path, monkeypatch):
    """The xacro file named relative to the working folder, as on a command
    line: expanded, and the working folder is the same afterwards."""
    pytest.importorskip("xacrodoc")
    source = _xacro_package(tmp_path / "src")
    monkeypatch.chdir(tmp_path / "src")
    relative = source.relative_to(tmp_path / "src")
    yaml_path, _ = scaffold_plugin("xjaw", relative, tmp_path / "pkg")
    assert yaml_path.is_file()
    assert Path.cwd() == tmp_path / "src"


def test_a_gripper_yaml_whose_urdf_is_sdformat_names_the_format(tmp_path):
    """Read as a gripper's URDF (a YAML's ``urdf`` field), an SDFormat file is
    named for what it is, as ``gripper new`` names it."""
    from wsgrasp.gripper._urdf import load_kinematics

    src = tmp_path / "g.urdf"
    src.write_text('<sdf version="1.6"><model name="g"/></sdf>')
    with pytest.raises(GripperError, match="an SDFormat .* not a URDF"):
        load_kinematics(src, "g")


def test_gripper_new_points_a_mimic_at_the_joint_it_means(tmp_path):
    """A robot's URDF that prefixes its hand's joints but not its mimics
    (``<mimic joint="left_joint">`` where the joint is ``L_left_joint``): `gripper
    new` points the copy's mimic at the joint it clearly means and says so; the
    reader, given the URDF itself, names the joint it likely meant."""
    text = jaw_urdf().replace('name="left_joint"', 'name="L_left_joint"')
    text = text.replace('name="right_joint"', 'name="L_right_joint"')
    urdf = _write(tmp_path, text, "robot_with_hand.urdf")
    with pytest.raises(GripperError) as err:
        guess_description(urdf, "jaw")
    assert "mimicking unknown joint 'left_joint'" in err.value.message
    assert "did you mean 'L_left_joint'" in err.value.message
    yaml_path, sc = scaffold_plugin("jaw", urdf, tmp_path / "out")
    copied = (yaml_path.parent / "jaw.urdf").read_text()
    assert '<mimic joint="L_left_joint"' in copied
    assert "L_right_joint ('left_joint' -> L_left_joint)" in yaml_path.read_text()
    assert any("L_left_joint" in w for w in sc.warnings)
    assert sc.data["fingers"]  # both fingers follow the one actuated joint
    assert [j for f in sc.data["fingers"] for j in f["joints"]] == ["L_left_joint"] * 2


def test_gripper_new_frees_a_fixed_joint_that_follows_another(tmp_path):
    """A URDF exported for a solver without mimic joints makes the followers
    ``fixed`` and leaves their ``<mimic>``, ``<axis>`` and ``<limit>`` in place:
    the copy makes them move again, as the joint they follow does, and says
    so; a fixed joint without the three stays fixed."""
    from wsgrasp.gripper._scaffold_urdf import free_fixed_mimics

    text = jaw_urdf()
    start = text.index('<joint name="right_joint" type="prismatic">')
    frozen = text[:start] + text[start:].replace('type="prismatic"', 'type="fixed"', 1)
    urdf = _write(tmp_path, frozen, "exported.urdf")
    yaml_path, sc = scaffold_plugin("jaw", urdf, tmp_path / "out")
    copied = (yaml_path.parent / "jaw.urdf").read_text()
    assert '<joint name="right_joint" type="prismatic">' in copied
    assert "right_joint (prismatic)" in yaml_path.read_text()
    assert any("made to move" in w and "right_joint" in w for w in sc.warnings)
    assert [j for f in sc.data["fingers"] for j in f["joints"]] == ["left_joint"] * 2
    # without its mimic, a fixed joint means fixed
    plain = frozen.replace('<mimic joint="left_joint"/>', "")
    path = _write(tmp_path, plain, "plain.urdf")
    assert free_fixed_mimics(path) == {}
    assert path.read_text() == plain


def _placed(
    text: str,
    joint: str,
    xyz: str = "0.3 0.1 0.5",
    rpy: str = "0 3.14159 0",
    root: str = "world",
):
    """``text`` (a URDF whose root is ``palm``) under a ``root`` link without
    geometry that places it, as a simulator's spawn (or a robot's stage) does."""
    head, tail = text.split("\n", 2)[:2], text.split("\n", 2)[2]
    world = (
        f'  <link name="{root}"/>\n'
        f'  <joint name="{root}_joint" type="{joint}">\n'
        f'    <parent link="{root}"/><child link="palm"/>\n'
        f'    <origin xyz="{xyz}" rpy="{rpy}"/>\n'
        "  </joint>\n"
    )
    return "\n".join(head) + "\n" + world + tail


def test_gripper_new_takes_the_hand_below_a_world_link_that_places_it(tmp_path):
    """A ``world`` root without geometry, joined by a fixed joint that moves and
    turns the hand (a simulator's spawn), was taken for the gripper's base: the
    pads went on the wrong half of the fingers and the tool frame 3 cm off. The
    base is the first link with geometry below it; the guess is the plain one."""
    plain = _write(tmp_path, jaw_urdf(), "plain.urdf")
    placed = _write(tmp_path, _placed(jaw_urdf(), "fixed"), "placed.urdf")
    a = guess_description(plain, "jaw").data
    b = guess_description(placed, "jaw").data
    assert b["base_link"] == "palm"
    for key in ("tool_frame", "approach_axis", "closing_axis", "fingers", "closed"):
        assert b[key] == a[key], key


@pytest.mark.parametrize("drawn_palm", [False, True], ids=["palm", "drawn-palm"])
def test_gripper_new_takes_the_hand_above_a_stage_its_fingers_reach(
    tmp_path, drawn_palm
):
    """A root without geometry under any name (the TriFinger's ``base_link``,
    the floor of its stage) that a fixed joint puts where the fingers reach, 29
    cm below the holder they hang from, was taken for the gripper's base: the
    base 29 cm below the hand. The base is the hand's first link, also where
    that link is drawn only and its joints part (the TriFinger's holder); the
    guess is the plain one. A root behind the hand is the mount an arm holds,
    and stays the base."""
    text = jaw_urdf()
    if drawn_palm:  # the palm drawn, not solid; its fingers hang from it
        start = text.index('<link name="palm">')
        end = text.index("</link>", start)
        palm = text[start:end].replace("collision", "visual")
        text = text[:start] + palm + text[end:]
    plain = _write(tmp_path, text, "plain.urdf")
    # the hand upside down 0.3 m above the root: its fingers reach down to it
    stage = _placed(text, "fixed", "0 0 0.3", "0 3.14159 0", root="base_link")
    placed = _write(tmp_path, stage, "stage.urdf")
    a = guess_description(plain, "jaw").data
    b = guess_description(placed, "jaw")
    assert b.data["base_link"] == "palm"
    assert "where a drawn-only holder's joints part" in b.notes["base_link"]
    for key in ("tool_frame", "approach_axis", "closing_axis", "fingers", "closed"):
        assert b.data[key] == a[key], key
    # the same root 5 cm behind the palm, the fingers pointing away: a mount
    mount = _placed(text, "fixed", "0 0 0.05", "0 0 0", root="base_link")
    c = guess_description(_write(tmp_path, mount, "mount.urdf"), "jaw").data
    assert c["base_link"] == "base_link"
    assert_allclose(
        c["tool_frame"]["xyz"],
        np.add(a["tool_frame"]["xyz"], [0.0, 0.0, 0.05]),
        atol=1e-4,
    )


def test_a_floating_joint_above_the_gripper_is_held_still(tmp_path):
    """A floating joint from a ``world`` link to the hand: below --base-link it
    is no part of the gripper and stands still; without --base-link it is one
    error naming the link to pass."""
    urdf = _write(tmp_path, _placed(jaw_urdf(), "floating", "0 0 0", "0 0 0"))
    with pytest.raises(GripperError, match="type 'floating'") as err:
        guess_description(urdf, "jaw")
    assert "--base-link palm" in (err.value.hint or "")
    sc = guess_description(urdf, "jaw", base_link="palm")
    assert sc.data["base_link"] == "palm" and len(sc.data["fingers"]) == 2


def test_a_finger_joint_that_turns_a_full_turn_is_one_error(tmp_path):
    """A finger joint whose limits span a full turn (-3.14 to 3.14: its ends
    meet) has no end-stops to close between; the thumb closed at one of them
    landed on the back of the hand. One error naming the joint."""
    source = write_claw(tmp_path / "claw")
    text = source.read_text().replace(
        '<limit lower="-0.3" upper="0.7"', '<limit lower="-3.14" upper="3.14"', 1
    )
    source.write_text(text)
    with pytest.raises(GripperError, match="joint 'upper_knuckle' moves a finger"):
        guess_description(source, "claw")


def test_gripper_new_names_the_users_urdf_in_its_errors(tmp_path):
    """An error found reading the package's copy of the URDF names the file the
    user gave (the copy goes with the half-written package) and a fix to it."""
    text = jaw_urdf().replace('name="left_joint"', 'name="first_joint"')
    text = text.replace('<mimic joint="left_joint"', '<mimic joint="no_such_joint"')
    urdf = _write(tmp_path, text, "vendor_gripper.urdf")
    with pytest.raises(GripperError) as err:
        scaffold_plugin("jaw", urdf, tmp_path / "out")
    assert str(urdf) in err.value.message and "jaw.urdf" not in err.value.message
    assert "no_such_joint" in err.value.message
    assert err.value.hint == "fix the URDF, then run `wsgrasp gripper new` again"
    assert not (tmp_path / "out").exists()


def _finger_meshes(tmp_path, visual_rpy: str, collision_rpy: str) -> Path:
    """The jaw, its left finger's visual and collision one mesh file placed at
    the two given rotations."""
    import trimesh

    box = trimesh.creation.box((0.02, 0.015, 0.05))
    box.apply_translation((0.0, 0.0075, 0.025))
    box.export(tmp_path / "finger.obj")

    def mesh(tag: str, rpy: str) -> str:
        return (
            f'<{tag}><origin xyz="0 0 0" rpy="{rpy}"/>'
            f'<geometry><mesh filename="finger.obj"/></geometry></{tag}>'
        )

    left = '<link name="left_finger">'
    text = jaw_urdf()
    start = text.index(left)
    end = text.index("</link>", start) + len("</link>")
    body = mesh("visual", visual_rpy) + mesh("collision", collision_rpy)
    return _write(tmp_path, text[:start] + left + body + "</link>" + text[end:])


def test_gripper_new_warns_of_a_collision_mesh_placed_apart_from_its_visual(tmp_path):
    """A link whose collision element is its visual's mesh file at another
    origin (a visual turned into place, its collision copy not) gets one
    warning naming the link and the fix; the same mesh in the same place none."""
    for rpy, warned in (("0 0 1.5708", True), ("0 0 0", False)):
        sc = guess_description(_finger_meshes(tmp_path, rpy, "0 0 0"), "jaw")
        found = [w for w in sc.warnings if "collision mesh 'finger.obj'" in w]
        assert bool(found) == warned, sc.warnings
        if warned:
            (w,) = found
            assert "link 'left_finger'" in w and "placed 90 deg and 0 mm" in w
            assert "fix the collision element's <origin>" in w


def test_gripper_new_places_a_misplaced_collision_mesh_as_its_visual(tmp_path):
    """`gripper new` gives a link whose collision mesh is its visual's mesh
    placed apart the visual's shapes in the copy it writes, and says so: the
    visual is what the URDF's authors looked at."""
    urdf = _finger_meshes(tmp_path, "0 0 0", "0 0 1.5708")
    yaml_path, sc = scaffold_plugin("jaw", urdf, tmp_path / "out")
    copied = (yaml_path.parent / "jaw.urdf").read_text()
    left = '<link name="left_finger">'
    link = copied[copied.index(left) : copied.index("</link>", copied.index(left))]
    assert 'rpy="0 0 1.5708"' not in link and "<collision" in link
    assert any("placed apart" in w and "left_finger" in w for w in sc.warnings)
    assert not any("fix the collision element" in w for w in sc.warnings)


def test_a_urdf_element_without_its_name_is_one_error_naming_it(tmp_path):
    """yourdfpy fails on an unnamed <robot> or link with a bare KeyError: the
    reader names the element instead."""
    for old, new, what in (
        ('<robot name="jaw">', "<robot>", "its <robot> element without a name"),
        ('<link name="palm">', "<link>", "its <link> number 1 without a name"),
        (
            '<child link="left_finger"/>',
            "<child/>",
            "joint 'left_joint''s <child> without a link attribute",
        ),
        ('<mimic joint="left_joint"/>', "<mimic/>", "<mimic> without a joint"),
    ):
        urdf = _write(tmp_path, jaw_urdf().replace(old, new, 1))
        with pytest.raises(GripperError) as err:
            guess_description(urdf, "jaw")
        assert what in err.value.message, err.value.message
        assert "which URDF requires" in err.value.message


def test_mirrored_jaws_the_urdf_drives_apart_move_together(tmp_path):
    """Two jaws, each on its own joint, whose paths mirror each other: the
    package's URDF makes the second follow the first (a mimic), the YAML's
    fingers share the first's joint and the header says so; with
    ``couple_jaws=False`` (``--independent-jaws``) they stay apart. Jaws whose
    ranges differ are left apart."""
    from wsgrasp.gripper._jaws import independent_jaws
    from wsgrasp.gripper._urdf import load_kinematics

    urdf = _write(tmp_path, jaw_urdf(mimic=False))
    sc = guess_description(urdf, "jaw")
    coupling = independent_jaws(load_kinematics(urdf, "jaw"), sc.data)
    assert coupling is not None
    assert (coupling.leader, coupling.follower) == ("left_joint", "right_joint")
    assert (coupling.multiplier, coupling.offset) == (1.0, 0.0)
    yaml_path, sc = scaffold_plugin("jaw", urdf, tmp_path / "out")
    assert [f["joints"] for f in sc.data["fingers"]] == [["left_joint"]] * 2
    kin = load_kinematics(yaml_path.parent / "jaw.urdf", "jaw")
    assert kin.joints["right_joint"].mimic == ("left_joint", 1.0, 0.0)
    # the joint that moves both jaws gets their efforts (1 N each) summed; a
    # prismatic jaw's gain stays the simulator's
    assert "drive" not in sc.data
    assert kin.joints["left_joint"].effort == 2.0
    assert kin.joints["right_joint"].effort == 1.0
    assert "right_joint follows left_joint" in yaml_path.read_text()
    assert any("--independent-jaws" in w for w in sc.warnings)
    yaml_path, sc = scaffold_plugin("jaw", urdf, tmp_path / "apart", couple_jaws=False)
    assert [f["joints"] for f in sc.data["fingers"]] == [
        ["left_joint"],
        ["right_joint"],
    ]
    assert "<mimic" not in (yaml_path.parent / "jaw.urdf").read_text()
    # ... `wsgrasp eval` warns of them, and `gripper check` says how to couple
    from wsgrasp.sim.gripper import load_sim_gripper

    apart_notes = load_sim_gripper(str(yaml_path)).notes_json()
    assert "float together" in apart_notes["warnings"][0]
    coupled_notes = load_sim_gripper(str(tmp_path / "out" / "wsgrasp_jaw" / "jaw.yaml"))
    assert "warnings" not in coupled_notes.notes_json()
    assert any("driven apart" in w and "(field fingers)" in w for w in sc.warnings)
    assert 'add <mimic joint="left_joint" multiplier="1" offset="0"/>' in (
        " ".join(line.lstrip("# ") for line in yaml_path.read_text().splitlines())
    )
    # jaws on either side of the approach axis (one turned half a turn about
    # it, as the EGK 40's), each on its own joint: coupled too
    turned = (
        jaw_urdf(mimic=False)
        .replace('xyz="0 0.005 0.05"', 'xyz="0.01 0.005 0.05"', 1)
        .replace('xyz="0 -0.005 0.05"', 'xyz="-0.01 -0.005 0.05"', 1)
    )
    assert turned.count('xyz="0.01 0.005 0.05"') == 1
    urdf = _write(tmp_path, turned, "turned.urdf")
    sc = guess_description(urdf, "jaw")
    assert independent_jaws(load_kinematics(urdf, "jaw"), sc.data) == coupling
    # revolute jaws (the claw): the joint that moves both holds each pad with
    # half its gain, so the guessed gain doubles
    claw = write_claw(tmp_path / "claw")
    _, apart = scaffold_plugin(
        "claw", claw, tmp_path / "claw_apart", check=False, couple_jaws=False
    )
    _, moved = scaffold_plugin("claw", claw, tmp_path / "claw_moved", check=False)
    assert [f["joints"] for f in moved.data["fingers"]] == [["upper_knuckle"]] * 2
    assert moved.data["drive"]["kp_revolute"] == pytest.approx(
        2 * apart.data["drive"]["kp_revolute"], rel=0.05
    )
    # one jaw travels farther than the other: no single drive moves both
    longer = jaw_urdf(mimic=False).replace('upper="0.04"', 'upper="0.05"', 1)
    urdf = _write(tmp_path, longer, "longer.urdf")
    sc = guess_description(urdf, "jaw")
    assert independent_jaws(load_kinematics(urdf, "jaw"), sc.data) is None


def test_a_robots_joint_without_limits_outside_the_gripper_is_held(tmp_path):
    """A robot's URDF with a wheel on a revolute joint without limits (invalid
    URDF, as some robots ship): refused naming the joint, unless ``--base-link``
    puts the gripper below another link, when the wheel is held at 0 with a
    warning and left out of the package; a finger joint without limits is
    refused either way."""
    from wsgrasp.gripper._urdf import load_kinematics

    wheel = (
        '<link name="wheel"><collision><geometry><cylinder radius="0.05" '
        'length="0.02"/></geometry></collision></link>'
        '<joint name="wheel_joint" type="revolute"><parent link="arm_base"/>'
        '<child link="wheel"/><origin xyz="0 0 -0.1"/><axis xyz="0 1 0"/></joint>'
    )
    robot = _on_arm(6).replace("</robot>", wheel + "</robot>")
    urdf = _write(tmp_path, robot, "robot.urdf")
    with pytest.raises(GripperError, match="'wheel_joint' without <limit lower upper>"):
        guess_description(urdf, "jaw")
    sc = guess_description(urdf, "jaw", base_link="palm")
    assert [f["joints"] for f in sc.data["fingers"]] == [["left_joint"]] * 2
    assert any("'wheel_joint'" in w and "held at 0" in w for w in sc.warnings)
    yaml_path, _ = scaffold_plugin("jaw", urdf, tmp_path / "out", base_link="palm")
    assert "wheel_joint" not in (yaml_path.parent / "jaw.urdf").read_text()
    # a finger's joint without limits is refused whatever the base
    bad = robot.replace(
        '<limit lower="0" upper="0.04" effort="1" velocity="1"/>', "", 1
    )
    with pytest.raises(GripperError, match="'left_joint' without <limit lower upper>"):
        load_kinematics(_write(tmp_path, bad, "bad.urdf"), "jaw", below="palm")


def test_a_collision_envelope_round_the_fingers_gives_way_to_the_visual(tmp_path):
    """A palm whose collision shape is an envelope drawn round the fingers (as
    for arm motion planning) and whose visual is its own form: the package's
    URDF gives the palm its visual as collision, says so, and the model checks
    without the envelope's error; the fingers' joints are guessed as before."""
    from wsgrasp.gripper._urdf import load_kinematics

    own = jaw_urdf()
    palm = '<link name="palm"><collision><origin xyz="0 0 0.025" rpy="0 0 0"/>'
    palm += '<geometry><box size="0.04 0.16 0.05"/></geometry></collision></link>'
    assert palm in own
    envelope = (
        '<link name="palm"><visual><origin xyz="0 0 0.025" rpy="0 0 0"/>'
        '<geometry><box size="0.04 0.16 0.05"/></geometry>'
        '<material name="grey"><color rgba="0.5 0.5 0.5 1"/></material></visual>'
        '<collision><origin xyz="0 0 0.07" rpy="0 0 0"/>'
        '<geometry><box size="0.06 0.2 0.14"/></geometry></collision></link>'
    )
    urdf = _write(tmp_path, own.replace(palm, envelope), "enveloped.urdf")
    yaml_path, sc = scaffold_plugin("env", urdf, tmp_path / "out")
    note = [w for w in sc.warnings if "envelop the fingers" in w]
    assert note and note[0].endswith("palm")
    assert not [w for w in sc.warnings if w.startswith("error")]
    kin = load_kinematics(yaml_path.parent / "env.urdf", "env")
    (shape,) = kin.shapes["palm"]
    assert shape.kind == "box" and shape.size == pytest.approx((0.04, 0.16, 0.05))
    assert (
        "<material"
        not in (yaml_path.parent / "env.urdf")
        .read_text()
        .split("<collision")[1]
        .split("</collision>")[0]
    )
    assert [f["joints"] for f in sc.data["fingers"]] == [["left_joint"]] * 2
