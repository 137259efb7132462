"""The table's outline (``Footprint``) is the convex hull of all its points."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy.spatial import ConvexHull, QhullError

from wsgrasp.geometry import plane_basis
from wsgrasp.perception.footprint import Footprint


def _rows(a: np.ndarray) -> np.ndarray:
    return a[np.lexsort(a.T[::-1])]


def _cloud(kind: str, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    if kind == "gaussian":
        uv = rng.normal(size=(n, 2))
    elif kind == "square":
        uv = rng.uniform(-0.3, 0.3, (n, 2))
    elif kind == "grid":  # many points on the hull's edges, ties everywhere
        uv = np.round(rng.uniform(-1.0, 1.0, (n, 2)), 1)
    else:  # a ring: most points are hull vertices
        a = rng.uniform(0.0, 2.0 * np.pi, n)
        uv = np.c_[np.cos(a), np.sin(a)] * rng.uniform(0.999, 1.0, (n, 1))
    return np.c_[uv, rng.normal(0.0, 1e-3, n)]  # (n, 3), the plane z = 0


@settings(max_examples=60, deadline=None)
@given(
    kind=st.sampled_from(["gaussian", "square", "grid", "ring"]),
    n=st.integers(3, 3000),
    seed=st.integers(0, 2**31),
)
@example(kind="square", n=6, seed=141)  # an offset's last bit differs
def test_outline_is_the_hull_of_every_point(kind: str, n: int, seed: int) -> None:
    points = _cloud(kind, n, seed)
    normal = np.array([0.0, 0.0, 1.0])
    outline = Footprint.from_points(normal, 0.0, points)
    try:
        full = ConvexHull(points @ plane_basis(normal)).equations
    except QhullError:  # a few grid points on one line or one node: no area
        assert not outline.bounded and len(outline.equations) == 0
        return
    # the same edges (their order may differ), to the last bit of an offset that
    # qhull computed from the edge's other end
    got, want = _rows(outline.equations), _rows(full)
    assert got.shape == want.shape
    np.testing.assert_allclose(got, want, rtol=0.0, atol=1e-15)


@pytest.mark.parametrize("n", [3, 10])
def test_points_on_a_line_span_no_area(n: int) -> None:
    points = np.c_[np.linspace(0.0, 1.0, n), np.zeros(n), np.zeros(n)]
    outline = Footprint.from_points([0.0, 0.0, 1.0], 0.0, points)
    assert not outline.bounded
    assert np.isinf(outline.depths(points)).all()
