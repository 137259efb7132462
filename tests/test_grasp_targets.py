"""Per-grasp joint targets: within the URDF's limits, and forward kinematics of
``joints_grasp`` puts each pad at its contacts."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import wsgrasp_grippers

import wsgrasp
from wsgrasp.geometry import transform_points
from wsgrasp.gripper import load_gripper
from wsgrasp.gripper._build import urdf_path
from wsgrasp.gripper._urdf import load_kinematics
from wsgrasp.perception.synth import synth_scene
from wsgrasp.spec import load_gripper_description, load_spec

ROOT = Path(__file__).resolve().parent.parent
SPECS = {
    "franka_hand": ROOT / "examples/specs/franka.yaml",
    "allegro_right": ROOT / "examples/specs/allegro.yaml",
}


@pytest.fixture(scope="module")
def plans():
    out = {}
    scene = synth_scene("box", size=(0.05, 0.06, 0.11), seed=1).points
    for name, spec in SPECS.items():
        # joint targets from the contacts (the Allegro spec closes to `closed`)
        data = load_spec(spec).model_dump()
        data["approach"]["close_to"] = "contacts"
        pipe = wsgrasp.Pipeline(load_spec(data))
        out[name] = (pipe, pipe.plan(scene))
    return out


def _kinematics(gripper):
    """The gripper's own URDF, read independently of the model."""
    yaml = (
        Path(wsgrasp_grippers.__file__).parent / gripper.name / f"{gripper.name}.yaml"
    )
    desc, base = load_gripper_description(yaml)
    return desc, load_kinematics(urdf_path(desc, base), desc.name)


@pytest.mark.parametrize("name", list(SPECS))
def test_joint_targets_within_limits_and_complete(plans, name):
    pipe, result = plans[name]
    assert result.found, result.hint
    g = pipe.gripper
    _, kin = _kinematics(g)
    assert set(result.joints_grasp) == set(result.joints_pregrasp)
    assert set(result.joints_grasp) >= {j for js in g.finger_joints for j in js}
    for j, v in result.joints_grasp.items():
        lo, hi = kin.joints[j].lower, kin.joints[j].upper
        assert lo - 1e-12 <= v <= hi + 1e-12, (j, v, lo, hi)
        assert lo - 1e-12 <= result.joints_pregrasp[j] <= hi + 1e-12


@pytest.mark.parametrize("name", list(SPECS))
def test_forward_kinematics_puts_pads_at_their_contacts(plans, name):
    """At the contact posture each pad centre is within a sphere's reach of the
    points its finger holds; the grasp posture moves it ``squeeze`` further."""
    pipe, result = plans[name]
    g = pipe.gripper
    desc, kin = _kinematics(g)
    squeeze = pipe.spec.approach.squeeze
    reach = float(g.sphere_radii.max()) * 2
    T = result.T_world_ee
    for finger, contact, target in zip(
        desc.fingers, result.contacts, result.finger_targets, strict=True
    ):
        posture_c = {**result.joints_pregrasp, **target["contact"]}
        posture_g = {**result.joints_grasp}
        pad_c = _pad_world(kin, desc, finger, posture_c, T)
        pad_g = _pad_world(kin, desc, finger, posture_g, T)
        gap = np.linalg.norm(contact.points - pad_c, axis=1).min()
        assert gap < reach, (finger.name, gap)
        # the interpolated pad the planner used agrees with the URDF's
        np.testing.assert_allclose(pad_c, target["pad_world"], atol=2e-3)
        moved = np.linalg.norm(pad_g - pad_c)
        shared = sum(
            j in t["grasp"] for t in result.finger_targets for j in target["grasp"]
        )
        if shared == len(target["grasp"]):  # the finger's joints are its own
            # the URDF's pad travels what the planner's interpolation said ...
            assert moved == pytest.approx(target["squeeze"], abs=3e-3)
            # ... the squeeze, unless the finger reached the end of its way
            # first: each joint at its closed value or, where its contact lay
            # past that, at its limit on the closing side
            limits = {
                j: lim
                for js, lims in zip(g.finger_joints, g.finger_limits, strict=True)
                for j, lim in zip(js, np.asarray(lims), strict=True)
            }

            def at_end(j: str, v: float) -> bool:
                c, p = g.closed.get(j, v), g.pregrasp.get(j, v)
                side = limits[j][1] if c > p else limits[j][0]
                return bool(v == pytest.approx(c) or v == pytest.approx(side))

            ended = all(at_end(j, v) for j, v in target["grasp"].items())
            assert target["squeeze"] == pytest.approx(squeeze, abs=2e-3) or ended
        else:  # a joint another finger shares closes as far as either asks
            assert moved >= squeeze - 2e-3


def _pad_world(kin, desc, finger, posture, T_world_gripper):
    T = kin.chain_poses(desc.base_link, finger.pad.link, posture)
    T = np.asarray(T).reshape(-1, 4, 4)[0]
    return transform_points(T_world_gripper @ T, np.array([finger.pad.center]))[0]


def test_pregrasp_pose_backs_off_along_the_approach(plans):
    pipe, result = plans["franka_hand"]
    g = pipe.gripper
    d = pipe.spec.approach.distance
    approach = result.T_world_ee[:3, :3] @ g.approach_axis
    np.testing.assert_allclose(
        result.T_world_pregrasp[:3, 3], result.T_world_ee[:3, 3] - d * approach
    )
    np.testing.assert_allclose(
        result.T_world_pregrasp[:3, :3], result.T_world_ee[:3, :3]
    )


def test_parallel_jaw_closes_past_the_object_width(plans):
    """For the Franka hand the grasp width is narrower than the contact width by
    the squeeze, and the open posture is the YAML's pregrasp."""
    pipe, result = plans["franka_hand"]
    j = "panda_finger_joint1"
    contact = min(t["contact"][j] for t in result.finger_targets)
    assert result.joints_pregrasp[j] == pytest.approx(0.04)
    assert result.joints_grasp[j] == pytest.approx(
        max(contact - pipe.spec.approach.squeeze, 0.0), abs=1e-3
    )
    assert "joints_grasp" in result.to_json()


def test_model_keeps_each_spheres_configurations():
    g = load_gripper("allegro_right")
    assert g.has_configurations
    counts = np.diff(g.sphere_config_ptr)
    assert len(counts) == len(g.sphere_radii) and counts.min() > 0
    # each listed configuration's pad samples reach into its sphere: its pad
    # centre lies within the pad's half-diagonal of the sphere
    for s in (0, 100, 250):
        k = g.sphere_configurations(np.array([s]))
        d = np.linalg.norm(g.config_pad[k] - g.sphere_centers[s], axis=1)
        assert d.max() < g.sphere_radii[s] + 0.02
        assert set(g.config_finger[k]) == {g.sphere_finger[s]}
    again = type(g).from_bytes(g.to_bytes())
    np.testing.assert_array_equal(again.sphere_config_index, g.sphere_config_index)
    np.testing.assert_array_equal(again.config_pad, g.config_pad)


def test_close_to_closed_takes_the_closed_posture_and_keeps_the_contacts():
    """``approach.close_to: closed``: joints_grasp is the gripper's closed
    posture (within limits); each finger's contact posture is still reported,
    its grasp posture is its part of joints_grasp, and its squeeze is how far
    the URDF's pad travels from the contact posture to there."""
    g = load_gripper("allegro_right")
    spec = load_spec(SPECS["allegro_right"]).model_dump()
    spec["approach"] = {"squeeze": 0.06, "close_to": "closed"}
    pipe = wsgrasp.Pipeline(load_spec(spec), gripper=g)
    result = pipe.plan(synth_scene("box", size=(0.05, 0.06, 0.11), seed=1).points)
    assert result.found
    for j, v in result.joints_grasp.items():
        assert v == pytest.approx(g.closed.get(j, result.joints_pregrasp[j]))
    assert len(result.finger_targets) == g.num_fingers
    assert all(t["contact"] for t in result.finger_targets)
    desc, kin = _kinematics(g)
    for finger, target in zip(desc.fingers, result.finger_targets, strict=True):
        assert target["grasp"] == {j: result.joints_grasp[j] for j in finger.joints}
        posture_c = {**result.joints_pregrasp, **target["contact"]}
        pad_c = _pad_world(kin, desc, finger, posture_c, result.T_world_ee)
        pad_g = _pad_world(kin, desc, finger, result.joints_grasp, result.T_world_ee)
        moved = float(np.linalg.norm(pad_g - pad_c))
        assert target["squeeze"] == pytest.approx(moved, abs=3e-3), finger.name


def test_a_model_without_configurations_closes_to_closed():
    """A format-1 model (no finger configurations) cannot place the pads: its
    grasp posture is the closed one, not the pre-grasp it approaches in."""
    import dataclasses

    from wsgrasp.planning.result import Contact
    from wsgrasp.planning.targets import grasp_targets

    g = load_gripper("franka_hand")
    bare = dataclasses.replace(g, config_pad=np.zeros((0, 3)))
    assert not bare.has_configurations
    contacts = [Contact(f, np.zeros((1, 3)), np.zeros(0, np.int64)) for f in "ab"]
    t = grasp_targets(bare, np.eye(4), contacts, approach_distance=0.1, squeeze=0.01)
    assert t.joints_grasp == {"panda_finger_joint1": 0.0}
    assert t.joints_pregrasp == {"panda_finger_joint1": 0.04}
    assert t.fingers == []


def test_a_contact_past_closed_squeezes_on_towards_the_limit():
    """A hand whose ``closed`` stops where its pads meet (0.375 rad for the
    Barrett-like fingers) holds a large object with its fingers curled further:
    from a contact at 1.0 rad each finger squeezes on towards its 1.6 rad limit,
    not back towards ``closed``."""
    from dataclasses import replace

    from wsgrasp.planning.result import Contact
    from wsgrasp.planning.targets import grasp_targets, pad_positions

    root = Path(__file__).resolve().parents[1]
    g = load_gripper(
        str(
            root / "examples/plugins/barrett_bh8_like/wsgrasp_barrett_bh8_like"
            "/barrett_bh8_like.yaml"
        )
    )
    closers = [j[-1] for j in g.finger_joints]  # the flexion joint of each finger
    g = replace(g, closed={**g.closed, **{j: 0.375 for j in closers}})
    contacts = []
    for f, joints in enumerate(g.finger_joints):
        q = np.array([[1.0 if j in closers else g.pregrasp[j] for j in joints]])
        pad = pad_positions(g, f, q)  # (1, 3), gripper frame = world here
        own = np.flatnonzero(g.sphere_finger == f)
        contacts.append(Contact(g.finger_names[f], pad, own))
    t = grasp_targets(
        g, np.eye(4), contacts, approach_distance=0.1, squeeze=0.01, close_to="contacts"
    )
    for ft in t.fingers:
        (j,) = [j for j in ft.contact if j in closers]
        assert ft.contact[j] > 0.8, ft
        assert ft.grasp[j] > ft.contact[j], ft
