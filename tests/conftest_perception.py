"""Helpers shared by the perception tests (imported as a module, not a conftest)."""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.spatial.transform import Rotation

from wsgrasp.geometry import transform_from, transform_points
from wsgrasp.perception.process import downsample
from wsgrasp.perception.synth import SynthScene, synth_scene
from wsgrasp.perception.types import Plane

VOXEL = 0.005


@lru_cache(maxsize=32)
def small_scene(
    kind: str = "box",
    pose: str = "upright",
    seed: int = 0,
    camera_frame: bool = False,
) -> SynthScene:
    """A quick 3-view scene at 160 x 120 pixels per view."""
    return synth_scene(
        kind,
        pose=pose,  # type: ignore[arg-type]
        seed=seed,
        camera_frame=camera_frame,
        width=160,
        height=120,
        table_size=0.4,
    )


@lru_cache(maxsize=32)
def small_points(kind: str = "box", pose: str = "upright", seed: int = 0) -> np.ndarray:
    """Downsampled merged points of ``small_scene`` (world frame, z up)."""
    return downsample(small_scene(kind, pose, seed).points, VOXEL)


def random_rigid(rng: np.random.Generator, reach: float = 2.0) -> np.ndarray:
    """A random rigid transform (4, 4) with translation within ``reach`` metres."""
    R = Rotation.random(random_state=rng).as_matrix()
    return transform_from(R, rng.uniform(-reach, reach, 3))


def move_plane(T: np.ndarray, plane: Plane) -> Plane:
    """The plane in the frame that ``T`` maps into."""
    n = T[:3, :3] @ plane.normal
    return Plane(n, float(plane.offset - n @ T[:3, 3]))


def moved(T: np.ndarray, points: np.ndarray) -> np.ndarray:
    """``points`` (n, 3) mapped by ``T``."""
    return transform_points(T, points)


def level_grid(
    x: tuple[float, float], y: tuple[float, float], z: float, step: float
) -> np.ndarray:
    """Points ``(n, 3)`` on a grid of ``step`` over ``x`` by ``y`` (ranges,
    the upper ends left out), at height ``z``: a table top, a floor."""
    u, v = np.arange(*x, step), np.arange(*y, step)
    uv = np.stack(np.meshgrid(u, v), -1).reshape(-1, 2)
    return np.column_stack([uv, np.full(len(uv), z)])
