"""Batched evaluation of grasp candidates (Algorithm 1, lines 8–24, vectorised).

Each candidate gets the first rejection reason that applies, in Algorithm 1's order:
table collision (gripper cloud inside the table superellipsoid), object collision
(object points inside a body superellipsoid), obstacle collision (points of other
objects inside a body superellipsoid), and a finger with no object point inside any
of its workspace spheres. Later checks run only on the survivors of earlier ones.

The finger check's cost does not grow with the number of spheres: see
``wsgrasp.planning.spheres``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from wsgrasp.geometry import (
    coordinates_in_superellipsoids,
    invert_transforms,
)
from wsgrasp.gripper.model import GripperModel
from wsgrasp.planning._holdings import HoldingField, Holdings, count_held
from wsgrasp.planning.dense import (
    CandidateStructure,
    StructuredPoses,
    body_and_fingers,
    hull_vertices,
    lowest_heights,
    table_bounds,
    table_exact,
)
from wsgrasp.planning.spheres import FingerSpheres

__all__ = [
    "CandidateStructure",
    "FingerSpheres",
    "Evaluation",
    "evaluate_candidates",
    "TableSE",
]

Array = NDArray[np.float64]

#: Work on at most this many transformed points at once (bounds memory).
_CHUNK_POINTS = 2_000_000
#: Object points in the coarse collision pass.
_COARSE_POINTS = 48


@dataclass(frozen=True)
class TableSE:
    """The table's superellipsoid, in the table frame (z = table normal).

    Attributes
    ----------
    T_world_table : (4, 4) float
    center, semi_axes : (3,) float
    exponent : float
    """

    T_world_table: Array
    center: Array
    semi_axes: Array
    exponent: float


@dataclass
class Evaluation:
    """What evaluation found, per candidate ``C`` and for the feasible ones ``F``.

    Attributes
    ----------
    reason : (C,) int
        Code into ``REASONS`` (0 feasible).
    contacts : (C, nf) int
        Object points held per finger (evaluated candidates only, else 0).
    feasible : (F,) int
        Indices of the feasible candidates.
    holding : (F, no, nf) bool
        Which object points each finger's spheres hold, per feasible candidate.
        The structured path builds it only when read (see :attr:`holdings`).
    min_table_height : (F,) float
        Lowest gripper-cloud point above the table surface, per feasible candidate.
    """

    reason: NDArray[np.int64]
    contacts: NDArray[np.int64]
    feasible: NDArray[np.int64]
    if TYPE_CHECKING:  # read as the array; set as the array or Holdings
        holding: NDArray[np.bool_]
    else:
        holding: NDArray[np.bool_] = HoldingField()
    min_table_height: Array

    @property
    def holdings(self) -> Holdings:
        """The feasible candidates' holdings as
        :class:`~wsgrasp.planning._holdings.Holdings`: their counts, and their
        rows or sums over the held points, without building ``holding``."""
        return type(self).__dict__["holding"].holdings_of(self)  # type: ignore[no-any-return]


def _chunks(n_items: int, points_per_item: int) -> list[slice]:
    step = max(1, _CHUNK_POINTS // max(points_per_item, 1))
    return [slice(i, min(i + step, n_items)) for i in range(0, n_items, step)]


def _inside(
    T: Array, points: Array, se: tuple[Array, Array, float]
) -> NDArray[np.bool_]:
    """Whether ``T[k] @ points[k]`` lies inside the SE, for transforms ``(k, 4, 4)``
    and points ``(k, 3)``: ``(k,)``."""
    p = np.einsum("kij,kj->ki", T[:, :3, :3], points) + T[:, :3, 3]  # (k, 3)
    return coordinates_in_superellipsoids(p[:, 0], p[:, 1], p[:, 2], *se)


def table_collisions(
    T_world_gripper: Array, cloud: Array, table: TableSE
) -> tuple[NDArray[np.bool_], Array]:
    """Candidates whose gripper cloud enters the table superellipsoid.

    Returns
    -------
    hit : (C,) bool
    min_height : (C,) float
        Lowest cloud point above the table surface (z = 0 of the table frame).
    """
    T_table_gripper = invert_transforms(table.T_world_table) @ T_world_gripper
    top = table.center[2] + table.semi_axes[2]
    hit = np.zeros(len(T_world_gripper), dtype=bool)
    min_height = np.empty(len(T_world_gripper))
    se = (table.center, table.semi_axes, table.exponent)
    for sl in _chunks(len(T_world_gripper), len(cloud)):
        T = T_table_gripper[sl]
        # heights of every cloud point in the table frame: (c, ng)
        z = T[:, 2, :3] @ cloud.T
        z += T[:, 2, 3][:, None]
        low = z.argmin(axis=1)  # (c,)
        min_height[sl] = z[np.arange(len(T)), low]
        # only points below the SE's top can be inside it
        maybe = np.flatnonzero(min_height[sl] < top)
        if maybe.size == 0:
            continue
        block = np.zeros(len(T), dtype=bool)
        # quick: the lowest point of each candidate is nearly always inside when
        # any point is; test it first, all the points below the top only for the rest
        block[maybe] = _inside(T[maybe], cloud[low[maybe]], se)
        rest = maybe[~block[maybe]]
        if rest.size:
            ci, pi = np.nonzero(z[rest] < top)
            inside = _inside(T[rest[ci]], cloud[pi], se)
            block[rest[ci[inside]]] = True
        hit[sl] = block
    return hit, min_height


def _coordinates(T: Array, points: Array) -> tuple[Array, Array, Array]:
    """Points ``(n, 3)`` under transforms ``(a, 4, 4)``, as three ``(n, a)`` arrays."""
    a = len(T)
    # one product for all: (n, 3) @ (3, 3a), columns x of every transform, then y, z
    M = T[:, :3, :3].transpose(2, 1, 0).reshape(3, 3 * a)
    P = points @ M  # (n, 3a)
    P += T[:, :3, 3].T.reshape(-1)
    return P[:, :a], P[:, a : 2 * a], P[:, 2 * a :]


def evaluate_candidates(
    T_world_gripper: Array,
    gripper: GripperModel,
    object_points: Array,
    obstacle_points: Array,
    table: TableSE,
    spheres: FingerSpheres | None = None,
    *,
    structure: CandidateStructure | None = None,
) -> Evaluation:
    """Evaluate every candidate pose.

    Parameters
    ----------
    T_world_gripper : (C, 4, 4) float
    gripper : GripperModel
    object_points : (no, 3) float
        World frame.
    obstacle_points : (k, 3) float
        Points of other objects, world frame (may be empty).
    table : TableSE
    spheres : FingerSpheres, optional
        Prebuilt sphere index of ``gripper`` (built here when omitted).
    structure : CandidateStructure, optional
        How ``T_world_gripper`` was built (``candidate_poses``: samples outer,
        orientations inner). With it, the tests run per orientation with the
        samples as translations, conservative bounds settling most candidates
        before any point is tested (``wsgrasp.planning.dense``); the verdicts,
        contacts and holdings are the same.
    """
    spheres = spheres or FingerSpheres(gripper)
    C, nf, no = len(T_world_gripper), gripper.num_fingers, len(object_points)
    reason = np.zeros(C, dtype=np.int64)
    contacts = np.zeros((C, nf), dtype=np.int64)

    # 1. table
    min_height: Array | None = None
    if structure is None:
        table_hit, min_height = table_collisions(T_world_gripper, gripper.cloud, table)
    else:
        poses, table_hit = _structured_table(T_world_gripper, gripper, table, structure)
        reason[table_hit] = 1
        alive = np.flatnonzero(~table_hit)
        v = body_and_fingers(
            poses, alive, gripper, spheres, object_points, obstacle_points
        )
        reason[alive] = v.reason
        contacts[alive] = v.contacts
        feasible = alive[v.reason == 0]
        # the lowest point of a cloud along a direction is a hull vertex
        low = (
            lowest_heights(poses, _cloud_hull(gripper), table, feasible)
            if feasible.size
            else np.zeros(0)
        )
        # the holdings as Holdings: built only if read
        return Evaluation(reason, contacts, feasible, v.holding, low)  # type: ignore[arg-type]
    reason[table_hit] = 1
    alive = np.flatnonzero(~table_hit)

    feasible_parts: list[NDArray[np.int64]] = []
    holding_parts: list[NDArray[np.bool_]] = []
    T_gripper_world = invert_transforms(T_world_gripper[alive])  # (A, 4, 4)
    se = (gripper.se_centers, gripper.se_semi_axes, gripper.se_exponent)
    for sl in _chunks(len(alive), max(no, len(obstacle_points))):
        idx = alive[sl]
        T = T_gripper_world[sl]
        # 2. object collision. A coarse pass with every k-th object point first:
        # a hit by a subset is a hit by the whole cloud, and it rejects most
        # colliding candidates at a fraction of the cost.
        coarse = coordinates_in_superellipsoids(
            *_coordinates(T, object_points[:: max(1, no // _COARSE_POINTS)]), *se
        ).any(axis=0)  # (a,)
        idx, T = idx[~coarse], T[~coarse]
        reason[alive[sl][coarse]] = 2
        # the rest, with every point, in the gripper frame: 3 × (no, a')
        xyz = _coordinates(T, object_points)
        obj_hit = coordinates_in_superellipsoids(*xyz, *se).any(axis=0)  # (a',)
        reason[idx[obj_hit]] = 2
        keep = ~obj_hit
        # 3. obstacles
        if len(obstacle_points) and keep.any():
            obs_hit = np.zeros(len(idx), dtype=bool)
            obs_xyz = _coordinates(T[keep], obstacle_points)
            obs_hit[keep] = coordinates_in_superellipsoids(*obs_xyz, *se).any(axis=0)
            reason[idx[obs_hit]] = 3
            keep &= ~obs_hit
        if not keep.any():
            continue
        # 4. fingers
        # (no, b, nf) -> (b, no, nf)
        held = spheres.holding_coordinates(*(c[:, keep] for c in xyz))
        held = held.transpose(1, 0, 2)
        counts = count_held(held)  # (b, nf)
        kept_idx = idx[keep]
        contacts[kept_idx] = counts
        ok = np.all(counts > 0, axis=1)
        reason[kept_idx[~ok]] = 4
        feasible_parts.append(kept_idx[ok])
        holding_parts.append(held[ok])

    feasible = (
        np.concatenate(feasible_parts) if feasible_parts else np.zeros(0, np.int64)
    )
    holding = (
        np.concatenate(holding_parts)
        if holding_parts
        else np.zeros((0, no, nf), dtype=bool)
    )
    return Evaluation(
        reason=reason,
        contacts=contacts,
        feasible=feasible,
        holding=holding,
        min_table_height=min_height[feasible],
    )


def _cloud_hull(gripper: GripperModel) -> Array:
    """The gripper cloud's convex-hull vertices, computed once and kept on the
    model (as its other derived lookups are)."""
    hull = gripper.__dict__.get("_cloud_hull")
    if hull is None:
        hull = hull_vertices(np.ascontiguousarray(gripper.cloud, dtype=np.float64))
        gripper.__dict__["_cloud_hull"] = hull
    return hull  # type: ignore[no-any-return]


def _structured_table(
    T_world_gripper: Array,
    gripper: GripperModel,
    table: TableSE,
    structure: CandidateStructure,
) -> tuple[StructuredPoses, NDArray[np.bool_]]:
    """The poses of a structured candidate set and their table verdicts: the
    support-function bounds decide most, the exact test over the whole cloud the
    rest."""
    C = len(T_world_gripper)
    if structure.num_candidates != C:
        raise ValueError(
            f"structure describes {structure.num_candidates} candidates, "
            f"T_world_gripper holds {C}; pass the structure it was built from"
        )
    poses = StructuredPoses.build(structure, gripper.T_gripper_gwc)
    if C:
        ends = np.array([0, C - 1])
        a, b = poses.transforms(ends), T_world_gripper[ends]
        # np.allclose(a, b, atol=1e-9) without its wrapper (a tenth of the time)
        if not np.all(np.abs(a - b) <= 1e-9 + 1e-5 * np.abs(b)):
            raise ValueError(
                "structure does not match T_world_gripper: pass the samples, "
                "orientations and depths candidate_poses was given"
            )
    cloud = np.ascontiguousarray(gripper.cloud, dtype=np.float64)
    hit, unsure = table_bounds(poses, _cloud_hull(gripper), table)
    idx = np.flatnonzero(unsure)
    if idx.size:
        hit[idx] = table_exact(poses, cloud, table, idx)
    return poses, hit
