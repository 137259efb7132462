"""Geometry kernels: superellipsoid evaluation and fitting, sampling, kinematics."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from wsgrasp.geometry import (
    JOINT_FIXED,
    JOINT_PRISMATIC,
    JOINT_REVOLUTE,
    box_corner_se_factors,
    box_grid_points,
    chain_forward_kinematics,
    enclosing_scale,
    farthest_point_indices,
    grid_configurations,
    points_in_spheres,
    points_in_superellipsoids,
    rot_x,
    rot_z,
    superellipsoid_surface,
    superellipsoid_values,
    transform_from,
)

#: floating-point tolerance of closed-form checks
TOL = 1e-12

CENTER = np.array([0.1, -0.2, 0.3])
AXES = np.array([0.02, 0.05, 0.03])


@pytest.mark.parametrize(
    ("offset", "expected"),
    [
        pytest.param((0.0, 0.0, 0.0), 0.0, id="centre"),
        pytest.param((0.02, 0.0, 0.0), 1.0, id="x-boundary"),
        pytest.param((0.0, -0.05, 0.0), 1.0, id="y-boundary"),
        pytest.param((0.0, 0.0, 0.03), 1.0, id="z-boundary"),
        pytest.param((0.0, 0.0, 0.015), 0.25, id="z-quadratic"),
        pytest.param((0.04, 0.0, 0.0), 2.0**10, id="x-outside"),
    ],
)
def test_superellipsoid_values_on_axes(offset, expected):
    p = (CENTER + np.array(offset))[None]  # (1, 3)
    v = superellipsoid_values(p, CENTER[None], AXES[None])
    assert v.shape == (1, 1)
    assert_allclose(v[0, 0], expected, rtol=1e-12, atol=TOL)


def test_superellipsoid_exponent_makes_a_cuboid():
    # (0.9a, 0.9b, 0): inside a near-cuboid (l = 10), outside an ellipsoid (l = 2)
    p = (CENTER + 0.9 * AXES * np.array([1.0, -1.0, 0.0]))[None]  # (1, 3)
    v10 = superellipsoid_values(p, CENTER[None], AXES[None], exponent=10.0)[0, 0]
    v2 = superellipsoid_values(p, CENTER[None], AXES[None], exponent=2.0)[0, 0]
    v4 = superellipsoid_values(p, CENTER[None], AXES[None], exponent=4.0)[0, 0]
    assert_allclose(v10, 2 * 0.9**10, rtol=1e-12)
    assert_allclose(v4, 2 * 0.9**4, rtol=1e-12)
    assert_allclose(v2, 2 * 0.9**2, rtol=1e-12)
    assert v10 < 1.0 < v2
    # a non-special exponent goes through np.power
    v7 = superellipsoid_values(p, CENTER[None], AXES[None], exponent=7.0)[0, 0]
    assert_allclose(v7, 2 * 0.9**7, rtol=1e-12)


def test_points_in_superellipsoids_is_strict_and_batched():
    rng = np.random.default_rng(0)
    centers = np.array([CENTER, CENTER + [0.2, 0, 0]])
    axes = np.array([AXES, AXES * 2])
    pts = rng.uniform(-0.3, 0.6, size=(4, 500, 3))
    inside = points_in_superellipsoids(pts, centers, axes)
    values = superellipsoid_values(pts, centers, axes)  # (4, 500, 2)
    assert inside.shape == (4, 500)
    np.testing.assert_array_equal(inside, np.any(values < 1.0, axis=-1))
    boundary = CENTER + [AXES[0], 0.0, 0.0]
    assert not points_in_superellipsoids(boundary[None], centers[:1], axes[:1])[0]


def test_points_in_spheres_is_strict_batched_and_the_plain_sum_bit_for_bit():
    """Strictly inside, any leading dimensions, and the squared distance summed
    as ``np.sum`` over the three coordinates sums it: points placed on the
    spheres' surfaces get the same verdict as the plain (n, m, 3) formula."""
    rng = np.random.default_rng(3)
    centers = rng.uniform(-0.1, 0.1, size=(40, 3))
    radii = rng.uniform(0.002, 0.05, size=40)
    pts = rng.uniform(-0.15, 0.15, size=(3, 300, 3))
    # a point on each sphere's surface, along a random direction
    u = rng.normal(size=(40, 3))
    pts[0, :40] = centers + radii[:, None] * u / np.linalg.norm(u, axis=1)[:, None]
    inside = points_in_spheres(pts, centers, radii)
    plain = np.sum((pts[..., :, None, :] - centers) ** 2, axis=-1) < radii**2
    assert inside.shape == (3, 300, 40)
    np.testing.assert_array_equal(inside, plain)
    assert inside.any() and not inside.all()
    assert not points_in_spheres(
        centers[:1] + [radii[0], 0, 0], centers[:1], radii[:1]
    )[0, 0]


def test_box_corner_factors_put_the_corners_on_the_surface():
    for exponent in (2.0, 4.0, 10.0, 30.0):
        f = box_corner_se_factors(exponent)
        corner = (CENTER + AXES)[None]  # (1, 3)
        v = superellipsoid_values(corner, CENTER[None], (AXES * f)[None], exponent)
        assert_allclose(v[0, 0], 1.0, rtol=1e-9)


def test_enclosing_scale_is_the_smallest_that_holds_every_point():
    rng = np.random.default_rng(1)
    pts = CENTER + rng.uniform(-1, 1, size=(300, 3)) * AXES * 1.3
    s = enclosing_scale(pts, CENTER, AXES, 10.0, margin=1e-6)
    v = superellipsoid_values(pts, CENTER[None], (AXES * s)[None])[:, 0]
    assert v.max() <= 1.0 - 1e-6 + 1e-9
    v_smaller = superellipsoid_values(pts, CENTER[None], (AXES * s * 0.999)[None])
    assert v_smaller.max() > 1.0 - 1e-6


def test_superellipsoid_surface_lies_on_the_surface():
    X, Y, Z = superellipsoid_surface(CENTER, AXES, 10.0, n_around=16, n_height=9)
    pts = np.stack([X, Y, Z], axis=-1).reshape(-1, 3)
    v = superellipsoid_values(pts, CENTER[None], AXES[None], 10.0)[:, 0]
    assert_allclose(v, 1.0, atol=1e-9)


def test_farthest_point_indices_spread_evenly():
    rng = np.random.default_rng(2)
    pts = rng.uniform(size=(2000, 3))
    idx = farthest_point_indices(pts, 100)
    assert len(np.unique(idx)) == 100
    np.testing.assert_array_equal(idx, farthest_point_indices(pts, 100))

    def min_gap(p):
        d = np.linalg.norm(p[:, None] - p[None], axis=-1)
        return d[np.triu_indices(len(p), 1)].min()

    random_subset = pts[rng.choice(2000, 100, replace=False)]
    assert min_gap(pts[idx]) > 2 * min_gap(random_subset)
    with pytest.raises(ValueError, match="count"):
        farthest_point_indices(pts, 0)


def test_box_grid_points_dedupes_flat_edges():
    p = box_grid_points((0, 0, 1), (0.02, 0.0, 0.04), 3)
    assert p.shape == (9, 3)
    assert_allclose(p[:, 1], 0.0)
    assert_allclose(p.min(axis=0), [-0.01, 0, 0.98], atol=TOL)
    assert_allclose(p.max(axis=0), [0.01, 0, 1.02], atol=TOL)


def test_grid_configurations_order():
    q = grid_configurations([0, -1], [1, 1], 3)
    assert q.shape == (9, 2)
    grid = q.reshape(3, 3, 2)  # (samples, samples, d): last joint fastest
    assert_allclose(grid[0, :, 1], [-1, 0, 1])
    assert_allclose(grid[:, 0, 0], [0, 0.5, 1])


def test_chain_forward_kinematics_matches_composition():
    rng = np.random.default_rng(3)
    O1 = transform_from(rot_x(0.3), [0.1, 0, 0])
    O2 = transform_from(rot_z(-0.4), [0, 0.2, 0.05])
    O3 = transform_from(None, [0, 0, 0.07])
    kinds = [JOINT_REVOLUTE, JOINT_PRISMATIC, JOINT_FIXED]
    axes = [[0, 0, 1], [1, 0, 0], [0, 0, 1]]
    q = rng.uniform(-1, 1, size=(7, 3))  # (batch, J)
    T = chain_forward_kinematics(np.stack([O1, O2, O3]), axes, kinds, q)
    assert T.shape == (7, 4, 4)
    for k in range(7):
        M1 = transform_from(rot_z(q[k, 0]))
        M2 = transform_from(None, [q[k, 1], 0, 0])
        assert_allclose(T[k], O1 @ M1 @ O2 @ M2 @ O3, atol=TOL)
    with pytest.raises(ValueError, match="last dimension"):
        chain_forward_kinematics(np.stack([O1, O2]), axes[:2], kinds[:2], q)
