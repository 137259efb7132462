"""Synthetic piles for the clutter tests: boxes and cylinders that touch, lean
or stack, rendered by the synthetic cameras, with each point's true object."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wsgrasp.geometry import transform_from, transform_points
from wsgrasp.perception.synth import default_cameras, make_object, render_scene
from wsgrasp.perception.types import Array, Scene

#: (kind, size, (x, y, z of the base centre), yaw in degrees); z = 0 on the table
Item = tuple[str, tuple[float, ...], tuple[float, float, float], float]


@dataclass
class Pile:
    scene: Scene
    labels: np.ndarray  # (n,) true object per point of scene.points, -1 table
    meshes: list[tuple[object, Array]]


def pile(
    items: list[Item], *, views: int = 4, noise: float = 0.0005, seed: int = 0
) -> Pile:
    """Render ``items`` on a table from ``views`` cameras around them."""
    rng = np.random.default_rng(seed)
    meshes = []
    for kind, size, (x, y, z), yaw in items:
        mesh = make_object(kind, size)
        lo = float(np.asarray(mesh.vertices)[:, 2].min())
        c, s = np.cos(np.radians(yaw)), np.sin(np.radians(yaw))
        R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        meshes.append((mesh, transform_from(R, [x, y, z - lo])))
    top = max(float(transform_points(T, m.vertices)[:, 2].max()) for m, T in meshes)
    centre = np.mean([T[:3, 3] for _, T in meshes], axis=0)
    cams = default_cameras(
        views,
        target=(centre[0], centre[1], top / 2.0),
        distance=0.6,
        elevation=np.radians(55.0),
        rng=rng,
    )
    rendered = render_scene(meshes, 0.8, cams, noise, rng)
    points = np.concatenate(
        [transform_points(v.T_world_camera, v.points) for v in rendered]
    )
    return Pile(
        scene=Scene(views=rendered, points=points),
        labels=true_labels(points, meshes),
        meshes=meshes,
    )


def true_labels(points: Array, meshes: list[tuple[object, Array]]) -> np.ndarray:
    """The mesh each point lies on (nearest surface), -1 for the table."""
    import open3d as o3d

    dist = []
    for mesh, T in meshes:
        sc = o3d.t.geometry.RaycastingScene()
        v = transform_points(T, np.asarray(mesh.vertices))
        sc.add_triangles(
            o3d.core.Tensor.from_numpy(v.astype(np.float32)),
            o3d.core.Tensor.from_numpy(np.asarray(mesh.faces, dtype=np.uint32)),
        )
        q = o3d.core.Tensor.from_numpy(points.astype(np.float32))
        dist.append(sc.compute_distance(q).numpy())
    d = np.stack(dist, axis=1)  # (n, objects)
    labels = np.argmin(d, axis=1)
    labels[points[:, 2] < 0.004] = -1
    return labels


def match(
    truth: np.ndarray, points: Array, clusters: list[Array]
) -> tuple[int, float, float]:
    """Instances found, the share of object points in the right instance (each
    true object matched to the instance holding most of its points, one to one)
    and the worst object's intersection over union."""
    from scipy.optimize import linear_sum_assignment
    from scipy.spatial import cKDTree

    pred = np.full(len(points), -1)
    if clusters:
        allc = np.concatenate(clusters)
        ids = np.concatenate([np.full(len(c), k) for k, c in enumerate(clusters)])
        d, j = cKDTree(allc).query(points)
        pred[d < 1e-9] = ids[j[d < 1e-9]]
    objs = int(truth.max()) + 1
    obj = truth >= 0
    # (objects, instances) overlap counts
    m = np.zeros((objs, max(len(clusters), 1)))
    np.add.at(m, (truth[obj & (pred >= 0)], pred[obj & (pred >= 0)]), 1)
    r, c = linear_sum_assignment(-m)
    correct = m[r, c].sum() / max(int(obj.sum()), 1)
    ious = []
    for k in range(objs):
        hit = c[r == k]
        if not len(hit):
            ious.append(0.0)
            continue
        t, q = truth == k, pred == hit[0]
        ious.append((t & q).sum() / max((t | q).sum(), 1))
    return len(clusters), float(correct), float(min(ious))
