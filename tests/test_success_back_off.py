"""The chosen grasp backs off where curling fingers would dig into the table."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import make_jaw_gripper

from wsgrasp.gripper import load_gripper
from wsgrasp.planning.closing import closing_paths, table_back_off

TABLE = np.eye(4)  # surface z = 0, normal +z


def _top_down(g, height: float) -> np.ndarray:
    """A pose approaching straight down with the gripper origin ``height`` above
    the table."""
    a = g.approach_axis
    c = g.closing_axis
    # gripper axes in the world: approach -> -z, closing -> +x
    R_world = np.stack([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0]], axis=1)  # (3, 2)
    R_grip = np.stack([c, a], axis=1)  # (3, 2)
    U, _, Vt = np.linalg.svd(R_world @ R_grip.T)
    R = U @ np.diag([1.0, 1.0, np.linalg.det(U @ Vt)]) @ Vt
    T = np.eye(4)
    T[:3, :3] = R
    T[2, 3] = height
    return T


def _lowest(g, T: np.ndarray) -> float:
    p = closing_paths(g).reshape(-1, 3) @ T[:3, :3].T + T[:3, 3]
    return float(p[:, 2].min())


@pytest.fixture(scope="module")
def allegro():
    return load_gripper("allegro_right")


def test_closing_paths_run_from_pregrasp_to_closed(allegro):
    paths = closing_paths(allegro)
    assert paths.shape == (allegro.num_fingers, 32, 3)
    # the curling fingers' pads sweep several centimetres along the approach
    depth = paths @ allegro.approach_axis  # (nf, K)
    assert np.ptp(depth[1:], axis=1).min() > 0.05


def test_fingers_that_would_dig_into_the_table_back_off_until_clear(allegro):
    T = _top_down(allegro, 0.08)
    assert _lowest(allegro, T) < 0.0  # closing from here digs in
    moved = table_back_off(allegro, T, TABLE)
    assert moved is not None
    d, T_back = moved
    assert 0.0 < d <= 0.03
    assert _lowest(allegro, T_back) >= 0.0
    # moved back along its own approach axis, orientation kept
    np.testing.assert_allclose(T_back[:3, :3], T[:3, :3])
    np.testing.assert_allclose(
        T_back[:3, 3], T[:3, 3] - d * (T[:3, :3] @ allegro.approach_axis)
    )
    # and no further back than the first 5 mm step that clears
    T_less = T_back.copy()
    T_less[2, 3] -= 0.005
    assert _lowest(allegro, T_less) < 0.0


def test_clear_grasps_and_grippers_without_paths_stay(allegro):
    assert table_back_off(allegro, _top_down(allegro, 0.3), TABLE) is None
    jaw = make_jaw_gripper()
    assert table_back_off(jaw, _top_down(jaw, 0.01), TABLE) is None
