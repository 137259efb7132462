"""What the simulator does with the values of a vendor URDF that MuJoCo cannot take,
or that would make a trial judge the URDF's author instead of the grasp.

Three kinds, each noted as a :class:`Repair` that reaches the run's report (and a
fourth, a flat collision mesh simulated as a box of its extent, noted by
:mod:`wsgrasp.sim.gripper`):

Inertials
    A link's ``<inertial>`` is kept when its mass lies within
    [``link_mass_floor``, ``link_mass_ceiling``] (:class:`~wsgrasp.sim.params.
    SimParams`, 1 g and 50 kg) and its inertia is finite, positive definite and
    satisfies the triangle inequality of its principal moments (A + B >= C, which
    every rigid body does and MuJoCo checks), and when no principal moment exceeds
    ``m R^2``, ``R`` the farthest the link's geometry reaches from the centre of
    mass (:func:`inertia_beyond_geometry`: a moment about an axis through the
    centre of mass is the mass times its mean squared distance from the axis, so
    a larger one puts mass outside the link; placeholders such as ``ixx="1"`` for
    a finger of 100 g, with a radius of gyration of 3 m, make it as sluggish as a
    door). Otherwise, and where it is missing,
    the link's mass properties come from its geometry as simulated (the collision
    shapes, a mesh as its convex hull, which is closed by construction; a hull
    without volume, from a flat mesh, as a box of its extent, at least
    ``MIN_THICKNESS`` thick) at ``gripper_density``: the centre of mass and the
    inertia about it, scaled to the URDF's mass where that mass is plausible. A
    link without geometry is a solid sphere of radius ``POINT_RADIUS`` at the
    URDF's centre of mass (else the link origin) of the URDF's mass where that is
    plausible; else a moving one weighs ``link_mass_floor`` and a welded one is
    a massless frame.

Finger efforts
    An actuated joint's force limit is the URDF's ``effort`` when it lies within
    [``effort_min_revolute``, ``effort_max_revolute``] N·m for a revolute joint,
    [``effort_min_prismatic``, ``effort_max_prismatic``] N for a prismatic one
    (0.1-200 N·m, 1-2000 N: from a small servo finger to an industrial
    gripper); outside (0, a missing value, 1000 or 1e6 written as "unlimited"),
    ``effort_revolute`` (5 N·m) or ``effort_prismatic`` (100 N, the Franka
    hand's jaw). A URDF effort within the range but below that default which
    cannot close its own fingers is replaced too
    (``wsgrasp.sim.gripper.EFFORT_SHORTFALL``).

Mimic joints
    A mimic joint moves through its leader's range mapped by the multiplier and
    offset; that is the range it is limited to. The URDF's own limits on a mimic
    joint are not used (robot_state_publisher ignores them too): a linkage whose
    followers carry limits of the wrong sign (the Robotiq 2F-C2's finger tips,
    multiplier -1, limits 0 to pi/2) otherwise stops at the first few degrees,
    its limit fighting the coupling.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp.geometry import JOINT_PRISMATIC
from wsgrasp.gripper._urdf import Inertial, Joint
from wsgrasp.sim.params import SimParams

__all__ = [
    "MIN_THICKNESS",
    "POINT_RADIUS",
    "MassProperties",
    "Repair",
    "effort_limit",
    "inertia_beyond_geometry",
    "inertia_problem",
    "link_mass_properties",
    "mimic_range",
    "solid_mass_properties",
]

Array = NDArray[np.float64]

#: a flat shape's box is at least this thick (m)
MIN_THICKNESS = 1e-3
#: a moving link without geometry is a solid sphere of this radius (m)
POINT_RADIUS = 0.01
#: principal moments whose A + B falls short of C by at most this fraction are
#: taken as rounding and balanced (C lowered to A + B), not recomputed
ROUNDING = 1e-6


@dataclass(frozen=True)
class Repair:
    """One value of the URDF the simulator did not take as it is.

    Attributes
    ----------
    item : str
        The link or joint.
    kind : str
        ``inertial``, ``effort``, ``mimic limits`` or ``geometry`` (a flat mesh
        simulated as a thin box).
    problem, action : str
        What was wrong; what the simulator used instead.
    """

    item: str
    kind: str
    problem: str
    action: str

    def to_json(self) -> dict[str, str]:
        return {
            "item": self.item,
            "kind": self.kind,
            "problem": self.problem,
            "action": self.action,
        }

    def __str__(self) -> str:
        return f"{self.item} ({self.kind}): {self.problem}; {self.action}"


@dataclass(frozen=True)
class MassProperties:
    """A body's mass, centre of mass and inertia, in its link frame.

    Attributes
    ----------
    mass : float
        kg.
    com : (3,) float
    inertia : (3, 3) float
        About the centre of mass, link axes (kg·m²).
    """

    mass: float
    com: Array
    inertia: Array

    def principal(self) -> tuple[Array, Array]:
        """Principal moments ``(3,)`` (ascending, A + B >= C guaranteed) and the
        rotation ``(3, 3)`` whose columns are the principal axes (det +1)."""
        moments, axes = np.linalg.eigh(0.5 * (self.inertia + self.inertia.T))
        if np.linalg.det(axes) < 0:
            axes[:, 2] *= -1.0
        moments = np.maximum(moments, 0.0)
        # what rounding leaves of a flat body's A + B = C, with a margin for the
        # 12 digits the MJCF is written with
        moments[2] = min(moments[2], (moments[0] + moments[1]) * (1.0 - 1e-9))
        return moments, axes


def inertia_problem(mass: float, inertia: Array, p: SimParams) -> str:
    """What is wrong with a URDF inertial's mass and inertia ``(3, 3)`` (empty
    when nothing is)."""
    problems = []
    if not np.isfinite(mass):
        problems.append(f"mass {mass} is not a number")
    elif mass < p.link_mass_floor:
        problems.append(f"mass {mass:.6g} kg is below {p.link_mass_floor:g} kg")
    elif mass > p.link_mass_ceiling:
        problems.append(f"mass {mass:.6g} kg is above {p.link_mass_ceiling:g} kg")
    inertia = np.asarray(inertia, dtype=np.float64)
    if not np.isfinite(inertia).all():
        problems.append("inertia is not finite")
        return "; ".join(problems)
    moments = np.linalg.eigvalsh(0.5 * (inertia + inertia.T))  # ascending
    text = ", ".join(f"{m:.3g}" for m in moments)
    if moments[0] <= 0.0:
        problems.append(f"inertia is not positive definite (principal moments {text})")
    elif moments[0] + moments[1] < moments[2] * (1.0 - ROUNDING):
        problems.append(f"inertia violates A + B >= C (principal moments {text} kg·m²)")
    return "; ".join(problems)


def inertia_beyond_geometry(props: MassProperties, solids: Sequence[Any]) -> str:
    """What is wrong with an inertial too large for the link it belongs to:
    a principal moment above ``mass * R**2``, ``R`` the farthest corner of the
    bounds of ``solids`` (the link's geometry, link frame) from the centre of
    mass (empty when nothing is). Bounds over-reach the geometry, so the test
    errs towards keeping the URDF's inertial."""
    if not solids or props.mass <= 0.0:
        return ""
    reach = 0.0
    for solid in solids:
        lo, hi = np.asarray(solid.bounds, dtype=np.float64)  # (2, 3)
        far = np.maximum(np.abs(lo - props.com), np.abs(hi - props.com))  # (3,)
        reach = max(reach, float(np.linalg.norm(far)))
    largest = float(np.linalg.eigvalsh(0.5 * (props.inertia + props.inertia.T))[-1])
    if largest <= props.mass * reach**2:
        return ""
    return (
        f"inertia too large for the link: a principal moment of {largest:.3g} kg·m² "
        f"puts its {_kg(props.mass)} {np.sqrt(largest / props.mass) * 1e3:.0f} mm "
        f"from the centre of mass (radius of gyration), where its geometry "
        f"reaches {reach * 1e3:.0f} mm"
    )


def solid_mass_properties(solids: Sequence[Any], density: float) -> MassProperties:
    """Mass properties of closed ``trimesh.Trimesh`` solids (one body, link
    frame; trimesh primitives exactly) at ``density`` (kg/m³); a solid without
    volume counts as a box of its extent, at least :data:`MIN_THICKNESS` thick."""
    masses, coms, inertias = [], [], []
    for solid in solids:
        volume = float(solid.volume)
        if solid.is_watertight and volume > MIN_THICKNESS**3:
            masses.append(density * volume)
            coms.append(np.asarray(solid.center_mass, dtype=np.float64))
            # about the centre of mass, link axes, with density 1
            inertias.append(density * np.asarray(solid.moment_inertia, np.float64))
        else:
            lo, hi = np.asarray(solid.bounds, dtype=np.float64)  # (2, 3)
            ext = np.maximum(hi - lo, MIN_THICKNESS)  # (3,)
            m = density * float(np.prod(ext))
            masses.append(m)
            coms.append((lo + hi) / 2.0)
            sq = ext**2
            inertias.append(np.diag(m / 12.0 * (sq.sum() - sq)))
    mass = float(np.sum(masses))
    com = np.einsum("i,ij->j", masses, np.stack(coms)) / mass  # (3,)
    inertia = np.zeros((3, 3))
    for m, c, inert in zip(masses, coms, inertias, strict=True):
        d = c - com  # parallel axes
        inertia += inert + m * (float(d @ d) * np.eye(3) - np.outer(d, d))
    return MassProperties(mass, com, inertia)


def _sphere(mass: float, com: Array) -> MassProperties:
    return MassProperties(mass, com, np.eye(3) * 0.4 * mass * POINT_RADIUS**2)


def _kg(mass: float) -> str:
    return f"{mass * 1e3:.3g} g" if mass < 1.0 else f"{mass:.3g} kg"


def link_mass_properties(
    link: str,
    inertial: Inertial | None,
    solids: Sequence[Any],
    moving: bool,
    p: SimParams,
) -> tuple[MassProperties | None, Repair | None]:
    """A link's mass properties for MuJoCo and, if it was not the URDF's, what
    was done (see the module docstring).

    Parameters
    ----------
    link
        The link's name (for the note).
    inertial
        The URDF's ``<inertial>`` (None where it is missing or gives no mass).
    solids
        The link's geometry as simulated: closed ``trimesh.Trimesh`` in the link
        frame.
    moving
        The link has a joint of its own (a welded link without geometry or a
        plausible mass stays a massless frame).

    Returns
    -------
    (MassProperties or None, Repair or None)
        None for the properties of a massless frame.
    """
    problem = "the URDF gives no inertial"
    if inertial is not None:
        R = inertial.T_link_inertial[:3, :3]
        urdf = MassProperties(
            float(inertial.mass),
            inertial.T_link_inertial[:3, 3].copy(),
            R @ np.asarray(inertial.inertia, dtype=np.float64) @ R.T,  # link axes
        )
        problem = inertia_problem(urdf.mass, urdf.inertia, p)
        if not problem:
            problem = inertia_beyond_geometry(urdf, solids)
        if not problem:
            return urdf, None
        mass_ok = p.link_mass_floor <= urdf.mass <= p.link_mass_ceiling
    else:
        urdf = None
        mass_ok = False

    def note(action: str) -> Repair:
        return Repair(link, "inertial", problem, action)

    if not solids:
        if urdf is None and not moving:  # a frame: nothing to weigh
            return None, None
        if not mass_ok and not moving:
            return None, note("left massless (a frame welded to its parent)")
        com = np.zeros(3) if urdf is None else urdf.com
        mass = urdf.mass if (mass_ok and urdf is not None) else p.link_mass_floor
        what = f"the URDF's mass ({_kg(mass)})" if mass_ok else _kg(mass)
        return _sphere(mass, com), note(
            f"no geometry: {what} as a sphere of {POINT_RADIUS * 1e3:g} mm radius"
        )
    geo = solid_mass_properties(solids, p.gripper_density)
    if mass_ok and urdf is not None:
        scale = urdf.mass / geo.mass
        return MassProperties(urdf.mass, geo.com, geo.inertia * scale), note(
            f"kept the URDF's mass ({_kg(urdf.mass)}); centre of mass and inertia "
            f"from the geometry"
        )
    if geo.mass < p.link_mass_floor:
        scale = p.link_mass_floor / geo.mass
        return MassProperties(p.link_mass_floor, geo.com, geo.inertia * scale), note(
            f"{_kg(p.link_mass_floor)} (the floor; the geometry at "
            f"{p.gripper_density:g} kg/m³ gives {_kg(geo.mass)}), inertia from the "
            "geometry"
        )
    return geo, note(
        f"{_kg(geo.mass)} and inertia from the geometry at {p.gripper_density:g} kg/m³"
    )


def effort_limit(joint: Joint, p: SimParams) -> tuple[float, Repair | None]:
    """The force limit of an actuated joint (N or N·m) and, where it is not the
    URDF's ``effort``, why (see the module docstring)."""
    if joint.kind == JOINT_PRISMATIC:
        lo, hi, default, unit = (
            p.effort_min_prismatic,
            p.effort_max_prismatic,
            p.effort_prismatic,
            "N",
        )
    else:
        lo, hi, default, unit = (
            p.effort_min_revolute,
            p.effort_max_revolute,
            p.effort_revolute,
            "N·m",
        )
    if lo <= joint.effort <= hi:
        return float(joint.effort), None
    kind = "prismatic" if joint.kind == JOINT_PRISMATIC else "revolute"
    return default, Repair(
        joint.name,
        "effort",
        f"effort {joint.effort:g} {unit} is outside {lo:g}-{hi:g} {unit} "
        f"(a {kind} finger's)",
        f"{default:g} {unit}, the default for a {kind} finger joint",
    )


def mimic_range(
    joint: Joint, master: Joint, multiplier: float, offset: float
) -> tuple[tuple[float, float] | None, Repair | None]:
    """The range of a mimic joint: its leader's (``master``'s) mapped by the
    composed ``multiplier`` and ``offset``; None for an unlimited leader. The
    repair notes a URDF whose own limits on ``joint`` leave part of it out."""
    if master.continuous:
        return None, None
    a, b = offset + multiplier * master.lower, offset + multiplier * master.upper
    lo, hi = min(a, b), max(a, b)
    if joint.continuous or (joint.lower <= lo + 1e-9 and hi - 1e-9 <= joint.upper):
        return (lo, hi), None
    return (lo, hi), Repair(
        joint.name,
        "mimic limits",
        f"its URDF limits [{joint.lower:g}, {joint.upper:g}] leave out part of the "
        f"range its leader {master.name!r} drives it through, [{lo:g}, {hi:g}] "
        f"(multiplier {multiplier:g}, offset {offset:g})",
        f"limited to [{lo:g}, {hi:g}]",
    )
