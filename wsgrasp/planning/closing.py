"""Where the fingers go when they close.

Each finger closes along the straight line in joint space from the pre-grasp
posture to the closed one (what a position-controlled hand closing to ``closed``
does): :func:`closing_paths` follows its pad centre along that line, and the
gripper model keeps points on the collision geometry of every link the finger's
joints move at postures along it (``GripperModel.finger_sweep``;
:func:`finger_sweep`). :mod:`wsgrasp.planning.sweeps` keeps those sweeps off the
table for every candidate at once.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from wsgrasp.gripper.model import GripperModel

__all__ = [
    "BACK_OFF_STEPS",
    "closing_centre",
    "closing_paths",
    "finger_sweep",
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
    from wsgrasp.planning.targets import pad_positions

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
    if g.has_sweeps:
        return g.finger_sweep
    return closing_paths(g)[:, :, None, :]
