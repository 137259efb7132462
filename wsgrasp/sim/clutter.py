"""Clutter removal: pick objects out of a pile until the table is clear.

The protocol of VGN (Breyer et al., 2020) and its successors, in this
package's simulator:

1. **Scene.** ``pile``: ``n`` objects dropped together, at random orientations
   and stacked a little apart in height, over a disc of radius
   :data:`PILE_RADIUS` at the table's centre, then left to settle. ``packed``:
   ``n`` objects stood upright (as modelled, random yaw) side by side in a
   grid, :data:`PACKED_GAP` apart, then left to settle. An object that falls off
   the table is not counted.
2. **Step.** The cameras (``params.views`` noisy depth views, the camera model
   of ``scene synth``) see what is left; the pipeline plans a grasp; the grasp
   is executed under the trial protocol (``params``: strict or lift; the
   execution error included) on the object the plan's target lies on, with the
   others in the world; every object lifted off its place (its centre of mass
   risen by ``lifted_fraction`` of ``lift_height``) is removed; the rest settle.
3. **End.** The table is clear, two steps in a row lifted nothing (no grasp,
   or the grasp did not take an object off the table), or ``max_steps``.

**Chance.** With ``pick="random"`` (``eval --scene pile --baseline random``) a
scene is cleared a second time by a policy that plans every step exactly as the
pipeline does (the same targets, in the same order) and executes, instead of
the plan's choice, a uniformly random feasible candidate of the same plan,
finished exactly as the choice is (``Pipeline.plan_choices``); a target none of
whose drawn candidates' plans finds a grasp counts as one without a grasp. The
scene, its cameras and the execution errors come from the scene's seed as
before; the draws from a stream of their own.

Grasp success rate = successful grasps / attempts (a plan that finds no grasp
is an attempt that failed); declutter rate = objects removed (lifted off the
table by a grasp; one pushed or knocked off the table is gone but not removed)
/ objects. Each failure gets a kind: ``no_grasp``, ``wrong_split`` (the
target's points lie on two objects), ``neighbour_collision`` (the approach was
flagged, or the gripper touched another object while it approached and closed,
before it touched the target: a neighbour in its way; a neighbour the fingers
meet around the target they hold, one the target moves, or one it knocks as it
falls back onto the pile, does not count),
``slip`` (dropped, slipped, not lifted) and ``two_lifted`` (more objects than
the target came up).
"""

from __future__ import annotations

import json
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from wsgrasp.sim._mujoco import require_mujoco
from wsgrasp.sim._xml import attrs
from wsgrasp.sim.objects import (
    OBJECT_CONAFFINITY,
    OBJECT_CONTYPE,
    SimObject,
)
from wsgrasp.sim.params import SimParams

__all__ = [
    "CLUTTER_SCENES",
    "PICKS",
    "ClutterWorld",
    "Step",
    "clutter_summary",
    "object_owners",
    "place_objects",
    "render_world",
    "run_clutter_scene",
    "scene_draws",
]

Array = NDArray[np.float64]
SceneKind = Literal["pile", "packed"]
#: the scene kinds of the benchmark
CLUTTER_SCENES: tuple[str, ...] = ("pile", "packed")
#: radius (m) of the disc a pile is dropped over
PILE_RADIUS = 0.06
#: gap (m) between the bounding boxes of packed objects
PACKED_GAP = 0.003
#: where removed objects are parked (m, world), one slot apart along y
_PARK = np.array([5.0, 0.0, 1.0])
#: share of the target's points that must lie on a second object for a wrong split
WRONG_SPLIT_SHARE = 0.2
#: what executes a step's grasp: the plan's choice, or a random feasible
#: candidate of the plan (the chance a clutter run is compared with)
PICKS: tuple[str, ...] = ("plan", "random")
#: seeds the random policy's draws apart from the scene's own stream
BASELINE_STREAM = 0x7A2D


# --------------------------------------------------------------------------------
# the world
# --------------------------------------------------------------------------------
def clutter_xml(objects: list[SimObject], gripper: Any, p: SimParams) -> str:
    """The MJCF text of a table with ``objects`` (bodies ``object<k>``, each on
    a free joint) and, when given, the gripper on the trial's 6-DoF drive."""
    from wsgrasp.sim.scene import _drive_actuators, _drive_xml, object_xml

    assets: list[str] = []
    bodies = []
    for k, obj in enumerate(objects):
        geoms, inertial = object_xml(obj, f"object{k}", p, assets)
        park = _PARK + [0.0, 0.3 * k, 0.0]
        bodies.append(
            f'<body name="object{k}" pos="{park[0]} {park[1]} {park[2]}">'
            f'<freejoint name="object{k}"/>' + inertial + "".join(geoms) + "</body>"
        )
    half = p.table_size / 2.0
    gripper_xml = equality = actuator = ""
    if gripper is not None:
        assets.append(gripper.asset_xml)
        gripper_xml = _drive_xml(gripper, p)
        equality = gripper.equality_xml
        actuator = _drive_actuators(p) + "\n" + gripper.actuator_xml
    option = attrs(
        timestep=p.timestep,
        integrator="implicitfast",
        cone="elliptic",
        impratio=p.impratio,
        noslip_iterations=p.noslip_iterations,
    )
    table = attrs(
        name="table",
        type="box",
        size=(half, half, 0.01),
        pos=(0, 0, -0.01),
        contype=OBJECT_CONTYPE,
        conaffinity=OBJECT_CONAFFINITY,
        priority=2,
        condim=4,
        solref=(p.contact_timeconst, 1.0),
        friction=(p.table_friction, p.torsional_friction, p.rolling_friction),
    )
    nl = "\n"
    return f"""<mujoco model="wsgrasp_clutter">
<compiler angle="radian" boundmass="1e-4" boundinertia="1e-9"/>
<option {option}/>
<asset>
{nl.join(a for a in assets if a)}
</asset>
<worldbody>
<geom {table}/>
{nl.join(bodies)}
{gripper_xml}
</worldbody>
<equality>
{equality}
</equality>
<actuator>
{actuator}
</actuator>
</mujoco>
"""


@dataclass
class ClutterWorld:
    """A compiled clutter world: its objects' bodies, joints, and whether each is
    still on the table (``present``)."""

    model: Any
    data: Any
    objects: list[SimObject]
    bodies: list[int]
    qpos: list[slice]
    dof: list[slice]
    present: NDArray[np.bool_]
    gripper: Any = None

    @classmethod
    def build(
        cls, objects: list[SimObject], p: SimParams, gripper: Any = None
    ) -> ClutterWorld:
        mujoco = require_mujoco()
        model = mujoco.MjModel.from_xml_string(clutter_xml(objects, gripper, p))
        data = mujoco.MjData(model)
        bodies, qpos, dof = [], [], []
        for k in range(len(objects)):
            bodies.append(
                mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"object{k}")
            )
            j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, f"object{k}")
            qa, da = int(model.jnt_qposadr[j]), int(model.jnt_dofadr[j])
            qpos.append(slice(qa, qa + 7))
            dof.append(slice(da, da + 6))
        world = cls(
            model, data, objects, bodies, qpos, dof, np.zeros(len(objects), bool)
        )
        world.gripper = gripper
        return world

    def poses(self) -> list[Array]:
        """Each object's pose ``(4, 4)`` now."""
        from wsgrasp.sim.trial import _qpos_to_pose

        return [_qpos_to_pose(self.data.qpos[q].copy()) for q in self.qpos]

    def set_poses(self, poses: list[Array], present: NDArray[np.bool_]) -> None:
        """Put the present objects at ``poses``, the others in their parking
        slots (floating, out of everything's way), everything at rest; the
        poses become the model's reset state too (``qpos0``)."""
        mujoco = require_mujoco()
        from wsgrasp.sim.trial import _pose_to_qpos

        m, d = self.model, self.data
        mujoco.mj_resetData(m, d)
        self.present = np.asarray(present, dtype=bool).copy()
        for k, (T, q) in enumerate(zip(poses, self.qpos, strict=True)):
            if self.present[k]:
                qk = _pose_to_qpos(T)
                m.body_gravcomp[self.bodies[k]] = 0.0
            else:
                qk = np.array([*(_PARK + [0.0, 0.3 * k, 0.0]), 1.0, 0.0, 0.0, 0.0])
                m.body_gravcomp[self.bodies[k]] = 1.0
            m.qpos0[q] = qk
            d.qpos[q] = qk
        mujoco.mj_forward(m, d)

    def settle(self, p: SimParams, limit: float | None = None) -> float:
        """Step until every present object is still (after at least 0.3 s) or
        ``limit`` (default ``settle_time``) simulated seconds; returns them."""
        mujoco = require_mujoco()
        m, d = self.model, self.data
        steps = max(1, int(round(0.05 / p.timestep)))
        end = p.settle_time if limit is None else limit
        dofs = [self.dof[k] for k in np.flatnonzero(self.present)]
        t = 0.0
        while t < end:
            mujoco.mj_step(m, d, nstep=steps)
            t += steps * p.timestep
            if t > 0.3 and all(
                np.linalg.norm(d.qvel[s][:3]) < 2e-3
                and np.linalg.norm(d.qvel[s][3:]) < 2e-2
                for s in dofs
            ):
                break
        return t

    def on_table(self, p: SimParams) -> NDArray[np.bool_]:
        """Present objects whose centre of mass is over the table and above it."""
        limit = p.table_size / 2.0 - 0.01
        com = self.data.xipos[self.bodies]  # (n, 3)
        over = (np.abs(com[:, :2]) < limit).all(axis=1) & (com[:, 2] > 0.0)
        return self.present & over  # type: ignore[no-any-return]


def _drop_pose(obj: SimObject, rng: np.random.Generator, upright: bool) -> Array:
    """A random orientation (upright: as modelled, random yaw), the object's
    lowest point at z = 0 and its box centred on the origin in x, y."""
    from scipy.spatial.transform import Rotation

    if upright:
        R = Rotation.from_rotvec([0.0, 0.0, rng.uniform(0, 2 * np.pi)]).as_matrix()
    else:
        R = Rotation.random(random_state=rng).as_matrix()
    v = np.asarray(obj.mesh().vertices, dtype=np.float64) @ R.T  # (n, 3)
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = -0.5 * (v.min(axis=0) + v.max(axis=0))
    T[2, 3] = -float(v[:, 2].min())
    return T


def place_objects(
    world: ClutterWorld, kind: str, rng: np.random.Generator, p: SimParams
) -> None:
    """Set up a ``pile`` or ``packed`` scene in ``world`` (no gripper) and let it
    settle; objects that leave the table are absent afterwards."""
    n = len(world.objects)
    poses = []
    if kind == "pile":
        z = 0.005
        for obj in world.objects:
            T = _drop_pose(obj, rng, upright=False)
            r, a = PILE_RADIUS * np.sqrt(rng.uniform()), rng.uniform(0, 2 * np.pi)
            T[:3, 3] += [r * np.cos(a), r * np.sin(a), z]
            height = float(np.max(obj.size()))
            z += height + 0.005
            poses.append(T)
    elif kind == "packed":
        upright = [_drop_pose(o, rng, upright=True) for o in world.objects]
        # footprints (x, y extents of each posed object's box)
        sizes = []
        for obj, T in zip(world.objects, upright, strict=True):
            v = np.asarray(obj.mesh().vertices) @ T[:3, :3].T
            sizes.append(v.max(axis=0)[:2] - v.min(axis=0)[:2])
        cols = int(np.ceil(np.sqrt(n)))
        rows = int(np.ceil(n / cols))
        w = max(s[0] for s in sizes) + PACKED_GAP
        h = max(s[1] for s in sizes) + PACKED_GAP
        for k, T in enumerate(upright):
            r, c = divmod(k, cols)
            T[0, 3] += (c - (cols - 1) / 2.0) * w
            T[1, 3] += (r - (rows - 1) / 2.0) * h
            poses.append(T)
    else:
        from wsgrasp.errors import InputError

        raise InputError(
            f"clutter scene {kind!r} is unknown, expected one of "
            f"{', '.join(CLUTTER_SCENES)}",
            hint="pass --scene pile or --scene packed",
        )
    world.set_poses(poses, np.ones(n, dtype=bool))
    world.settle(p, limit=3.0 * p.settle_time)
    world.present = world.on_table(p)


def scene_draws(pool: int, per_scene: int, scenes: int, seed: int) -> list[list[int]]:
    """The objects of each of ``scenes`` clutter scenes: ``per_scene`` distinct
    indices into a pool of ``pool`` objects, drawn from ``seed``'s stream (scene
    ``i`` then runs with seed ``seed + i``: :func:`run_clutter_scene`)."""
    rng = np.random.default_rng(seed)
    return [
        [int(i) for i in rng.choice(pool, per_scene, replace=False)]
        for _ in range(scenes)
    ]


# --------------------------------------------------------------------------------
# one scene
# --------------------------------------------------------------------------------
@dataclass
class _Capture:
    """A plan observer that keeps the target's points (for judging the split)."""

    object_points: Array | None = None
    segments: int = 0

    def on_start(self, spec: Any, gripper: Any, scene: Any) -> None:
        self.object_points = None

    def on_stage(self, stage: str, data: dict[str, Any]) -> None:
        if stage == "segmentation":
            self.object_points = np.asarray(data["object_points"])
            self.segments = 1 + len(data.get("obstacles") or [])

    def on_result(self, result: Any) -> None:
        pass

    def on_error(self, error: BaseException) -> None:
        pass


@dataclass
class Step:
    """One attempt of a clutter scene (see the module docstring)."""

    step: int
    objects_left: int
    found: bool
    target: str | None = None
    outcome: str = "no_grasp"
    success: bool = False
    kind: str | None = None
    lifted: list[str] = field(default_factory=list)
    #: the neighbours that moved more than ``displaced_distance``
    #: (horizontally) before the lift, pushed by the gripper or by the target
    pushed: list[str] = field(default_factory=list)
    #: the neighbours the gripper touched while it approached and closed
    touched: list[str] = field(default_factory=list)
    #: those it touched before it first touched the target (all of them where
    #: it never did): in its way, not met around the target
    touched_first: list[str] = field(default_factory=list)
    #: per neighbour touched, the gripper's links that touched it
    touched_by: dict[str, list[str]] = field(default_factory=dict)
    #: wall-clock time of the step's plans (ms), recording included
    plan_ms: float = 0.0
    #: the candidate executed (index into the plan's candidates) where the
    #: scene is cleared by random feasible candidates; None for the choice
    candidate: int | None = None
    #: the plans' own time (ms, their ``timing_ms["total"]``: segmentation to
    #: joint targets), and the first plan's alone
    pipeline_ms: float = 0.0
    first_plan_ms: float = 0.0
    segments: int = 0
    hint: str = ""
    #: plans made (the target's, then other instances' where it had no grasp)
    tries: int = 0
    records: list[str] = field(default_factory=list)
    error: str | None = None
    #: the attempt drawn step by step (``film_dir``), a PNG's path
    film: str | None = None


def render_world(
    world: ClutterWorld, rng: np.random.Generator, p: SimParams
) -> tuple[Any, list[int], list[tuple[Any, Array]]]:
    """The cameras' ``Scene`` of the present objects, their indices and their
    meshes at their poses."""
    from wsgrasp.geometry import transform_points
    from wsgrasp.perception.types import Scene
    from wsgrasp.sim.trial import render_meshes

    present = [int(k) for k in np.flatnonzero(world.present)]
    poses = world.poses()
    meshes = [(world.objects[k].mesh(), poses[k]) for k in present]
    views = render_meshes(meshes, rng, p)
    points = np.concatenate(
        [transform_points(v.T_world_camera, v.points) for v in views]
    )
    return Scene(views=views, points=points), present, meshes


def object_owners(points: Array, meshes: list[tuple[Any, Array]]) -> NDArray[np.int64]:
    """Index into ``meshes`` of the surface nearest each point ``(n, 3)``."""
    from wsgrasp._open3d import load_open3d

    o3d = load_open3d()

    from wsgrasp.geometry import transform_points

    q = o3d.core.Tensor.from_numpy(np.ascontiguousarray(points, dtype=np.float32))
    dist = []
    for mesh, T in meshes:
        sc = o3d.t.geometry.RaycastingScene()
        v = transform_points(T, np.asarray(mesh.vertices, dtype=np.float64))
        sc.add_triangles(
            o3d.core.Tensor.from_numpy(v.astype(np.float32)),
            o3d.core.Tensor.from_numpy(np.asarray(mesh.faces, dtype=np.uint32)),
        )
        dist.append(sc.compute_distance(q).numpy())
    return np.argmin(np.stack(dist, axis=1), axis=1)  # type: ignore[no-any-return]


def run_clutter_scene(
    objects: list[SimObject],
    kind: str,
    pipeline: Any,
    sim_gripper: Any,
    p: SimParams,
    seed: int,
    *,
    max_steps: int | None = None,
    record_dir: str | Path | None = None,
    pick: str = "plan",
    film_dir: str | Path | None = None,
) -> dict[str, Any]:
    """Clear one ``pile`` or ``packed`` scene of ``objects`` with ``pipeline``
    (see the module docstring); with ``record_dir``, every step's plan is
    recorded there (``step-NN.mcap``) and ``clutter.json`` lists the steps with
    their outcomes. ``pick`` ``"random"`` executes a random feasible candidate
    of each step's plan instead of its choice (the module docstring's
    *Chance*). With ``film_dir``, each attempt is drawn step by step there
    (``step-NN.png``, :mod:`wsgrasp.sim.film`).

    Returns
    -------
    dict
        ``scene``, ``seed``, ``objects`` (names of those that stayed on the
        table), ``attempts``, ``successes``, ``removed`` (objects lifted off
        the table by a grasp), ``fell_off`` (names of those that left the
        table otherwise: pushed or knocked off, not removed), ``steps`` (each
        a :class:`Step` as a dict), ``end`` (``clear``, ``two_failures`` or
        ``step_limit``).
    """
    from wsgrasp.sim.trial import execution_error

    if pick not in PICKS:
        from wsgrasp.errors import InputError

        raise InputError(
            f"clutter pick {pick!r} is unknown, expected one of {', '.join(PICKS)}",
            hint="pick the plan's choice (plan) or random feasible candidates",
        )
    rng = np.random.default_rng(seed)
    # the random policy's draws: a stream of their own, so the scene, the
    # cameras and the execution errors are the seed's whatever is drawn
    draws = np.random.default_rng([seed, BASELINE_STREAM]) if pick == "random" else None
    settle = ClutterWorld.build(objects, p)
    place_objects(settle, kind, rng, p)
    present = settle.present.copy()
    poses = settle.poses()
    names = [o.name for o in objects]
    start = [names[k] for k in np.flatnonzero(present)]
    grip = ClutterWorld.build(objects, p, sim_gripper)
    limit = max_steps if max_steps is not None else 2 * len(start)
    out_dir = None if record_dir is None else Path(record_dir)
    for folder in (out_dir, film_dir):
        if folder is not None:
            Path(folder).mkdir(parents=True, exist_ok=True)
    steps: list[Step] = []
    end = "step_limit"
    for i in range(limit):
        if not present.any():
            end = "clear"
            break
        settle.set_poses(poses, present)
        scene, shown, meshes = render_world(settle, rng, p)
        step = Step(step=i, objects_left=int(present.sum()), found=False)
        t0 = time.perf_counter()
        result, capture = _plan_step(pipeline, scene, step, out_dir, draws)
        step.plan_ms = (time.perf_counter() - t0) * 1e3
        step.segments = capture.segments
        if result is None or not result.found:
            step.kind = "no_grasp"
            step.hint = "" if result is None else result.hint
        else:
            step.found = True
            target, share = _target(capture.object_points, meshes)
            k_target = shown[target]
            step.target = names[k_target]
            grip.set_poses(poses, present)
            before = grip.data.xipos[grip.bodies].copy()  # (n, 3)
            world = _target_scene(grip, k_target)
            from wsgrasp.sim.trial import execute_grasp

            ex = execute_grasp(
                world,
                poses[k_target],
                np.asarray(result.T_world_ee, dtype=np.float64),
                p,
                T_world_pregrasp=result.T_world_pregrasp,
                joints_pregrasp=dict(result.joints_pregrasp),
                joints_grasp=dict(result.joints_grasp),
                error=execution_error(rng, p),
                film=film_dir is not None,
            )
            if film_dir is not None:
                step.film = _draw_step(ex, step, Path(film_dir))
            after = grip.data.xipos[grip.bodies].copy()
            rise = after[:, 2] - before[:, 2]
            lifted = present & (rise > p.lifted_fraction * p.lift_height)
            # the neighbours moved before the lift (by the gripper, or by the
            # target it pushed): one that moves later, as a failed grasp lets
            # its target fall back onto the pile, says nothing of the approach
            assert ex.xipos_closed is not None
            closed = ex.xipos_closed[grip.bodies]
            pushed = present & (
                np.linalg.norm(closed[:, :2] - before[:, :2], axis=1)
                > p.displaced_distance
            )
            pushed[k_target] = False
            touched = np.isin(grip.bodies, ex.touched)
            first = np.isin(grip.bodies, ex.touched_first)
            step.outcome = ex.outcome
            step.success = ex.outcome == "success"
            step.lifted = [names[k] for k in np.flatnonzero(lifted)]
            step.pushed = [names[k] for k in np.flatnonzero(pushed)]
            step.touched = [names[k] for k in np.flatnonzero(touched)]
            step.touched_first = [names[k] for k in np.flatnonzero(first)]
            step.touched_by = _touched_by(grip, names, ex.touched_by)
            step.kind = _kind(ex.outcome, share, int(lifted.sum()), bool(first.any()))
            # what is left settles where the attempt left it
            poses = grip.poses()
            present = present & ~lifted
            settle.set_poses(poses, present)
            settle.settle(p)
            present = settle.on_table(p)
            poses = settle.poses()
        steps.append(step)
        if _two_failures(steps):
            end = "two_failures"
            break
    else:
        if not present.any():
            end = "clear"
    # removed: lifted by a grasp; what left the table otherwise (pushed or
    # knocked off) is no more on it, but was not removed
    lifted_names = {n for s in steps for n in s.lifted}
    removed = len(lifted_names)
    fell_off = [
        n for n in start if n not in lifted_names and not present[names.index(n)]
    ]
    summary = {
        "scene": kind,
        "seed": seed,
        "pick": pick,
        "objects": start,
        "attempts": len(steps),
        "successes": sum(s.success for s in steps),
        "removed": removed,
        "fell_off": fell_off,
        "end": end,
        "steps": [s.__dict__ for s in steps],
    }
    if out_dir is not None:
        (out_dir / "clutter.json").write_text(json.dumps(summary, indent=1) + "\n")
    return summary


def _draw_step(ex: Any, step: Step, folder: Path) -> str:
    """Draw a filmed attempt (``folder/step-NN.png``; the objects off the
    table, parked far from it, fall outside every frame); returns the path."""
    from wsgrasp.sim.film import draw_film

    path = folder / f"step-{step.step:02d}.png"
    title = f"step {step.step}: {step.target} of {step.objects_left} left, "
    draw_film(ex.film, path, title=title + ex.outcome)
    return str(path)


def _two_failures(steps: list[Step]) -> bool:
    """Whether the last two steps both failed to remove anything: no grasp
    found, or nothing lifted off the table. A step that lifted its target but
    let it slip in the grip failed the trial protocol, yet cleared the table
    of it, as clutter-removal benchmarks count a grasp (VGN: consecutive
    attempts that lifted nothing end the round)."""
    return len(steps) >= 2 and not steps[-1].lifted and not steps[-2].lifted


def _plan_step(
    pipeline: Any,
    scene: Any,
    step: Step,
    out_dir: Path | None,
    draws: np.random.Generator | None = None,
) -> tuple[Any, _Capture]:
    """Plan a step: the pipeline's own target first; where it finds no grasp,
    the other targets the first plan's instances give (:func:`_other_targets`),
    until one has a grasp. Each plan is recorded in
    ``out_dir`` (``step-NN-T.mcap``, try ``T``) and listed in ``step.records``;
    ``step.tries`` counts them. With ``draws``, a plan's grasp is a random
    feasible candidate of it (:func:`_random_choice`) instead of its choice.
    Returns the last plan (None where it raised) and what it segmented."""
    from copy import copy

    from wsgrasp.errors import WsgraspError

    order: list[Any] | None = None
    current = pipeline
    result: Any = None
    capture = _Capture()
    while True:
        capture = _Capture()
        observers: list[Any] = [capture]
        recorder = None
        if out_dir is not None:
            from wsgrasp.record import RunRecorder

            name = f"step-{step.step:02d}-{step.tries}.mcap"
            recorder = RunRecorder(out_dir / name, force=True)
            observers.append(recorder)
            step.records.append(name)
        step.tries += 1
        try:
            result = current.plan(scene, observers=observers)
        except WsgraspError as exc:
            result = None
            step.error = str(exc).splitlines()[0]
        finally:
            if recorder is not None:
                recorder.close()
        if result is not None:
            ms = float(result.timing_ms.get("total", 0.0))
            step.pipeline_ms += ms
            if step.tries == 1:
                step.first_plan_ms = ms
        if result is not None and result.found and draws is not None:
            result = _random_choice(current, scene, result, draws, step)
        if result is not None and result.found:
            return result, capture
        if order is None:
            order = _other_targets(
                [] if result is None else result.info.get("segments", [])
            )
        if not order:
            return result, capture
        current = copy(pipeline)
        current.spec = pipeline.spec.model_copy(update={"target": order.pop(0)})


def _random_choice(
    pipeline: Any, scene: Any, result: Any, draws: np.random.Generator, step: Step
) -> Any:
    """The plan that takes a random feasible candidate of ``result`` instead
    of its choice: the first of :data:`~wsgrasp.sim.runner.BASELINE_DRAWS`
    uniform draws whose plan finds a grasp (a drawn candidate's pre-grasp pose
    can lie in the table), finished as the choice is; where none does, a plan
    without a grasp (``found`` false) that says so. The executed candidate's
    index goes to ``step.candidate``."""
    from dataclasses import replace

    from wsgrasp.sim.runner import random_candidates

    drawn = random_candidates(result, draws, 1)
    unique = list(dict.fromkeys(drawn))
    for index, plan in zip(unique, pipeline.plan_choices(scene, unique), strict=True):
        if plan.found and plan.T_world_ee is not None:
            step.candidate = index
            return plan
    return replace(
        result,
        found=False,
        hint=f"none of the {len(unique)} random feasible candidates drawn has a "
        "grasp (each one's pre-grasp pose lies in the table)",
    )


def _other_targets(segs: list[dict[str, Any]]) -> list[Any]:
    """What to plan for where the first target has no grasp: the other
    instances, highest first (rule ``id``), then each cluster the segmenter
    split into several instances, as one object, highest first (rule
    ``cluster``: an object split at a concave seam of its own)."""
    from wsgrasp.spec import TargetRule

    high = sorted(segs, key=lambda s: -s["top"])
    order = [TargetRule(rule="id", id=s["id"]) for s in high if not s["target"]]
    size = Counter(s["cluster"] for s in segs)
    seen: set[int] = set()
    for s in high:
        if size[s["cluster"]] > 1 and s["cluster"] not in seen:
            seen.add(s["cluster"])
            order.append(TargetRule(rule="cluster", id=s["id"]))
    return order


def _target(
    object_points: Array | None, meshes: list[tuple[Any, Array]]
) -> tuple[int, float]:
    """The mesh most of the target's points lie on, and the share of them on
    the second most."""
    if object_points is None or not len(object_points):
        return 0, 0.0
    owners = object_owners(object_points, meshes)
    counts = np.bincount(owners, minlength=len(meshes))
    order = np.argsort(-counts)
    second = float(counts[order[1]]) / len(owners) if len(meshes) > 1 else 0.0
    return int(order[0]), second


def _kind(outcome: str, share: float, lifted: int, in_the_way: bool) -> str | None:
    """The failure kind of an executed attempt (None for a success);
    ``in_the_way``: the gripper touched a neighbour before the target."""
    if lifted > 1:
        return "two_lifted"
    if outcome == "success":
        return None
    if share >= WRONG_SPLIT_SHARE:
        return "wrong_split"
    if outcome == "approach_collision" or in_the_way:
        return "neighbour_collision"
    return "slip"


def _touched_by(
    grip: ClutterWorld, names: list[str], touched_by: dict[int, NDArray[np.int64]]
) -> dict[str, list[str]]:
    """Per neighbour touched (its name in ``names``, as ``grip.bodies`` orders
    them), the names of the gripper's links that touched it."""
    mujoco = require_mujoco()
    from wsgrasp.sim.gripper import PREFIX

    bodies = list(grip.bodies)
    out: dict[str, list[str]] = {}
    for body, links in sorted(touched_by.items()):
        if body not in bodies:
            continue
        out[names[bodies.index(body)]] = [
            str(
                mujoco.mj_id2name(grip.model, mujoco.mjtObj.mjOBJ_BODY, int(b))
            ).removeprefix(PREFIX)
            for b in links
        ]
    return out


def _target_scene(world: ClutterWorld, k: int) -> Any:
    """``world`` as the trial's ``SimScene`` with object ``k`` as its object."""
    mujoco = require_mujoco()
    from wsgrasp.sim.gripper import PREFIX
    from wsgrasp.sim.scene import DRIVE_JOINTS, SimScene, _has_ancestor

    m = world.model
    g = world.gripper
    root = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, g.root_body)
    gbodies = [b for b in range(m.nbody) if _has_ancestor(m, b, root)]
    gj = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, DRIVE_JOINTS[0])
    qa, da = int(m.jnt_qposadr[gj]), int(m.jnt_dofadr[gj])
    joint_qpos: dict[str, int] = {}
    for j in range(m.njnt):
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or ""
        if name.startswith(PREFIX):
            joint_qpos[name[len(PREFIX) :]] = int(m.jnt_qposadr[j])
    return SimScene(
        model=m,
        data=world.data,
        object_body=world.bodies[k],
        object_qpos=world.qpos[k],
        object_dof=world.dof[k],
        gripper=g,
        gripper_bodies=np.asarray(gbodies, dtype=np.int64),
        gripper_qpos=slice(qa, qa + 6),
        gripper_dof=slice(da, da + 6),
        root_body=root,
        table_geom=mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "table"),
        joint_qpos=joint_qpos,
    )


def clutter_summary(scenes: list[dict[str, Any]]) -> dict[str, Any]:
    """Grasp success rate (successes / attempts: held to the end of the trial
    protocol), lift rate (attempts that took their target off the table /
    attempts: what clutter-removal benchmarks count as a successful grasp, a
    grasp that slipped in the grip under the ``strict`` disturbances included),
    declutter rate (removed / objects), the failed attempts by kind, the
    attempts whose gripper touched a neighbour while it approached and closed
    (``touched_neighbour``), those of them that touched it before the target
    (``touched_neighbour_first``) and the attempts that lifted two objects or more
    (``two_lifted``; both successes too) over
    ``scenes`` (:func:`run_clutter_scene`'s results), with the steps' planning
    times (ms):
    wall-clock with recording (median, maximum), the plans' own time (median)
    and the first plan's (median, 90th percentile)."""
    attempts = sum(s["attempts"] for s in scenes)
    successes = sum(s["successes"] for s in scenes)
    objects = sum(len(s["objects"]) for s in scenes)
    removed = sum(s["removed"] for s in scenes)
    kinds: dict[str, int] = {}
    times, own, first = [], [], []
    two = 0
    target_lifted = 0
    touched = touched_first = 0
    for s in scenes:
        for st in s["steps"]:
            times.append(st["plan_ms"])
            touched += bool(st.get("touched"))
            touched_first += bool(st.get("touched_first"))
            target_lifted += bool(st.get("target")) and st["target"] in st["lifted"]
            if st.get("first_plan_ms"):
                own.append(st["pipeline_ms"])
                first.append(st["first_plan_ms"])
            two += st["kind"] == "two_lifted"
            if st["kind"] and not st["success"]:
                kinds[st["kind"]] = kinds.get(st["kind"], 0) + 1
    return {
        "scenes": len(scenes),
        "objects": objects,
        "attempts": attempts,
        "successes": successes,
        "removed": removed,
        "target_lifted": target_lifted,
        "grasp_success_rate": successes / attempts if attempts else None,
        "lift_rate": target_lifted / attempts if attempts else None,
        "declutter_rate": removed / objects if objects else None,
        "failure_kinds": kinds,
        "two_lifted": two,
        "touched_neighbour": touched,
        "touched_neighbour_first": touched_first,
        "plan_ms_median": float(np.median(times)) if times else None,
        "plan_ms_max": float(np.max(times)) if times else None,
        "pipeline_ms_median": float(np.median(own)) if own else None,
        "first_plan_ms_median": float(np.median(first)) if first else None,
        "first_plan_ms_p90": float(np.percentile(first, 90)) if first else None,
    }
