"""Object frame, box samples, table frame and superellipsoid, normals."""

from __future__ import annotations

import numpy as np
import pytest
from conftest_perception import moved, random_rigid
from numpy.testing import assert_allclose

from wsgrasp.errors import InputError
from wsgrasp.geometry import check_transforms, transform_from, transform_points
from wsgrasp.perception.frame import (
    ObjectFrame,
    estimate_normals,
    grid_shape,
    object_frame,
    sample_box,
    table_frame,
    table_superellipsoid,
)
from wsgrasp.perception.types import Plane
from wsgrasp.spec import Sampling, TableSettings

METHODS = ["farthest_split", "pca"]


def box_surface(dims: tuple[float, float, float], n: int, seed: int = 0) -> np.ndarray:
    """Points on the surface of a box centred at the origin, (n, 3)."""
    rng = np.random.default_rng(seed)
    d = np.asarray(dims)
    pts = rng.uniform(-0.5, 0.5, (n, 3)) * d
    axis = rng.integers(0, 3, n)
    pts[np.arange(n), axis] = rng.choice([-0.5, 0.5], n) * d[axis]
    return pts


def cylinder_surface(radius: float, height: float, n: int, seed: int = 0) -> np.ndarray:
    """Points on a closed cylinder along z, (n, 3)."""
    rng = np.random.default_rng(seed)
    a = rng.uniform(0, 2 * np.pi, n)
    z = rng.uniform(-height / 2, height / 2, n)
    r = np.full(n, radius)
    cap = rng.random(n) < 0.2
    r[cap] = radius * np.sqrt(rng.random(int(cap.sum())))
    z[cap] = np.sign(z[cap]) * height / 2
    return np.column_stack([r * np.cos(a), r * np.sin(a), z])


SHAPES = {
    "box": box_surface((0.06, 0.08, 0.2), 800),
    "flat-box": box_surface((0.12, 0.2, 0.04), 800, seed=1),
    "cylinder": cylinder_surface(0.03, 0.15, 800),
}


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("shape", list(SHAPES))
def test_z_is_the_long_side(shape: str, method: str) -> None:
    pts = SHAPES[shape]
    frame = object_frame(pts, method)  # type: ignore[arg-type]
    check_transforms(frame.T_world_object)
    R = frame.T_world_object[:3, :3]
    long_axis = np.eye(3)[int(np.argmax(np.ptp(pts, axis=0)))]
    assert abs(R[:, 2] @ long_axis) > np.cos(np.radians(5))
    assert_allclose(frame.T_world_object[:3, 3], pts.mean(axis=0), atol=1e-12)
    assert frame.extents[2] == pytest.approx(np.ptp(pts, axis=0).max(), rel=0.05)


@pytest.mark.parametrize("method", METHODS)
def test_box_axes_and_extents(method: str) -> None:
    frame = object_frame(SHAPES["box"], method)  # type: ignore[arg-type]
    R = frame.T_world_object[:3, :3]
    # x is the second longest side (0.08 along world y), y the shortest
    assert abs(R[:, 0] @ [0, 1, 0]) > np.cos(np.radians(5))
    assert_allclose(np.sort(frame.extents), [0.06, 0.08, 0.2], atol=0.01)
    assert_allclose(np.cross(R[:, 2], R[:, 0]), R[:, 1], atol=1e-12)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("seed", range(8))
def test_frame_moves_with_the_object(method: str, seed: int) -> None:
    """Equivariance: transform the cloud and the frame transforms with it (up to
    the sign of each axis)."""
    pts = SHAPES["box"]
    T = random_rigid(np.random.default_rng(100 + seed))
    f0 = object_frame(pts, method)  # type: ignore[arg-type]
    f1 = object_frame(moved(T, pts), method)  # type: ignore[arg-type]
    expected = T @ f0.T_world_object
    assert_allclose(f1.T_world_object[:3, 3], expected[:3, 3], atol=1e-9)
    dots = np.abs((f1.T_world_object[:3, :3] * expected[:3, :3]).sum(axis=0))
    assert_allclose(dots, 1.0, atol=1e-6)
    assert_allclose(f1.extents, f0.extents, atol=1e-9)


def test_147_samples_are_a_centred_7_7_3_grid_inside_the_box() -> None:
    assert grid_shape(147) == (7, 7, 3)
    frame = object_frame(SHAPES["box"])
    samples = sample_box(frame, Sampling())
    assert samples.shape == (147, 3)
    half = frame.extents * np.array([0.95, 0.95, 0.70]) / 2
    lo, hi = frame.box_center - half, frame.box_center + half
    assert ((samples >= lo - 1e-12) & (samples <= hi + 1e-12)).all()
    assert_allclose(samples.min(axis=0), lo, atol=1e-12)
    assert_allclose(samples.max(axis=0), hi, atol=1e-12)
    assert_allclose(samples.mean(axis=0), frame.box_center, atol=1e-12)
    assert [len(np.unique(np.round(samples[:, i], 9))) for i in range(3)] == [7, 7, 3]


@pytest.mark.parametrize("points", [1, 8, 27, 100, 147, 500, 2000])
def test_grid_shape_counts(points: int) -> None:
    shape = grid_shape(points)
    assert abs(np.prod(shape) - points) <= 0.1 * points
    assert shape[2] <= shape[0]


def test_explicit_grid_and_single_points() -> None:
    frame = ObjectFrame(np.eye(4), np.array([0.1, 0.2, 0.3]), np.array([0.01, 0, 0]))
    samples = sample_box(frame, Sampling(grid=(1, 2, 1), scale=(1, 1, 1)))
    assert_allclose(samples, [[0.01, -0.1, 0.0], [0.01, 0.1, 0.0]])


def test_table_frame_and_superellipsoid() -> None:
    T = random_rigid(np.random.default_rng(3))
    plane = Plane(-T[:3, 2], float(T[:3, 2] @ T[:3, 3]))  # normal pointing away
    centroid = transform_points(T, np.array([[0.02, -0.01, 0.07]]))[0]
    T_world_table = table_frame(plane, centroid)
    check_transforms(T_world_table)
    # z towards the object, origin under the centroid
    assert_allclose(T_world_table[:3, 2], T[:3, 2], atol=1e-12)
    expected_origin = transform_points(T, np.array([[0.02, -0.01, 0.0]]))[0]
    assert_allclose(T_world_table[:3, 3], expected_origin, atol=1e-12)
    center, axes, exponent = table_superellipsoid(TableSettings(clearance=0.01))
    assert_allclose(center, [0, 0, -0.04])
    assert_allclose(axes, [0.35, 0.35, 0.05])
    assert exponent == 10.0


def test_normals_point_outwards() -> None:
    pts = cylinder_surface(0.03, 0.15, 2000)
    T = random_rigid(np.random.default_rng(0))
    normals = estimate_normals(moved(T, pts), k=12)
    outward = (moved(T, pts) - T[:3, 3]) * normals
    assert (outward.sum(axis=1) >= 0).all()
    assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-9)
    side = np.abs(pts[:, 2]) < 0.07  # away from the caps: radial normals
    radial = pts[side] * [1, 1, 0]
    radial /= np.linalg.norm(radial, axis=1, keepdims=True)
    local = normals[side] @ T[:3, :3]
    assert np.median(np.abs((local * radial).sum(axis=1))) > 0.95


# --------------------------------------------------------------------------------
# degenerate objects
# --------------------------------------------------------------------------------
def test_too_few_points() -> None:
    with pytest.raises(InputError, match="has 5 points, expected at least 10"):
        object_frame(SHAPES["box"][:5])


def test_flat_sheet() -> None:
    sheet = box_surface((0.1, 0.2, 0.0), 500)
    T = random_rigid(np.random.default_rng(1))
    with pytest.raises(InputError, match="is flat"):
        object_frame(moved(T, sheet))


def test_collinear_points() -> None:
    line = np.outer(np.linspace(0, 0.1, 50), [1, 2, 3])
    with pytest.raises(InputError, match="is flat"):
        object_frame(line)


def test_unknown_method_and_bad_shape() -> None:
    with pytest.raises(InputError, match="unknown"):
        object_frame(SHAPES["box"], "magic")  # type: ignore[arg-type]
    with pytest.raises(InputError, match=r"expected \(n, 3\)"):
        object_frame(np.zeros((20, 2)))


def test_frame_is_a_rigid_transform_for_any_shape() -> None:
    rng = np.random.default_rng(7)
    for _ in range(10):
        pts = rng.normal(size=(200, 3)) * rng.uniform(0.01, 0.1, 3)
        T = transform_from(None, rng.normal(size=3))
        check_transforms(object_frame(moved(T, pts)).T_world_object)
