"""Where the fingers go when they close, and the grasp depth that keeps them off
the table.

A hand whose fingers curl (the Allegro hand's sweep 9.6 cm along the approach
axis as they close) drives its fingertips into the table when it grasps a low
object from above at the depth the search chose: in the physics trials nearly
every Allegro grasp that slipped had fingertips pressed on the table, stopped
there before they reached round the object. This module follows each finger's
pad centre along its closing path, the straight line in joint space from the
pre-grasp posture to the closed one (what a position-controlled hand closing to
``closed`` does), and backs the chosen grasp off along its approach axis until
no pad centre's path passes below the table surface: the fingertips then brush
the table instead of digging into it.

Measured (``wsgrasp eval``, random objects 000-099, 1 trial, seed 0): Allegro
hand, approach-sphere sampling 46 % held without the back-off, 70 % with it (65 %
with a fixed 1.5 cm, 4 % with a fixed 4 cm: the depth matters to the centimetre);
paper sampling 36 % -> 53 %. For a parallel jaw or the Barrett hand, whose pads
do not sink while closing, the table test already keeps them up and nothing
changes.

Only models that keep their fingers' joint configurations (format 2) have the
paths.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from wsgrasp.gripper.model import GripperModel

__all__ = ["closing_paths", "table_back_off"]

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
        for f, joints in enumerate(g.finger_joints):
            lim = np.asarray(g.finger_limits[f], dtype=np.float64)  # (d, 2)
            pre = np.array(
                [g.pregrasp.get(j, lo) for j, lo in zip(joints, lim[:, 0], strict=True)]
            )
            closed = np.array(
                [g.closed.get(j, p) for j, p in zip(joints, pre, strict=True)]
            )
            pre = np.clip(pre, lim[:, 0], lim[:, 1])
            closed = np.clip(closed, lim[:, 0], lim[:, 1])
            out.append(pad_positions(g, f, pre + t * (closed - pre)))  # (K, 3)
        paths = np.stack(out)
    g.__dict__["_closing_paths"] = paths
    return paths


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
