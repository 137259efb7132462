"""Where the fingers go when they close.

Each finger closes along the straight line in joint space from the pre-grasp
posture to the closed one (as a position-controlled hand closing to ``closed``
does): :func:`closing_paths` follows its pad centre along that line,
:func:`finger_sweep` the links its joints move, and :mod:`wsgrasp.planning.sweeps`
keeps those sweeps off the table for every candidate at once.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import RegularGridInterpolator

from wsgrasp.gripper.model import GripperModel

__all__ = [
    "BACK_OFF_STEPS",
    "closing_centre",
    "closing_paths",
    "finger_sweep",
    "pad_positions",
]

Array = NDArray[np.float64]

#: pad positions along each finger's closing path
_PATH_STEPS = 32
#: back-off steps tried (m): 0, 5 mm, ..., 3 cm
BACK_OFF_STEPS = np.arange(7) * 0.005


def closing_paths(g: GripperModel) -> Array:
    """Each finger's pad centre along its closing path.

    Returns
    -------
    (nf, K, 3) float
        Gripper frame, from the pre-grasp posture (``K = 32`` steps, joints
        clipped to their limits) to the closed one; ``(0, K, 3)`` for a model
        without finger configurations. Kept on the model (built once).
    """
    cached = g.__dict__.get("_closing_paths")
    if cached is not None:
        return cached  # type: ignore[no-any-return]
    paths = np.zeros((0, _PATH_STEPS, 3))
    if g.has_configurations:
        t = np.linspace(0.0, 1.0, _PATH_STEPS)[:, None]  # (K, 1)
        out = []
        for f in range(g.num_fingers):
            pre, closed = _pre_closed(g, f)
            out.append(pad_positions(g, f, pre + t * (closed - pre)))  # (K, 3)
        paths = np.stack(out)
    g.__dict__["_closing_paths"] = paths
    return paths


def _pre_closed(g: GripperModel, f: int) -> tuple[Array, Array]:
    """Finger ``f``'s joints at the pre-grasp and closed postures, clipped to
    their limits: ``(d,)`` each, the closing path running straight between."""
    joints = g.finger_joints[f]
    lim = np.asarray(g.finger_limits[f], dtype=np.float64)  # (d, 2)
    pre = np.array(
        [g.pregrasp.get(j, lo) for j, lo in zip(joints, lim[:, 0], strict=True)]
    )
    closed = np.array([g.closed.get(j, p) for j, p in zip(joints, pre, strict=True)])
    return np.clip(pre, lim[:, 0], lim[:, 1]), np.clip(closed, lim[:, 0], lim[:, 1])


def closing_centre(g: GripperModel) -> Array:
    """Where the fingers close to: the centroid of the pad centres at the end of
    their closing paths (the ``closed`` posture), gripper frame, ``(3,)``; the
    tool frame's origin for a model without finger configurations."""
    paths = closing_paths(g)
    if len(paths) == 0:
        return np.asarray(g.T_gripper_tcp[:3, 3], dtype=np.float64)
    return np.asarray(paths[:, -1].mean(axis=0), dtype=np.float64)


def finger_sweep(g: GripperModel) -> Array:
    """The fingers' closing sweeps: ``GripperModel.finger_sweep``, or for a model
    without them (format 2) the pad centres' closing paths.

    Returns
    -------
    (nf, K, P, 3) float
        Gripper frame; ``(nf, K, 1, 3)`` from pad centres; ``(0, K, 1, 3)`` for a
        model without finger configurations either.
    """
    return g.finger_sweep if g.has_sweeps else closing_paths(g)[:, :, None, :]


def pad_positions(g: GripperModel, finger: int, q: Array) -> Array:
    """The pad centre of ``finger`` at joint values ``q`` ``(n, d)``, gripper frame,
    ``(n, 3)``: multilinear between the model's joint-grid samples."""
    return _interpolator(g, finger)(np.asarray(q, dtype=np.float64))


def _interpolator(g: GripperModel, finger: int) -> Callable[[Array], Array]:
    """Multilinear interpolation of one finger's pad centre over its joint grid,
    the joints clipped to their limits; one per model and finger, kept on the
    model (built once)."""
    cache: dict[int, Callable[[Array], Array]] = g.__dict__.setdefault(
        "_pad_interp", {}
    )
    if finger in cache:
        return cache[finger]
    lim = np.asarray(g.finger_limits[finger], dtype=np.float64)  # (d, 2)
    n = g.joint_samples
    start, stop = g.config_offsets[finger], g.config_offsets[finger + 1]
    grid = g.config_pad[start:stop].reshape((n,) * len(lim) + (3,))  # (n, ..., n, 3)
    # a joint whose limits coincide has one distinct grid value: drop its axis
    moving = lim[:, 1] > lim[:, 0]
    axes = [np.linspace(lo, hi, n) for lo, hi in lim[moving]]
    index = tuple(slice(None) if m else 0 for m in moving)
    fn = RegularGridInterpolator(axes, grid[index], method="linear") if axes else None

    def pads(q: Array) -> Array:
        q = np.clip(q, lim[:, 0], lim[:, 1])  # (n, d)
        if fn is None:  # no joint moves: one pad position
            return np.broadcast_to(grid.reshape(-1, 3)[0], (len(q), 3)).copy()
        return np.asarray(fn(q[:, moving]), dtype=np.float64)

    cache[finger] = pads
    return pads
