"""Batched forward kinematics of serial chains (URDF-style joints).

A chain is a list of joints from a root frame to a tip frame. Joint ``j`` has a fixed
``origin`` (its frame in its parent link's frame, ``(4, 4)``), a unit ``axis`` in its
own frame and a kind: fixed, revolute (also continuous) or prismatic. The tip pose is

``T_root_tip(q) = O_0 @ M_0(q_0) @ O_1 @ M_1(q_1) @ ... @ O_{J-1} @ M_{J-1}(q_{J-1})``

with ``M_j`` a rotation about (revolute) or a translation along (prismatic) the axis.
Everything is vectorised over a batch of configurations; the only Python loop is over
the joints of the chain, which are few.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]

JOINT_FIXED = 0
JOINT_REVOLUTE = 1
JOINT_PRISMATIC = 2


def axis_angle_matrices(axis: ArrayLike, angles: ArrayLike) -> Array:
    """Rotations about one unit ``axis`` by a batch of ``angles`` (Rodrigues).

    Parameters
    ----------
    axis : (3,) float
        Unit rotation axis.
    angles : (...,) float
        Radians.

    Returns
    -------
    (..., 3, 3) float
    """
    k = np.asarray(axis, dtype=np.float64)
    a = np.asarray(angles, dtype=np.float64)
    K = np.array(
        [[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]]
    )  # (3, 3) cross-product matrix
    s = np.sin(a)[..., None, None]
    c = np.cos(a)[..., None, None]
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def joint_motion_transforms(kind: int, axis: ArrayLike, q: ArrayLike) -> Array:
    """The motion part ``M(q)`` of one joint for a batch of positions.

    Parameters
    ----------
    kind
        ``JOINT_FIXED``, ``JOINT_REVOLUTE`` or ``JOINT_PRISMATIC``.
    axis : (3,) float
        Unit axis in the joint frame.
    q : (...,) float
        Joint positions (rad or m).

    Returns
    -------
    (..., 4, 4) float
    """
    q = np.asarray(q, dtype=np.float64)
    M = np.zeros((*q.shape, 4, 4))
    M[..., 3, 3] = 1.0
    if kind == JOINT_REVOLUTE:
        M[..., :3, :3] = axis_angle_matrices(axis, q)
    else:
        M[..., :3, :3] = np.eye(3)
        if kind == JOINT_PRISMATIC:
            M[..., :3, 3] = q[..., None] * np.asarray(axis, dtype=np.float64)
        elif kind != JOINT_FIXED:
            raise ValueError(f"unknown joint kind {kind}")
    return M


def chain_forward_kinematics(
    origins: ArrayLike, axes: ArrayLike, kinds: ArrayLike, q: ArrayLike
) -> Array:
    """Tip poses of a serial chain for a batch of configurations.

    Parameters
    ----------
    origins : (J, 4, 4) float
        Fixed transform of each joint frame in its parent link frame.
    axes : (J, 3) float
        Unit joint axes in the joint frames (ignored for fixed joints).
    kinds : (J,) int
        ``JOINT_FIXED``, ``JOINT_REVOLUTE`` or ``JOINT_PRISMATIC`` per joint.
    q : (..., J) float
        Position of every joint of the chain (fixed joints: any value).

    Returns
    -------
    (..., 4, 4) float
        ``T_root_tip`` per configuration.
    """
    Os = np.asarray(origins, dtype=np.float64).reshape(-1, 4, 4)
    A = np.asarray(axes, dtype=np.float64).reshape(-1, 3)
    k = np.asarray(kinds).reshape(-1)
    q = np.asarray(q, dtype=np.float64)
    if q.shape[-1] != Os.shape[0]:
        raise ValueError(
            f"q: expected last dimension {Os.shape[0]} (joints), got {q.shape}"
        )
    T = np.broadcast_to(np.eye(4), (*q.shape[:-1], 4, 4)).copy()
    for j in range(Os.shape[0]):
        T = T @ Os[j]
        if k[j] != JOINT_FIXED:
            T = T @ joint_motion_transforms(int(k[j]), A[j], q[..., j])
    return T


def grid_configurations(lower: ArrayLike, upper: ArrayLike, samples: int) -> Array:
    """All configurations of a regular grid over a box of joint ranges.

    Parameters
    ----------
    lower, upper : (d,) float
        Joint limits.
    samples
        Grid points per joint (limits included).

    Returns
    -------
    (samples ** d, d) float
        Row-major: the last joint varies fastest, so a reshape to
        ``(samples,) * d + (d,)`` gives the grid. No joints (``d = 0``): the
        one empty configuration, ``(1, 0)``.
    """
    lo = np.asarray(lower, dtype=np.float64).reshape(-1)
    hi = np.asarray(upper, dtype=np.float64).reshape(-1)
    if len(lo) == 0:
        return np.zeros((1, 0))
    axes = [np.linspace(a, b, samples) for a, b in zip(lo, hi, strict=True)]
    mesh = np.meshgrid(*axes, indexing="ij")  # d arrays of shape (samples,) * d
    return np.stack([m.reshape(-1) for m in mesh], axis=-1)  # (samples**d, d)
