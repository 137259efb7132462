"""Where the fingers go when they close.

Each finger closes along the straight line in joint space from the pre-grasp
posture to the closed one (what a position-controlled hand closing to ``closed``
does): :func:`closing_paths` follows its pad centre along that line, and the
gripper model keeps points on the collision geometry of every link the finger's
joints move at postures along it (``GripperModel.finger_sweep``;
:func:`finger_sweep`). :mod:`wsgrasp.planning.sweeps` keeps those sweeps off the
table for every candidate at once.

:func:`table_back_off` is the older rule for one pose: the pad centres' whole
paths kept above the table, what the search applies to its best before the
finishing step judges every feasible candidate by the sweeps.
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
    "table_back_off",
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


def table_back_off(
    g: GripperModel, T_world_gripper: Array, T_world_table: Array
) -> tuple[float, Array] | None:
    """The least back-off along the approach axis that keeps every finger's
    closing path above the table.

    Parameters
    ----------
    g : GripperModel
    T_world_gripper : (4, 4) float
        The chosen grasp.
    T_world_table : (4, 4) float
        Table frame: origin on the surface, z its normal towards the object.

    Returns
    -------
    (distance, T_world_gripper) or None
        The back-off (m, > 0, at most 3 cm in 5 mm steps) and the pose moved back
        by it; None when the paths already stay above the table, or stay below
        it even 3 cm back, or the model has no paths.
    """
    paths = closing_paths(g)
    if len(paths) == 0:
        return None
    T = np.asarray(T_world_gripper, dtype=np.float64)
    a = T[:3, :3] @ g.approach_axis  # (3,) world
    n = T_world_table[:3, 2]
    # pad heights above the table at the grasp, then moved back along -a
    p = paths.reshape(-1, 3) @ T[:3, :3].T + T[:3, 3]  # (nf K, 3) world
    low = float(((p - T_world_table[:3, 3]) @ n).min())
    heights = low - BACK_OFF_STEPS * float(a @ n)  # (k,)
    ok = np.flatnonzero(heights >= 0.0)
    if len(ok) == 0 or ok[0] == 0:
        return None
    d = float(BACK_OFF_STEPS[ok[0]])
    T_back = T.copy()
    T_back[:3, 3] -= d * a
    return d, T_back


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
