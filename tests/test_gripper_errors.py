"""Bad gripper input: each case is one GripperError naming the gripper, the field
and the fix."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from wsgrasp.errors import GripperError
from wsgrasp.gripper import build_model
from wsgrasp.spec import load_gripper_description

FRANKA = Path(__file__).resolve().parents[1] / "plugins/grippers/wsgrasp_grippers"
FRANKA = FRANKA / "franka_hand"


@pytest.fixture
def franka(tmp_path) -> Path:
    """An editable copy of the Franka hand (YAML path)."""
    folder = tmp_path / "franka"
    shutil.copytree(FRANKA, folder)
    return folder / "franka_hand.yaml"


def _edit(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text, old
    path.write_text(text.replace(old, new))


def _build(yaml: Path):
    desc, base = load_gripper_description(yaml)
    return build_model(desc, base)


def _fails(yaml: Path, *fragments: str) -> GripperError:
    with pytest.raises(GripperError) as info:
        _build(yaml)
    msg = str(info.value)
    assert "'franka_hand'" in msg, msg
    assert "(fix: " in msg, msg
    for fragment in fragments:
        assert fragment in msg, msg
    return info.value


def test_urdf_that_is_not_xml(franka):
    (franka.parent / "franka_hand.urdf").write_text("<robot name='x'><link name=")
    _fails(franka, "franka_hand.urdf", "not valid XML", "urdf")


def test_urdf_that_is_missing(franka):
    (franka.parent / "franka_hand.urdf").unlink()
    _fails(franka, "does not exist")


def test_urdf_with_a_joint_without_limits(franka):
    urdf = franka.parent / "franka_hand.urdf"
    _edit(
        urdf,
        '<limit lower="0.0" upper="0.04" effort="100" velocity="0.2"/>\n'
        "  </joint>\n\n  <!--",
        "</joint>\n\n  <!--",
    )
    _fails(franka, "panda_finger_joint1", "without <limit")


@pytest.mark.parametrize(
    ("old", "new", "fragments"),
    [
        pytest.param(
            "link: panda_leftfinger",
            "link: panda_leftfingr",
            ("fingers[left].pad.link", "'panda_leftfingr'", "'panda_leftfinger'"),
            id="pad-link",
        ),
        pytest.param(
            "joints: [panda_finger_joint1]\n    pad: {link: panda_left",
            "joints: [panda_finger_jiont1]\n    pad: {link: panda_left",
            ("fingers[left].joints", "did you mean 'panda_finger_joint1'"),
            id="finger-joint",
        ),
        pytest.param(
            "base_link: panda_hand",
            "base_link: panda_hnd",
            ("base_link", "did you mean 'panda_hand'"),
            id="base-link",
        ),
        pytest.param(
            "pregrasp: {panda_finger_joint1: 0.04}",
            "pregrasp: {panda_finger_joint: 0.04}",
            ("pregrasp", "'panda_finger_joint'"),
            id="pregrasp-joint",
        ),
    ],
)
def test_names_missing_from_the_urdf_suggest_close_ones(franka, old, new, fragments):
    _edit(franka, old, new)
    _fails(franka, "does not have", *fragments)


def test_pregrasp_outside_the_limits(franka):
    _edit(
        franka,
        "pregrasp: {panda_finger_joint1: 0.04}",
        "pregrasp: {panda_finger_joint1: 0.05}",
    )
    _fails(franka, "pregrasp.panda_finger_joint1", "limits")


def test_finger_whose_joints_are_not_on_its_pads_chain(franka):
    urdf = franka.parent / "franka_hand.urdf"
    # make the right finger independent: its joint no longer mimics joint1
    _edit(urdf, '<mimic joint="panda_finger_joint1" multiplier="1" offset="0"/>', "")
    _fails(
        franka, "fingers[right].joints", "does not move pad link", "panda_finger_joint2"
    )


def test_finger_whose_joints_do_not_move_its_pad(franka):
    # a range of a micrometre: the pad travels next to nothing
    urdf = franka.parent / "franka_hand.urdf"
    _edit(urdf, 'lower="0.0" upper="0.04"', 'lower="0.0" upper="0.000001"')
    _edit(franka, "pregrasp: {panda_finger_joint1: 0.04}", "pregrasp: {}")
    _fails(franka, "fingers[left]", "do not move pad link")


def test_finger_joint_whose_limits_are_equal(franka):
    urdf = franka.parent / "franka_hand.urdf"
    _edit(urdf, 'lower="0.0" upper="0.04"', 'lower="0.0" upper="0.0"')
    _edit(franka, "pregrasp: {panda_finger_joint1: 0.04}", "pregrasp: {}")
    _fails(franka, "fingers[left]", "(lower = upper = 0) spans nothing", "<mimic")


def test_workspace_too_thin_for_a_sphere(franka):
    _edit(franka, "min_sphere_radius: 0.002", "min_sphere_radius: 0.02")
    _fails(franka, "finger 'left'", "too thin", "min_sphere_radius 20.0 mm", "5.00 mm")


def test_more_spheres_than_the_workspace_can_place(franka):
    _edit(franka, "min_sphere_radius: 0.002", "min_sphere_radius: 0.005")
    _edit(franka, "spheres_per_finger: 10", "spheres_per_finger: 200")
    err = _fails(franka, "finger 'left'", "spheres_per_finger asks for 200")
    assert "unreachable" in err.message
    assert "spheres_per_finger" in (err.hint or "")


def test_every_error_class_is_exported_from_the_package():
    """Each error wsgrasp raises on purpose can be caught as ``wsgrasp.X``, as
    the errors page lists them."""
    import inspect

    import wsgrasp
    import wsgrasp.errors as errors

    mine = [
        name
        for name, obj in vars(errors).items()
        if inspect.isclass(obj)
        and issubclass(obj, errors.WsgraspError)
        and obj.__module__ == errors.__name__
    ]
    assert "SimulationError" in mine
    for name in mine:
        assert getattr(wsgrasp, name) is getattr(errors, name), name
        assert name in wsgrasp.__all__, name
