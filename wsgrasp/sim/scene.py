"""The MuJoCo world of a trial: table, object, and optionally the gripper.

The table is a slab whose top is the plane z = 0 (the world frame of ``scene
synth``). The gripper's root body has a free joint and is welded to the mocap body
``target``: moving the target drives the gripper like an impedance-controlled arm,
and contacts stop it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp.sim._mujoco import require_mujoco
from wsgrasp.sim._xml import attrs, fmt
from wsgrasp.sim.gripper import PREFIX, SimGripper
from wsgrasp.sim.objects import OBJECT_CONAFFINITY, OBJECT_CONTYPE, SimObject
from wsgrasp.sim.params import SimParams

__all__ = ["SimScene", "build_scene", "scene_xml"]

Array = NDArray[np.float64]


def scene_xml(obj: SimObject, gripper: SimGripper | None, p: SimParams) -> str:
    """The MJCF text of the world (see the module docstring)."""
    assets: list[str] = []
    geoms = []
    for i, part in enumerate(obj.parts):
        shape, pose = part.to_mjcf(f"object/{i}", assets)
        geoms.append(
            f"<geom {shape} {pose} "
            + attrs(
                name=f"object/{i}",
                contype=OBJECT_CONTYPE,
                conaffinity=OBJECT_CONAFFINITY,
                priority=1,
                condim=4,
                friction=(obj.friction, p.torsional_friction, p.rolling_friction),
                density=0,
            )
            + "/>"
        )
    com, inertia = obj.inertial()
    full = (
        inertia[0, 0],
        inertia[1, 1],
        inertia[2, 2],
        inertia[0, 1],
        inertia[0, 2],
        inertia[1, 2],
    )
    inertial = "<inertial " + attrs(pos=com, mass=obj.mass, fullinertia=full) + "/>"
    half = p.table_size / 2.0
    gripper_xml = ""
    equality = ""
    actuator = ""
    if gripper is not None:
        assets.append(gripper.asset_xml)
        gripper_xml = (
            '<body name="target" mocap="true" pos="0 0 1"/>\n'
            + gripper.body_xml.replace(
                f'<body name="{gripper.root_body}" gravcomp="1"',
                f'<body name="{gripper.root_body}" gravcomp="1" pos="0 0 1"',
                1,
            )
        )
        equality = (
            "<weld "
            + attrs(
                name="drive",
                body1="target",
                body2=gripper.root_body,
                relpose="0 0 0 1 0 0 0",
                solref=(p.drive_timeconst, 1.0),
            )
            + "/>\n"
            + gripper.equality_xml
        )
        actuator = gripper.actuator_xml
    return f"""<mujoco model="wsgrasp_trial">
<compiler angle="radian" boundmass="1e-4" boundinertia="1e-9"/>
<option {
        attrs(
            timestep=p.timestep,
            integrator="implicitfast",
            cone="elliptic",
            impratio=p.impratio,
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
            friction=(0.5, 0.005, 0.0001),
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
        The gripper root's free joint in ``qpos``.
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
    mocap: int
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
    mocap = -1
    joint_qpos: dict[str, int] = {}
    if gripper is not None:
        root = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, gripper.root_body)
        gbodies = [b for b in range(model.nbody) if _has_ancestor(model, b, root)]
        gj = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, PREFIX + "free")
        gq = slice(int(model.jnt_qposadr[gj]), int(model.jnt_qposadr[gj]) + 7)
        gd = slice(int(model.jnt_dofadr[gj]), int(model.jnt_dofadr[gj]) + 6)
        target = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "target")
        mocap = int(model.body_mocapid[target])
        for j in range(model.njnt):
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or ""
            if name.startswith(PREFIX) and name != PREFIX + "free":
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
        mocap=mocap,
        table_geom=table,
        joint_qpos=joint_qpos,
    )


def _has_ancestor(model: Any, body: int, ancestor: int) -> bool:
    while body > 0:
        if body == ancestor:
            return True
        body = int(model.body_parentid[body])
    return False


_ = fmt
