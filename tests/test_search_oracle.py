"""The vectorised search agrees with the loop-by-loop Algorithm 1 (the oracle)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import box_object, make_jaw_gripper
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation
from wsgrasp_scorers import CentroidDistanceScorer

from wsgrasp.geometry import transform_points
from wsgrasp.planning.candidates import candidate_poses, orientation_angles
from wsgrasp.planning.evaluate import TableSE, evaluate_candidates
from wsgrasp.planning.reference import reference_search
from wsgrasp.planning.search import SearchInput, run_search


def _scene(seed: int, T_world_scene: np.ndarray, obstacles: bool):
    rng = np.random.default_rng(seed)
    size = rng.uniform([0.02, 0.02, 0.04], [0.09, 0.09, 0.22])
    obj = box_object(size, 400, seed)
    T_scene_object = np.eye(4)
    T_scene_object[:3, 3] = obj.mean(axis=0)
    samples = rng.uniform(-size / 2, size / 2, (60, 3))
    obs = (
        box_object([0.04, 0.04, 0.1], 150, seed + 1) + [size[0] / 2 + 0.06, 0, 0]
        if obstacles
        else np.zeros((0, 3))
    )
    table = TableSE(
        T_world_scene, np.array([0, 0, -0.05]), np.array([0.35, 0.35, 0.05]), 10.0
    )
    return (
        transform_points(T_world_scene, obj),
        T_world_scene @ T_scene_object,
        samples,
        transform_points(T_world_scene, obs),
        table,
    )


def _check(gripper, seed, T_world_scene, obstacles, orientations=4, flip=False):
    obj, T_world_object, samples, obs, table = _scene(seed, T_world_scene, obstacles)
    thetas = orientation_angles(orientations, 360)
    _, T_world_gripper, _, _, _ = candidate_poses(
        T_world_object, samples, thetas, gripper.T_gripper_gwc, flip
    )
    fast = evaluate_candidates(T_world_gripper, gripper, obj, obs, table)
    ref = reference_search(
        gripper, T_world_object, samples, thetas, obj, obs, table, flip
    )
    np.testing.assert_array_equal(fast.reason, ref.reason)
    np.testing.assert_array_equal(fast.contacts, ref.contacts)
    out = run_search(
        SearchInput(
            gripper,
            T_world_object,
            np.ptp(obj, axis=0),
            samples,
            thetas,
            obj,
            obs,
            table,
            flip,
        ),
        [("centroid_distance", CentroidDistanceScorer(), None, 1.0)],
    )
    assert out.best == ref.best
    return ref


@pytest.mark.parametrize("seed", range(8), ids=lambda s: f"seed{s}")
@pytest.mark.parametrize("obstacles", [False, True], ids=["alone", "clutter"])
@pytest.mark.parametrize("flip", [False, True], ids=["once", "flipped"])
def test_fast_search_matches_reference(jaw_gripper, seed, obstacles, flip):
    _check(jaw_gripper, seed, np.eye(4), obstacles, flip=flip)


def test_sweep_finds_feasible_and_rejected(jaw_gripper):
    """The seeded sweep is not vacuous: every reason occurs somewhere."""
    seen = np.zeros(5, dtype=int)
    for seed in range(8):
        obj, T_wo, samples, obs, table = _scene(seed, np.eye(4), True)
        thetas = orientation_angles(4, 360)
        _, T_wg, _, _, _ = candidate_poses(
            T_wo, samples, thetas, jaw_gripper.T_gripper_gwc
        )
        seen += np.bincount(
            evaluate_candidates(T_wg, jaw_gripper, obj, obs, table).reason, minlength=5
        )
    assert np.all(seen > 0), seen


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    seed=st.integers(0, 10_000),
    rotvec=st.tuples(*[st.floats(-3.0, 3.0)] * 3),
    shift=st.tuples(*[st.floats(-2.0, 2.0)] * 3),
    orientations=st.integers(1, 8),
    flip=st.booleans(),
)
def test_reference_agreement_in_any_frame(seed, rotvec, shift, orientations, flip):
    """Any rigid frame for the whole scene, any number of orientations."""
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(rotvec).as_matrix()
    T[:3, 3] = shift
    gripper = make_jaw_gripper(spheres_per_finger=1 + seed % 12)
    _check(gripper, seed, T, bool(seed % 2), orientations=orientations, flip=flip)


def test_frame_invariance(jaw_gripper):
    """Moving the whole scene moves the result and changes no reason."""
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec([0.4, -1.1, 2.0]).as_matrix()
    T[:3, 3] = [0.3, -0.2, 1.5]
    a = _check(jaw_gripper, 3, np.eye(4), True)
    b = _check(jaw_gripper, 3, T, True)
    np.testing.assert_array_equal(a.reason, b.reason)
    assert a.best == b.best
