"""Voxel downsampling: open3d's voxels and means, in the voxels' order."""

from __future__ import annotations

import numpy as np
import open3d as o3d
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wsgrasp.perception.process import downsample


def _open3d(points: np.ndarray, voxel: float) -> np.ndarray:
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    return np.asarray(cloud.voxel_down_sample(voxel).points)


def _rows(a: np.ndarray) -> np.ndarray:
    return a[np.lexsort(a.T[::-1])]


def _cloud(n: int, scale: float, seed: int, outlier: bool) -> np.ndarray:
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3)) * scale + rng.uniform(-5.0, 5.0, 3)
    if outlier:  # far from the rest: too many voxels for a dense grid
        p = np.vstack([p, [[80.0, -40.0, 30.0]]])
    return p


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(1, 4000),
    scale=st.floats(0.01, 2.0),
    voxel=st.sampled_from([0.003, 0.005, 0.01, 0.05]),
    seed=st.integers(0, 2**31),
    outlier=st.booleans(),
)
def test_voxels_and_means_are_open3ds(
    n: int, scale: float, voxel: float, seed: int, outlier: bool
) -> None:
    p = _cloud(n, scale, seed, outlier)
    # the same points bit for bit; open3d's order is its hash map's
    np.testing.assert_array_equal(_rows(downsample(p, voxel)), _rows(_open3d(p, voxel)))


def test_the_order_is_the_voxels_not_the_inputs() -> None:
    rng = np.random.default_rng(0)
    p = rng.uniform(-0.2, 0.2, (5000, 3))
    shuffled = p[rng.permutation(len(p))]
    # means add the points in another order: equal to rounding
    np.testing.assert_allclose(
        downsample(shuffled, 0.01), downsample(p, 0.01), rtol=0, atol=1e-15
    )


def test_float32_clouds_and_coordinates_past_a_voxel_key() -> None:
    rng = np.random.default_rng(1)
    p = rng.uniform(-0.2, 0.2, (2000, 3))
    np.testing.assert_array_equal(
        downsample(p.astype(np.float32), 0.01),
        downsample(p.astype(np.float32).astype(np.float64), 0.01),
    )
    # 1e15 m away at 5 mm: more voxels than an int64 key holds
    far = np.vstack([p[:10], [[1e15, 1e15, 1e15]]])
    out = downsample(far, 0.005)
    assert out.shape == (11, 3)
    assert_rows = _rows(out)
    np.testing.assert_array_equal(assert_rows, _rows(far))


@pytest.mark.parametrize("points", [np.zeros((0, 3)), np.ones((4, 3))])
def test_no_voxel_or_no_points_gives_the_points_back(points: np.ndarray) -> None:
    np.testing.assert_array_equal(downsample(points, 0.0), points)
    assert downsample(points, 0.01).shape == (min(len(points), 1), 3)
