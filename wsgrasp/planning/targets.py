"""What the hand does for one grasp: joint targets from the holding spheres.

Each workspace sphere of the gripper model remembers the finger configurations
whose pad samples fell inside it (``GripperModel.sphere_config_index``). Each
finger's contact posture is the configuration, among those of the spheres holding
object points, whose pad centre lies nearest the points it holds; its grasp posture
drives it on towards ``closed`` until the pad has travelled ``squeeze`` metres
through the contact (or a joint limit stops it): a position-controlled finger whose
target lies inside the object presses on it. No inverse kinematics is solved: the
pad positions over each finger's joint grid, kept in the model, are interpolated.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from wsgrasp.geometry import invert_transforms, transform_points
from wsgrasp.gripper.model import GripperModel
from wsgrasp.planning.closing import _interpolator, pad_positions
from wsgrasp.planning.result import Contact
from wsgrasp.planning.sweeps import prepare_sweeps

__all__ = [
    "FingerTarget",
    "GraspTargets",
    "config_tree",
    "grasp_targets",
    "prepare",
    "pad_positions",
    "pregrasp_pose",
]

Array = NDArray[np.float64]

#: points along the joint-space ray towards ``closed`` searched for the squeeze
_SQUEEZE_STEPS = 129
#: configurations nearest each held point tried first for the contact posture
_NEAR = 16


@dataclass
class FingerTarget:
    """One finger's part of a grasp.

    Attributes
    ----------
    finger : str
    contact : dict of str to float
        The finger's joints at the contact posture; empty for a finger that
        holds no object point (one outside the gripper's ``contact_fingers``).
    grasp : dict of str to float
        The same joints driven ``squeeze`` through the contact (a finger
        without a contact: its ``closed`` posture).
    pad_world : (3,) float
        The pad centre at the contact posture (without one: at the grasp
        posture), world frame.
    gap : float or None
        Distance (m) from that pad centre to the nearest point the finger holds;
        None where it holds none.
    squeeze : float
        How far (m) the pad travels from the contact to the grasp posture.
    """

    finger: str
    contact: dict[str, float]
    grasp: dict[str, float]
    pad_world: Array
    gap: float | None
    squeeze: float


@dataclass
class GraspTargets:
    """The pre-grasp pose and both postures of a grasp.

    Attributes
    ----------
    T_world_pregrasp : (4, 4) float
        The grasp pose backed off along the approach axis.
    joints_pregrasp, joints_grasp : dict of str to float
        Every actuated joint: the posture the gripper approaches in, and the one
        it closes to.
    fingers : list of FingerTarget
    """

    T_world_pregrasp: Array
    joints_pregrasp: dict[str, float]
    joints_grasp: dict[str, float]
    fingers: list[FingerTarget]


def pregrasp_pose(
    gripper: GripperModel, T_world_gripper: Array, distance: float
) -> Array:
    """``T_world_gripper`` ``(4, 4)`` backed off ``distance`` (m) along the
    gripper's approach axis: the pre-grasp pose."""
    T = np.array(T_world_gripper, dtype=np.float64)
    T[:3, 3] -= distance * (T[:3, :3] @ gripper.approach_axis)
    return T


def grasp_targets(
    gripper: GripperModel,
    T_world_gripper: Array,
    contacts: list[Contact],
    *,
    approach_distance: float,
    squeeze: float,
    close_to: str = "contacts",
) -> GraspTargets:
    """Joint targets and pre-grasp pose for a chosen grasp.

    Parameters
    ----------
    gripper : GripperModel
    T_world_gripper : (4, 4) float
    contacts : list of Contact
        Per finger, the object points its spheres hold and those spheres.
    approach_distance : float
        How far (m) the pre-grasp pose stands back along the approach axis.
    squeeze : float
        How far (m) each pad is driven through its contact.
    close_to : {"contacts", "closed"}
        ``joints_grasp`` from the contacts, or the gripper's ``closed`` posture
        (the fingers' contact postures are still reported, each finger's grasp
        posture is its part of ``closed`` and its squeeze the pad's travel from
        the contact to there). A model that keeps no finger configurations
        (format 1) closes to ``closed`` either way.
    """
    g = gripper
    T = np.asarray(T_world_gripper, dtype=np.float64)
    pre = _within_limits(g, {j: g.pregrasp.get(j, 0.0) for j in g.actuated_joints})
    closed: dict[str, float] | None = None
    if close_to == "closed" or not g.has_configurations:
        closed = _within_limits(g, {j: g.closed.get(j, v) for j, v in pre.items()})
    grasp = dict(pre) if closed is None else closed
    fingers: list[FingerTarget] = []
    if g.has_configurations:
        T_gripper_world = invert_transforms(T)
        held_all = [transform_points(T_gripper_world, c.points) for c in contacts]
        # the middle of the grasp: the mean of the fingers' contact centroids
        centre = np.mean([h.mean(axis=0) for h in held_all if len(h)], axis=0)
        for f, (held, contact) in enumerate(zip(held_all, contacts, strict=True)):
            ft = _finger_target(
                g, f, held, contact.spheres, squeeze, pre, centre, closed
            )
            ft.pad_world = transform_points(T, ft.pad_world[None])[0]
            fingers.append(ft)
        if closed is None:
            # a joint several fingers share closes as far as any of them asks: the
            # farthest from its pre-grasp value towards its closed one
            for j in dict.fromkeys(j for ft in fingers for j in ft.grasp):
                asked = [ft.grasp[j] for ft in fingers if j in ft.grasp]
                p = float(g.pregrasp.get(j, 0.0))
                way = np.sign(float(g.closed.get(j, p)) - p)
                grasp[j] = max(asked, key=lambda v: (v - p) * way)
    return GraspTargets(pregrasp_pose(g, T, approach_distance), pre, grasp, fingers)


def _within_limits(g: GripperModel, posture: dict[str, float]) -> dict[str, float]:
    """``posture`` with each finger joint clipped to its limits."""
    limits = {
        j: (float(lo), float(hi))
        for joints, lim in zip(g.finger_joints, g.finger_limits, strict=True)
        for j, (lo, hi) in zip(joints, np.asarray(lim), strict=True)
    }
    return {
        j: float(np.clip(v, *limits[j])) if j in limits else float(v)
        for j, v in posture.items()
    }


def _finger_target(
    g: GripperModel,
    f: int,
    held: Array,
    spheres: NDArray[np.int64],
    squeeze: float,
    pre: dict[str, float],
    centre: Array,
    posture: dict[str, float] | None = None,
) -> FingerTarget:
    """The contact and grasp postures of finger ``f`` holding ``held`` (k, 3),
    gripper frame, in a grasp whose contacts centre on ``centre`` (3,); with
    a ``posture`` to close to (every actuated joint), the grasp posture is the
    finger's part of it.

    The contact posture is the configuration whose pad centre lies nearest the
    held points among those whose pad stays on the outer side of them (not
    nearer the grasp's middle than they are), so that the finger presses on the
    surface from outside rather than sitting inside the object; where no
    configuration does, the nearest of all.
    """
    joints = g.finger_joints[f]
    if len(held) == 0:  # no contact: it closes with the others to its ``closed``
        grasp = _within_limits(g, {j: g.closed.get(j, pre.get(j, 0.0)) for j in joints})
        pad = pad_positions(g, f, np.array([[grasp[j] for j in joints]]))[0]
        return FingerTarget(g.finger_names[f], {}, grasp, pad, None, 0.0)
    start = int(g.config_offsets[f])
    q_grid = g.finger_configurations(f)  # (K, d)
    is_allowed = _allowed_mask(g, f, spheres)  # (K,)
    if not is_allowed.any():  # none of the spheres lists one: every configuration
        is_allowed[:] = True
    allowed = np.flatnonzero(is_allowed)  # (c,) into the grid
    # first the few configurations nearest each held point (the finger's pad tree,
    # built once per model), then, if none of them qualifies, all allowed ones
    m = min(_NEAR, len(q_grid))
    d_near, near = config_tree(g, f).query(held, k=m)
    near = np.asarray(near).reshape(len(held), m)  # (k, m)
    d_near = np.asarray(d_near).reshape(len(held), m)  # (k, m)
    # (masks: np.intersect1d and np.isin took 5.6 ms of the Allegro hand's plan)
    is_near = np.zeros(len(q_grid), dtype=bool)
    is_near[near.reshape(-1)] = True
    first = np.flatnonzero(is_near & is_allowed)  # (c,)
    # outside: a pad not nearer the grasp's middle than the held points' centroid
    c_f = held.mean(axis=0)
    norm = float(np.linalg.norm(c_f - centre))
    out = (c_f - centre) / norm if norm > 1e-9 else np.zeros(3)  # 0: all outside
    local, best, gap = allowed, 0, np.inf
    for candidates in (first, allowed):
        outside = (g.config_pad[start + candidates] - c_f) @ out >= 0.0  # (c,)
        if not outside.any():
            continue
        limit = np.inf  # pads farther are not searched (their distance: inf)
        if candidates is first:
            # a held point's distance to a qualifying configuration among its
            # nearest bounds the least pad distance from above (with a relative
            # margin, so that a pad at exactly that distance stays found)
            qualifies = np.zeros(len(q_grid), dtype=bool)
            qualifies[candidates[outside]] = True
            limit = float(d_near[qualifies[near]].min()) * (1.0 + 1e-9) + 1e-12
        kept = np.flatnonzero(outside)  # (o,)
        pads = g.config_pad[start + candidates[kept]]
        nearest, _ = cKDTree(held).query(pads, distance_upper_bound=limit)  # (o,)
        k = int(np.argmin(nearest))
        local, best, gap = candidates, int(kept[k]), float(nearest[k])
        break
    pad = g.config_pad[start + local[best]].copy()  # (3,)
    q_contact = q_grid[local[best]]  # (d,)
    contact = {j: float(v) for j, v in zip(joints, q_contact, strict=True)}
    if posture is not None:
        end = tuple(posture[j] for j in joints)
        moved = float(np.linalg.norm(_pad_at(g, f, end) - pad))
        grasp = {j: posture[j] for j in joints}
        return FingerTarget(g.finger_names[f], contact, grasp, pad, gap, moved)
    pre_f = np.array([pre.get(j, q) for j, q in zip(joints, q_contact, strict=True)])
    closed = np.array([g.closed.get(j, p) for j, p in zip(joints, pre_f, strict=True)])
    lim = np.asarray(g.finger_limits[f], dtype=np.float64)
    closed = np.clip(closed, lim[:, 0], lim[:, 1])
    # a joint whose contact lies at or past ``closed`` (a hand whose ``closed``
    # stops where its pads meet, holding a large object) squeezes on towards
    # its limit on the closing side, never back towards ``closed``
    way = np.sign(closed - pre_f)  # (d,) +1 closes upwards, -1 downwards
    beyond = np.where(way > 0, lim[:, 1], lim[:, 0])  # (d,) the closing side's limit
    past = (way != 0) & ((closed - q_contact) * way <= 0.0)
    closed = np.where(past & (np.abs(beyond - closed) > 1e-6), beyond, closed)
    t = np.linspace(0.0, 1.0, _SQUEEZE_STEPS)
    ray = q_contact + t[:, None] * (closed - q_contact)  # (T, d)
    p_ray = pad_positions(g, f, ray)  # (T, 3)
    travel = np.linalg.norm(p_ray - p_ray[0], axis=1)  # (T,)
    reach = np.flatnonzero(travel >= squeeze)
    k = int(reach[0]) if len(reach) else len(t) - 1
    grasp = {j: float(v) for j, v in zip(joints, ray[k], strict=True)}
    return FingerTarget(g.finger_names[f], contact, grasp, pad, gap, float(travel[k]))


def _pad_at(g: GripperModel, f: int, q: tuple[float, ...]) -> Array:
    """Finger ``f``'s pad centre at joint values ``q``, gripper frame, ``(3,)``:
    ``pad_positions`` kept on the model per finger and posture, as every plan
    that closes to ``closed`` asks for the same one (one interpolation took
    0.36 ms, a quarter of an Allegro finger's target)."""
    cache: dict[tuple[int, tuple[float, ...]], Array] = g.__dict__.setdefault(
        "_pad_at", {}
    )
    key = (f, q)
    if key not in cache:
        if len(cache) >= 64:  # a model whose closed posture is changed: bounded
            cache.clear()
        cache[key] = pad_positions(g, f, np.array([q]))[0]
    return cache[key]


def _allowed_mask(
    g: GripperModel, finger: int, spheres: NDArray[np.int64]
) -> NDArray[np.bool_]:
    """``(K,)`` over the finger's grid: the configurations that put a pad sample
    point inside any of ``spheres`` (the finger's own): the set
    ``GripperModel.sphere_configurations`` gives, less the finger's offset."""
    o = g.config_offsets
    count = int(o[finger + 1] - o[finger])
    rows = sphere_config_bits(g)[np.asarray(spheres, dtype=np.int64)]  # (s, B)
    return np.unpackbits(np.bitwise_or.reduce(rows, axis=0), count=count).view(bool)


def sphere_config_bits(g: GripperModel) -> NDArray[np.uint8]:
    """Per workspace sphere, its configurations as bits over its finger's grid
    (``np.packbits`` of a ``(K,)`` mask, ``K`` the finger's configurations),
    ``(S, ceil(max K / 8))``: the sphere lists of ``sphere_config_index`` in a
    form whose union over a few spheres is one OR. Built once per model and kept
    on it."""
    cached = g.__dict__.get("_sphere_config_bits")
    if cached is None:
        ptr, o = g.sphere_config_ptr, g.config_offsets
        width = int(np.diff(o).max()) if len(o) > 1 else 0
        owner = np.repeat(np.arange(len(ptr) - 1), np.diff(ptr))  # (M,) sphere
        local = g.sphere_config_index - o[g.config_finger[g.sphere_config_index]]
        mask = np.zeros((len(ptr) - 1, width), dtype=bool)  # (S, max K)
        mask[owner, local] = True
        cached = np.packbits(mask, axis=1)
        cached.flags.writeable = False
        g.__dict__["_sphere_config_bits"] = cached
    return cached  # type: ignore[no-any-return]


def config_tree(g: GripperModel, finger: int) -> cKDTree:
    """A KD-tree over one finger's pad centres (``config_pad``), built once per
    model and kept on it."""
    trees: dict[int, cKDTree] = g.__dict__.setdefault("_config_trees", {})
    if finger not in trees:
        o = g.config_offsets
        trees[finger] = cKDTree(g.config_pad[o[finger] : o[finger + 1]])
    return trees[finger]


def prepare(g: GripperModel) -> None:
    """Build the per-finger lookups the joint targets use (pad KD-trees,
    interpolators and the spheres' configuration bits) and those that keep the
    fingers' closing sweeps off the table (``wsgrasp.planning.sweeps``), so
    that the first plan does not pay for them."""
    if g.has_configurations:
        for f in range(g.num_fingers):
            config_tree(g, f)
            _interpolator(g, f)
        sphere_config_bits(g)
    prepare_sweeps(g)
