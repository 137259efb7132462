"""Homogeneous transforms, batch-first.

Conventions: ``T_a_b`` maps coordinates in frame ``b`` into frame ``a``, so
``p_a = T_a_b @ p_b``; arrays are float64, poses ``(..., 4, 4)``, points ``(n, 3)``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]


def check_points(points: ArrayLike, name: str = "points") -> Array:
    """Return ``points`` as a float64 ``(n, 3)`` array or raise ``ValueError``.

    Parameters
    ----------
    points : (n, 3) float
    name
        Used in the error message.
    """
    arr = np.asarray(points, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name}: expected shape (n, 3), got {arr.shape}")
    return arr


def check_transforms(T: ArrayLike, name: str = "T") -> Array:
    """Return ``T`` as a float64 ``(..., 4, 4)`` array of rigid transforms or raise.

    Checks the shape, the bottom row and that the rotation part is orthonormal with
    determinant +1 (tolerance 1e-6).
    """
    arr = np.asarray(T, dtype=np.float64)
    if arr.ndim < 2 or arr.shape[-2:] != (4, 4):
        raise ValueError(f"{name}: expected shape (..., 4, 4), got {arr.shape}")
    R = arr[..., :3, :3]
    eye = np.broadcast_to(np.eye(3), R.shape)
    if not np.allclose(R @ np.swapaxes(R, -1, -2), eye, atol=1e-6):
        raise ValueError(f"{name}: rotation part is not orthonormal")
    if not np.allclose(np.linalg.det(R), 1.0, atol=1e-6):
        raise ValueError(f"{name}: rotation part has determinant != +1")
    if not np.allclose(arr[..., 3, :], [0.0, 0.0, 0.0, 1.0], atol=1e-9):
        raise ValueError(f"{name}: bottom row must be [0, 0, 0, 1]")
    return arr


def transform_from(R: ArrayLike | None = None, p: ArrayLike | None = None) -> Array:
    """Build transforms ``(..., 4, 4)`` from rotations ``(..., 3, 3)`` and
    translations ``(..., 3)``; either may be omitted (identity / zero)."""
    R_arr = np.eye(3) if R is None else np.asarray(R, dtype=np.float64)
    p_arr = np.zeros(3) if p is None else np.asarray(p, dtype=np.float64)
    batch = np.broadcast_shapes(R_arr.shape[:-2], p_arr.shape[:-1])
    T = np.zeros((*batch, 4, 4))
    T[..., :3, :3] = R_arr
    T[..., :3, 3] = p_arr
    T[..., 3, 3] = 1.0
    return T


def invert_transforms(T: ArrayLike) -> Array:
    """Invert rigid transforms ``(..., 4, 4)`` using the transpose of the rotation."""
    T = np.asarray(T, dtype=np.float64)
    R_inv = np.swapaxes(T[..., :3, :3], -1, -2)
    out = np.zeros_like(T)
    out[..., :3, :3] = R_inv
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", R_inv, T[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def transform_points(T: ArrayLike, points: ArrayLike) -> Array:
    """Apply transforms to points.

    Parameters
    ----------
    T : (..., 4, 4) float
    points : (n, 3) float or (..., n, 3) float broadcastable with the batch of ``T``

    Returns
    -------
    (..., n, 3) float
    """
    T = np.asarray(T, dtype=np.float64)
    points = np.asarray(points, dtype=np.float64)
    R = T[..., :3, :3]
    t = T[..., None, :3, 3]
    # points @ R^T: (..., n, 3) @ (..., 3, 3) -> (..., n, 3)
    return points @ np.swapaxes(R, -1, -2) + t


def _rot(axis: int, angles: ArrayLike) -> Array:
    a = np.asarray(angles, dtype=np.float64)
    c, s = np.cos(a), np.sin(a)
    R = np.zeros((*a.shape, 3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R[..., axis, axis] = 1.0
    R[..., i, i] = c
    R[..., j, j] = c
    R[..., i, j] = -s
    R[..., j, i] = s
    return R


def rot_x(angles: ArrayLike) -> Array:
    """Rotations ``(..., 3, 3)`` about x by ``angles`` (radians)."""
    return _rot(0, angles)


def rot_y(angles: ArrayLike) -> Array:
    """Rotations ``(..., 3, 3)`` about y by ``angles`` (radians)."""
    return _rot(1, angles)


def rot_z(angles: ArrayLike) -> Array:
    """Rotations ``(..., 3, 3)`` about z by ``angles`` (radians)."""
    return _rot(2, angles)


def plane_basis(normal: ArrayLike) -> Array:
    """Two unit vectors ``(3, 2)`` spanning the plane of unit ``normal``: the
    first is ``normal`` crossed with the world axis least aligned with it, the
    second ``normal`` crossed with the first. ``points @ plane_basis(n)`` gives
    points' in-plane coordinates ``(k, 2)``."""
    n = np.asarray(normal, dtype=np.float64)
    helper = np.eye(3)[int(np.argmin(np.abs(n)))]
    u = np.cross(n, helper)
    u /= np.linalg.norm(u)
    return np.stack([u, np.cross(n, u)], axis=1)


def rotation_angle_deg(Ra: ArrayLike, Rb: ArrayLike) -> float:
    """The angle (degrees) of the rotation between rotation matrices ``Ra`` and
    ``Rb`` ``(3, 3)``: ``arccos((trace(Ra^T Rb) - 1) / 2)``, the cosine clipped
    to [-1, 1] against rounding."""
    R = np.asarray(Ra, dtype=np.float64).T @ np.asarray(Rb, dtype=np.float64)
    c = (np.trace(R) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))
