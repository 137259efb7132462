"""A plain, loop-by-loop implementation of the paper's Algorithm 1.

This is the oracle the vectorised search is tested against and the baseline of
``wsgrasp bench``. It follows the paper's structure: loops over samples,
orientations, superellipsoids, fingers and spheres, with only the innermost
loop over points done by numpy (as the authors' C++ does with PCL). It is not
used for planning.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from wsgrasp.geometry import invert_transforms, transform_points
from wsgrasp.gripper.model import GripperModel
from wsgrasp.planning.poses import TableSE

__all__ = ["ReferenceResult", "reference_search", "paper_orientation"]

Array = NDArray[np.float64]


@dataclass
class ReferenceResult:
    reason: NDArray[np.int64]  # (C,) codes into REASONS
    contacts: NDArray[np.int64]  # (C, nf)
    best: int | None  # index of the paper's choice, or None


def _se_value(p: Array, center: Array, axes: Array, exponent: float) -> Array:
    d = np.abs(p - center) / axes
    return d[:, 0] ** exponent + d[:, 1] ** exponent + d[:, 2] ** 2


def _in_body(g: GripperModel, p: Array) -> bool:
    """Whether some point of ``p`` (gripper frame) lies inside some body
    superellipsoid, one superellipsoid at a time."""
    bodies = zip(g.se_centers, g.se_semi_axes, strict=True)
    return any(bool(np.any(_se_value(p, c, a, g.se_exponent) < 1)) for c, a in bodies)


def paper_orientation(theta: float, turned: bool = False) -> Array:
    """``R_object_gwc`` (3, 3) of Algorithm 1, lines 2–6: x along the major axis,
    approaching it from the direction ``theta``; ``turned`` half a turn about the
    approach axis."""
    c, sn = np.cos(theta), np.sin(theta)
    sign = -1.0 if turned else 1.0
    R = np.zeros((3, 3))
    R[:, 0] = [0.0, 0.0, sign]
    R[:, 1] = [-sn * sign, c * sign, 0.0]
    R[:, 2] = [-c, -sn, 0.0]
    return R


def reference_search(
    gripper: GripperModel,
    T_world_object: Array,
    samples_object: Array,
    R_object_gwc: Array,
    object_points: Array,
    obstacle_points: Array,
    table: TableSE,
    depth: Array | None = None,
) -> ReferenceResult:
    """Algorithm 1, one candidate at a time; same candidate order as the fast path
    (samples outer, orientations ``R_object_gwc`` (O, 3, 3) inner, each with its
    ``depth`` (O,) offset along its approach axis)."""
    g = gripper
    nf = g.num_fingers
    # the fingers that must hold a point: those the description names, else all
    named = (g.description or {}).get("contact_fingers") or g.finger_names
    required = [name in named for name in g.finger_names]
    C = len(samples_object) * len(R_object_gwc)
    reason = np.zeros(C, dtype=np.int64)
    contacts = np.zeros((C, nf), dtype=np.int64)
    T_table_world = invert_transforms(table.T_world_table)
    T_gwc_gripper = invert_transforms(g.T_gripper_gwc)
    best, best_d = None, np.inf
    depths = np.zeros(len(R_object_gwc)) if depth is None else depth
    pairs = itertools.product(samples_object, zip(R_object_gwc, depths, strict=True))
    for k, (s, (R, dz)) in enumerate(pairs):
        T_object_gwc = np.eye(4)
        T_object_gwc[:3, :3] = R
        T_object_gwc[:3, 3] = s + dz * R[:, 2]
        T_world_gwc = T_world_object @ T_object_gwc
        T_world_gripper = T_world_gwc @ T_gwc_gripper
        # table: gripper cloud in the table frame
        cloud_table = transform_points(T_table_world @ T_world_gripper, g.cloud)
        if np.any(
            _se_value(cloud_table, table.center, table.semi_axes, table.exponent) < 1.0
        ):
            reason[k] = 1
            continue
        T_gripper_world = invert_transforms(T_world_gripper)
        obj = transform_points(T_gripper_world, object_points)
        if _in_body(g, obj):
            reason[k] = 2
            continue
        if len(obstacle_points) and _in_body(
            g, transform_points(T_gripper_world, obstacle_points)
        ):
            reason[k] = 3
            continue
        d = float(np.linalg.norm(T_world_gwc[:3, 3] - T_world_object[:3, 3]))
        held = np.zeros((len(obj), nf), dtype=bool)
        for c, r, f in zip(
            g.sphere_centers, g.sphere_radii, g.sphere_finger, strict=True
        ):
            held[:, f] |= np.sum((obj - c) ** 2, axis=-1) < r * r
        contacts[k] = held.sum(axis=0)
        if all(contacts[k, f] > 0 for f in range(nf) if required[f]):
            if d < best_d:
                best, best_d = k, d
        else:
            reason[k] = 4
    return ReferenceResult(reason, contacts, best)
