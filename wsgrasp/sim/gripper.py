"""A gripper in MuJoCo, built from the same URDF and YAML as the planner's model.

The URDF is read with the standard library's XML parser (links, collision
primitives and meshes, fixed/revolute/continuous/prismatic joints, ``<mimic>``)
and written out as MJCF, so any gripper plugin can be simulated, and what happens
to mimic joints does not depend on the MuJoCo version: each becomes a joint
equality ``q = offset + multiplier * q_master``. Every other movable joint gets a
position actuator (gains in :class:`~wsgrasp.sim.params.SimParams`).

:mod:`wsgrasp.sim.scene` mounts the root body on a 6-DoF drive that the trial
moves.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp.errors import SimulationError
from wsgrasp.sim._xml import attrs, fmt, pose_attrs, rpy_matrix
from wsgrasp.sim.params import SimParams

__all__ = ["SimGripper", "load_sim_gripper", "sim_gripper_from_files"]

Array = NDArray[np.float64]

#: name prefix of the gripper's bodies, joints and geoms in the MJCF
PREFIX = "g/"
#: collision bits: gripper geoms touch the table and the object, not each other
GRIPPER_CONTYPE, GRIPPER_CONAFFINITY = 2, 1


@dataclass
class _Joint:
    name: str
    kind: str
    parent: str
    child: str
    T_parent_child: Array  # (4, 4)
    axis: Array  # (3,)
    lower: float
    upper: float
    effort: float
    mimic: tuple[str, float, float] | None = None


@dataclass
class SimGripper:
    """A gripper ready to be put in a MuJoCo scene.

    Attributes
    ----------
    name : str
    body_xml : str
        The ``<body>`` tree rooted at the URDF's root link.
    asset_xml, equality_xml, actuator_xml : str
        What the body needs in ``<asset>``, ``<equality>``, ``<actuator>``.
    root_body : str
        MJCF name of the root body (carried by the trial's drive).
    T_root_base : (4, 4) float
        The YAML's ``base_link`` in the root link's frame (identity when the base
        link is the root).
    approach_axis, closing_axis : (3,) float
        In the base frame.
    actuated : list of str
        Joints with an actuator, in actuator order.
    pregrasp, closed : (A,) float
        Actuator targets of the open and closed postures.
    qpos_pregrasp : dict of str to float
        Every movable joint (mimic joints included) in the pregrasp posture.
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


def load_sim_gripper(name: str, params: SimParams | None = None) -> SimGripper:
    """The simulated gripper of a registered gripper name or a gripper YAML path."""
    from wsgrasp.plugins import get_registry
    from wsgrasp.spec import load_gripper_description

    path = Path(name)
    if path.suffix not in (".yaml", ".yml", ".json", ".toml"):
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
    YAML's content) and the directory its ``urdf`` path is relative to."""
    p = params or SimParams()
    name = str(description["name"])
    urdf = (Path(base_dir) / str(description["urdf"])).resolve()
    if not urdf.exists():
        raise SimulationError(
            f"gripper {name!r}: URDF {urdf} does not exist",
            hint="fix the `urdf` path in the gripper YAML (relative to the YAML)",
        )
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
    try:
        root = ET.parse(urdf).getroot()
    except ET.ParseError as exc:
        raise SimulationError(
            f"gripper {name!r}: URDF {urdf} is not XML: {exc}"
        ) from None
    links = {ln.get("name", ""): ln for ln in root.findall("link")}
    joints = [_read_joint(j, name) for j in root.findall("joint")]
    by_child = {j.child: j for j in joints}
    children: dict[str, list[_Joint]] = {}
    for j in joints:
        children.setdefault(j.parent, []).append(j)
    roots = [ln for ln in links if ln not in by_child]
    if len(roots) != 1:
        raise SimulationError(
            f"gripper {name!r}: URDF {urdf.name} has {len(roots)} root links "
            f"({roots}), expected one tree"
        )
    joint_names = {j.name: j for j in joints}
    movable = [j for j in joints if j.kind != "fixed"]
    for label, posture in (("pregrasp", pregrasp), ("closed", closed)):
        for jn in posture:
            if jn not in joint_names or joint_names[jn].kind == "fixed":
                raise SimulationError(
                    f"gripper {name!r}: {label} names joint {jn!r}, which is not a "
                    f"movable joint of {urdf.name}",
                    hint="use the URDF's joint names: "
                    + ", ".join(j.name for j in movable),
                )
    actuated = [j for j in movable if j.mimic is None]
    if not actuated:
        raise SimulationError(
            f"gripper {name!r}: URDF {urdf.name} has no movable joint"
        )

    def target(j: _Joint, posture: dict[str, float]) -> float:
        v = posture.get(j.name, pregrasp.get(j.name, 0.0))
        return float(np.clip(v, j.lower, j.upper))

    pre = np.array([target(j, pregrasp) for j in actuated])
    clo = np.array([target(j, closed) for j in actuated])
    if np.allclose(pre, clo):
        raise SimulationError(
            f"gripper {name!r}: the closed configuration equals the pregrasp one",
            hint="set `closed` in the gripper YAML to the posture the fingers close "
            "towards",
        )
    qpos_pre = {j.name: target(j, pregrasp) for j in actuated}
    for j in movable:
        if j.mimic is not None:
            master, mult, off = j.mimic
            if master not in qpos_pre:
                raise SimulationError(
                    f"gripper {name!r}: joint {j.name!r} mimics {master!r}, which is "
                    "not an actuated joint"
                )
            qpos_pre[j.name] = off + mult * qpos_pre[master]

    assets: list[str] = []

    def body(link: str, T_parent: Array | None, joint: _Joint | None) -> str:
        el = links[link]
        head = f'<body name="{PREFIX}{link}" gravcomp="1"'
        if T_parent is not None:
            head += " " + pose_attrs(T_parent)
        lines = [head + ">"]
        if joint is not None and joint.kind != "fixed":
            prismatic = joint.kind == "prismatic"
            lines.append(
                "<joint "
                + attrs(
                    name=PREFIX + joint.name,
                    type="slide" if prismatic else "hinge",
                    axis=joint.axis,
                    range=None
                    if joint.kind == "continuous"
                    else fmt((joint.lower, joint.upper)),
                    limited="false" if joint.kind == "continuous" else "true",
                    damping=p.damping_prismatic if prismatic else p.damping_revolute,
                    armature=p.armature_prismatic if prismatic else p.armature_revolute,
                )
                + "/>"
            )
        inertial = el.find("inertial")
        if inertial is not None and inertial.find("mass") is not None:
            lines.append(_inertial(inertial))
        for i, col in enumerate(el.findall("collision")):
            lines.append(_geom(col, f"{PREFIX}{link}/{i}", urdf.parent, p, assets))
        for j in children.get(link, []):
            lines.append(body(j.child, j.T_parent_child, j))
        lines.append("</body>")
        return "\n".join(lines)

    body_xml = body(roots[0], None, None)
    equality = [
        "<joint "
        + attrs(
            name=f"{PREFIX}mimic/{j.name}",
            joint1=PREFIX + j.name,
            joint2=PREFIX + j.mimic[0],
            polycoef=fmt((j.mimic[2], j.mimic[1], 0, 0, 0)),
        )
        + "/>"
        for j in movable
        if j.mimic is not None
    ]
    actuators = []
    for j in actuated:
        prismatic = j.kind == "prismatic"
        lines_attrs = attrs(
            name=PREFIX + j.name,
            joint=PREFIX + j.name,
            kp=p.kp_prismatic if prismatic else p.kp_revolute,
            ctrlrange=fmt((j.lower, j.upper)) if j.kind != "continuous" else None,
            forcerange=fmt((-j.effort, j.effort)) if j.effort > 0 else None,
        )
        actuators.append(f"<position {lines_attrs}/>")
    T_root_base = _fixed_chain(str(description["base_link"]), roots[0], by_child, name)
    return SimGripper(
        name=name,
        body_xml=body_xml,
        asset_xml="\n".join(assets),
        equality_xml="\n".join(equality),
        actuator_xml="\n".join(actuators),
        root_body=PREFIX + roots[0],
        T_root_base=T_root_base,
        approach_axis=np.asarray(description["approach_axis"], dtype=np.float64),
        closing_axis=np.asarray(description["closing_axis"], dtype=np.float64),
        actuated=[j.name for j in actuated],
        pregrasp=pre,
        closed=clo,
        qpos_pregrasp=qpos_pre,
    )


# --------------------------------------------------------------------------------
def _origin(el: ET.Element | None) -> Array:
    T = np.eye(4)
    if el is None:
        return T
    T[:3, 3] = [float(v) for v in el.get("xyz", "0 0 0").split()]
    T[:3, :3] = rpy_matrix([float(v) for v in el.get("rpy", "0 0 0").split()])
    return T


def _read_joint(el: ET.Element, gripper: str) -> _Joint:
    name = el.get("name", "")
    kind = el.get("type", "")
    if kind not in ("fixed", "revolute", "continuous", "prismatic"):
        raise SimulationError(
            f"gripper {gripper!r}: joint {name!r} is of type {kind!r}; the simulator "
            "handles fixed, revolute, continuous and prismatic joints"
        )
    parent, child = el.find("parent"), el.find("child")
    if parent is None or child is None:
        raise SimulationError(f"gripper {gripper!r}: joint {name!r} lacks parent/child")
    axis_el = el.find("axis")
    axis = np.array(
        [
            float(v)
            for v in (
                axis_el.get("xyz", "1 0 0") if axis_el is not None else "1 0 0"
            ).split()
        ]
    )
    axis = axis / max(float(np.linalg.norm(axis)), 1e-12)
    limit = el.find("limit")
    lower = float(limit.get("lower", "0")) if limit is not None else 0.0
    upper = float(limit.get("upper", "0")) if limit is not None else 0.0
    effort = float(limit.get("effort", "0")) if limit is not None else 0.0
    mimic_el = el.find("mimic")
    mimic = None
    if mimic_el is not None:
        mimic = (
            mimic_el.get("joint", ""),
            float(mimic_el.get("multiplier", "1")),
            float(mimic_el.get("offset", "0")),
        )
    return _Joint(
        name=name,
        kind=kind,
        parent=parent.get("link", ""),
        child=child.get("link", ""),
        T_parent_child=_origin(el.find("origin")),
        axis=axis,
        lower=lower,
        upper=upper,
        effort=effort,
        mimic=mimic,
    )


def _inertial(el: ET.Element) -> str:
    T = _origin(el.find("origin"))
    mass_el = el.find("mass")
    mass = float(mass_el.get("value", "0")) if mass_el is not None else 0.0
    i = el.find("inertia")
    vals = {
        k: float(i.get(k, "0")) if i is not None else 0.0
        for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")
    }
    # the inertia is given in the inertial frame: rotate it into the link frame
    inertia = np.array(
        [
            [vals["ixx"], vals["ixy"], vals["ixz"]],
            [vals["ixy"], vals["iyy"], vals["iyz"]],
            [vals["ixz"], vals["iyz"], vals["izz"]],
        ]
    )
    R = T[:3, :3]
    inertia = R @ inertia @ R.T  # (3, 3) in the link frame
    full = tuple(
        inertia[i, j] for i, j in ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
    )
    return (
        "<inertial "
        + attrs(pos=T[:3, 3], mass=max(mass, 1e-4), fullinertia=full)
        + "/>"
    )


def _geom(
    col: ET.Element, name: str, urdf_dir: Path, p: SimParams, assets: list[str]
) -> str:
    T = _origin(col.find("origin"))
    geo = col.find("geometry")
    shape = None if geo is None else next(iter(geo), None)
    common = attrs(
        name=name,
        contype=GRIPPER_CONTYPE,
        conaffinity=GRIPPER_CONAFFINITY,
        density=p.gripper_density,
        friction=fmt((p.gripper_friction, p.torsional_friction, p.rolling_friction)),
        group=1,
    )
    pose = pose_attrs(T)
    if shape is None:
        raise SimulationError(f"collision {name!r} has no geometry")
    if shape.tag == "box":
        size = np.array([float(v) for v in shape.get("size", "0 0 0").split()]) / 2.0
        return f'<geom type="box" size="{fmt(size)}" {pose} {common}/>'
    if shape.tag == "cylinder":
        r, length = float(shape.get("radius", "0")), float(shape.get("length", "0"))
        return (
            f'<geom type="cylinder" size="{fmt((r, length / 2.0))}" {pose} {common}/>'
        )
    if shape.tag == "sphere":
        radius = fmt(float(shape.get("radius", "0")))
        return f'<geom type="sphere" size="{radius}" {pose} {common}/>'
    if shape.tag == "mesh":
        hull = _mesh_hull(shape, urdf_dir, name)
        mesh_name = name + "/mesh"
        assets.append(f'<mesh name="{mesh_name}" vertex="{fmt(hull.reshape(-1))}"/>')
        return f'<geom type="mesh" mesh="{mesh_name}" {pose} {common}/>'
    raise SimulationError(f"collision {name!r}: unknown URDF geometry <{shape.tag}>")


def _mesh_hull(shape: ET.Element, urdf_dir: Path, name: str) -> Array:
    """Vertices ``(n, 3)`` of the convex hull of a URDF mesh (scaled)."""
    import trimesh

    fname = shape.get("filename", "")
    for prefix in ("package://", "file://"):
        if fname.startswith(prefix):
            fname = fname[len(prefix) :]
    rel = Path(fname)
    candidates = [urdf_dir / rel]
    if len(rel.parts) > 1:  # package://NAME/sub/file.stl: drop the package name
        candidates.append(urdf_dir / Path(*rel.parts[1:]))
    candidates.append(urdf_dir / rel.name)
    path = next((c for c in candidates if c.exists()), None)
    if path is None:
        raise SimulationError(
            f"collision {name!r}: mesh {shape.get('filename')!r} not found next to "
            f"the URDF ({urdf_dir})",
            hint="give mesh paths relative to the URDF",
        )
    mesh: Any = trimesh.load(path, force="mesh")
    scale = np.array([float(v) for v in shape.get("scale", "1 1 1").split()])
    v = np.asarray(mesh.convex_hull.vertices, dtype=np.float64) * scale  # (n, 3)
    return v


def _fixed_chain(
    base: str, root: str, by_child: dict[str, _Joint], gripper: str
) -> Array:
    """``T_root_base`` through fixed joints only."""
    T = np.eye(4)
    link = base
    while link != root:
        j = by_child.get(link)
        if j is None:
            raise SimulationError(
                f"gripper {gripper!r}: base_link {base!r} is not in the URDF"
            )
        if j.kind != "fixed":
            raise SimulationError(
                f"gripper {gripper!r}: base_link {base!r} moves relative to the URDF "
                f"root {root!r} (joint {j.name!r})",
                hint="make base_link the URDF's root link or fix it to the root",
            )
        T = j.T_parent_child @ T
        link = j.parent
    return T
