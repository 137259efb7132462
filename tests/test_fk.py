"""Batched forward kinematics of the gripper builder against yourdfpy."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yourdfpy
from numpy.testing import assert_allclose

from wsgrasp.gripper._urdf import load_kinematics

GRIPPERS = Path(__file__).resolve().parents[1] / "plugins" / "grippers"
URDFS = {
    "franka_hand": GRIPPERS / "wsgrasp_grippers/franka_hand/franka_hand.urdf",
    "allegro_right": GRIPPERS / "wsgrasp_grippers/allegro_right/allegro_right.urdf",
}
#: poses agree to this (m, and unitless for rotation entries)
TOL = 1e-9

MIMIC_URDF = """<?xml version="1.0"?>
<robot name="mimic_test">
  <link name="base"/>
  <link name="a"/>
  <link name="b"/>
  <link name="c"/>
  <link name="tip"/>
  <joint name="j1" type="revolute">
    <parent link="base"/><child link="a"/>
    <origin xyz="0.01 0.02 0.03" rpy="0.1 -0.2 0.3"/>
    <axis xyz="0 0.6 0.8"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <joint name="j2" type="prismatic">
    <parent link="a"/><child link="b"/>
    <origin xyz="0 0 0.05" rpy="0 0.5 0"/>
    <axis xyz="1 0 0"/>
    <limit lower="0" upper="0.04" effort="1" velocity="1"/>
  </joint>
  <joint name="j3" type="revolute">
    <parent link="b"/><child link="c"/>
    <origin xyz="0 0.03 0.02" rpy="0 0 1.2"/>
    <axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/>
    <mimic joint="j1" multiplier="-0.5" offset="0.2"/>
  </joint>
  <joint name="tip_joint" type="fixed">
    <parent link="c"/><child link="tip"/>
    <origin xyz="0.02 0 0.01" rpy="0.3 0.2 0.1"/>
  </joint>
</robot>
"""


def _compare(urdf_path: Path, base: str, n: int = 25) -> None:
    kin = load_kinematics(urdf_path, "test")
    ref = yourdfpy.URDF.load(str(urdf_path), load_meshes=False)
    names = ref.actuated_joint_names
    rng = np.random.default_rng(0)
    lo = np.array([kin.joints[j].lower for j in names])
    hi = np.array([kin.joints[j].upper for j in names])
    q = rng.uniform(lo, hi, size=(n, len(names)))  # (n, dof)
    links = [link for link in kin.subtree(base) if link != base]
    for link in links:
        # ours: one batched call over all n configurations
        ours = kin.chain_poses(base, link, {j: q[:, i] for i, j in enumerate(names)})
        assert ours.shape == (n, 4, 4)
        for k in range(n):
            ref.update_cfg(q[k])
            expected = ref.get_transform(link, base)
            assert_allclose(ours[k], expected, atol=TOL, err_msg=f"{link} cfg {k}")


@pytest.mark.parametrize("gripper", list(URDFS))
def test_batched_fk_matches_yourdfpy(gripper):
    base = {"franka_hand": "panda_hand", "allegro_right": "allegro_mount"}[gripper]
    _compare(URDFS[gripper], base)


def test_mimic_with_multiplier_and_offset_matches_yourdfpy(tmp_path):
    path = tmp_path / "mimic.urdf"
    path.write_text(MIMIC_URDF)
    _compare(path, "base")


def test_franka_fingers_move_apart_symmetrically():
    kin = load_kinematics(URDFS["franka_hand"], "franka_hand")
    q = np.array([0.0, 0.02, 0.04])
    left = kin.chain_poses("panda_hand", "panda_leftfinger", {"panda_finger_joint1": q})
    right = kin.chain_poses(
        "panda_hand", "panda_rightfinger", {"panda_finger_joint1": q}
    )
    assert_allclose(left[:, 1, 3], q, atol=1e-12)
    assert_allclose(right[:, 1, 3], -q, atol=1e-12)
    assert_allclose(left[:, 2, 3], 0.0584, atol=1e-12)
