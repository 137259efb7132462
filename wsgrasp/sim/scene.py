"""The MuJoCo world of a trial: table, object, and optionally the gripper.

The table is a slab whose top is the plane z = 0 (the world frame of ``scene
synth``). The gripper stands on a 6-DoF drive, three slides and three hinges along
the world axes, each with a force-limited position actuator: an arm's Cartesian
impedance controller in miniature. Moving the targets drives the gripper; what it
hits stops it (the drive gives way at ``drive_force``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp.sim._mujoco import require_mujoco
from wsgrasp.sim._xml import attrs
from wsgrasp.sim.gripper import PREFIX, SimGripper
from wsgrasp.sim.objects import (
    OBJECT_CONAFFINITY,
    OBJECT_CONTYPE,
    SimObject,
    trial_friction,
    trial_mass,
)
from wsgrasp.sim.params import SimParams

__all__ = ["SimScene", "build_scene", "scene_xml"]

Array = NDArray[np.float64]


def object_xml(
    obj: SimObject, name: str, p: SimParams, assets: list[str]
) -> tuple[list[str], str]:
    """The ``<geom>`` elements (named ``name/<part>``) and the ``<inertial>`` of
    an object's body under the trial's mass, friction and contact parameters;
    the parts' mesh assets are appended to ``assets``."""
    mass, friction = trial_mass(obj, p), trial_friction(obj, p)
    geoms = []
    for i, part in enumerate(obj.parts):
        shape, pose = part.to_mjcf(f"{name}/{i}", assets)
        geoms.append(
            f"<geom {shape} {pose} "
            + attrs(
                name=f"{name}/{i}",
                contype=OBJECT_CONTYPE,
                conaffinity=OBJECT_CONAFFINITY,
                priority=1,
                condim=4,
                solref=(p.contact_timeconst, 1.0),
                friction=(friction, p.torsional_friction, p.rolling_friction),
                density=0,
            )
            + "/>"
        )
    com, inertia = obj.inertial(mass)
    # MuJoCo's fullinertia order: xx, yy, zz, xy, xz, yz
    full = [inertia[i, j] for i, j in ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))]
    inertial = "<inertial " + attrs(pos=com, mass=mass, fullinertia=full) + "/>"
    return geoms, inertial


def scene_xml(obj: SimObject, gripper: SimGripper | None, p: SimParams) -> str:
    """The MJCF text of the world (see the module docstring)."""
    assets: list[str] = []
    geoms, inertial = object_xml(obj, "object", p, assets)
    half = p.table_size / 2.0
    gripper_xml = ""
    equality = ""
    actuator = ""
    if gripper is not None:
        assets.append(gripper.asset_xml)
        gripper_xml = _drive_xml(gripper, p)
        equality = gripper.equality_xml
        actuator = _drive_actuators(p) + "\n" + gripper.actuator_xml
    return f"""<mujoco model="wsgrasp_trial">
<compiler angle="radian" boundmass="1e-4" boundinertia="1e-9"/>
<option {
        attrs(
            timestep=p.timestep,
            integrator="implicitfast",
            cone="elliptic",
            impratio=p.impratio,
            noslip_iterations=p.noslip_iterations,
        )
    }/>
<asset>
{chr(10).join(a for a in assets if a)}
</asset>
<worldbody>
<geom {
        attrs(
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
    }/>
<body name="object" pos="0 0 0.2">
<freejoint name="object"/>
{inertial}
{chr(10).join(geoms)}
</body>
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
class SimScene:
    """A compiled world and the indices a trial needs.

    Attributes
    ----------
    model, data : mujoco.MjModel, mujoco.MjData
    object_body : int
    object_qpos : slice
        The object's free joint in ``qpos`` (x, y, z, qw, qx, qy, qz).
    gripper_bodies : (B,) int
        Bodies of the gripper (empty without one).
    gripper_qpos : slice or None
        The drive's joints in ``qpos`` (x, y, z, rx, ry, rz; see
        ``DRIVE_JOINTS``); their actuators are the first six.
    table_geom : int
    joint_qpos : dict of str to int
        qpos address of each gripper joint by its URDF name.
    """

    model: Any
    data: Any
    object_body: int
    object_qpos: slice
    object_dof: slice
    gripper: SimGripper | None
    gripper_bodies: NDArray[np.int64]
    gripper_qpos: slice | None
    gripper_dof: slice | None
    root_body: int
    table_geom: int
    joint_qpos: dict[str, int]


def build_scene(
    obj: SimObject, gripper: SimGripper | None, params: SimParams | None = None
) -> SimScene:
    """Compile the world of ``obj`` (and ``gripper``) in MuJoCo."""
    mujoco = require_mujoco()
    from wsgrasp.errors import SimulationError

    p = params or SimParams()
    xml = scene_xml(obj, gripper, p)
    try:
        model = mujoco.MjModel.from_xml_string(xml)
    except ValueError as exc:
        raise SimulationError(
            f"MuJoCo cannot compile the scene of {obj.name!r}"
            + (f" with gripper {gripper.name!r}" if gripper else "")
            + f": {exc}",
            hint="check the gripper's URDF geometry and joint limits",
        ) from None
    data = mujoco.MjData(model)
    obj_body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "object")
    jnt = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, "object")
    qa, da = int(model.jnt_qposadr[jnt]), int(model.jnt_dofadr[jnt])
    table = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "table")
    gbodies: list[int] = []
    gq = gd = None
    root = -1
    joint_qpos: dict[str, int] = {}
    if gripper is not None:
        root = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, gripper.root_body)
        gbodies = [b for b in range(model.nbody) if _has_ancestor(model, b, root)]
        gj = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, DRIVE_JOINTS[0])
        gq = slice(int(model.jnt_qposadr[gj]), int(model.jnt_qposadr[gj]) + 6)
        gd = slice(int(model.jnt_dofadr[gj]), int(model.jnt_dofadr[gj]) + 6)
        for j in range(model.njnt):
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or ""
            if name.startswith(PREFIX):
                joint_qpos[name[len(PREFIX) :]] = int(model.jnt_qposadr[j])
    return SimScene(
        model=model,
        data=data,
        object_body=obj_body,
        object_qpos=slice(qa, qa + 7),
        object_dof=slice(da, da + 6),
        gripper=gripper,
        gripper_bodies=np.asarray(gbodies, dtype=np.int64),
        gripper_qpos=gq,
        gripper_dof=gd,
        root_body=root,
        table_geom=table,
        joint_qpos=joint_qpos,
    )


def _has_ancestor(model: Any, body: int, ancestor: int) -> bool:
    while body > 0:
        if body == ancestor:
            return True
        body = int(model.body_parentid[body])
    return False


#: the drive's joints: translations along world x, y, z, then small rotations
DRIVE_JOINTS = ("drive/x", "drive/y", "drive/z", "drive/rx", "drive/ry", "drive/rz")


def _drive_xml(gripper: SimGripper, p: SimParams) -> str:
    """The arm stand-in: a chain of 3 slides and 3 hinges (world axes) carrying
    the gripper's root body, whose orientation (``body_quat``) each trial sets to
    the planned one, so the hinges stay near zero (no gimbal lock)."""
    joints = []
    for name, kind, axis in zip(
        DRIVE_JOINTS,
        ("slide",) * 3 + ("hinge",) * 3,
        ((1, 0, 0), (0, 1, 0), (0, 0, 1)) * 2,
        strict=True,
    ):
        lin = kind == "slide"
        joints.append(
            "<joint "
            + attrs(
                name=name,
                type=kind,
                axis=axis,
                damping=p.drive_damping_linear if lin else p.drive_damping_angular,
                armature=p.drive_armature_linear if lin else p.drive_armature_angular,
                limited="false",
            )
            + "/>"
        )
    body = gripper.body_xml.replace('<freejoint name="g/free"/>', "", 1)
    return (
        '<body name="drive" gravcomp="1">\n'
        + "\n".join(joints)
        + '\n<inertial pos="0 0 0" mass="0.01" diaginertia="1e-5 1e-5 1e-5"/>\n'
        + body
        + "\n</body>"
    )


def _drive_actuators(p: SimParams) -> str:
    out = []
    for i, name in enumerate(DRIVE_JOINTS):
        lin = i < 3
        limit = p.drive_force if lin else p.drive_torque
        out.append(
            "<position "
            + attrs(
                name=name,
                joint=name,
                kp=p.drive_kp_linear if lin else p.drive_kp_angular,
                forcerange=(-limit, limit),
            )
            + "/>"
        )
    return "\n".join(out)
