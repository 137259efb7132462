"""Candidate gripper poses: bounding-box samples × orientations.

An orientation is a rotation ``R_object_gwc`` of the gripper-workspace-centroid
(GWC) frame, whose z axis is the approach direction and whose y axis is the
closing direction. Three ways to sample them (``sampling.mode``):

``major_axis`` (the paper, Algorithm 1, lines 2–6): the GWC x axis along the
object's major axis (object z), so the gripper stands perpendicular to it, and the
approach axis points towards the axis from the direction ``theta`` in the object's
xy plane::

    x_gwc = z_obj
    z_gwc = -(cos θ x_obj + sin θ y_obj)
    y_gwc = z_gwc × x_gwc

With ``flip``, each pose is also tried turned half a turn about its approach axis
(``x_gwc = -z_obj``): the same grasp for a gripper that is symmetric about its
approach axis, a different one for a hand with a thumb on one side.

The paper measures θ from the object frame's x axis and leaves the half turn to
the sign of the major axis (``sampling.angles_from: object``); ``angles_from:
table`` (the default) turns them from the table instead (:func:`from_above`,
:func:`across_narrowest`, :func:`far_side`; why: the docs' method page, "Beyond the
paper").

``xyz`` (the authors' follow-up): ``R_object_gwc = Rz(γ) Ry(β) Rx(α)``, about the
object frame's fixed axes over a full turn each, a rotation reached twice kept once.

``approach_sphere``: approach directions spread evenly over those not from under
the table (:func:`approach_sphere_orientations`), times rolls about each; roll 0
puts the GWC x axis along the object's major axis projected across the approach.

No orientation whose approach points up, from under the table, by more than
``upward_tolerance_deg`` is generated, in any mode. With ``sampling.depths`` above
1, each is also tried moved along its approach (:func:`depth_offsets`), the object
nearer the palm or the fingertips (a long-fingered hand pinches with its tips).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from wsgrasp.planning.poses import CandidateStructure, StructuredPoses

__all__ = [
    "Orientations",
    "orientation_angles",
    "orientation_set",
    "major_axis_orientations",
    "xyz_orientations",
    "approach_sphere_orientations",
    "candidate_poses",
    "depth_offsets",
    "far_side",
    "from_above",
]

Array = NDArray[np.float64]


def orientation_angles(count: int, range_deg: float) -> Array:
    """``count`` angles (rad) evenly spread over ``range_deg`` degrees, end point
    excluded: ``(4, 360)`` gives 0, 90, 180, 270 degrees, ``(4, 180)`` 0, 45, 90, 135.
    """
    return np.deg2rad(range_deg) * np.arange(count, dtype=np.float64) / count


@dataclass
class Orientations:
    """A set of candidate orientations ``O``.

    Attributes
    ----------
    R_object_gwc : (O, 3, 3) float
    theta : (O,) float
        The angle that names each within its mode (rad): about the major axis
        (``major_axis``), the roll about the approach (``approach_sphere``), or γ
        about object z (``xyz``).
    flipped : (O,) bool
        Turned half a turn about the approach axis (``major_axis`` with flip).
    depth : (O,) float
        Offset (m) of the GWC along its approach axis from the box sample.
    mode : str
    """

    R_object_gwc: Array
    theta: Array
    flipped: NDArray[np.bool_]
    depth: Array
    mode: str = "major_axis"

    def __len__(self) -> int:
        return int(self.R_object_gwc.shape[0])

    def select(self, index: NDArray[np.bool_] | NDArray[np.int64]) -> Orientations:
        """The orientations a mask or an index array picks, in its order."""
        return Orientations(
            self.R_object_gwc[index],
            self.theta[index],
            self.flipped[index],
            self.depth[index],
            self.mode,
        )


#: a major axis within this angle of the table's plane is level (no side of the
#: gripper faces the table), one within this angle of its normal upright (no
#: ``major_axis`` angle approaches from above)
LEVEL_DEG = 10.0
#: a gripper reaching this much (m) farther on one side of its approach axis than
#: on the other has a far side (:func:`far_side`)
FAR_SIDE_MARGIN = 0.01


def far_side(points_gwc: Array) -> int:
    """The side (+1 or -1) of the GWC x axis that ``points_gwc`` (the gripper's
    body cloud, GWC frame) reach farther along by ``FAR_SIDE_MARGIN`` or more,
    else 0 (about as far both ways)."""
    x = np.asarray(points_gwc, dtype=np.float64).reshape(-1, 3)[:, 0]
    lean = float(x.max() + x.min()) if len(x) else 0.0  # +x's reach past -x's
    return 0 if abs(lean) < FAR_SIDE_MARGIN else int(np.sign(lean))


def from_above(normal_object: Array, thetas: Array) -> float:
    """The turn (rad) to add to the ``major_axis`` angles ``thetas`` so that the
    middle one approaches from straight above the table (along ``-normal``
    projected into the object's xy plane), or 0 where the major axis stands
    within ``LEVEL_DEG`` of the table's normal (every angle is then a side
    approach). ``normal_object``: the table's unit normal in the object frame."""
    if _upright(normal_object) or not len(thetas):
        return 0.0
    nx, ny = float(normal_object[0]), float(normal_object[1])
    # z_gwc = -(cos θ, sin θ, 0) is -normal's direction at θ = atan2(ny, nx)
    return float(np.arctan2(ny, nx) - thetas[len(thetas) // 2])


def _upright(normal_object: Array) -> bool:
    """Whether the major axis (object z) stands within ``LEVEL_DEG`` of the
    table's unit normal ``normal_object`` (object frame)."""
    return bool(
        np.hypot(normal_object[0], normal_object[1]) <= np.sin(np.deg2rad(LEVEL_DEG))
    )


def across_narrowest(points: Array, R_world_object: Array, thetas: Array) -> float:
    """The turn (rad) to add to the ``major_axis`` angles ``thetas`` so that the
    middle one's fingers close across the object's narrowest width in the plane
    perpendicular to its major axis (``points`` ``(n, 3)``, world frame; the
    width of their outline, :func:`~wsgrasp.perception.footprint.
    narrowest_across`), or 0 where the outline has no area."""
    from wsgrasp.perception.footprint import narrowest_across

    _, across = narrowest_across(points, R_world_object[:, 2])
    if across is None or not len(thetas):
        return 0.0
    d = R_world_object.T @ across  # object frame, in its xy plane
    # y_gwc = (-sin θ, cos θ, 0) lies along d at θ = atan2(d_y, d_x) - π / 2
    return float(np.arctan2(d[1], d[0]) - 0.5 * np.pi - thetas[len(thetas) // 2])


def major_axis_orientations(thetas: Array, flip: bool = False) -> Orientations:
    """The paper's orientations about the major axis (then turned, with ``flip``).

    Parameters
    ----------
    thetas : (nos,) float
    flip : bool

    Returns
    -------
    Orientations
        ``nos * (2 if flip else 1)``: each angle, then (with ``flip``) turned.
    """
    nf = 2 if flip else 1
    thetas = np.repeat(np.asarray(thetas, dtype=np.float64), nf)
    flipped = np.tile(np.arange(nf) == 1, len(thetas) // nf)
    nos = len(thetas)  # orientations × flips
    c, s = np.cos(thetas), np.sin(thetas)
    R = np.zeros((nos, 3, 3))
    R[:, 2, 0] = 1.0  # x_gwc = z_obj
    R[:, 0, 2] = -c  # z_gwc = -(cos θ, sin θ, 0)
    R[:, 1, 2] = -s
    R[:, 0, 1] = -s  # y_gwc = z_gwc × x_gwc = (-sin θ, cos θ, 0)
    R[:, 1, 1] = c
    # half a turn about z_gwc: x_gwc and y_gwc change sign
    R[flipped, :, :2] *= -1.0
    return Orientations(R, thetas, flipped, np.zeros(nos), "major_axis")


def xyz_orientations(steps: tuple[int, int, int]) -> Orientations:
    """Rotations about the object's x, y and z axes, ``steps`` angles each over a
    full turn, repeated rotations kept once (first in grid order).

    Returns
    -------
    Orientations
        At most ``nx * ny * nz``, α slowest, γ fastest.
    """
    axes = [2.0 * np.pi * np.arange(n) / n for n in steps]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    # extrinsic x, then y, then z: R = Rz(γ) Ry(β) Rx(α)
    R = Rotation.from_euler("xyz", grid).as_matrix()  # (n, 3, 3)
    key = np.round(R.reshape(len(R), 9), 9) + 0.0  # -0.0 and 0.0 alike
    _, first = np.unique(key, axis=0, return_index=True)
    keep = np.sort(first)
    none = np.zeros(len(keep))
    return Orientations(R[keep], grid[keep, 2], none.astype(bool), none, "xyz")


def approach_sphere_orientations(
    directions: int,
    rolls: int,
    roll_range_deg: float,
    T_world_object: Array,
    table_normal: Array,
    upward_tolerance_deg: float,
) -> Orientations:
    """Approach directions spread evenly over those not from under the table,
    times rolls about each.

    The directions are a Fibonacci lattice on the spherical cap of unit vectors
    ``d`` with ``d · n <= sin(upward_tolerance_deg)`` (``n`` the table normal,
    towards the object): equal area per direction, from straight down to level
    (and a little above, within the tolerance). The first direction is straight
    down, ``-n``, exactly.

    Parameters
    ----------
    directions : int
    rolls : int
    roll_range_deg : float
    T_world_object : (4, 4) float
    table_normal : (3,) float
    upward_tolerance_deg : float

    Returns
    -------
    Orientations
        ``directions * rolls``: directions outer, rolls inner.
    """
    n = np.asarray(table_normal, dtype=np.float64)
    n = n / np.linalg.norm(n)
    top = np.sin(np.deg2rad(upward_tolerance_deg))
    i = np.arange(directions, dtype=np.float64)
    # heights along n uniform in [-1, top]: equal area bands of the cap
    h = -1.0 + (top + 1.0) * (i + 0.5) / directions  # (D,)
    # the lattice's first direction, nearest the pole, moved onto it: straight
    # down onto the table is always tried (a lattice of 12 starts 17 degrees
    # off it, where a long-fingered hand's fingertips reach the table first)
    h[0] = -1.0
    phi = i * np.pi * (3.0 - np.sqrt(5.0))  # golden angle
    r = np.sqrt(np.clip(1.0 - h * h, 0.0, None))
    e = np.eye(3)[int(np.argmin(np.abs(n)))]
    u = e - (e @ n) * n
    u = u / np.linalg.norm(u)  # (3,) a unit vector perpendicular to n
    v = np.cross(n, u)
    rc, rs = (r * np.cos(phi))[:, None], (r * np.sin(phi))[:, None]
    d = rc * u + rs * v + h[:, None] * n  # (D, 3) world
    R_wo = np.asarray(T_world_object, dtype=np.float64)[:3, :3]
    # roll 0: x_gwc along the major axis (object z) made perpendicular to the
    # approach, or object x where the approach lies (nearly) along the major axis
    x0, alt = (a[None, :] - (d @ a)[:, None] * d for a in (R_wo[:, 2], R_wo[:, 0]))
    use_alt = np.linalg.norm(x0, axis=1) < 1e-3
    x0[use_alt] = alt[use_alt]
    x0 = x0 / np.linalg.norm(x0, axis=1, keepdims=True)  # (D, 3)
    y0 = np.cross(d, x0)
    psi = orientation_angles(rolls, roll_range_deg)
    c, s = np.cos(psi)[None, :, None], np.sin(psi)[None, :, None]  # (1, M, 1)
    x = c * x0[:, None, :] + s * y0[:, None, :]  # (D, M, 3)
    z = np.broadcast_to(d[:, None, :], x.shape)
    y = np.cross(z, x)
    R_world_gwc = np.stack([x, y, z], axis=-1).reshape(-1, 3, 3)  # (D*M, 3, 3)
    R = np.einsum("ji,njk->nik", R_wo, R_world_gwc)  # R_object_gwc = R_wo^T R_wg
    theta = np.tile(psi, directions)
    none = np.zeros(len(R))
    return Orientations(R, theta, none.astype(bool), none, "approach_sphere")


def depth_offsets(count: int, reach: tuple[float, float]) -> Array:
    """``count`` GWC offsets (m) along the approach that put the box sample at
    evenly spaced depths over ``reach`` (the span of the workspace spheres along
    the approach axis, GWC frame, ends included); ``[0]`` for one."""
    # moving the GWC by -z along the approach brings the object to GWC z
    return -np.linspace(*reach, count) if count > 1 else np.zeros(1)


def orientation_set(
    sampling: Any,
    T_world_object: Array,
    table_normal: Array,
    reach: tuple[float, float] = (0.0, 0.0),
    side: int = 0,
    object_points: Array | None = None,
) -> Orientations:
    """The orientations a spec's ``sampling`` asks for, none from under the table.

    Parameters
    ----------
    sampling
        The spec's ``Sampling``.
    T_world_object : (4, 4) float
    table_normal : (3,) float
        Unit normal of the table, towards the object.
    reach : (float, float)
        Lowest and highest workspace sphere centre along the approach axis, GWC
        frame (m); the span ``sampling.depths`` offsets cover.
    side : int
        The gripper's far side along GWC x (:func:`far_side`): ``major_axis``
        without ``flip`` turns its poses so that side does not face the table
        (with ``angles_from: table``, wherever the major axis leans more than
        ``LEVEL_DEG`` out of the table's plane); 0 leaves them as the paper's.
    object_points : (n, 3) float, optional
        The object, world frame: ``major_axis`` with ``angles_from: table``
        and ``across_narrowest`` turns the angles on an upright object to close
        across its narrowest width (:func:`across_narrowest`); without them, the
        paper's angles.
    """
    mode = getattr(sampling, "mode", "major_axis")
    tol = float(getattr(sampling, "upward_tolerance_deg", 5.0))
    R_wo = np.asarray(T_world_object, dtype=np.float64)[:3, :3]
    n = np.asarray(table_normal, dtype=np.float64)
    if mode == "xyz":
        o = xyz_orientations(tuple(sampling.steps or (4, 4, 4)))
    elif mode == "approach_sphere":
        o = approach_sphere_orientations(
            int(sampling.directions or 24),
            int(sampling.orientations),
            float(sampling.angle_range_deg),
            T_world_object,
            table_normal,
            tol,
        )
    else:
        flip = bool(sampling.flip)
        thetas = orientation_angles(sampling.orientations, sampling.angle_range_deg)
        table = getattr(sampling, "angles_from", "object") == "table"
        level = np.sin(np.deg2rad(LEVEL_DEG))
        narrowest = getattr(sampling, "across_narrowest", False)
        if table:
            normal_object = R_wo.T @ n
            if not _upright(normal_object):
                thetas = thetas + from_above(normal_object, thetas)
            elif narrowest and object_points is not None:
                thetas = thetas + across_narrowest(object_points, R_wo, thetas)
        o = major_axis_orientations(thetas, flip)
        # x_gwc is the major axis: the far side faces the table where it points
        # down out of the table's plane
        if table and not flip and -side * float(n @ R_wo[:, 2]) > level:
            o.R_object_gwc[:, :, :2] *= -1.0  # half a turn about the approach
            o.flipped[:] = True
    up = n @ (R_wo @ o.R_object_gwc[:, :, 2].T)  # (O,) along the normal
    keep = np.flatnonzero(up <= np.sin(np.deg2rad(tol)) + 1e-12)
    # each orientation kept at each depth offset: orientations outer, offsets inner
    offsets = depth_offsets(int(getattr(sampling, "depths", 1)), reach)
    o = o.select(np.repeat(keep, len(offsets)))
    o.depth = o.depth + np.tile(offsets, len(keep))
    return o


def candidate_poses(
    T_world_object: Array,
    samples_object: Array,
    R_object_gwc: Array,
    T_gripper_gwc: Array,
    depth: Array | None = None,
) -> tuple[Array, Array, NDArray[np.int64], NDArray[np.int64]]:
    """All candidate poses, samples outer and orientations inner.

    Parameters
    ----------
    T_world_object : (4, 4) float
    samples_object : (ns, 3) float
        Bounding-box samples in the object frame.
    R_object_gwc : (O, 3, 3) float
    T_gripper_gwc : (4, 4) float
    depth : (O,) float, optional
        Offset of each orientation's GWC along its approach axis (m).

    Returns
    -------
    T_world_gwc : (C, 4, 4) float
        ``C = ns * O``; samples outermost, then orientations.
    T_world_gripper : (C, 4, 4) float
    sample : (C,) int
    orientation : (C,) int
        Index into the orientations.
    """
    # per orientation a rotation and an offset, per sample a shift
    # (``wsgrasp.planning.poses``)
    structure = CandidateStructure(T_world_object, samples_object, R_object_gwc, depth)
    gwc = StructuredPoses.build(structure)
    gripper = StructuredPoses.build(structure, T_gripper_gwc)
    sample, orientation = structure.indices()
    return gwc.every(), gripper.every(), sample, orientation
