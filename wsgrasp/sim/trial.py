"""One grasp trial, as in the paper's experiments (Sorour et al. 2019, Sec. V).

1. **Drop.** The object is dropped onto the table at a random (seeded) position
   and yaw, tilted at random from its natural resting pose (``drop_pose
   "natural"``, as a person would put it down; ``"random"`` draws any
   orientation) and left to settle.
2. **Look.** Three noisy depth views of the settled scene are rendered with the
   camera model of ``scene synth``; the planner gets only these views.
3. **Plan.** The pipeline plans a grasp: the pose of the gripper's base link.
4. **Approach.** The gripper starts at the plan's pre-grasp pose
   (``T_world_pregrasp``; without one, ``standoff`` back along its approach axis)
   with the fingers in the plan's ``joints_pregrasp`` and is driven in a straight
   line to the planned pose. Under the ``strict`` protocol both poses are off by
   the trial's execution error (:func:`execution_error`): a rigid motion about
   the object's centre of mass, as if the camera had put the object there.
5. **Close.** The position actuators' targets ramp to the plan's ``joints_grasp``
   (the fingers at their contacts, squeezed through them) over ``close_time``,
   then hold ``close_wait`` to build the grip. A plan without joint targets
   closes towards the gripper YAML's ``closed`` posture instead.
6. **Lift and hold.** The gripper is driven 20 cm up and held there
   (``hold_time``: 10 s under ``lift``, 1 s under ``strict``).
7. **Disturb** (``strict``). A force of ``disturbance_weights`` times the
   object's weight pulls at its centre of mass along -x, +x, -y, +y, -z, +z,
   ``disturbance_time`` each (:data:`DISTURBANCE_DIRECTIONS`), then
   ``rest_time`` without; the trial stops as soon as the object is lost.

Outcomes: ``success`` (object held off the table at the end and, under
``strict``, within ``slip_distance``/``slip_angle_deg`` of where it sat in the
grip when the fingers had closed), ``no_grasp`` (the planner found none),
``approach_collision`` (the object was pushed more than
``displaced_distance``/``displaced_angle_deg`` or the gripper was blocked before
closing, and the grasp then failed), ``slipped_lifting`` (not held after the
lift), ``dropped_holding`` (held after the lift, lost during the hold),
``dropped_disturbed`` (lost under a disturbance or in the rest after them) and
``slipped_in_grip`` (held to the end, but moved in the grip past the limits).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp.geometry import rotation_angle_deg
from wsgrasp.sim._mujoco import require_mujoco
from wsgrasp.sim.film import Film, Frame, film_geometry, snapshot
from wsgrasp.sim.objects import SimObject
from wsgrasp.sim.params import SimParams
from wsgrasp.sim.scene import SimScene

__all__ = [
    "DISTURBANCE_DIRECTIONS",
    "OUTCOMES",
    "Execution",
    "ExecutionError",
    "Settled",
    "close_fingers",
    "execute_grasp",
    "execution_error",
    "render_views",
    "settle_object",
]

Array = NDArray[np.float64]

#: trial outcomes, success first, then the failure classes in protocol order
OUTCOMES = (
    "success",
    "no_grasp",
    "approach_collision",
    "slipped_lifting",
    "dropped_holding",
    "dropped_disturbed",
    "slipped_in_grip",
    "sim_crashed",
)

#: the strict protocol's disturbance directions (world), in the order applied:
#: DexGraspBench/BODex's -x, +x, -y, +y, -z, +z
DISTURBANCE_DIRECTIONS = np.array(
    [
        [-1.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, -1.0],
        [0.0, 0.0, 1.0],
    ]
)  # (6, 3)

#: the entry appended to a trial's seed sequence for its execution error, so the
#: error is drawn from a stream of its own (the drop and the views are not moved)
EXECUTION_STREAM = 1


@dataclass(frozen=True)
class ExecutionError:
    """Where the executed grasp is, against the planned one: a rigid motion
    about the object's centre of mass, in world axes.

    Attributes
    ----------
    offset : (3,) float
        Translation (m).
    rotvec : (3,) float
        Rotation vector (rad), about the object's centre of mass.
    """

    offset: Array
    rotvec: Array

    def transform(self, center: Array) -> Array:
        """The ``(4, 4)`` world motion, rotating about ``center`` ``(3,)``."""
        from scipy.spatial.transform import Rotation

        R = Rotation.from_rotvec(np.asarray(self.rotvec, dtype=np.float64)).as_matrix()
        c = np.asarray(center, dtype=np.float64)
        E = np.eye(4)
        E[:3, :3] = R
        E[:3, 3] = c + np.asarray(self.offset, dtype=np.float64) - R @ c
        return E

    def to_json(self) -> dict[str, list[float]]:
        return {
            "offset": [float(v) for v in self.offset],
            "rotvec": [float(v) for v in self.rotvec],
        }


def execution_error(
    seed: Sequence[int] | np.random.Generator, p: SimParams
) -> ExecutionError:
    """The execution error of a trial: ``p.execution_offset`` (m) in a uniformly
    random direction and ``p.execution_angle_deg`` about a uniformly random axis.

    ``seed`` is the trial's seed sequence (:func:`wsgrasp.sim.runner.task_seed`),
    drawn from with :data:`EXECUTION_STREAM` appended, or a generator to draw
    from. The same seed gives the same error, whatever the gripper or spec.
    """
    rng = (
        seed
        if isinstance(seed, np.random.Generator)
        else np.random.default_rng([*[int(v) for v in seed], EXECUTION_STREAM])
    )
    u = rng.normal(size=(2, 3))  # (2, 3) directions: the offset's, the axis
    u /= np.maximum(np.linalg.norm(u, axis=1, keepdims=True), 1e-12)
    return ExecutionError(
        offset=u[0] * p.execution_offset,
        rotvec=u[1] * np.radians(p.execution_angle_deg),
    )


@dataclass
class Settled:
    """The object at rest on the table.

    Attributes
    ----------
    T_world_object : (4, 4) float
    drops : int
        Drops needed (an object that rolls off the table is dropped again).
    settle_s : float
        Simulated seconds until it came to rest.
    """

    T_world_object: Array
    drops: int
    settle_s: float


def _pose_to_qpos(T: Array) -> Array:
    from wsgrasp.sim._xml import quat_wxyz

    return np.concatenate([T[:3, 3], quat_wxyz(T[:3, :3])])


def _qpos_to_pose(q: Array) -> Array:
    from scipy.spatial.transform import Rotation

    T = np.eye(4)
    T[:3, 3] = q[:3]
    T[:3, :3] = Rotation.from_quat([q[4], q[5], q[6], q[3]]).as_matrix()
    return T


def settle_object(
    scene: SimScene, obj: SimObject, rng: np.random.Generator, p: SimParams
) -> Settled:
    """Drop ``obj`` at a random pose in ``scene`` (table and object only) and let
    it come to rest; returns its pose."""
    mujoco = require_mujoco()
    from scipy.spatial.transform import Rotation

    m, d = scene.model, scene.data
    verts = np.asarray(obj.mesh().vertices, dtype=np.float64)  # (n, 3) object frame
    steps = max(1, int(round(0.05 / p.timestep)))
    limit = p.table_size / 2.0 - 0.03
    for drop in range(1, 11):
        mujoco.mj_resetData(m, d)
        if p.drop_pose == "random":
            R = Rotation.random(random_state=rng).as_matrix()
        else:  # natural: upright as modelled, random yaw, tilted up to drop_tilt
            axis = np.array([*rng.normal(size=2), 0.0])
            axis /= max(float(np.linalg.norm(axis)), 1e-12)
            tilt = np.radians(p.drop_tilt_deg) * rng.uniform(0.0, 1.0)
            yaw = rng.uniform(0.0, 2.0 * np.pi)
            R = (
                Rotation.from_rotvec(axis * tilt) * Rotation.from_rotvec([0, 0, yaw])
            ).as_matrix()
        xy = rng.uniform(-p.drop_radius, p.drop_radius, 2)
        z = -float((verts @ R.T)[:, 2].min()) + p.drop_height
        T = np.eye(4)
        T[:3, :3] = R
        T[:3, 3] = [xy[0], xy[1], z]
        d.qpos[scene.object_qpos] = _pose_to_qpos(T)
        m.dof_damping[scene.object_dof] = p.settle_damping
        t = _run_until_still(m, d, scene, steps, p.settle_time, p.timestep)
        # then without the extra damping: what is still tipping over, tips now
        m.dof_damping[scene.object_dof] = 0.0
        mujoco.mj_step(m, d, nstep=int(round(0.5 / p.timestep)))
        t += 0.5 + _run_until_still(m, d, scene, steps, p.settle_time, p.timestep)
        T = _qpos_to_pose(d.qpos[scene.object_qpos].copy())
        com = d.xipos[scene.object_body]  # (3,) centre of mass, world
        if abs(com[0]) < limit and abs(com[1]) < limit and com[2] > 0.0:
            return Settled(T_world_object=T, drops=drop, settle_s=t)
    from wsgrasp.errors import SimulationError

    raise SimulationError(
        f"object {obj.name!r} did not come to rest on the table in 10 drops",
        hint="check the object's size (metres) and shape",
    )


def _run_until_still(
    m: Any, d: Any, scene: SimScene, steps: int, limit: float, dt: float
) -> float:
    """Step until the object is still (after at least 0.3 s) or ``limit`` s."""
    mujoco = require_mujoco()
    t = 0.0
    while t < limit:
        mujoco.mj_step(m, d, nstep=steps)
        t += steps * dt
        v = d.qvel[scene.object_dof]  # (6,) linear, angular
        if t > 0.3 and np.linalg.norm(v[:3]) < 2e-3 and np.linalg.norm(v[3:]) < 2e-2:
            break
    return t


def render_views(
    obj: SimObject, T_world_object: Array, rng: np.random.Generator, p: SimParams
) -> list[Any]:
    """The object's views (:func:`render_meshes`)."""
    return render_meshes([(obj.mesh(), T_world_object)], rng, p)


def render_meshes(
    meshes_with_poses: Sequence[tuple[Any, Array]],
    rng: np.random.Generator,
    p: SimParams,
) -> list[Any]:
    """The noisy depth views of ``scene synth``'s camera model of meshes at
    their poses on the table: ``p.views`` cameras at ``p.camera_elevation_deg``,
    aimed at the table centre; returns ``View`` objects (points in camera
    frames)."""
    from wsgrasp.perception.synth import default_cameras, render_scene

    cams = default_cameras(
        p.views,
        target=(0.0, 0.0, 0.05),
        elevation=np.radians(p.camera_elevation_deg),
        rng=rng,
    )
    return render_scene(
        meshes_with_poses, p.table_size, cams, p.depth_noise, rng, p.flying_pixels
    )


@dataclass
class Execution:
    """What happened when the planned grasp was executed.

    Attributes
    ----------
    outcome : str
        One of :data:`OUTCOMES` (never ``no_grasp``).
    metrics : dict
        ``displacement`` (m) and ``rotation_deg`` of the object during the
        approach, ``blocked`` (m, gripper's lag behind its target at the planned
        pose), ``rise_after_lift`` and ``rise_after_hold`` (m, object height gain),
        ``contact_after_lift``/``contact_after_hold`` (object touching the
        gripper), ``grip_force`` (N, sum of the normal forces between gripper and
        object once closed), ``friction_use_closed``, ``friction_use_lifted``
        and ``friction_use_held`` (the share of their friction cones the
        gripper's contacts with the object use, weighted by their normal
        forces, once closed, after the lift and after the hold: near 1, the grip
        is about to slide; None without a contact), ``closing_push`` (m, how
        far the object's centre of mass moved while the fingers closed: a
        finger that arrives first pushes it along the table, a hand that wraps
        it draws it in), ``joints_closed`` (actuated joint name to position
        once closed), ``sim_s`` (simulated seconds); what MuJoCo was given:
        ``object_mass`` (kg), ``object_friction``, ``disturbance_force`` (N, 0
        without disturbances), ``execution_offset`` (m) and
        ``execution_angle_deg``; ``disturbances_held`` (directions the object
        stayed held through), ``slip_distance`` (m) and ``slip_angle_deg`` (the
        object's motion in the grip from the closed grip to the end),
        ``slip_distance_hold`` and ``slip_angle_deg_hold`` (the same, to the end
        of the hold: what the lift moved).
    xipos_closed : (nbody, 3) float, optional
        Every body's centre of mass (world) once the fingers had closed, before
        the lift: what the approach and the closing moved in a world of several
        objects (``wsgrasp.sim.clutter``).
    touched : (k,) int
        The bodies other than the object, the gripper's and the table's that
        the gripper touched during the approach and the closing (a world of
        several objects: the neighbours it collided with), ascending.
    touched_first : (j,) int
        Those of ``touched`` that the gripper touched before it first touched
        the object (all of them where it never did): the neighbours in its
        way, not those its fingers met around the object they held.
    touched_by : dict of int to (i,) int
        For each body of ``touched``, the gripper's bodies that touched it.
    film : Film, optional
        The world at each step of the protocol (``execute_grasp(...,
        film=True)``; None otherwise), for :func:`wsgrasp.sim.film.draw_film`.
    """

    outcome: str
    metrics: dict[str, Any] = field(default_factory=dict)
    xipos_closed: Array | None = None
    touched: NDArray[np.int64] = field(
        default_factory=lambda: np.zeros(0, dtype=np.int64)
    )
    touched_first: NDArray[np.int64] = field(
        default_factory=lambda: np.zeros(0, dtype=np.int64)
    )
    touched_by: dict[int, NDArray[np.int64]] = field(default_factory=dict)
    film: Film | None = None


def close_fingers(
    m: Any,
    d: Any,
    start: Array,
    goal: Array,
    p: SimParams,
    after_step: Callable[[], None] | None = None,
) -> None:
    """Step 5 of the protocol: ramp the finger actuators' targets (``d.ctrl[6:]``,
    after the drive's six) from ``start`` to ``goal`` over ``close_time``, then
    let the grip build up for ``close_wait``; ``after_step`` is called after
    every simulation step."""
    mujoco = require_mujoco()
    n = max(1, int(round(p.close_time / p.timestep)))
    for i in range(1, n + 1):
        d.ctrl[6:] = start + (goal - start) * (i / n)
        mujoco.mj_step(m, d)
        if after_step is not None:
            after_step()
    wait = max(1, int(round(p.close_wait / p.timestep)))
    if after_step is None:
        mujoco.mj_step(m, d, nstep=wait)
        return
    for _ in range(wait):
        mujoco.mj_step(m, d)
        after_step()


def _contacts(scene: SimScene) -> tuple[bool, bool]:
    """(object touches the gripper, object touches the table)."""
    m, d = scene.model, scene.data
    n = d.ncon
    if n == 0:
        return False, False
    geoms = np.asarray(d.contact.geom[:n])  # (n, 2)
    bodies = m.geom_bodyid[geoms]  # (n, 2)
    has_obj = (bodies == scene.object_body).any(axis=1)
    other = np.where(bodies[:, 0] == scene.object_body, bodies[:, 1], bodies[:, 0])
    other_geom = np.where(bodies[:, 0] == scene.object_body, geoms[:, 1], geoms[:, 0])
    grip = bool((has_obj & np.isin(other, scene.gripper_bodies)).any())
    table = bool((has_obj & (other_geom == scene.table_geom)).any())
    return grip, table


def execute_grasp(
    scene: SimScene,
    T_world_object: Array,
    T_world_base: Array,
    p: SimParams,
    *,
    T_world_pregrasp: Array | None = None,
    joints_pregrasp: Mapping[str, float] | None = None,
    joints_grasp: Mapping[str, float] | None = None,
    error: ExecutionError | None = None,
    film: bool = False,
) -> Execution:
    """Run steps 4–7 of the protocol for a planned base pose ``(4, 4)``.

    Parameters
    ----------
    scene
        A world with the gripper (:func:`~wsgrasp.sim.scene.build_scene`).
    T_world_object : (4, 4) float
        The settled object's pose.
    T_world_base : (4, 4) float
        The planned pose of the gripper's base link.
    p
        The trial's parameters (its protocol: disturbances, slip limits).
    T_world_pregrasp : (4, 4) float, optional
        Where the approach starts (the plan's pre-grasp pose); the straight line
        from there to ``T_world_base`` is driven at the grasp's orientation.
        Default: ``p.standoff`` back along the approach axis.
    joints_pregrasp, joints_grasp : dict of str to float, optional
        Actuated joint targets to approach in and to close to (the plan's
        per-grasp postures); joints they leave out, or all of them when not
        given, take the gripper YAML's ``pregrasp`` and ``closed`` values.
    error : ExecutionError, optional
        Moves the grasp and pre-grasp poses about the object's centre of mass
        (:func:`execution_error`); none when not given.
    film : bool
        Keep the world at each step of the protocol in ``Execution.film``
        (:mod:`wsgrasp.sim.film`).
    """
    mujoco = require_mujoco()
    g = scene.gripper
    assert g is not None and scene.gripper_qpos is not None
    m, d = scene.model, scene.data
    mujoco.mj_resetData(m, d)
    m.dof_damping[scene.object_dof] = 0.0
    d.qpos[scene.object_qpos] = _pose_to_qpos(T_world_object)
    obj = scene.object_body
    if error is not None:  # about the centre of mass: body_ipos, object frame
        com = T_world_object[:3, :3] @ m.body_ipos[obj] + T_world_object[:3, 3]
        E = error.transform(com)
        T_world_base = E @ np.asarray(T_world_base, dtype=np.float64)
        if T_world_pregrasp is not None:
            T_world_pregrasp = E @ np.asarray(T_world_pregrasp, dtype=np.float64)
    T_base_root = np.linalg.inv(g.T_root_base)
    T_goal = T_world_base @ T_base_root  # root pose at the grasp
    T_start = T_goal.copy()
    if T_world_pregrasp is None:
        approach = T_world_base[:3, :3] @ g.approach_axis  # (3,) world
        T_start[:3, 3] -= p.standoff * approach
    else:  # its position; the orientation stays the grasp's
        T_start[:3, 3] = (np.asarray(T_world_pregrasp, np.float64) @ T_base_root)[:3, 3]
    ctrl_pre = g.pregrasp
    qpos_pre = g.qpos_pregrasp
    if joints_pregrasp:
        ctrl_pre = g.targets(joints_pregrasp, g.pregrasp, "joints_pregrasp")
        qpos_pre = g.joint_qpos(ctrl_pre)
    ctrl_grasp = g.closed
    if joints_grasp:
        ctrl_grasp = g.targets(joints_grasp, g.closed, "joints_grasp")
    from wsgrasp.sim._xml import quat_wxyz

    m.body_quat[scene.root_body] = quat_wxyz(T_goal[:3, :3])
    d.qpos[scene.gripper_qpos] = 0.0
    d.qpos[scene.gripper_qpos][:3] = T_start[:3, 3]
    d.ctrl[:6] = 0.0
    d.ctrl[:3] = T_start[:3, 3]
    for jn, v in qpos_pre.items():
        d.qpos[scene.joint_qpos[jn]] = v
    d.ctrl[6:] = ctrl_pre
    d.xfrc_applied[:] = 0.0
    mujoco.mj_forward(m, d)
    z0 = float(d.xpos[obj][2])
    p0 = d.xpos[obj].copy()
    R0 = d.xmat[obj].reshape(3, 3).copy()
    dt = p.timestep

    # the other objects of a world of several (none for a single object), and
    # those of them the gripper touches while it approaches and closes
    is_grip = np.zeros(m.nbody, dtype=bool)
    is_grip[scene.gripper_bodies] = True
    is_other = np.zeros(m.nbody, dtype=bool)
    is_other[m.geom_bodyid] = True
    is_other[[0, obj]] = False  # the world's (the table) and the object's
    is_other &= ~is_grip
    # the step of the approach and closing at which each body was first touched
    # (-1: never; the object's own too), and which gripper body touched which
    first = np.full(m.nbody, -1, dtype=np.int64)
    by = np.zeros((m.nbody, m.nbody), dtype=bool)  # (gripper body, other body)
    count = [0]

    def watch() -> None:
        count[0] += 1
        n = d.ncon
        if n:
            pair = m.geom_bodyid[d.contact.geom[:n]]  # (n, 2) bodies
            grip = is_grip[pair]  # (n, 2)
            one = grip[:, 0] != grip[:, 1]
            if one.any():
                other = np.where(grip[:, 0], pair[:, 1], pair[:, 0])[one]
                mine = np.where(grip[:, 0], pair[:, 0], pair[:, 1])[one]
                keep = is_other[other] | (other == obj)
                other, mine = other[keep], mine[keep]
                by[mine, other] = True
                new = other[first[other] < 0]
                first[new] = count[0]

    def move(
        start: Array,
        goal: Array,
        speed: float,
        after_step: Callable[[], None] | None = None,
    ) -> None:
        dist = float(np.linalg.norm(goal - start))
        n = max(1, int(np.ceil(dist / speed / dt)))
        for i in range(1, n + 1):
            d.ctrl[:3] = start + (goal - start) * (i / n)
            mujoco.mj_step(m, d)
            if after_step is not None:
                after_step()

    def wait(seconds: float) -> None:
        mujoco.mj_step(m, d, nstep=max(1, int(round(seconds / dt))))

    def held() -> tuple[bool, bool, float]:
        """(held off the table, touching the gripper, rise above the start)."""
        grip, table = _contacts(scene)
        rise = float(d.xpos[obj][2]) - z0
        return (
            grip and not table and rise > p.lifted_fraction * p.lift_height,
            grip,
            rise,
        )

    def in_grip() -> tuple[Array, Array]:
        """The object's centre of mass ``(3,)`` and orientation ``(3, 3)`` in
        the gripper's root frame."""
        R_root = d.xmat[scene.root_body].reshape(3, 3)
        c = R_root.T @ (d.xipos[obj] - d.xpos[scene.root_body])
        return c, R_root.T @ d.xmat[obj].reshape(3, 3)

    frames: list[Frame] = []
    geometry = film_geometry(m, obj, scene.gripper_bodies) if film else None

    def snap(label: str) -> None:
        if geometry is not None:
            frames.append(snapshot(d, geometry, label))

    snap("pre-grasp")
    # 4. approach
    on_step = watch if is_other.any() else None
    move(T_start[:3, 3], T_goal[:3, 3], p.approach_speed, on_step)
    wait(0.1)
    snap("grasp pose")
    root = d.xpos[scene.root_body]
    blocked = float(np.linalg.norm(root - T_goal[:3, 3]))
    disp = float(np.linalg.norm(d.xpos[obj] - p0))
    rot = rotation_angle_deg(R0, d.xmat[obj].reshape(3, 3))
    collided = (
        disp > p.displaced_distance
        or rot > p.displaced_angle_deg
        or blocked > p.blocked_distance
    )
    # 5. close: ramp the targets, then let the grip build up
    p_approached = d.xipos[obj].copy()  # centre of mass
    after = on_step
    if geometry is not None:  # a third and two thirds into the ramp
        ramp = max(1, int(round(p.close_time / p.timestep)))
        at = {ramp // 3: "closing 33 %", (2 * ramp) // 3: "closing 67 %"}
        steps = [0]

        def filmed() -> None:
            if on_step is not None:
                on_step()
            steps[0] += 1
            if steps[0] in at:
                snap(at[steps[0]])

        after = filmed
    close_fingers(m, d, ctrl_pre, ctrl_grasp, p, after)
    snap("closed")
    joints_closed = {
        jn: float(d.qpos[scene.joint_qpos[jn]]) for jn in g.actuated
    }  # where the fingers stopped
    touching = _grip_contacts(scene)
    grip_force = sum((f_n for f_n, _ in touching), 0.0)  # their normal forces (N)
    use_closed = _friction_use(scene, touching)
    pushed = float(np.linalg.norm(d.xipos[obj] - p_approached))
    xipos_closed = d.xipos.copy()
    c_closed, R_closed = in_grip()
    # 6. lift, then hold
    top = T_goal[:3, 3] + np.array([0.0, 0.0, p.lift_height])
    move(T_goal[:3, 3], top, p.lift_speed)
    wait(0.2)
    snap("lifted")
    lifted, grip, rise_lift = held()
    use_lifted = _friction_use(scene)
    wait(p.hold_time)
    held_hold, grip2, rise_hold = held()
    snap("held")
    use_held = _friction_use(scene)
    c_hold, R_hold = in_grip()  # where the lift and the hold left it
    # 7. disturb: the six directions in turn, stopping once the object is lost
    weight = float(m.body_mass[obj] * np.linalg.norm(m.opt.gravity))
    force = p.disturbance_weights * weight
    survived = 0
    held_end = held_hold
    if held_hold and force > 0.0:
        for direction in DISTURBANCE_DIRECTIONS:
            d.xfrc_applied[obj, :3] = force * direction
            wait(p.disturbance_time)
            snap("pulled " + _direction_name(direction))
            held_end = held()[0]
            if not held_end:
                break
            survived += 1
        d.xfrc_applied[obj, :] = 0.0
        if held_end:
            wait(p.rest_time)
            held_end = held()[0]
            snap("rested")
    c_end, R_end = in_grip()
    slip = float(np.linalg.norm(c_end - c_closed))
    slip_deg = rotation_angle_deg(R_closed, R_end)
    still = (p.slip_distance <= 0.0 or slip <= p.slip_distance) and (
        p.slip_angle_deg <= 0.0 or slip_deg <= p.slip_angle_deg
    )
    if held_end and still:
        outcome = "success"
    elif collided:
        outcome = "approach_collision"
    elif not lifted:
        outcome = "slipped_lifting"
    elif not held_hold:
        outcome = "dropped_holding"
    elif not held_end:
        outcome = "dropped_disturbed"
    else:
        outcome = "slipped_in_grip"
    object_geoms = np.flatnonzero(m.geom_bodyid == obj)  # (k,) the object's geoms
    # the other objects touched, and those touched before the object
    touched = is_other & (first >= 0)
    ahead = touched & ((first[obj] < 0) | (first < first[obj]))
    offset, angle = (
        (0.0, 0.0)
        if error is None
        else (
            float(np.linalg.norm(error.offset)),
            float(np.degrees(np.linalg.norm(error.rotvec))),
        )
    )
    return Execution(
        outcome,
        {
            "displacement": disp,
            "rotation_deg": rot,
            "blocked": blocked,
            "approach_flagged": bool(collided),
            "rise_after_lift": rise_lift,
            "rise_after_hold": rise_hold,
            "contact_after_lift": bool(grip),
            "contact_after_hold": bool(grip2),
            "grip_force": grip_force,
            "friction_use_closed": use_closed,
            "friction_use_lifted": use_lifted,
            "friction_use_held": use_held,
            "closing_push": pushed,
            "joints_closed": joints_closed,
            "sim_s": float(d.time),
            "object_mass": float(m.body_mass[obj]),
            "object_friction": float(m.geom_friction[object_geoms[0], 0]),
            "disturbance_force": float(force),
            "disturbances_held": survived,
            "slip_distance": slip,
            "slip_angle_deg": slip_deg,
            "slip_distance_hold": float(np.linalg.norm(c_hold - c_closed)),
            "slip_angle_deg_hold": rotation_angle_deg(R_closed, R_hold),
            "execution_offset": offset,
            "execution_angle_deg": angle,
        },
        xipos_closed,
        np.flatnonzero(touched).astype(np.int64),
        np.flatnonzero(ahead).astype(np.int64),
        {
            int(b): np.flatnonzero(by[:, b]).astype(np.int64)
            for b in np.flatnonzero(touched)
        },
        None
        if geometry is None
        else Film(geometry, frames, T_world_base[:3, :3] @ np.asarray(g.closing_axis)),
    )


def _direction_name(direction: Array) -> str:
    """``"+x"``, ``"-z"``, ...: a disturbance's axis and sign."""
    k = int(np.argmax(np.abs(direction)))
    return ("+" if direction[k] > 0 else "-") + "xyz"[k]


#: contacts pressing with less than this share of the object's weight are left
#: out of :func:`_friction_use` (a finger grazing the object, a contact closing)
_FRICTION_USE_FROM = 0.01


def _grip_contacts(scene: SimScene) -> list[tuple[float, float | None]]:
    """Per contact of the gripper with the object: its normal force ``f_n`` (N)
    and its friction scaled by its cone, ``|f_t / mu|`` over its friction
    directions (tangential and, where ``condim`` has it, torsional: on MuJoCo's
    elliptic cone the contact slides where it equals ``f_n``); None for a
    frictionless contact."""
    mujoco = require_mujoco()
    m, d = scene.model, scene.data
    n = d.ncon
    if n == 0:
        return []
    bodies = m.geom_bodyid[np.asarray(d.contact.geom[:n])]  # (n, 2)
    obj = (bodies == scene.object_body).any(axis=1)
    grip = np.isin(bodies, scene.gripper_bodies).any(axis=1)
    wrench = np.zeros(6)
    out: list[tuple[float, float | None]] = []
    for i in np.flatnonzero(obj & grip):
        mujoco.mj_contactForce(m, d, int(i), wrench)  # contact frame, normal first
        f_n = float(wrench[0])
        dim = int(d.contact.dim[i])
        scaled = None
        if dim >= 3:
            mu = np.asarray(d.contact.friction[i][: dim - 1], dtype=np.float64)
            scaled = float(np.linalg.norm(wrench[1:dim] / np.maximum(mu, 1e-12)))
        out.append((f_n, scaled))
    return out


def _friction_use(
    scene: SimScene, contacts: list[tuple[float, float | None]] | None = None
) -> float | None:
    """How near the grip is to sliding: the share of its friction cone each
    contact of the gripper with the object uses, ``|f_t / mu| / f_n``
    (``contacts``, :func:`_grip_contacts` of ``scene`` by default), their mean
    weighted by normal force. 0 is a squeeze along the normals alone, 1 every
    contact sliding. Contacts pressing with less than
    :data:`_FRICTION_USE_FROM` of the object's weight are left out; None where
    none is left.

    The largest use of any one contact says little: a finger still closing
    slides over the object in grasps that hold (the Ability hand's held grasps
    on ``random:060``-``062`` had one, lift protocol)."""
    m = scene.model
    least = _FRICTION_USE_FROM * float(
        m.body_mass[scene.object_body] * np.linalg.norm(m.opt.gravity)
    )
    used = pressed = 0.0
    for f_n, scaled in _grip_contacts(scene) if contacts is None else contacts:
        if f_n <= least or scaled is None:
            continue
        used += scaled
        pressed += f_n
    return used / pressed if pressed > 0.0 else None
