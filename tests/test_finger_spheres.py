"""The sphere index (the depth grid and its sphere lists) answers exactly what a
brute-force test answers."""

from __future__ import annotations

import numpy as np
from conftest import make_jaw_gripper
from hypothesis import example, given, settings
from hypothesis import strategies as st

from wsgrasp.geometry import points_in_spheres
from wsgrasp.planning.evaluate import FingerSpheres


def _brute(g, points):
    inside = points_in_spheres(points, g.sphere_centers, g.sphere_radii)  # (n, S)
    return np.stack(
        [inside[:, g.sphere_finger == f].any(axis=1) for f in range(g.num_fingers)],
        axis=1,
    )


@settings(max_examples=20, deadline=None)
@given(
    seed=st.integers(0, 100_000),
    fingers=st.integers(1, 5),
    per_finger=st.integers(1, 40),
    cell=st.sampled_from([None, 0.004, 0.02]),
)
# 256 list codes, one byte each: numpy's lookup read past the last one
@example(seed=98, fingers=3, per_finger=39, cell=0.02)
def test_grid_lookup_matches_brute_force(seed, fingers, per_finger, cell):
    rng = np.random.default_rng(seed)
    g = make_jaw_gripper()
    n = fingers * per_finger
    g.sphere_centers = rng.uniform(-0.05, 0.05, (n, 3))
    g.sphere_radii = rng.uniform(0.002, 0.02, n)
    g.sphere_finger = np.repeat(np.arange(fingers), per_finger).astype(np.int64)
    g.finger_names = [f"f{i}" for i in range(fingers)]
    points = rng.uniform(-0.09, 0.09, (4000, 3))
    # points on sphere surfaces and at centres: the boundary cases
    k = rng.integers(0, n, 200)
    dirs = rng.normal(size=(200, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    surface = g.sphere_centers[k] + dirs * g.sphere_radii[k, None]
    points = np.concatenate([points, surface, g.sphere_centers])
    index = FingerSpheres(g, cell)
    got = index.holding_coordinates(*points.T)
    np.testing.assert_array_equal(got, _brute(g, points))


def test_points_far_outside_the_grid(jaw_gripper):
    index = FingerSpheres(jaw_gripper)
    far = np.array([[1e3, 0, 0], [-1e3, -1e3, -1e3], [0, 0, 1e6]])
    assert not index.holding_coordinates(*far.T).any()
