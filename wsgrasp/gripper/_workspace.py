"""Fingertip workspaces and the spheres that fill them (paper, section II).

Per finger: a grid over the finger's joint space, batched forward kinematics of the
pad points (the sampled operation space), a voxel grid of it with small gaps closed,
the Euclidean distance transform (largest inscribed radius at each voxel), and a
greedy choice of spheres, each the largest that stays inside the workspace at its
centre, picked to cover as many not-yet-covered voxels as possible.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from wsgrasp.errors import GripperError
from wsgrasp.geometry import (
    JOINT_FIXED,
    box_grid_points,
    grid_configurations,
    transform_points,
)
from wsgrasp.gripper._urdf import Kinematics
from wsgrasp.spec import FingerDescription, GripperDescription

Array = NDArray[np.float64]

#: a pad must move at least this far (m) over its joint range to count as moving
MIN_PAD_TRAVEL = 1e-4
#: pad points computed per finger at most (joint grid times pad samples)
MAX_WORKSPACE_SAMPLES = 20_000_000
#: voxels of one finger's workspace grid at most (about 20 bytes each while
#: closing and distance-transforming)
MAX_WORKSPACE_VOXELS = 100_000_000
#: a pad moving farther than this (m) over its joint range is not a fingertip
MAX_FINGER_SPAN = 1.5
#: the largest gap-closing radius (voxels) applied before giving up on closing more
MAX_CLOSING_VOXELS = 6
#: candidates whose exact coverage gain is evaluated together in the greedy loop
GAIN_BATCH = 128


@dataclass
class Workspace:
    """The sampled operation space of one fingertip and its voxel grid.

    Attributes
    ----------
    points : (n, 3) float
        Pad points over the joint grid, gripper frame.
    occupied : (X, Y, Z) bool
        Voxels holding a sample, with gaps closed.
    origin : (3,) float
        Centre of voxel ``(0, 0, 0)``; voxel ``i`` has centre
        ``origin + i * voxel`` (centres, not corners, sit on the lattice, so a
        sample grid with the voxel's spacing maps onto voxel centres exactly).
    voxel : float
    distance : (X, Y, Z) float
        Distance (voxels) from each voxel centre to the nearest empty voxel centre.
    closing : int
        Radius (voxels) of the morphological closing applied.
    joints : list of str
        The actuated joints the finger samples (mimics replaced by masters).
    lower, upper : (d,) float
        Their limits: the grid's ends.
    samples : int
        Grid points per joint; configuration ``k`` is row ``k`` of
        ``grid_configurations(lower, upper, samples)``.
    pad_centers : (K, 3) float
        The pad's centre at each configuration of the grid, gripper frame.

    ``points`` holds ``K`` blocks of the pad's ``P`` sample points, configuration
    after configuration, so point ``i`` belongs to configuration ``i // P``.
    """

    finger: str
    points: Array
    occupied: NDArray[np.bool_]
    origin: Array
    voxel: float
    distance: Array
    closing: int
    joints: list[str]
    lower: Array
    upper: Array
    samples: int
    pad_centers: Array

    @property
    def configurations(self) -> Array:
        """The joint grid, ``(K, d)``."""
        return grid_configurations(self.lower, self.upper, self.samples)

    @property
    def points_per_configuration(self) -> int:
        return len(self.points) // len(self.pad_centers)

    def centers(self, index: NDArray[np.int64]) -> Array:
        """Voxel centres ``(k, 3)`` of voxel indices ``(k, 3)``."""
        return self.origin + np.asarray(index) * self.voxel

    def contains(self, points: Array) -> NDArray[np.bool_]:
        """Whether each point ``(n, 3)`` falls in an occupied voxel."""
        idx = np.rint((np.asarray(points) - self.origin) / self.voxel).astype(int)
        shape = np.array(self.occupied.shape)
        ok = np.all((idx >= 0) & (idx < shape), axis=1)
        out = np.zeros(len(idx), dtype=bool)
        out[ok] = self.occupied[tuple(idx[ok].T)]
        return out

    @property
    def volume(self) -> float:
        """Occupied volume (m³)."""
        return float(self.occupied.sum()) * self.voxel**3


def finger_joints(
    kin: Kinematics, desc: GripperDescription, finger: FingerDescription
) -> list[str]:
    """The actuated joints a finger samples (mimics replaced by their masters),
    checked to exist and to lie on the chain from the base to the pad."""
    where = f"fingers[{finger.name}]"
    kin.check_link(finger.pad.link, desc.name, f"{where}.pad.link")
    try:
        chain = kin.chain(desc.base_link, finger.pad.link)
    except ValueError:
        raise GripperError(
            f"gripper {desc.name!r}: {where}.pad.link {finger.pad.link!r} is not "
            f"below base_link {desc.base_link!r} in the URDF",
            hint="choose a pad link that the base link carries",
        ) from None
    on_chain = {kin.master(j.name) for j in chain if j.kind != JOINT_FIXED}
    masters: list[str] = []
    for name in finger.joints:
        kin.check_joint(name, desc.name, f"{where}.joints")
        m = kin.master(name)
        if kin.joints[m].kind == JOINT_FIXED:
            raise GripperError(
                f"gripper {desc.name!r}: {where}.joints lists {name!r}, a fixed "
                "joint, which cannot move the pad",
                hint="list the revolute or prismatic joints of this finger",
            )
        if m not in on_chain:
            movers = sorted(on_chain) or ["none"]
            raise GripperError(
                f"gripper {desc.name!r}: {where}.joints lists {name!r}, which does "
                f"not move pad link {finger.pad.link!r} (joints that do: "
                f"{', '.join(movers)})",
                hint=f"list the joints between {desc.base_link!r} and "
                f"{finger.pad.link!r} in {where}.joints",
            )
        if m not in masters:
            masters.append(m)
    if not finger.joints:
        closers = {kin.master(j) for f in desc.fingers for j in f.joints}
        moved = sorted(on_chain & closers)
        if moved:
            raise GripperError(
                f"gripper {desc.name!r}: {where} is a rigid jaw (no joints), but "
                f"joints {moved} of other fingers move its pad link "
                f"{finger.pad.link!r}",
                hint=f"list the joints that move {finger.pad.link!r} in "
                f"{where}.joints, or put the rigid jaw's pad on a link they do "
                "not move",
            )
    return masters


def sample_workspace(
    kin: Kinematics, desc: GripperDescription, finger: FingerDescription
) -> Workspace:
    """Sampled operation space of one fingertip, voxelized.

    The finger's joints take ``desc.joint_samples`` values each over their limits;
    other joints stay in the pre-grasp posture; mimic joints follow their masters.
    A rigid jaw (no joints) samples its pad box once, where the base holds it.
    """
    masters = finger_joints(kin, desc, finger)
    lower = np.array([kin.joints[m].lower for m in masters])
    upper = np.array([kin.joints[m].upper for m in masters])
    n = desc.joint_samples
    d = len(masters)
    where = f"gripper {desc.name!r}: fingers[{finger.name}]"
    pad = finger.pad
    v = desc.workspace_voxel
    sizes = np.asarray(pad.size, dtype=np.float64)
    # a rigid jaw's workspace is its pad box: filled a voxel apart, as a moving
    # pad's sweep fills its workspace
    per_edge = (
        np.broadcast_to(np.asarray(pad.samples, dtype=np.int64), (3,))
        if d
        else np.ceil(sizes / v).astype(np.int64) + 1
    )
    samples = n**d * int(np.prod(per_edge))
    if samples > MAX_WORKSPACE_SAMPLES and not d:
        raise GripperError(
            f"{where}: a rigid jaw's pad box of "
            f"{' x '.join(f'{x * 1000:.0f}' for x in sizes)} mm at "
            f"workspace_voxel {v:g} m makes {samples:,} points, more than "
            f"{MAX_WORKSPACE_SAMPLES:,}",
            hint="give the rigid jaw's pad.size the jaw's face and a depth of "
            "a centimetre or so",
        )
    if samples > MAX_WORKSPACE_SAMPLES:
        fit = max(2, int((MAX_WORKSPACE_SAMPLES / np.prod(per_edge)) ** (1 / d)))
        raise GripperError(
            f"{where}: joint_samples {n} over {d} joints and pad.samples "
            f"{_samples_text(pad.samples)} make {samples:,} pad points to compute, "
            f"more than {MAX_WORKSPACE_SAMPLES:,}",
            hint=f"lower joint_samples to {fit} or less, or pad.samples",
        )
    q = grid_configurations(lower, upper, n)  # (n**d, d)
    values: dict[str, Any] = dict(desc.pregrasp)
    for i, m in enumerate(masters):
        values[m] = q[:, i]
    T = kin.chain_poses(desc.base_link, finger.pad.link, values).reshape(-1, 4, 4)
    pad_pts = box_grid_points(pad.center, pad.size, per_edge)  # (P, 3)
    pts = transform_points(T, pad_pts)  # (K, P, 3)
    pad_centers = transform_points(T, np.asarray(pad.center, float)[None])[:, 0]
    travel = float(np.linalg.norm(np.ptp(pts[:, 0, :], axis=0)))
    if d and travel < MIN_PAD_TRAVEL:
        # a joint whose URDF limits are equal cannot move: the URDF's fault
        stuck = [
            f"{m} (lower = upper = {lower[i]:g})"
            for i, m in enumerate(masters)
            if upper[i] - lower[i] <= 1e-12
        ]
        if stuck:
            limits = ", ".join(stuck)
            raise GripperError(
                f"{where}: the URDF's <limit> of joint(s) {limits} spans nothing, "
                f"so pad link {pad.link!r} does not move",
                hint="give the joint its range in the URDF; if it moves with "
                "another joint (one motor driving both jaws), give it a <mimic "
                "joint=...> of that joint instead, then run `wsgrasp gripper new` "
                "again",
            )
        raise GripperError(
            f"{where}: joints {masters} do not move pad link {pad.link!r} "
            f"(it travels {travel * 1000:.3f} mm over their limits)",
            hint="check the joint limits and axes in the URDF, and that "
            "fingers.joints and fingers.pad.link belong to the same finger",
        )
    # largest distance between neighbouring samples, along each joint and pad edge
    grid = pts.reshape(*(n,) * d, -1, 3)  # (n, ..., n, P, 3)
    gap = 0.0
    for axis in range(d):
        step = np.linalg.norm(np.diff(grid, axis=axis), axis=-1)
        gap = max(gap, float(step.max()))
    if d:  # the pad's own spacing along each edge that has several points
        spaced = (per_edge > 1) & (sizes > 0)
        if spaced.any():
            gap = max(gap, float(np.max(sizes[spaced] / (per_edge[spaced] - 1))))
    flat = pts.reshape(-1, 3)  # (K * P, 3)
    span = np.ptp(flat, axis=0)  # (3,)
    if float(span.max()) > MAX_FINGER_SPAN:
        raise GripperError(
            f"{where}: the pad of link {pad.link!r} moves over "
            f"{float(span.max()):.4g} m; fingertips move centimetres, so the URDF "
            "is probably in millimetres (URDF lengths are metres), or the pad sits "
            "on the wrong link",
            hint="convert the URDF to metres (scale the origins and meshes by "
            "0.001), or fix fingers.pad.link",
        )
    closing = int(min(MAX_CLOSING_VOXELS, max(1, np.ceil(gap / (2.0 * v)))))
    margin = closing + 2
    voxels = float(np.prod(span / v + 2 * margin + 1))
    if voxels > MAX_WORKSPACE_VOXELS:
        coarser = float((np.prod(span) / MAX_WORKSPACE_VOXELS) ** (1 / 3))
        raise GripperError(
            f"{where}: workspace_voxel {v:g} m over the pad's "
            f"{' x '.join(f'{x * 1000:.0f}' for x in span)} mm workspace makes "
            f"{voxels:.3g} voxels, more than {MAX_WORKSPACE_VOXELS:.0e}",
            hint=f"raise workspace_voxel to {max(coarser * 1.2, 1e-4):.2g} m or more",
        )
    origin = flat.min(axis=0) - margin * v
    idx = np.rint((flat - origin) / v).astype(np.int64)  # (K * P, 3)
    shape = tuple(int(s) for s in idx.max(axis=0) + margin + 1)
    occupied = np.zeros(shape, dtype=bool)
    occupied[tuple(idx.T)] = True
    if closing:
        r = np.arange(-closing, closing + 1)
        ball = (
            r[:, None, None] ** 2 + r[None, :, None] ** 2 + r[None, None, :] ** 2
        ) <= (closing**2)  # (2c+1, 2c+1, 2c+1)
        occupied = ndimage.binary_closing(occupied, structure=ball)
    distance = ndimage.distance_transform_edt(occupied)
    return Workspace(
        finger.name,
        flat,
        occupied,
        origin,
        v,
        distance,
        closing,
        joints=masters,
        lower=lower,
        upper=upper,
        samples=n,
        pad_centers=pad_centers,
    )


def _samples_text(samples: int | tuple[int, int, int]) -> str:
    """``pad.samples`` as the YAML writes it."""
    if isinstance(samples, int):
        return str(samples)
    return "[" + ", ".join(str(k) for k in samples) + "]"


@dataclass
class SphereFill:
    """Spheres placed in one workspace and how much of it they cover."""

    centers: Array  # (nsp, 3)
    radii: Array  # (nsp,)
    covered_fraction: float
    candidates: int


def fill_spheres(
    ws: Workspace, count: int, min_radius: float, gripper: str
) -> SphereFill:
    """Place ``count`` spheres in a workspace, greedily maximising coverage.

    A sphere centred at a voxel gets the largest radius that keeps it inside the
    occupied voxels: ``(distance - 1) * voxel``, i.e. it reaches at most the centre
    of the last occupied voxel. Each step takes the candidate that covers the most
    not-yet-covered voxels (lazy greedy: gains only shrink, so stale gains are upper
    bounds and only the best few are re-evaluated, as one batched gather). Once all
    is covered, further spheres go to the largest candidates farthest from the
    spheres already placed.

    Raises
    ------
    GripperError
        When no voxel can hold a sphere of ``min_radius``, or fewer voxels can than
        ``count``.
    """
    v = ws.voxel
    r_vox = ws.distance - 1.0  # (X, Y, Z) radius in voxels at each centre
    where = f"gripper {gripper!r}: finger {ws.finger!r}"
    best = float(r_vox.max()) * v
    cand_mask = r_vox * v >= min_radius - 1e-12
    cand_idx = np.argwhere(cand_mask)  # (C, 3)
    C = len(cand_idx)
    if C == 0:
        raise GripperError(
            f"{where}: its workspace is too thin to hold a sphere of "
            f"min_sphere_radius {min_radius * 1000:.1f} mm (the largest that fits is "
            f"{max(best, 0.0) * 1000:.2f} mm at workspace_voxel "
            f"{v * 1000:.1f} mm)",
            hint="lower min_sphere_radius or workspace_voxel, enlarge fingers.pad."
            "size, or widen the joint limits",
        )
    if C < count:
        raise GripperError(
            f"{where}: only {C} sphere centres of radius >= min_sphere_radius "
            f"{min_radius * 1000:.1f} mm fit in its workspace, but "
            f"spheres_per_finger asks for {count} ({count - C} unreachable)",
            hint="lower spheres_per_finger, workspace_voxel or min_sphere_radius",
        )
    radii = r_vox[tuple(cand_idx.T)]  # (C,) voxels
    shape = np.array(ws.occupied.shape)
    strides = np.array([shape[1] * shape[2], shape[2], 1])
    cand_flat = cand_idx @ strides  # (C,)
    # stencil of lattice offsets within the largest radius, sorted by length
    R = int(np.floor(radii.max()))
    g = np.arange(-R, R + 1)
    off = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    norm = np.linalg.norm(off, axis=1)
    order = np.argsort(norm, kind="stable")
    off, norm = off[order], norm[order]  # (M, 3), (M,)
    off_flat = off @ strides  # (M,)
    n_in = np.searchsorted(norm, radii + 1e-9, side="right")  # (C,) voxels covered
    # flat occupancy, padded so that stencil offsets beyond a candidate's own
    # radius (masked out below) never index outside it
    pad = int(np.abs(off_flat).max())
    uncovered = np.zeros(ws.occupied.size + 2 * pad, dtype=bool)  # (V + 2 pad,)
    uncovered[pad : -pad or None] = ws.occupied.reshape(-1)
    cand_flat = cand_flat + pad
    total = int(np.count_nonzero(uncovered))
    bound = n_in.astype(np.int64)  # upper bounds of the gains
    chosen: list[int] = []
    available = np.ones(C, dtype=bool)
    centres_m = ws.centers(cand_idx)  # (C, 3)
    min_d = np.full(C, np.inf)  # distance to the nearest chosen centre (m)
    while len(chosen) < count:
        masked = np.where(available, bound, -1)
        if masked.max() <= 0:
            # everything covered: spread the rest, large and far first
            score = np.where(available, radii * v + min_d, -np.inf)
            pick = int(np.argmax(score))
        else:
            k = min(GAIN_BATCH, int(available.sum()))
            top = np.argpartition(-masked, k - 1)[:k]  # (k,)
            m = int(n_in[top].max())
            ids = cand_flat[top, None] + off_flat[None, :m]  # (k, m)
            inside = np.arange(m)[None, :] < n_in[top, None]  # (k, m)
            gains = np.count_nonzero(uncovered[ids] & inside, axis=1)  # (k,)
            bound[top] = gains
            rest = masked.copy()
            rest[top] = -1
            j = int(np.argmax(gains))
            if gains[j] < rest.max():
                continue
            pick = int(top[j])
        chosen.append(pick)
        available[pick] = False
        uncovered[cand_flat[pick] + off_flat[: n_in[pick]]] = False
        min_d = np.minimum(min_d, np.linalg.norm(centres_m - centres_m[pick], axis=1))
    sel = np.array(chosen)
    covered = total - int(np.count_nonzero(uncovered))
    return SphereFill(
        centers=centres_m[sel],
        radii=radii[sel] * v,
        covered_fraction=covered / total if total else 0.0,
        candidates=C,
    )
