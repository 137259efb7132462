"""Candidate gripper poses: bounding-box samples × orientations about the major axis.

The gripper-workspace-centroid (GWC) frame of a candidate has its x axis along the
object's major axis (object z), so the gripper stands perpendicular to it, and its
approach axis (GWC z) points towards the axis from the direction ``theta`` in the
object's xy plane (Algorithm 1, lines 2–6)::

    x_gwc = z_obj
    z_gwc = -(cos θ x_obj + sin θ y_obj)
    y_gwc = z_gwc × x_gwc

With ``flip``, each pose is also tried turned half a turn about its approach axis
(``x_gwc = -z_obj``): the same grasp for a gripper that is symmetric about its
approach axis, a different one for a hand with a thumb on one side.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from wsgrasp.geometry import invert_transforms

__all__ = ["orientation_angles", "candidate_poses"]

Array = NDArray[np.float64]


def orientation_angles(count: int, range_deg: float) -> Array:
    """``count`` angles (rad) evenly spread over ``range_deg`` degrees.

    A full turn (360) does not repeat its end point; a partial range is sampled
    end point excluded too, so ``(4, 360)`` gives 0, 90, 180, 270 degrees and
    ``(4, 180)`` gives 0, 45, 90, 135.
    """
    return np.deg2rad(range_deg) * np.arange(count, dtype=np.float64) / count


def candidate_poses(
    T_world_object: Array,
    samples_object: Array,
    thetas: Array,
    T_gripper_gwc: Array,
    flip: bool = False,
) -> tuple[Array, Array, NDArray[np.int64], Array, NDArray[np.bool_]]:
    """All candidate poses, samples outer and orientations inner.

    Parameters
    ----------
    T_world_object : (4, 4) float
    samples_object : (ns, 3) float
        Bounding-box samples in the object frame.
    thetas : (nos,) float
    T_gripper_gwc : (4, 4) float
    flip : bool
        Also try every pose turned half a turn about the approach axis.

    Returns
    -------
    T_world_gwc : (C, 4, 4) float
        ``C = ns * nos * (2 if flip else 1)``; samples outermost, then
        orientations, then (with ``flip``) unflipped before flipped.
    T_world_gripper : (C, 4, 4) float
    sample : (C,) int
    theta : (C,) float
    flipped : (C,) bool
    """
    ns = len(samples_object)
    nf = 2 if flip else 1
    thetas = np.repeat(np.asarray(thetas, dtype=np.float64), nf)
    flipped = np.tile(np.arange(nf) == 1, len(thetas) // nf)
    nos = len(thetas)  # orientations × flips
    c, s = np.cos(thetas), np.sin(thetas)
    R_object_gwc = np.zeros((nos, 3, 3))
    R_object_gwc[:, 2, 0] = 1.0  # x_gwc = z_obj
    R_object_gwc[:, 0, 2] = -c  # z_gwc = -(cos θ, sin θ, 0)
    R_object_gwc[:, 1, 2] = -s
    R_object_gwc[:, 0, 1] = -s  # y_gwc = z_gwc × x_gwc = (-sin θ, cos θ, 0)
    R_object_gwc[:, 1, 1] = c
    # half a turn about z_gwc: x_gwc and y_gwc change sign
    R_object_gwc[flipped, :, :2] *= -1.0
    T_object_gwc = np.zeros((ns, nos, 4, 4))
    T_object_gwc[:, :, :3, :3] = R_object_gwc[None]
    T_object_gwc[:, :, :3, 3] = samples_object[:, None, :]
    T_object_gwc[:, :, 3, 3] = 1.0
    T_object_gwc_flat = T_object_gwc.reshape(ns * nos, 4, 4)  # (C, 4, 4)
    T_world_gwc = T_world_object @ T_object_gwc_flat
    T_world_gripper = T_world_gwc @ invert_transforms(T_gripper_gwc)
    sample = np.repeat(np.arange(ns, dtype=np.int64), nos)
    theta = np.tile(thetas, ns)
    return T_world_gwc, T_world_gripper, sample, theta, np.tile(flipped, ns)
