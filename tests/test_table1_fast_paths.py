"""The search's fast paths for few candidates (the paper's Table I setting) give
bit for bit what the general paths give: the normals of the held points alone,
the body test's box narrowing, and the search with both."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import make_jaw_gripper

from wsgrasp.geometry import coordinates_in_superellipsoids
from wsgrasp.perception import frame
from wsgrasp.perception.frame import estimate_normals
from wsgrasp.planning.body import _inside_narrowing
from wsgrasp.planning.scoring import CandidateBatch

ROOT = Path(__file__).resolve().parent.parent


def _bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64).view(np.uint64)


def _cloud(kind: str, seed: int) -> np.ndarray:
    """Clouds of a few shapes and sizes, near and far from the origin, (n, 3)."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(20, 1500))
    if kind == "blob":
        p = rng.normal(size=(n, 3)) * rng.uniform(0.01, 0.3, 3)
    elif kind == "cylinder":
        a = rng.uniform(0.0, 2.0 * np.pi, n)
        p = np.c_[0.03 * np.cos(a), 0.03 * np.sin(a), rng.uniform(-0.1, 0.1, n)]
    else:  # voxel centres with a little noise: many near-equal distances
        p = np.round(rng.uniform(-0.08, 0.08, (n, 3)) / 0.005) * 0.005
        p += rng.normal(0.0, 1e-4, p.shape)
    return p + rng.uniform(-2.0, 2.0, 3)


@pytest.mark.parametrize("kind", ["blob", "cylinder", "voxels"])
@pytest.mark.parametrize("seed", range(6))
def test_normals_of_some_rows_are_the_whole_clouds(kind: str, seed: int) -> None:
    p = _cloud(kind, seed)
    rng = np.random.default_rng(100 + seed)
    k = int(rng.integers(3, 20))
    rows = rng.choice(len(p), size=int(rng.integers(1, len(p))), replace=False)
    whole = estimate_normals(p, k=k)
    np.testing.assert_array_equal(
        _bits(estimate_normals(p, k=k, rows=rows)), _bits(whole[rows])
    )
    assert frame._normals_of_rows(p, rows, k) is not None  # not open3d's path


@pytest.mark.parametrize("n", [5, 15, 16])
def test_normals_of_rows_of_tiny_or_tied_clouds(n: int) -> None:
    """Clouds with no more points than neighbours, and an exact grid (ties in
    every neighbourhood), take open3d's path, with the same answers."""
    grid = np.stack(np.meshgrid(*[np.arange(4) * 0.01] * 3), axis=-1).reshape(-1, 3)
    for p, own_path in ((_cloud("blob", n)[:n], n > 15), (grid, False)):
        rows = np.arange(0, len(p), 2)
        assert (frame._normals_of_rows(p, rows, 15) is not None) == own_path
        np.testing.assert_array_equal(
            _bits(estimate_normals(p, rows=rows)), _bits(estimate_normals(p)[rows])
        )


def _jaw_batch(seed: int, normals_of: bool) -> tuple[CandidateBatch, list]:
    rng = np.random.default_rng(seed)
    F, no, nf = 12, 300, 2
    points = _cloud("blob", seed)[:no]
    no = len(points)
    holding = rng.random((F, no, nf)) < 0.02
    T = np.tile(np.eye(4), (F, 1, 1))
    T[:, :3, 3] = rng.normal(0.0, 0.05, (F, 3))
    asked: list = []

    def rows_fn(p: np.ndarray, rows: np.ndarray) -> np.ndarray:
        asked.append(rows)
        return estimate_normals(p, rows=rows)

    batch = CandidateBatch(
        gripper=make_jaw_gripper(),
        T_world_gwc=T,
        T_world_gripper=T,
        theta=np.zeros(F),
        holding=holding,
        object_points=points,
        T_world_object=np.eye(4),
        extents=np.array([0.06, 0.06, 0.1]),
        table_normal=np.array([0.0, 0.0, 1.0]),
        min_table_height=np.zeros(F),
        normals_fn=estimate_normals,
        normals_of=rows_fn if normals_of else None,
    )
    return batch, asked


@pytest.mark.parametrize("seed", range(4))
def test_contact_normals_from_the_held_points_alone(seed: int) -> None:
    fast, asked = _jaw_batch(seed, normals_of=True)
    slow, _ = _jaw_batch(seed, normals_of=False)
    np.testing.assert_array_equal(
        _bits(fast.contact_normals), _bits(slow.contact_normals)
    )
    held = np.flatnonzero(slow.holding.any(axis=(0, 2)))
    assert len(asked) == 1
    np.testing.assert_array_equal(asked[0], held)
    # every point's normals, when asked for, are the whole cloud's
    np.testing.assert_array_equal(
        _bits(fast.object_normals), _bits(slow.object_normals)
    )


@pytest.mark.parametrize("seed", range(8))
def test_box_narrowing_is_the_superellipsoid_test(seed: int) -> None:
    """Points around the jaw's bodies, many within rounding of their surfaces."""
    g = make_jaw_gripper(seed=seed)
    rng = np.random.default_rng(seed)
    for e in range(len(g.se_centers)):
        c, ax = g.se_centers[e], g.se_semi_axes[e]
        p = c + rng.uniform(-1.3, 1.3, (4000, 3)) * ax
        on = rng.random(len(p)) < 0.3  # pushed onto a face: ties in the box test
        axis = rng.integers(0, 3, len(p))
        p[on, axis[on]] = (
            c[axis[on]] + np.sign(rng.normal(size=on.sum())) * ax[axis[on]]
        )
        want = coordinates_in_superellipsoids(
            p[:, 0], p[:, 1], p[:, 2], c[None], ax[None], g.se_exponent
        )
        for axes in [(0, 1, 2), (2, 0, 1), (1, 2, 0)]:
            got = _inside_narrowing(
                lambda i, at: p[at, i], len(p), c, ax, g.se_exponent, axes
            )
            np.testing.assert_array_equal(got, np.flatnonzero(want))


@pytest.mark.parametrize(
    "scene", ["box_upright", "mug", "bottle_lying", "box_camera_frame"]
)
def test_search_with_the_held_points_normals_is_the_same(scene: str) -> None:
    """The Franka spec (antipodal scorer) on the example scenes: the search with
    the held points' normals alone gives the verdicts, scores and choice of the
    search with every point's."""
    from wsgrasp.api import Pipeline, _normals, as_scene
    from wsgrasp.planning.search import run_search
    from wsgrasp.spec import load_spec

    pipe = Pipeline(load_spec(ROOT / "examples" / "specs" / "franka.yaml"))
    prep = pipe.prepare(as_scene(ROOT / "examples" / "scenes" / f"{scene}.npz"))
    centroid = prep.search_input.T_world_object[:3, 3]
    asked: list = []

    def normals_of(p: np.ndarray, rows: np.ndarray) -> np.ndarray:
        asked.append(len(rows))
        return _normals(p, centroid, rows)  # as Pipeline.search passes it

    inp, sc, k, sp = prep.search_input, pipe._scorers, pipe.spec.top_k, pipe._spheres
    every = lambda p: _normals(p, centroid)  # noqa: E731
    slow = run_search(inp, sc, top_k=k, spheres=sp, normals_fn=every)
    fast = run_search(
        inp, sc, top_k=k, spheres=sp, normals_fn=every, normals_of=normals_of
    )
    assert pipe.search(prep).best == fast.best
    assert asked and 0 < asked[0] < len(prep.search_input.object_points)
    assert fast.best == slow.best
    np.testing.assert_array_equal(fast.candidates.reason, slow.candidates.reason)
    np.testing.assert_array_equal(fast.candidates.contacts, slow.candidates.contacts)
    np.testing.assert_array_equal(
        _bits(fast.candidates.score), _bits(slow.candidates.score)
    )
    for name, column in slow.candidates.terms.items():
        np.testing.assert_array_equal(_bits(fast.candidates.terms[name]), _bits(column))
