"""The fingers' closing sweeps: points on each finger's moving geometry, posed
along its closing path.

A finger's closing path is the straight line in joint space from the pre-grasp
posture to the closed one (what a position-controlled hand does as its targets
ramp); its moving geometry is the collision geometry of every link that the
finger's own joints move (the links below its first joint on the way to its pad,
and the links of a linkage that the same joints drive, given to the finger whose
pad they lie nearest). The planner keeps these sweeps clear of the table up to
where the finger meets the object (``wsgrasp.planning.sweeps``): the pad centre
alone misses the fingertip beyond it and the knuckles of a finger that closes
downwards.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from wsgrasp.geometry import (
    JOINT_FIXED,
    box_grid_points,
    farthest_point_indices,
    transform_points,
)
from wsgrasp.gripper._urdf import Kinematics, shape_mesh
from wsgrasp.gripper._workspace import Workspace
from wsgrasp.spec import GripperDescription

__all__ = ["SWEEP_POINTS", "SWEEP_STEPS", "finger_links", "finger_sweeps"]

Array = NDArray[np.float64]

#: postures along each finger's closing path, pre-grasp and closed included
SWEEP_STEPS = 32
#: points on each finger's moving geometry
SWEEP_POINTS = 160
#: dense surface samples per finger before farthest-point thinning
_DENSE = 4000


def finger_links(
    kin: Kinematics, desc: GripperDescription, masters: Sequence[Sequence[str]]
) -> list[list[str]]:
    """Per finger, the links with geometry that its joints ``masters[f]`` move.

    A link that the joints of several fingers move (a parallel jaw's mimic
    finger, a four-bar linkage's coupler) goes to the finger whose pad chain
    shares the most joints with its own chain, and among those to the one
    whose pad centre lies nearest the link in the pre-grasp posture.
    """
    base = desc.base_link
    poses = kin.link_poses(base, dict(desc.pregrasp))
    pad_chains = [
        [j.name for j in kin.chain(base, f.pad.link)] for f in desc.fingers
    ]  # per finger, the joints from the base to its pad link
    pads = [
        transform_points(poses[f.pad.link], np.asarray(f.pad.center, float)[None])[0]
        for f in desc.fingers
    ]
    out: list[list[str]] = [[] for _ in desc.fingers]
    for link in kin.subtree(base)[1:]:
        if not kin.shapes.get(link):
            continue
        chain = kin.chain(base, link)
        movers = {kin.master(j.name) for j in chain if j.kind != JOINT_FIXED}
        owners = [f for f, m in enumerate(masters) if movers & set(m)]
        if not owners:
            continue
        names = [j.name for j in chain]

        def shared(f: int, names: list[str] = names) -> int:
            n = 0
            for a, b in zip(names, pad_chains[f], strict=False):
                if a != b:
                    break
                n += 1
            return n

        centre = poses[link][:3, 3]
        best = min(
            owners, key=lambda f: (-shared(f), float(np.linalg.norm(pads[f] - centre)))
        )
        out[best].append(link)
    return out


def finger_sweeps(
    kin: Kinematics,
    desc: GripperDescription,
    workspaces: Sequence[Workspace],
    *,
    steps: int = SWEEP_STEPS,
    count: int = SWEEP_POINTS,
) -> Array:
    """Points on each finger's moving geometry along its closing path.

    Parameters
    ----------
    kin, desc
        The gripper's kinematics and description.
    workspaces
        Per finger, its sampled workspace (the joints it samples and their
        limits).

    Returns
    -------
    (nf, steps, count, 3) float
        Gripper frame; step 0 is the pre-grasp posture (finger joints clipped to
        their limits, a joint missing from it at its lower limit), the last the
        closed posture (a joint missing from it stays). The same ``count``
        material points at every step: spread evenly (farthest-point) over the
        finger's links' collision geometry with their convex hulls' corners (a
        fingertip's farthest point), and the pad centre; a rigid jaw's (no
        joints), its pad box, still at every step.
    """
    base = desc.base_link
    masters = [ws.joints for ws in workspaces]
    links = finger_links(kin, desc, masters)
    t = np.linspace(0.0, 1.0, steps)  # (K,)
    values: dict[str, object] = dict(desc.pregrasp)
    for ws in workspaces:
        lim = np.stack([ws.lower, ws.upper], axis=1)  # (d, 2)
        for j, (lo, hi) in zip(ws.joints, lim, strict=True):
            pre = float(np.clip(desc.pregrasp.get(j, lo), lo, hi))
            closed = float(np.clip(desc.closed.get(j, pre), lo, hi))
            values[j] = pre + t * (closed - pre)  # (K,)
    import trimesh

    rng = np.random.default_rng(0)
    out = np.zeros((len(workspaces), steps, count, 3))
    for f, finger in enumerate(desc.fingers):
        # (link, points in its frame) of every part of this finger's geometry
        parts: list[tuple[str, Array]] = [
            (finger.pad.link, np.asarray(finger.pad.center, dtype=np.float64)[None])
        ]
        if not finger.joints:
            # a rigid jaw moves nothing: it reaches what lies in its pad box,
            # where the other fingers push the object onto it
            box = box_grid_points(finger.pad.center, finger.pad.size, 3)
            parts.append((finger.pad.link, box))
        meshes = [
            (link, shape_mesh(shape)) for link in links[f] for shape in kin.shapes[link]
        ]
        area = sum(float(m.area) for _, m in meshes)
        for link, mesh in meshes:
            n = max(1, int(round(_DENSE * float(mesh.area) / area))) if area else 1
            dense, _ = trimesh.sample.sample_surface(mesh, n, seed=rng)
            parts.append((link, np.asarray(dense, dtype=np.float64)))
            parts.append((link, np.asarray(mesh.convex_hull.vertices, np.float64)))
        posed = []
        for link, p in parts:
            T = kin.chain_poses(base, link, values)  # (K, 4, 4)
            posed.append(transform_points(T, p))  # (K, n, 3)
        sweep = np.concatenate(posed, axis=1)  # (K, N, 3)
        start = sweep[0]  # (N, 3) pre-grasp posture
        # the pad centre (index 0) first, then the rest spread from it; a finger
        # with fewer points repeats them
        picked = farthest_point_indices(start, min(count, len(start)), start=0)
        out[f] = sweep[:, np.resize(picked, count)]
    return out
