"""Physical parameters of the grasp trials, in one place.

They are the same for every object and every gripper; nothing is tuned per object.
Units are SI. Values and why:

Simulation
    ``timestep`` 2 ms with MuJoCo's ``implicitfast`` integrator, elliptic friction
    cones and ``impratio`` 10 (MuJoCo's recommendation against slip in grasping).

    ``noslip_iterations`` 10: MuJoCo's noslip post-processing, which removes the
    drift in the friction dimensions that its soft constraints let through.
    Without it a grip creeps though it is well inside its friction cone, which
    static friction does not: the jaw of ``tests/test_sim.py`` holding a box
    whose weight needs 0.09, 0.4, 0.6 and 0.8 of the grip's friction (μ times
    the sum of the normal forces) let it slide 0.7, 2.5, 3.6 and 4.7 mm in a
    10 s hold; with the noslip pass 0.07 mm or less. Past the friction limit
    the box slips out either way (0.92 and 1.03 of it, and more), so the pass
    makes grips no stickier than Coulomb friction. In the grasp trials the
    creep was most of the objects dropped while held (allegro_right on
    ``random:000-199``, 1 trial: 10 dropped without it, 1 with it).

Contacts
    Every contact with the object uses the object's parameters (the object's geoms
    have the higher ``priority``): sliding friction ``friction`` (the protocol's,
    below; ``--friction`` overrides it), torsional friction ``torsional_friction``
    (m), ``condim`` 4, ``solref`` (``contact_timeconst``, damping ratio 1) and
    MuJoCo's default ``solimp`` (0.9, 0.95, 1 mm). Contacts of the object with
    the table take the table's parameters instead (its ``priority`` is higher
    still): ``table_friction`` 0.8 whatever the protocol, and the same torsional
    and rolling friction, ``condim`` and ``solref``, so an object settles on the
    table in the same pose under every protocol and the same plans are executed.
    Gripper geoms do not collide with each other.

    ``contact_timeconst`` is 5 ms, not MuJoCo's default 20 ms: the objects are
    rigid plastic, and a contact 16 times softer let a pad pressing 40-50 N sink
    3.5 mm into the object. So deep inside a convex part, the collision's normal
    can flip from one step to the next (``random_066`` held by the Franka hand,
    44 N on four contacts, still for 3 s of the hold: at t = 6.546 s one pad's
    normal turned from (0.80, 0.60, 0) to (0.95, -0.30, 0.05) and the object fell
    out within 10 ms). At 5 ms the same grip sinks 0.5 mm. It stays above MuJoCo's
    stability floor of two time steps (4 ms).

Masses
    An object's mass is ``object_mass`` when one is forced (``--mass``), else the
    mass its set gives (``paper13``'s table, a ``masses.json`` beside the meshes),
    else ``density`` times the volume of its collision parts (mesh files without a
    mass, and the ``random`` set, whose URDFs give every one of the 1,000 objects
    the same 0.1 kg). 1,200 kg/m³ is the median of mass over mesh volume of the
    19 YCB objects in ``../shared/objects/ycb`` (their published masses; 54 to
    12,700 kg/m³: a sponge, hollow cups scanned as shells, a steel wrench) and the
    density of the solid plastics household things are made of (PP 900, ABS 1,050,
    PC 1,200 kg/m³). The mass is spread uniformly over the parts. A gripper
    link keeps its URDF ``<inertial>`` when the mass lies within
    [``link_mass_floor``, ``link_mass_ceiling``] (1 g, 50 kg) and the inertia is
    positive definite with A + B >= C; otherwise, and where the inertial is
    missing, its mass properties come from its collision geometry (meshes as
    their convex hulls, as simulated) at ``gripper_density``, scaled to the
    URDF's mass where that is plausible (:mod:`wsgrasp.sim._repairs`). 1000
    kg/m³: aluminium and plastic parts, hollow and thinner than their hulls;
    the six vendor hands of ``../shared/grippers`` with inertials weigh 600 to
    3,500 kg/m³ over their links' hulls, median 1,200. The gripper is
    gravity-compensated, as an arm holding it would be.

Gripper drive
    The gripper stands on a 6-DoF drive (slides along world x, y, z and hinges
    about them) with position actuators: stiffness ``drive_kp_linear`` (N/m) and
    ``drive_kp_angular`` (N·m/rad), force limits ``drive_force`` (N) and
    ``drive_torque`` (N·m), damping and armature as below; a Cartesian impedance
    controller of an arm, in miniature. The targets move along straight lines at
    ``approach_speed`` and ``lift_speed``; the gripper follows, and what it hits
    stops it instead of being passed through.

Finger drive
    Each actuated finger joint has a position actuator (gain ``kp_prismatic``
    N/m or ``kp_revolute`` N·m/rad), joint damping ``damping_prismatic`` /
    ``damping_revolute`` and armature ``armature_prismatic`` /
    ``armature_revolute``. Its force limit is the URDF's ``effort`` when that
    lies within [``effort_min_prismatic``, ``effort_max_prismatic``] (1-2000 N)
    or [``effort_min_revolute``, ``effort_max_revolute``] (0.1-200 N·m), else
    ``effort_prismatic`` (100 N, the Franka hand's jaw) or ``effort_revolute``
    (5 N·m): 0, 1000 or 1e6 are placeholders, not a finger's force; so is an
    effort below that default that cannot close the fingers in the air
    (``wsgrasp.sim.gripper.EFFORT_SHORTFALL``). URDF
    ``<mimic>`` joints are coupled to their master by a joint equality ``q =
    offset + multiplier * q_master`` and limited to the range that maps from
    the master's. Closing ramps
    the targets from the plan's ``joints_pregrasp`` to its ``joints_grasp`` (or,
    for a plan without them, from the YAML's ``pregrasp`` to its ``closed``
    posture) over ``close_time``, then waits ``close_wait``.

    A position-controlled finger presses only as far as its target lies past the
    surface: the plan's ``joints_grasp`` drives each pad ``approach.squeeze``
    (10 mm by default) through its contact, and the grip is the gain times the
    part of that margin left when the fingers have sunk into MuJoCo's soft
    contacts (the jaw of ``tests/test_sim.py``, sent 10 mm past the faces of a
    4 cm box, stops 0.3 mm in and presses 49 N at 5000 N/m; a mimic pair shares
    its master's force).

    A mimic joint follows its master through a joint equality as stiff as the
    contacts: ``solref`` (``mimic_timeconst`` 5 ms, damping ratio 1) and a
    constant impedance ``mimic_impedance`` 0.99. A linkage does not give way
    under the grip: the jaw's mimic finger stays within 0.3 mm of its master
    while it presses 49 N. With MuJoCo's default equality (20 ms, impedance 0.9
    to 0.95) the same jaw's mimic finger fell 8.6 mm out of step and the jaw
    pressed 28 N, and a finger whose distal joint mimics its proximal one (the
    Ability hand's) was bent open at the tip by the object it pressed.

    The Franka hand's ``kp_prismatic`` 5000 N/m: with 2000 N/m a 10 mm squeeze
    held its paper13 grasps with half the force of closing towards ``closed``
    (all 26 held either way; measured with MuJoCo's default equality). Raising
    ``kp_revolute`` does not help the Allegro hand (13, 13, 14, 12 and 10 of 26
    held at 0.7, 2, 5, 10 and 20 N·m/rad): its misses are fingers whose targets
    leave the pad off the object's surface, which no gain changes.

Protocol
    The object is dropped from ``drop_height`` above the table at a random
    position (within ``drop_radius`` of the table centre) and yaw, tilted by up
    to ``drop_tilt_deg`` from its natural resting pose (``drop_pose`` "natural";
    "random" draws any orientation, so mugs land on their sides) and
    settles with extra damping ``settle_damping`` on its free joint (removed for
    the grasp). The gripper starts at the plan's pre-grasp pose (a plan without
    one: ``standoff`` back along its approach axis), approaches, closes, lifts
    ``lift_height`` and holds for ``hold_time``.

    Two protocols (:data:`PROTOCOLS`; :meth:`SimParams.for_protocol`):

    ``strict`` (the default) adds what real execution adds, so that a trial tells
    a good grasp from one that merely closes on the object:

    - *Execution error.* The grasp is executed ``execution_offset`` (3 mm) away
      from the planned pose in a random direction and turned by
      ``execution_angle_deg`` (1.5°) about a random axis through the object's
      centre of mass, the pre-grasp pose with it: the object is not quite where
      the camera put it. Hand–eye calibration alone leaves residuals under a
      millimetre and under a degree with an industrial camera on a small arm
      (Zivid's hand–eye guide; 0.28 mm and 0.25° with the flange method of
      arXiv 2407.16041), millimetres on large arms; what reaches the grasp adds
      the depth camera's own error (σ 1 mm here, more for a consumer camera at
      arm's length), the arm's absolute accuracy (worse than its repeatability)
      and the object's pose seen from one side: 3 mm and 1.5° together. It is
      drawn per trial from its own seeded stream
      (:func:`wsgrasp.sim.trial.execution_error`), so every gripper, spec and
      candidate of a trial gets the same one.
    - *Disturbances.* After the lift and a hold of ``hold_time`` (1 s), a force
      of ``disturbance_weights`` (1) times the object's weight pulls at its
      centre of mass along -x, +x, -y, +y, -z and +z (world), each for
      ``disturbance_time`` (2 s), then ``rest_time`` (0.5 s) without. This is
      DexGraspBench/BODex's test (Chen et al., ICRA 2025; its MuJoCo code applies
      10 m/s² times the object's mass along the same six directions, 2 s each,
      and fails a grasp whose object drifts 5 cm or 15°) with gravity left on, as
      in NVIDIA's GraspDataGen (five 0.5 s tugs of 1 g along +z, ±x, ±y).
    - *Held means held still.* The object's pose in the gripper's frame when the
      grip has closed (before the lift) is compared with its pose at the end: a
      drift past ``slip_distance`` (5 mm, its centre of mass) or
      ``slip_angle_deg`` (10°) in the grip fails (``slipped_in_grip``), where the
      lift protocol counts only a drop. BODex's 5 cm / 15° is a drop in all but
      name; a few millimetres of creep is what spoils a placement.
    - *Friction* 0.5: a rubber-like pad on smooth moulded plastic. Tabulated
      static coefficients of moulded plastics lie at 0.35-0.75 (PP 0.35-0.45, PS
      0.45-0.6, PC 0.4-0.65, ABS 0.6-0.75), DexGraspBench uses 0.6; the lift
      protocol's 0.8 is grippy rubber on cardboard.

    A strict trial simulates about 18 s (approach 1.1, close 1, lift 1.2, hold 1,
    disturbances 12, rest 0.5) against the lift protocol's 13.3 s, and stops as
    soon as the object is lost.

    ``lift`` is the earlier protocol, kept for comparison: friction 0.8, no
    execution error, no disturbance, a 10 s hold, success on "still held".
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, fields
from typing import Any

__all__ = ["PROTOCOLS", "SimParams", "parse_overrides"]

#: what each protocol sets differently from :class:`SimParams`' defaults (strict)
PROTOCOLS: dict[str, dict[str, Any]] = {
    "strict": {},
    "lift": {
        "friction": 0.8,
        "hold_time": 10.0,
        "disturbance_weights": 0.0,
        "execution_offset": 0.0,
        "execution_angle_deg": 0.0,
        "slip_distance": 0.0,
        "slip_angle_deg": 0.0,
    },
}


@dataclass(frozen=True)
class SimParams:
    """Everything physical about a trial; see the module docstring.

    The defaults are the ``strict`` protocol's; :meth:`for_protocol` gives
    another protocol's values.
    """

    protocol: str = "strict"
    timestep: float = 0.002
    impratio: float = 10.0
    noslip_iterations: int = 10
    # table: a 2 cm slab whose top is z = 0, as rendered by ``scene synth``
    table_size: float = 0.6
    # object contacts
    friction: float = 0.5
    torsional_friction: float = 0.005
    rolling_friction: float = 0.0001
    contact_timeconst: float = 0.005
    mimic_timeconst: float = 0.005
    mimic_impedance: float = 0.99
    table_friction: float = 0.8
    #: forced mass of every object (kg); None: the set's, else density x volume
    object_mass: float | None = None
    density: float = 1200.0
    # gripper
    gripper_density: float = 1000.0
    link_mass_floor: float = 0.001
    link_mass_ceiling: float = 50.0
    effort_prismatic: float = 100.0
    effort_revolute: float = 5.0
    effort_min_prismatic: float = 1.0
    effort_max_prismatic: float = 2000.0
    effort_min_revolute: float = 0.1
    effort_max_revolute: float = 200.0
    gripper_friction: float = 0.8
    drive_kp_linear: float = 3000.0
    drive_kp_angular: float = 100.0
    drive_force: float = 60.0
    drive_torque: float = 10.0
    drive_damping_linear: float = 150.0
    drive_damping_angular: float = 3.0
    drive_armature_linear: float = 0.5
    drive_armature_angular: float = 0.01
    kp_prismatic: float = 5000.0
    kp_revolute: float = 2.0
    damping_prismatic: float = 20.0
    damping_revolute: float = 0.05
    armature_prismatic: float = 0.05
    armature_revolute: float = 0.001
    # protocol
    drop_pose: str = "natural"
    drop_tilt_deg: float = 15.0
    drop_height: float = 0.01
    drop_radius: float = 0.05
    settle_time: float = 3.0
    settle_damping: float = 0.05
    standoff: float = 0.10
    approach_speed: float = 0.10
    close_time: float = 0.6
    close_wait: float = 0.4
    lift_height: float = 0.20
    lift_speed: float = 0.20
    hold_time: float = 1.0
    # strict protocol: disturbances, execution error, slip in the grip (0: off)
    disturbance_weights: float = 1.0
    disturbance_time: float = 2.0
    rest_time: float = 0.5
    execution_offset: float = 0.003
    execution_angle_deg: float = 1.5
    slip_distance: float = 0.005
    slip_angle_deg: float = 10.0
    # classification thresholds
    displaced_distance: float = 0.02
    displaced_angle_deg: float = 20.0
    blocked_distance: float = 0.01
    lifted_fraction: float = 0.5
    # rendering (the camera model of ``scene synth``)
    views: int = 3
    depth_noise: float = 0.001
    #: the cameras' elevation above the table (degrees, each jittered by up to
    #: 5 degrees; 90: looking straight down)
    camera_elevation_deg: float = 45.0
    #: share (0-1) of the pixels along depth edges that come back as flying
    #: pixels, hanging between an object's outline and the surface behind it
    #: (``perception.synth.flying_pixels``); 0: none
    flying_pixels: float = 0.0

    def __post_init__(self) -> None:
        if self.protocol not in PROTOCOLS:
            from wsgrasp.errors import InputError

            raise InputError(
                f"protocol {self.protocol!r} is unknown, expected one of "
                + ", ".join(PROTOCOLS),
                hint="pass --protocol strict (the default) or --protocol lift",
            )

    @classmethod
    def for_protocol(cls, name: str, **overrides: Any) -> SimParams:
        """The parameters of protocol ``name`` (:data:`PROTOCOLS`), with
        ``overrides`` (field name to value) on top."""
        if name not in PROTOCOLS:
            cls(protocol=name)  # raises, naming the protocols
        return cls(protocol=name, **{**PROTOCOLS[name], **overrides})

    def to_json(self) -> dict[str, Any]:
        return asdict(self)


#: parameters that ``eval --sim`` leaves to options of their own
OWN_OPTIONS = {
    "protocol": "--protocol",
    "drop_pose": "--drop",
    "object_mass": "--mass",
    "density": "--density",
    "friction": "--friction",
}
#: parameters that must be above zero (the others may be zero)
POSITIVE = frozenset(
    {
        "timestep",
        "impratio",
        "kp_prismatic",
        "kp_revolute",
        "table_size",
        "contact_timeconst",
        "mimic_timeconst",
        "mimic_impedance",
        "approach_speed",
        "lift_speed",
        "views",
        "camera_elevation_deg",
    }
)

#: parameters that must be below 1 (an impedance)
BELOW_ONE = frozenset({"mimic_impedance"})
#: parameters with an upper bound (a camera above the table looks down at most
#: straight down; a share is at most all)
AT_MOST = {"camera_elevation_deg": 90.0, "flying_pixels": 1.0}


def parse_overrides(items: Sequence[str]) -> dict[str, Any]:
    """``KEY=VALUE`` settings (``wsgrasp eval --sim``) as overrides for
    :meth:`SimParams.for_protocol`: ``KEY`` a field of :class:`SimParams`,
    ``VALUE`` a finite number of the field's kind, zero or more (above zero for
    :data:`POSITIVE`). A later setting of a key replaces an earlier one."""
    from wsgrasp.errors import InputError

    kinds = {f.name: f.type for f in fields(SimParams)}
    out: dict[str, Any] = {}
    for item in items:
        key, sep, text = (part.strip() for part in item.partition("="))
        if not sep or not key or not text:
            raise InputError(
                f"--sim {item!r} is not KEY=VALUE",
                hint="pass a parameter and its value, e.g. --sim kp_revolute=10",
            )
        if key in OWN_OPTIONS:
            raise InputError(
                f"--sim {key} is set by an option of its own",
                hint=f"pass {OWN_OPTIONS[key]} instead",
            )
        if key not in kinds:
            near = difflib.get_close_matches(key, list(kinds), n=1)
            raise InputError(
                f"--sim {key!r} is not a simulation parameter",
                hint=f"did you mean {near[0]}?"
                if near
                else "the parameters are the fields of wsgrasp.sim.params.SimParams",
            )
        integer = kinds[key] == "int"
        try:
            value: float = int(text) if integer else float(text)
        except ValueError:
            kind = "an integer" if integer else "a number"
            raise InputError(
                f"--sim {key}={text!r} is not {kind}",
                hint=f"pass e.g. --sim {key}={getattr(SimParams(), key)}",
            ) from None
        low = "above zero" if key in POSITIVE else "zero or more"
        if not math.isfinite(value) or value < 0 or (value == 0 and key in POSITIVE):
            raise InputError(
                f"--sim {key}={text} is out of range: {key} must be finite and {low}",
                hint=f"the default is {getattr(SimParams(), key)} (strict protocol)",
            )
        if key in BELOW_ONE and value >= 1.0:
            raise InputError(
                f"--sim {key}={text} is out of range: {key} must be below 1",
                hint=f"the default is {getattr(SimParams(), key)} (MuJoCo's solimp "
                "impedance lies between 0 and 1)",
            )
        if key in AT_MOST and value > AT_MOST[key]:
            raise InputError(
                f"--sim {key}={text} is out of range: {key} must be at most "
                f"{AT_MOST[key]:g}",
                hint=f"the default is {getattr(SimParams(), key)}",
            )
        out[key] = value
    return out
