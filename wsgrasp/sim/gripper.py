"""A gripper in MuJoCo, built from the same URDF and YAML as the planner's model.

The URDF is read by the planner's reader, :func:`wsgrasp.gripper._urdf.
load_kinematics` (yourdfpy), and the subtree carried by the YAML's ``base_link`` is
written out as MJCF: the links above the base link (an arm the hand is mounted on)
are left out, and the base link becomes the root body that the trial's drive
carries. The bodies collide with the same shapes the planner samples (collision
elements; visual ones for a link without any), mesh shapes as their convex hulls.
What happens to mimic joints does not depend on the MuJoCo version: each becomes a
joint equality ``q = offset + multiplier * q_master``, limited to the range its
master maps to. Every other movable joint gets a position actuator (gains in
:class:`~wsgrasp.sim.params.SimParams`). Vendor values MuJoCo refuses or that are
placeholders (inertials, ``effort``, a mimic joint's own limits) are replaced as
:mod:`wsgrasp.sim._repairs` describes, and each replacement is listed in
:attr:`SimGripper.repairs`.

:mod:`wsgrasp.sim.scene` mounts the root body on a 6-DoF drive that the trial
moves.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp._names import is_gripper_path
from wsgrasp.errors import SimulationError
from wsgrasp.geometry import JOINT_FIXED, JOINT_PRISMATIC
from wsgrasp.gripper._jaws import independent_jaws
from wsgrasp.gripper._urdf import Joint, Kinematics, Shape, load_kinematics, shape_mesh
from wsgrasp.sim._mujoco import require_mujoco
from wsgrasp.sim._repairs import (
    MIN_THICKNESS,
    Repair,
    effort_limit,
    link_mass_properties,
    mimic_range,
)
from wsgrasp.sim._xml import attrs, fmt, pose_attrs, quat_wxyz
from wsgrasp.sim.params import SimParams

__all__ = ["SimGripper", "load_sim_gripper", "sim_gripper_from_files"]

Array = NDArray[np.float64]

#: name prefix of the gripper's bodies, joints and geoms in the MJCF
PREFIX = "g/"
#: grid (m) a mesh's vertices are snapped to when its convex hull comes out open
HULL_GRID = 1e-5
#: collision bits: gripper geoms touch the table and the object, not each other
GRIPPER_CONTYPE, GRIPPER_CONAFFINITY = 2, 1


@dataclass
class SimGripper:
    """A gripper ready to be put in a MuJoCo scene.

    Attributes
    ----------
    name : str
    body_xml : str
        The ``<body>`` tree rooted at the YAML's ``base_link``.
    asset_xml, equality_xml, actuator_xml : str
        What the body needs in ``<asset>``, ``<equality>``, ``<actuator>``.
    root_body : str
        MJCF name of the root body (the base link, carried by the trial's drive).
    T_root_base : (4, 4) float
        The base link in the root body's frame: the identity, since the root body
        is the base link.
    approach_axis, closing_axis : (3,) float
        In the base frame.
    actuated : list of str
        Joints with an actuator, in actuator order (URDF file order).
    pregrasp, closed : (A,) float
        Actuator targets of the YAML's open and closed postures.
    qpos_pregrasp : dict of str to float
        Every movable joint (mimic joints included) in the pregrasp posture.
    lower, upper : (A,) float
        Limits of the actuated joints (-inf, inf for a continuous joint).
    mimics : dict of str to (str, float, float)
        Each mimic joint's ``(actuated master, multiplier, offset)``, the mimic
        chain composed: ``q = offset + multiplier * q_master``.
    efforts : dict of str to (float, str, str)
        Each actuated joint's force limit, its unit (``N`` or ``N·m``) and where
        it came from (``urdf`` or ``default``).
    gains : dict of str to (float, str)
        The position gain of each kind of finger joint (``revolute`` in N·m/rad,
        ``prismatic`` in N/m) and where it came from: ``gripper`` (the YAML's
        ``drive``) or ``params`` (the run's ``kp_revolute`` / ``kp_prismatic``).
    joint_gains : dict of str to float
        The gains of single actuated joints over their kind's (the YAML's
        ``drive.joints``).
    repairs : list of Repair
        The URDF's values replaced (inertials, efforts, mimic limits), with what
        was wrong and what was used instead.
    """

    name: str
    body_xml: str
    asset_xml: str
    equality_xml: str
    actuator_xml: str
    root_body: str
    T_root_base: Array
    approach_axis: Array
    closing_axis: Array
    actuated: list[str]
    pregrasp: Array
    closed: Array
    qpos_pregrasp: dict[str, float] = field(default_factory=dict)
    lower: Array = field(default_factory=lambda: np.zeros(0))
    upper: Array = field(default_factory=lambda: np.zeros(0))
    mimics: dict[str, tuple[str, float, float]] = field(default_factory=dict)
    efforts: dict[str, tuple[float, str, str]] = field(default_factory=dict)
    gains: dict[str, tuple[float, str]] = field(default_factory=dict)
    joint_gains: dict[str, float] = field(default_factory=dict)
    repairs: list[Repair] = field(default_factory=list)
    #: what the trials will show that the description could change (two
    #: mirrored jaws driven apart, which float together at their force limit)
    warnings: list[str] = field(default_factory=list)

    def notes_json(self) -> dict[str, Any]:
        """The efforts and repairs as plain data (what a report carries)."""
        return {
            "efforts": {
                j: {"effort": v, "unit": unit, "source": src}
                for j, (v, unit, src) in self.efforts.items()
            },
            "gains": {
                kind: {"kp": v, "source": src} for kind, (v, src) in self.gains.items()
            },
            **(
                {"joint_gains": {j: {"kp": v} for j, v in self.joint_gains.items()}}
                if self.joint_gains
                else {}
            ),
            "repairs": [r.to_json() for r in self.repairs],
            **({"warnings": list(self.warnings)} if self.warnings else {}),
        }

    def targets(
        self, posture: Mapping[str, float], default: Array, where: str = "posture"
    ) -> Array:
        """Actuator targets ``(A,)`` of a posture (actuated joint name to value),
        clipped into the joint limits; joints it does not name keep ``default``.

        Raises
        ------
        SimulationError
            ``posture`` names a joint that is not an actuated joint of the gripper.
        """
        out = np.array(default, dtype=np.float64, copy=True)  # (A,)
        index = {j: i for i, j in enumerate(self.actuated)}
        for joint, value in posture.items():
            if joint not in index:
                raise SimulationError(
                    f"gripper {self.name!r}: {where} names joint {joint!r}, which is "
                    "not an actuated joint of the simulated gripper",
                    hint="give values for these joints: " + ", ".join(self.actuated),
                )
            out[index[joint]] = float(value)
        return np.clip(out, self.lower, self.upper)

    def joint_qpos(self, targets: Array) -> dict[str, float]:
        """Every movable joint's position (mimics included) when the actuated
        joints are at ``targets`` ``(A,)``."""
        q = {j: float(v) for j, v in zip(self.actuated, targets, strict=True)}
        for joint, (master, mult, off) in self.mimics.items():
            q[joint] = mult * q[master] + off
        return q


def load_sim_gripper(name: str, params: SimParams | None = None) -> SimGripper:
    """The simulated gripper of a registered gripper name or a gripper YAML path."""
    from wsgrasp.plugins import get_registry
    from wsgrasp.spec import load_gripper_description

    path = Path(name)
    if not is_gripper_path(name):
        entry = get_registry().get("grippers", name)
        obj = entry.obj
        if not isinstance(obj, (str, Path)):
            desc = getattr(obj, "description", None)
            src = desc.get("_source") if isinstance(desc, dict) else None
            if src is None:
                raise SimulationError(
                    f"gripper {name!r} is registered as a built model, not as a "
                    "YAML beside a URDF, so it cannot be simulated",
                    hint="register the gripper by the path of its YAML",
                )
            obj = src
        path = Path(obj)
    desc, base_dir = load_gripper_description(path)
    return sim_gripper_from_files(desc.model_dump(), base_dir, params)


def sim_gripper_from_files(
    description: dict[str, Any], base_dir: Path, params: SimParams | None = None
) -> SimGripper:
    """Build the simulated gripper from a gripper description (as a dict, the
    YAML's content) and the directory its ``urdf`` path is relative to.

    Raises
    ------
    GripperError
        The URDF is missing or unreadable, or ``base_link`` is not one of its links
        (the planner's reader says which).
    SimulationError
        The postures are missing or name joints the gripper does not move.
    """
    p = params or SimParams()
    name = str(description["name"])
    urdf = Path(str(description["urdf"])).expanduser()
    if not urdf.is_absolute():
        urdf = Path(base_dir) / urdf
    kin = load_kinematics(urdf.resolve(), name)
    base = str(description["base_link"])
    kin.check_link(base, name, "base_link")
    pregrasp = {
        str(k): float(v) for k, v in (description.get("pregrasp") or {}).items()
    }
    closed = {str(k): float(v) for k, v in (description.get("closed") or {}).items()}
    if not closed:
        raise SimulationError(
            f"gripper {name!r} has no closed configuration",
            hint="add `closed: {joint: position, ...}` to the gripper YAML: the "
            "joint positions the fingers close towards",
        )
    movable = [j for j in kin.subtree_joints(base) if j.kind != JOINT_FIXED]
    movable_names = {j.name for j in movable}
    actuated = [j for j in movable if j.mimic is None]
    if not actuated:
        raise SimulationError(
            f"gripper {name!r}: no movable joint below base_link {base!r} in "
            f"{urdf.name}",
            hint="set base_link to the link that carries the fingers",
        )
    mimics: dict[str, tuple[str, float, float]] = {}
    for j in movable:
        if j.mimic is not None:
            mimics[j.name] = kin.mimic_of(j.name)
            if mimics[j.name][0] not in movable_names:
                raise SimulationError(
                    f"gripper {name!r}: joint {j.name!r} mimics "
                    f"{mimics[j.name][0]!r}, which is not below base_link {base!r}",
                    hint="set base_link to a link that carries both joints",
                )
    drive = description.get("drive") or {}
    joint_gains = drive.get("joints") or {}
    for label, posture in (
        ("pregrasp", pregrasp),
        ("closed", closed),
        ("drive.joints", joint_gains),
    ):
        for jn in posture:
            if jn not in movable_names:
                raise SimulationError(
                    f"gripper {name!r}: {label} names joint {jn!r}, which is not a "
                    f"movable joint below base_link {base!r} of {urdf.name}",
                    hint="use the URDF's joint names: "
                    + ", ".join(j.name for j in movable),
                )
            if jn in mimics:
                raise SimulationError(
                    f"gripper {name!r}: {label} sets {jn!r}, a mimic joint of "
                    f"{mimics[jn][0]!r}",
                    hint=f"set {mimics[jn][0]!r} instead; mimics follow it",
                )
    lower = np.array([-np.inf if j.continuous else j.lower for j in actuated])
    upper = np.array([np.inf if j.continuous else j.upper for j in actuated])
    # (A,) a joint that a posture leaves out sits at its pregrasp value, else at 0
    pre = np.clip([pregrasp.get(j.name, 0.0) for j in actuated], lower, upper)
    clo = np.clip(
        [closed.get(j.name, pregrasp.get(j.name, 0.0)) for j in actuated], lower, upper
    )
    if np.allclose(pre, clo):
        raise SimulationError(
            f"gripper {name!r}: the closed configuration equals the pregrasp one",
            hint="set `closed` in the gripper YAML to the posture the fingers close "
            "towards",
        )
    gripper = SimGripper(
        name=name,
        body_xml="",
        asset_xml="",
        equality_xml="",
        actuator_xml="",
        root_body=PREFIX + base,
        T_root_base=np.eye(4),
        approach_axis=np.asarray(description["approach_axis"], dtype=np.float64),
        closing_axis=np.asarray(description["closing_axis"], dtype=np.float64),
        actuated=[j.name for j in actuated],
        pregrasp=pre,
        closed=clo,
        lower=lower,
        upper=upper,
        mimics=mimics,
    )
    gripper.qpos_pregrasp = gripper.joint_qpos(pre)
    repairs: list[Repair] = []
    ranges: dict[str, tuple[float, float] | None] = {}
    for jn, (master, mult, off) in mimics.items():
        ranges[jn], fix = mimic_range(kin.joints[jn], kin.joints[master], mult, off)
        repairs += [fix] if fix else []
    for j in actuated:
        effort, fix = effort_limit(j, p)
        unit = "N" if j.kind == JOINT_PRISMATIC else "N·m"
        gripper.efforts[j.name] = (effort, unit, "default" if fix else "urdf")
        repairs += [fix] if fix else []
    assets: list[str] = []
    body_repairs: list[Repair] = []
    # a rigid jaw's link: the object is pushed against its face, which the
    # link's convex hull would cover where the link is concave (a jaw standing
    # out of a motor housing); it collides as its convex parts
    jaws = {
        str(f["pad"]["link"])
        for f in description.get("fingers") or []
        if not f.get("joints")
    }
    gripper.body_xml = _body(kin, base, None, p, assets, ranges, body_repairs, jaws)
    gripper.repairs = body_repairs + repairs
    gripper.asset_xml = "\n".join(assets)
    gripper.equality_xml = "\n".join(
        "<joint "
        + attrs(
            name=f"{PREFIX}mimic/{j.name}",
            joint1=PREFIX + j.name,
            joint2=PREFIX + j.mimic[0],
            polycoef=fmt((j.mimic[2], j.mimic[1], 0, 0, 0)),
            solref=(p.mimic_timeconst, 1.0),
            solimp=(p.mimic_impedance, p.mimic_impedance, 0.001, 0.5, 2.0),
        )
        + "/>"
        for j in movable
        if j.mimic is not None
    )
    for kind in ("revolute", "prismatic"):
        own = drive.get(f"kp_{kind}")
        gripper.gains[kind] = (
            (float(own), "gripper")
            if own is not None
            else (float(getattr(p, f"kp_{kind}")), "params")
        )
    gripper.joint_gains = {jn: float(kp) for jn, kp in joint_gains.items()}
    gripper.actuator_xml = _actuators(gripper, actuated)
    weak = _weak_efforts(gripper, actuated, p)
    if weak:
        gripper.repairs += weak
        gripper.actuator_xml = _actuators(gripper, actuated)
    coupling = independent_jaws(kin, description)
    if coupling is not None:
        gripper.warnings.append(
            f"gripper {name!r}: its jaws on joints {coupling.leader!r} and "
            f"{coupling.follower!r} mirror each other but are driven apart: under a "
            "side push each gives way on its own (at their force limit on an "
            "object, they float together), and the object moves in the grip "
            "(slipped_in_grip). If one drive moves both, `wsgrasp gripper check` "
            "says how to couple them"
        )
    return gripper


def _actuators(gripper: SimGripper, actuated: list[Joint]) -> str:
    """The ``<actuator>`` elements of ``actuated`` at the gripper's gains and
    efforts."""
    return "\n".join(
        _actuator(
            j,
            gripper.gains,
            gripper.efforts[j.name][0],
            gripper.joint_gains.get(j.name),
        )
        for j in actuated
    )


#: a joint whose URDF effort, free of any object, leaves it this fraction of its
#: travel from ``pregrasp`` to ``closed`` short of where the default effort takes
#: it is driven with the default: the effort cannot move the finger's own
#: linkage (TIAGo Pro's gripper, 0.1 N·m on a four-bar of six joints, stops 40 %
#: of the way; 5 N·m closes it 99 %)
EFFORT_SHORTFALL = 0.2


def _default_effort(j: Joint, p: SimParams) -> float:
    return p.effort_prismatic if j.kind == JOINT_PRISMATIC else p.effort_revolute


def _weak_efforts(
    gripper: SimGripper, actuated: list[Joint], p: SimParams
) -> list[Repair]:
    """Close ``gripper`` free of any object with the URDF's efforts, and with the
    default effort on each joint whose URDF effort is below it; each such joint
    that the default closes :data:`EFFORT_SHORTFALL` further gets the default in
    ``gripper.efforts`` and a repair saying how far each closed it."""
    low = [
        j
        for j in actuated
        if gripper.efforts[j.name][2] == "urdf"
        and gripper.efforts[j.name][0] < _default_effort(j, p)
    ]
    if not low:
        return []
    try:
        own = free_closing(gripper, p)
    except SimulationError:
        return []  # mujoco missing, or the gripper does not compile: a trial says
    strong = replace(gripper, efforts=dict(gripper.efforts))
    for j in low:
        strong.efforts[j.name] = (_default_effort(j, p), *gripper.efforts[j.name][1:])
    strong.actuator_xml = _actuators(strong, actuated)
    default = free_closing(strong, p)
    repairs = []
    for j in low:
        i = gripper.actuated.index(j.name)
        if default[i] - own[i] <= EFFORT_SHORTFALL:
            continue
        effort, unit, _ = gripper.efforts[j.name]
        gripper.efforts[j.name] = (_default_effort(j, p), unit, "default")
        kind = "prismatic" if j.kind == JOINT_PRISMATIC else "revolute"
        repairs.append(
            Repair(
                j.name,
                "effort",
                f"effort {effort:g} {unit} closes the finger {own[i]:.0%} of the "
                f"way to closed, free of any object (the default effort: "
                f"{default[i]:.0%})",
                f"{_default_effort(j, p):g} {unit}, the default for a {kind} "
                "finger joint",
            )
        )
    return repairs


def free_closing(gripper: SimGripper, p: SimParams) -> Array:
    """How far each actuated joint of ``gripper`` closes ``(A,)``, held in the
    air with nothing between its fingers, its targets ramped from ``pregrasp``
    to ``closed`` as a trial ramps them: 0 at ``pregrasp``, 1 at ``closed``."""
    from wsgrasp.sim.objects import Part, SimObject
    from wsgrasp.sim.scene import build_scene
    from wsgrasp.sim.trial import close_fingers

    mujoco = require_mujoco()
    # the scene needs an object: a small ball on the table, far from the gripper
    scene = build_scene(
        SimObject("probe", [Part("sphere", (0.005,))], 0.01), gripper, p
    )
    m, d = scene.model, scene.data
    assert scene.gripper_qpos is not None
    mujoco.mj_resetData(m, d)
    d.qpos[scene.object_qpos] = [0.2, 0.2, 0.005, 1.0, 0.0, 0.0, 0.0]
    d.qpos[scene.gripper_qpos] = 0.0
    d.qpos[scene.gripper_qpos][2] = d.ctrl[2] = 0.5  # half a metre above the table
    for jn, v in gripper.qpos_pregrasp.items():
        d.qpos[scene.joint_qpos[jn]] = v
    d.ctrl[6:] = gripper.pregrasp
    mujoco.mj_forward(m, d)
    close_fingers(m, d, gripper.pregrasp, gripper.closed, p)
    q = np.array([d.qpos[scene.joint_qpos[jn]] for jn in gripper.actuated])
    span = gripper.closed - gripper.pregrasp
    moves = np.abs(span) > 1e-9
    return np.where(moves, (q - gripper.pregrasp) / np.where(moves, span, 1.0), 1.0)


# --------------------------------------------------------------------------------
def _body(
    kin: Kinematics,
    link: str,
    joint: Joint | None,
    p: SimParams,
    assets: list[str],
    ranges: dict[str, tuple[float, float] | None],
    repairs: list[Repair],
    concave: set[str] = frozenset(),  # type: ignore[assignment]
) -> str:
    """The ``<body>`` of ``link`` and, nested, of every link below it; ``joint``
    attaches it to its parent (None for the root body). ``ranges`` holds the
    mimic joints' ranges; the inertial repairs are appended to ``repairs``. The
    mesh shapes of the links in ``concave`` collide as their convex
    decompositions, the others' as their convex hulls."""
    head = f'<body name="{PREFIX}{link}" gravcomp="1"'
    if joint is not None:
        head += " " + pose_attrs(joint.origin)
    lines = [head + ">"]
    moving = joint is not None and joint.kind != JOINT_FIXED
    if joint is not None and moving:
        prismatic = joint.kind == JOINT_PRISMATIC
        limits = (
            ranges[joint.name]
            if joint.name in ranges
            else (None if joint.continuous else (joint.lower, joint.upper))
        )
        lines.append(
            "<joint "
            + attrs(
                name=PREFIX + joint.name,
                type="slide" if prismatic else "hinge",
                axis=joint.axis,
                range=None if limits is None else fmt(limits),
                limited="false" if limits is None else "true",
                damping=p.damping_prismatic if prismatic else p.damping_revolute,
                armature=p.armature_prismatic if prismatic else p.armature_revolute,
            )
            + "/>"
        )
    shapes = kin.shapes.get(link, [])
    solids = [_solid(shape) for shape in shapes]  # each in its shape frame
    for shape, solid in zip(shapes, solids, strict=True):
        if shape.kind == "mesh" and solid.__class__.__name__ == "Box":
            name = shape.mesh_path.name if shape.mesh_path else "?"
            size = " x ".join(f"{e * 1e3:.3g}" for e in solid.primitive.extents)
            repairs.append(
                Repair(
                    link,
                    "geometry",
                    f"mesh {name} is flat (its convex hull has no volume)",
                    f"a box of its extent, {size} mm",
                )
            )
    props, fix = link_mass_properties(
        link,
        kin.inertials.get(link),
        [
            s.copy().apply_transform(shape.T_link_shape)
            for s, shape in zip(solids, shapes, strict=True)
        ],
        moving,
        p,
    )
    repairs += [fix] if fix else []
    if props is not None:
        moments, axes = props.principal()
        lines.append(
            "<inertial "
            + attrs(
                pos=props.com,
                quat=quat_wxyz(axes),
                mass=props.mass,
                diaginertia=moments,
            )
            + "/>"
        )
    for i, (shape, solid) in enumerate(zip(shapes, solids, strict=True)):
        name = f"{PREFIX}{link}/{i}"
        if link in concave and shape.kind == "mesh":
            lines += _convex_parts(shape, name, p, assets)
        else:
            lines.append(_geom(shape, solid, name, p, assets))
    for child in kin.child_joints(link):
        lines.append(
            _body(kin, child.child, child, p, assets, ranges, repairs, concave)
        )
    lines.append("</body>")
    return "\n".join(lines)


def _solid(shape: Shape) -> Any:
    """The body MuJoCo simulates for a shape, in the shape's frame: a trimesh
    primitive (whose mass properties are exact, as MuJoCo's), or a mesh's
    (scaled) convex hull; a flat mesh's hull, which has no volume, as a box of
    its extent, at least ``MIN_THICKNESS`` thick."""
    import trimesh

    if shape.kind == "box":
        return trimesh.primitives.Box(extents=shape.size)
    if shape.kind == "cylinder":
        return trimesh.primitives.Cylinder(radius=shape.size[0], height=shape.size[1])
    if shape.kind == "sphere":
        return trimesh.primitives.Sphere(radius=shape.size[0])
    mesh = shape_mesh(shape, frame="shape")
    try:
        with np.errstate(invalid="ignore", divide="ignore"):  # a flat hull's
            hull = mesh.convex_hull  # centre of mass divides by its volume, 0
            if not hull.is_watertight:
                # near-coplanar facets of a finely curved mesh can leave qhull's
                # hull open; vertices snapped to a grid far below the geometry's
                # size close it
                grid = np.round(np.asarray(mesh.vertices) / HULL_GRID) * HULL_GRID
                hull = trimesh.convex.convex_hull(np.unique(grid, axis=0))
            if hull.is_watertight and hull.volume > MIN_THICKNESS**3:
                return hull
    except Exception:  # noqa: BLE001 - qhull refuses points on a line or plane
        pass
    # flat: MuJoCo cannot make a hull of it either; a box of its extent
    lo, hi = np.asarray(mesh.bounds, dtype=np.float64)  # (2, 3)
    T = np.eye(4)
    T[:3, 3] = (lo + hi) / 2.0
    return trimesh.primitives.Box(
        extents=np.maximum(hi - lo, MIN_THICKNESS), transform=T
    )


def _geom(shape: Shape, solid: Any, name: str, p: SimParams, assets: list[str]) -> str:
    """A shape's ``<geom>``; ``solid`` is its mesh's hull or box (:func:`_solid`).
    Its mass is the body's ``<inertial>``, so the geom weighs nothing of its own."""
    import trimesh

    common = _geom_attrs(name, p)
    pose = pose_attrs(shape.T_link_shape)
    if shape.kind == "box":
        size = np.asarray(shape.size, dtype=np.float64) / 2.0
        return f'<geom type="box" size="{fmt(size)}" {pose} {common}/>'
    if shape.kind == "cylinder":
        r, length = shape.size
        return (
            f'<geom type="cylinder" size="{fmt((r, length / 2.0))}" {pose} {common}/>'
        )
    if shape.kind == "sphere":
        return f'<geom type="sphere" size="{fmt(shape.size[0])}" {pose} {common}/>'
    if isinstance(solid, trimesh.primitives.Box):  # a flat mesh (see _solid)
        pose = pose_attrs(shape.T_link_shape @ solid.primitive.transform)
        size = np.asarray(solid.primitive.extents, dtype=np.float64) / 2.0
        return f'<geom type="box" size="{fmt(size)}" {pose} {common}/>'
    # a mesh: its convex hull (scaled), in the shape's frame
    hull = np.asarray(solid.vertices, dtype=np.float64)  # (n, 3)
    mesh_name = name + "/mesh"
    assets.append(f'<mesh name="{mesh_name}" vertex="{fmt(hull.reshape(-1))}"/>')
    return f'<geom type="mesh" mesh="{mesh_name}" {pose} {common}/>'


def _convex_parts(
    shape: Shape, name: str, p: SimParams, assets: list[str]
) -> list[str]:
    """A mesh shape's ``<geom>`` elements, one per convex part of its coacd
    decomposition (cached as the objects' are: :mod:`wsgrasp.sim._meshes`)."""
    from wsgrasp.sim._meshes import convex_decomposition

    parts = convex_decomposition(shape_mesh(shape, frame="shape")).hulls
    pose = pose_attrs(shape.T_link_shape)
    out = []
    for k, hull in enumerate(parts):
        part = f"{name}/part{k}"
        verts = np.asarray(hull, dtype=np.float64).reshape(-1)
        assets.append(f'<mesh name="{part}" vertex="{fmt(verts)}"/>')
        common = _geom_attrs(part, p)
        out.append(f'<geom type="mesh" mesh="{part}" {pose} {common}/>')
    return out


def _geom_attrs(name: str, p: SimParams) -> str:
    """What every gripper geom carries: its name, collision classes, no mass
    of its own (the body's ``<inertial>`` has it), friction."""
    return attrs(
        name=name,
        contype=GRIPPER_CONTYPE,
        conaffinity=GRIPPER_CONAFFINITY,
        density=0,
        friction=fmt((p.gripper_friction, p.torsional_friction, p.rolling_friction)),
        group=1,
    )


def _actuator(
    j: Joint,
    gains: Mapping[str, tuple[float, str]],
    effort: float,
    own: float | None = None,
) -> str:
    """The position actuator of joint ``j``: at its kind's gain, or at ``own``
    where the joint has a gain of its own."""
    kind = "prismatic" if j.kind == JOINT_PRISMATIC else "revolute"
    return (
        "<position "
        + attrs(
            name=PREFIX + j.name,
            joint=PREFIX + j.name,
            kp=gains[kind][0] if own is None else own,
            ctrlrange=None if j.continuous else fmt((j.lower, j.upper)),
            forcerange=fmt((-effort, effort)),
        )
        + "/>"
    )
