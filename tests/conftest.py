"""Shared fixtures: a Franka-like gripper model built from plain arrays (no URDF),
synthetic object clouds, and a fresh plugin registry."""

from __future__ import annotations

import os

import numpy as np
import pytest

from wsgrasp.gripper.model import GripperModel

os.environ.setdefault("MPLBACKEND", "Agg")


def _box_surface(center, half, n, rng):
    """Points on the surface of an axis-aligned box: (n, 3)."""
    center = np.asarray(center, float)
    half = np.asarray(half, float)
    p = rng.uniform(-1, 1, size=(n, 3))
    axis = rng.integers(0, 3, size=n)
    p[np.arange(n), axis] = np.sign(p[np.arange(n), axis])
    return center + p * half


def make_jaw_gripper(
    spheres_per_finger: int = 10, seed: int = 0, name: str = "fake_jaw"
) -> GripperModel:
    """A Franka-hand-like model from the authors' published numbers: five body
    superellipsoids, ten 5 mm spheres per finger between the fingertips."""
    rng = np.random.default_rng(seed)
    se_axes = np.array(
        [
            [0.025, 0.11, 0.045],
            [0.01, 0.01, 0.03],
            [0.01, 0.01, 0.03],
            [0.05, 0.04, 0.02],
            [0.015, 0.045, 0.015],
        ]
    )
    se_centers = np.array(
        [
            [0.0, 0.0, 0.0225],
            [0.0, 0.05, 0.09],
            [0.0, -0.05, 0.09],
            [-0.01, 0.0, -0.02],
            [-0.07, 0.0, -0.03],
        ]
    )
    cloud = np.concatenate(
        [
            _box_surface(c, a * 0.95, 100, rng)
            for c, a in zip(se_centers, se_axes, strict=True)
        ]
    )
    offsets = np.linspace(0.004, 0.040, spheres_per_finger)
    left = np.stack([np.zeros_like(offsets), offsets, np.full_like(offsets, 0.104)], 1)
    right = left * [1, -1, 1]
    centers = np.concatenate([left, right])
    radii = np.full(len(centers), 0.005)
    finger = np.repeat([0, 1], spheres_per_finger)
    T_gripper_gwc = np.eye(4)
    T_gripper_gwc[:3, 3] = centers.mean(axis=0)
    T_gripper_tcp = np.eye(4)
    T_gripper_tcp[2, 3] = 0.1034
    return GripperModel(
        name=name,
        cloud=cloud,
        sphere_centers=centers,
        sphere_radii=radii,
        sphere_finger=finger.astype(np.int64),
        finger_names=["left", "right"],
        se_centers=se_centers,
        se_semi_axes=se_axes,
        se_exponent=10.0,
        T_gripper_tcp=T_gripper_tcp,
        T_gripper_gwc=T_gripper_gwc,
        approach_axis=np.array([0.0, 0.0, 1.0]),
        closing_axis=np.array([0.0, 1.0, 0.0]),
        pregrasp={"finger_joint1": 0.04},
        closed={"finger_joint1": 0.0},
        max_opening=0.08,
        description={"name": name, "urdf": "none.urdf"},
        source_hash="fake",
    )


@pytest.fixture(scope="session")
def jaw_gripper() -> GripperModel:
    return make_jaw_gripper()


def box_object(size, n=600, seed=0):
    """Surface points of a box of ``size`` standing on the plane z = 0: (n, 3)."""
    rng = np.random.default_rng(seed)
    half = np.asarray(size, float) / 2
    return _box_surface([0, 0, half[2]], half, n, rng)
