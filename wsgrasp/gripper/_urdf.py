"""A URDF read into plain arrays: the joint tree, mimic couplings, link geometry
and mass properties.

yourdfpy parses the file; forward kinematics is ours (batched, in
:mod:`wsgrasp.geometry`), so no yourdfpy call is made per configuration. Meshes are
loaded lazily, only when a cloud is sampled, with trimesh (STL, OBJ, PLY, GLB/GLTF,
and COLLADA through pycollada). A link's shapes are its collision elements; where
the URDF has none at all, its visual ones. ``package://PKG/...`` URIs resolve as ROS
resolves them (:func:`package_roots`). In a URDF that gives collision elements,
a link with visual ones alone is drawn, not solid (a marker sphere at a tool
frame, display copies of links), as every simulator reads it. The planner
(:mod:`wsgrasp.gripper`) and the simulator (:mod:`wsgrasp.sim.gripper`) both read
their URDF here.
"""

from __future__ import annotations

import contextlib
import functools
import io
import os
import re
import xml.etree.ElementTree as ET
from collections.abc import Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp._names import did_you_mean
from wsgrasp.errors import GripperError
from wsgrasp.geometry import (
    JOINT_FIXED,
    JOINT_PRISMATIC,
    JOINT_REVOLUTE,
    PRIMITIVES,
    chain_forward_kinematics,
    primitive_mesh,
    rotation_angle_deg,
)

Array = NDArray[np.float64]

_KINDS = {
    "fixed": JOINT_FIXED,
    "revolute": JOINT_REVOLUTE,
    "continuous": JOINT_REVOLUTE,
    "prismatic": JOINT_PRISMATIC,
}


@dataclass(frozen=True)
class Joint:
    """One URDF joint."""

    name: str
    kind: int
    parent: str
    child: str
    origin: Array  # (4, 4) joint frame in the parent link frame
    axis: Array  # (3,) unit axis in the joint frame
    lower: float
    upper: float
    mimic: tuple[str, float, float] | None = None  # (master, multiplier, offset)
    effort: float = 0.0  # <limit effort>: N or N·m; 0 where the URDF gives none
    continuous: bool = False  # a URDF continuous joint: no limits of its own


@dataclass(frozen=True)
class Inertial:
    """A link's mass properties (URDF ``<inertial>``).

    Attributes
    ----------
    mass : float
        kg.
    T_link_inertial : (4, 4) float
        The inertial frame (origin at the centre of mass) in the link frame.
    inertia : (3, 3) float
        Inertia tensor about the centre of mass, in the inertial frame (kg·m²).
    """

    mass: float
    T_link_inertial: Array
    inertia: Array


@dataclass(frozen=True)
class Shape:
    """One collision (or visual) element of a link, in the link frame."""

    link: str
    kind: str  # box | cylinder | sphere | mesh
    T_link_shape: Array  # (4, 4)
    size: tuple[float, ...] = ()  # box: (x, y, z); cylinder: (r, length); sphere: (r,)
    mesh_path: Path | None = None
    mesh_scale: tuple[float, float, float] = (1.0, 1.0, 1.0)


@dataclass
class Kinematics:
    """The joint tree of a URDF and its link geometry.

    Attributes
    ----------
    joints : dict of str to Joint
    parent_joint : dict of str to str
        For each link with a parent, the joint that attaches it.
    shapes : dict of str to list of Shape
        Collision elements per link (visual ones where the URDF has no collision
        element at all).
    inertials : dict of str to Inertial
        Mass properties of the links whose ``<inertial>`` gives a mass.
    warnings : list of str
        Geometry left out while reading (a visual mesh, not found, of a link
        without collision geometry), naming the link and the file.
    misplaced : dict of str to str
        Per link whose collision mesh is a visual's mesh placed elsewhere, a
        sentence saying so (``gripper new`` warns of those in the gripper).
    drawn_only : list of str
        The links with visual elements alone in a URDF that gives other links
        collision elements: no shape (``gripper new`` notes those in the gripper).
    """

    robot_name: str
    path: Path
    joints: dict[str, Joint]
    links: list[str]
    parent_joint: dict[str, str]
    shapes: dict[str, list[Shape]] = field(default_factory=dict)
    inertials: dict[str, Inertial] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    misplaced: dict[str, str] = field(default_factory=dict)
    drawn_only: list[str] = field(default_factory=list)

    # -- names -------------------------------------------------------------------
    def check_link(self, link: str, gripper: str, where: str) -> None:
        """Raise ``GripperError`` naming ``where`` if the URDF has no ``link``."""
        self._check_name("link", link, self.links, gripper, where)

    def check_joint(self, joint: str, gripper: str, where: str) -> None:
        """Raise ``GripperError`` naming ``where`` if the URDF has no ``joint``."""
        self._check_name("joint", joint, self.joints, gripper, where)

    def _check_name(
        self, kind: str, name: str, names: Collection[str], gripper: str, where: str
    ) -> None:
        if name not in names:
            close = did_you_mean(name, names, list_known=False)
            raise GripperError(
                f"gripper {gripper!r}: {where} names {kind} {name!r}, which "
                f"{self.path.name} does not have{close}",
                hint=f"use one of the {kind}s of {self.path.name} in {where}",
            )

    def master(self, joint: str) -> str:
        """The actuated joint that drives ``joint`` (itself unless it is a mimic)."""
        seen = set()
        while self.joints[joint].mimic is not None:
            if joint in seen:
                raise GripperError(
                    f"URDF {self.path.name}: mimic joints form a cycle at {joint!r}",
                    hint="make every mimic chain end at an actuated joint",
                )
            seen.add(joint)
            joint = self.joints[joint].mimic[0]  # type: ignore[index]
        return joint

    def actuated(self) -> list[str]:
        """Names of the movable joints that are not mimics, in file order."""
        return [
            j.name
            for j in self.joints.values()
            if j.kind != JOINT_FIXED and j.mimic is None
        ]

    # -- chains ------------------------------------------------------------------
    def chain(self, base: str, tip: str) -> list[Joint]:
        """The joints from link ``base`` down to link ``tip``, root first.

        Raises ``ValueError`` when ``tip`` is not below ``base``.
        """
        out: list[Joint] = []
        link = tip
        while link != base:
            jname = self.parent_joint.get(link)
            if jname is None:
                raise ValueError(f"link {tip!r} is not below link {base!r}")
            joint = self.joints[jname]
            out.append(joint)
            link = joint.parent
        return out[::-1]

    def child_joints(self, link: str) -> list[Joint]:
        """The joints whose parent is ``link``, in file order."""
        return [j for j in self.joints.values() if j.parent == link]

    def subtree(self, base: str) -> list[str]:
        """``base`` and every link below it, parents before children (depth
        first, children in file order)."""
        children: dict[str, list[str]] = {}
        for j in self.joints.values():
            children.setdefault(j.parent, []).append(j.child)
        order, stack = [], [base]
        while stack:
            link = stack.pop()
            order.append(link)
            stack.extend(reversed(children.get(link, [])))
        return order

    def subtree_joints(self, base: str) -> list[Joint]:
        """The joints below link ``base`` (those that attach a link of its
        subtree other than ``base`` itself), in file order."""
        below = set(self.subtree(base)) - {base}
        return [j for j in self.joints.values() if j.child in below]

    def mimic_of(self, joint: str) -> tuple[str, float, float]:
        """``(master, multiplier, offset)`` with ``q = offset + multiplier *
        q_master``, ``master`` the actuated joint at the end of the mimic chain
        (``(joint, 1, 0)`` for an actuated joint)."""
        mult, off = 1.0, 0.0
        name = joint
        while self.joints[name].mimic is not None:
            m_name, m_mult, m_off = self.joints[name].mimic  # type: ignore[misc]
            mult, off = mult * m_mult, off * m_mult + m_off
            name = m_name
        return name, mult, off

    def joint_positions(
        self, chain: Iterable[Joint], masters: Mapping[str, Any]
    ) -> Array:
        """Positions of the joints of ``chain`` from actuated-joint values.

        Parameters
        ----------
        chain
            Joints, e.g. from :meth:`chain`.
        masters
            Actuated joint name to position, a float or an array ``(...,)``;
            missing joints are held at 0 clipped into their limits.

        Returns
        -------
        (..., J) float
        """
        cols = []
        for j in chain:
            if j.kind == JOINT_FIXED:
                cols.append(np.asarray(0.0))
                continue
            name, mult, off = self.mimic_of(j.name)
            if name in masters:
                value = np.asarray(masters[name], dtype=np.float64)
            else:
                m = self.joints[name]
                value = np.asarray(np.clip(0.0, m.lower, m.upper))
            cols.append(mult * value + off)
        shape = np.broadcast_shapes(*(c.shape for c in cols)) if cols else ()
        return np.stack([np.broadcast_to(c, shape) for c in cols], axis=-1)

    def chain_poses(self, base: str, tip: str, masters: Mapping[str, Any]) -> Array:
        """``T_base_tip`` for (a batch of) actuated-joint values.

        Returns
        -------
        (..., 4, 4) float
            The batch shape is that of the values in ``masters`` broadcast together.
        """
        batch = np.broadcast_shapes(*(np.shape(v) for v in masters.values()))
        chain = self.chain(base, tip)
        if not chain:
            return np.broadcast_to(np.eye(4), (*batch, 4, 4)).copy()
        q = self.joint_positions(chain, masters)  # (..., J)
        T = chain_forward_kinematics(
            np.stack([j.origin for j in chain]),
            np.stack([j.axis for j in chain]),
            np.array([j.kind for j in chain]),
            q,
        )
        return np.broadcast_to(T, (*batch, 4, 4)).copy()

    def link_poses(self, base: str, masters: Mapping[str, float]) -> dict[str, Array]:
        """``T_base_link`` of every link below ``base`` at one configuration."""
        poses = {base: np.eye(4)}
        for link in self.subtree(base)[1:]:
            joint = self.joints[self.parent_joint[link]]
            q = self.joint_positions([joint], masters)  # (1,)
            T = chain_forward_kinematics(
                joint.origin[None], joint.axis[None], np.array([joint.kind]), q
            )
            poses[link] = poses[joint.parent] @ T
        return poses


def _origin(o: Any) -> Array:
    return np.eye(4) if o is None else np.asarray(o, dtype=np.float64).copy()


#: an element or attribute name with a namespace prefix: ``<drake:member``
_PREFIX = re.compile(rb"(?:</?|\s)([A-Za-z_][\w.-]*):[A-Za-z_][\w.-]*")


def parse_xml(text: bytes) -> ET.Element:
    """The root element of a URDF's text, read as ROS and Drake read it: a
    namespace prefix the file uses without declaring it (``<drake:member>`` in
    a Drake URDF; tinyxml2 does not check them) is declared on the root for the
    parse. Other XML errors raise ``ET.ParseError`` as they are."""
    try:
        return ET.fromstring(text)
    except ET.ParseError as exc:
        if "unbound prefix" not in str(exc):
            raise
        declared = set(re.findall(rb"xmlns:([A-Za-z_][\w.-]*)\s*=", text))
        used = set(_PREFIX.findall(text)) - declared - {b"xmlns", b"xml"}
        if not used:
            raise
        root = re.search(rb"<(?![?!])[A-Za-z_][\w.:-]*", text)
        if root is None:
            raise
        names = b"".join(
            b' xmlns:%s="urn:undeclared:%s"' % (p, p) for p in sorted(used)
        )
        return ET.fromstring(text[: root.end()] + names + text[root.end() :])


#: descriptions of a robot that are not URDF, by their root element
_OTHER_FORMATS = {
    "sdf": "an SDFormat (Gazebo) description",
    "mujoco": "a MuJoCo (MJCF) model",
    "COLLADA": "a COLLADA mesh",
}


def not_urdf(root: ET.Element) -> str | None:
    """What a file whose root element is ``root`` is, where it is no URDF
    (whose root is ``<robot>``): "an SDFormat (Gazebo) description", ...; None
    for a URDF."""
    if root.tag == "robot":
        return None
    tag = root.tag.rsplit("}", 1)[-1]
    return _OTHER_FORMATS.get(tag, f"XML whose root element is <{tag}>")


def mimic_meant(target: str, mimicking: str, names: Iterable[str]) -> str | None:
    """The joint a ``<mimic joint="target">`` of joint ``mimicking`` means where
    no joint is named ``target``, when one is clear: of the joints whose names
    end with ``target`` (a robot's URDF that prefixes each hand's joints,
    ``Left_index_q1`` where its mimic says ``index_q1``), the one sharing a
    longer prefix with ``mimicking`` than every other; else None."""
    ends = [n for n in names if n != mimicking and n.endswith(target)]
    shared = sorted(
        ((len(os.path.commonprefix([n, mimicking])), n) for n in ends), reverse=True
    )
    if not shared or (len(shared) > 1 and shared[0][0] == shared[1][0]):
        return None
    return shared[0][1]


def _closest_joint(target: str, mimicking: str, names: list[str]) -> str | None:
    """:func:`mimic_meant`, else the joint of the closest spelling, or None."""
    import difflib

    meant = mimic_meant(target, mimicking, names)
    if meant is not None:
        return meant
    near = difflib.get_close_matches(target, names, n=1, cutoff=0.75)
    return near[0] if near else None


def _unnamed(root: ET.Element) -> str | None:
    """The first element a URDF must name and does not (``<robot>``, a
    ``<link>``, a ``<joint>``, a ``<joint>``'s ``<parent link>``, ``<child
    link>`` or ``<mimic joint>``), described for a message; None if all are
    named (yourdfpy fails on those with a bare ``KeyError``)."""
    if not root.get("name"):
        return "its <robot> element without a name attribute"
    for tag in ("link", "joint"):
        for i, el in enumerate(root.findall(tag)):
            if not el.get("name"):
                return f"its <{tag}> number {i + 1} without a name attribute"
    for el in root.findall("joint"):
        for tag, attr in (("parent", "link"), ("child", "link"), ("mimic", "joint")):
            sub = el.find(tag)
            if sub is None and tag != "mimic":
                return f"joint {el.get('name')!r} without a <{tag}> element"
            if sub is not None and not sub.get(attr):
                return f"joint {el.get('name')!r}'s <{tag}> without a {attr} attribute"
    return None


def load_kinematics(
    path: Path,
    gripper: str,
    *,
    package_paths: Sequence[Path] = (),
    below: str | None = None,
) -> Kinematics:
    """Read a URDF with yourdfpy into :class:`Kinematics`.

    Parameters
    ----------
    path
        The URDF file.
    gripper
        The gripper's name, for messages.
    package_paths
        Folders holding ROS packages, searched for ``package://`` URIs (see
        :func:`package_roots`).
    below
        The gripper's base link, where it is known (``gripper new
        --base-link``): a revolute or prismatic joint without limits outside
        the tree below it (a robot's wheel) is held at 0 with a warning, not
        refused; one below it still is.

    Raises
    ------
    GripperError
        The file is missing or does not parse, a movable joint lacks limits, or a
        collision mesh is not found.
    """
    import yourdfpy

    def fail(what: str) -> GripperError:
        return GripperError(
            f"gripper {gripper!r}: urdf {str(path)!r} {what}",
            hint="fix the URDF, or point the `urdf` field of the gripper YAML at a "
            "valid URDF file (relative to the YAML)",
        )

    if not path.is_file():
        raise fail("does not exist")
    text = path.read_bytes()
    try:
        root = parse_xml(text)
    except ET.ParseError as exc:
        raise fail(f"is not valid XML: {exc}") from None
    other = not_urdf(root)
    if other is not None:
        raise fail(f"is {other}, not a URDF (whose root element is <robot>)")
    unnamed = _unnamed(root)
    if unnamed:
        raise fail(f"has {unnamed}, which URDF requires")
    sink = io.StringIO()
    try:
        with contextlib.redirect_stdout(sink), contextlib.redirect_stderr(sink):
            urdf = yourdfpy.URDF.load(
                str(path),
                build_scene_graph=False,
                build_collision_scene_graph=False,
                load_meshes=False,
                load_collision_meshes=False,
            )
    except Exception as exc:  # noqa: BLE001 - any parser failure is a user error
        raise fail(f"does not parse: {type(exc).__name__}: {exc}") from None
    robot = urdf.robot
    links = [link.name for link in robot.links]
    if not links:
        raise fail("has no links")
    joints: dict[str, Joint] = {}
    parent_joint: dict[str, str] = {}
    unlimited: dict[str, str] = {}  # joint -> type, movable without limits
    # joint -> type: floating and planar joints, which place a robot in a world
    # (a simulator's spawn); outside the gripper they stand still
    placing: dict[str, str] = {}
    for j in robot.joints:
        if j.type not in _KINDS:
            placing[j.name] = str(j.type)
        kind = _KINDS.get(j.type, JOINT_FIXED)
        if j.parent not in links or j.child not in links:
            raise fail(f"has joint {j.name!r} between unknown links")
        axis = np.asarray(j.axis if j.axis is not None else (1, 0, 0), float)
        if kind != JOINT_FIXED:
            norm = float(np.linalg.norm(axis))
            if not np.isfinite(norm):
                raise fail(f"has joint {j.name!r} with an axis that is not finite")
            if norm < 1e-9:
                raise fail(f"has joint {j.name!r} with a zero axis")
            axis = axis / norm
        lower, upper = 0.0, 0.0
        effort = 0.0
        if j.limit is not None and j.limit.effort is not None:
            effort = float(j.limit.effort)
        if j.type == "continuous":
            lower, upper = -np.pi, np.pi
            if j.limit is not None and j.limit.lower is not None:
                lower, upper = float(j.limit.lower), float(j.limit.upper)
        elif kind != JOINT_FIXED:
            if j.limit is None or j.limit.lower is None or j.limit.upper is None:
                unlimited[j.name] = j.type
            else:
                lower, upper = float(j.limit.lower), float(j.limit.upper)
        numbers = [*axis, lower, upper, effort, *_origin(j.origin).ravel()]
        if not np.isfinite(numbers).all():
            raise fail(
                f"has joint {j.name!r} with a value that is not a finite number "
                "(NaN or inf in its origin, axis or limits)"
            )
        if lower > upper:
            raise fail(
                f"has joint {j.name!r} with lower limit {lower:g} above upper "
                f"limit {upper:g}"
            )
        mimic = None
        if j.mimic is not None:
            mimic = (
                j.mimic.joint,
                float(1.0 if j.mimic.multiplier is None else j.mimic.multiplier),
                float(0.0 if j.mimic.offset is None else j.mimic.offset),
            )
            if not np.isfinite(mimic[1:]).all():
                raise fail(f"has joint {j.name!r} with a non-finite mimic factor")
        joints[j.name] = Joint(
            j.name,
            kind,
            j.parent,
            j.child,
            _origin(j.origin),
            axis,
            lower,
            upper,
            mimic,
            effort=effort,
            continuous=j.type == "continuous",
        )
        if j.child in parent_joint:
            raise fail(f"gives link {j.child!r} two parents")
        parent_joint[j.child] = j.name
    for j in joints.values():
        if j.mimic is not None and j.mimic[0] not in joints:
            near = _closest_joint(j.mimic[0], j.name, list(joints))
            raise fail(
                f"has joint {j.name!r} mimicking unknown joint {j.mimic[0]!r}"
                + (f" (did you mean {near!r}?)" if near else "")
            )
    kin = Kinematics(robot.name, path, joints, links, parent_joint)
    for j in joints:
        kin.master(j)  # cycles
    gripper_links = (
        set(kin.subtree(below)) if below is not None and below in links else set(links)
    )
    for name, kind_name in placing.items():
        if joints[name].parent not in gripper_links:
            kin.warnings.append(
                f"{kind_name} joint {name!r} is outside the gripper below {below!r} "
                "and held still"
            )
            continue
        raise GripperError(
            f"gripper {gripper!r}: urdf {str(path)!r} has joint {name!r} of type "
            f"{kind_name!r}, which no gripper's finger moves on (supported: "
            + ", ".join(_KINDS)
            + ")",
            hint=f"a {kind_name} joint places a robot in a world (a simulator's "
            f"spawn): pass --base-link {joints[name].child} to take the gripper "
            "below it, or remove the joint and its parent link from the URDF",
        )
    for name, kind_name in unlimited.items():
        if joints[name].parent in gripper_links:
            raise fail(f"has {kind_name} joint {name!r} without <limit lower upper>")
        kin.warnings.append(
            f"{kind_name} joint {name!r} has no <limit lower upper>; it is outside "
            f"the gripper below {below!r} and held at 0"
        )
    # visual elements are a link's shapes only in a URDF without collision ones
    solid = any(link.collisions for link in robot.links)
    for link in robot.links:
        if solid and not link.collisions:
            kin.shapes[link.name] = []
            if link.visuals:
                kin.drawn_only.append(link.name)
        else:
            kin.shapes[link.name] = _shapes(
                link, path.parent, fail, kin.warnings, package_paths
            )
        twin = _misplaced_collision(link)
        if twin:
            kin.misplaced[link.name] = twin
        inertial = link.inertial
        if inertial is not None and inertial.mass is not None:
            inertia = (
                np.zeros((3, 3))
                if inertial.inertia is None
                else np.asarray(inertial.inertia, dtype=np.float64).reshape(3, 3)
            )
            kin.inertials[link.name] = Inertial(
                float(inertial.mass), _origin(inertial.origin), inertia
            )
    return kin


def _shapes(
    link: Any,
    urdf_dir: Path,
    fail: Any,
    warnings: list[str],
    package_paths: Sequence[Path],
) -> list[Shape]:
    """A link's collision elements, or its visual ones when it has none (the
    caller asks only in a URDF without collision elements). A collision mesh
    that is not found raises; a visual one is left out, with a warning."""
    collision = bool(link.collisions)
    elements = link.collisions if collision else (link.visuals or [])
    out = []
    for el in elements:
        g = el.geometry
        T = _origin(el.origin)
        if g is None:
            continue
        if g.box is not None:
            out.append(Shape(link.name, "box", T, tuple(float(v) for v in g.box.size)))
        elif g.cylinder is not None:
            size = (float(g.cylinder.radius), float(g.cylinder.length))
            if size[0] > 0.0:  # radius 0: a line, no solid (written as a frame)
                out.append(Shape(link.name, "cylinder", T, size))
        elif g.sphere is not None:
            if float(g.sphere.radius) > 0.0:  # radius 0: a point, no solid
                out.append(Shape(link.name, "sphere", T, (float(g.sphere.radius),)))
        elif g.mesh is not None:
            mesh_path = resolve_mesh(g.mesh.filename, urdf_dir, package_paths)
            if mesh_path is None and collision:
                raise fail(
                    f"link {link.name!r} references collision mesh "
                    f"{g.mesh.filename!r}, which is not found"
                )
            if mesh_path is None:
                warnings.append(
                    f"link {link.name!r} has no collision geometry and its visual "
                    f"mesh {g.mesh.filename!r} is not found: the link has no shape"
                )
                continue
            scale = g.mesh.scale
            if scale is None:
                sc: tuple[float, float, float] = (1.0, 1.0, 1.0)
            else:
                s = np.broadcast_to(np.asarray(scale, dtype=np.float64), (3,))
                sc = (float(s[0]), float(s[1]), float(s[2]))
            out.append(Shape(link.name, "mesh", T, (), mesh_path, sc))
    return out


#: a collision mesh placed this far (degrees, metres) from the same mesh as the
#: link's visual is reported as likely misplaced
TWIN_ANGLE_DEG = 1.0
TWIN_OFFSET = 0.001


def _misplaced_collision(link: Any) -> str | None:
    """Where one of a link's collision meshes is the very file of one of its
    visuals, at the same scale, but placed elsewhere, a sentence saying so (one
    of the two origins is likely wrong: a visual turned into place and its
    collision copy not turned), else None. wsgrasp takes the link's shape from
    its collision elements."""

    def scale(m: Any) -> Array:
        return np.broadcast_to(np.asarray(1.0 if m.scale is None else m.scale), 3)

    for c in link.collisions or []:
        cm = c.geometry.mesh if c.geometry is not None else None
        if cm is None:
            continue
        twins = [
            v
            for v in link.visuals or []
            if v.geometry is not None
            and v.geometry.mesh is not None
            and v.geometry.mesh.filename == cm.filename
            and np.allclose(scale(v.geometry.mesh), scale(cm))
        ]
        if not twins:
            continue
        Tc = _origin(c.origin)
        apart = []
        for v in twins:
            Tv = _origin(v.origin)
            angle = rotation_angle_deg(Tv[:3, :3], Tc[:3, :3])
            offset = float(np.linalg.norm(Tv[:3, 3] - Tc[:3, 3]))
            if angle <= TWIN_ANGLE_DEG and offset <= TWIN_OFFSET:
                break  # a visual in the same place
            apart.append((angle, offset))
        else:
            angle, offset = apart[0]
            return (
                f"link {link.name!r}: its collision mesh {Path(cm.filename).name!r} "
                f"is its visual's mesh placed {angle:.0f} deg and "
                f"{offset * 1000:.0f} mm from it; wsgrasp takes the link's shape "
                "from the collision element, so if the visual is where the link "
                "is, fix the collision element's <origin> in the URDF"
            )
    return None


#: how deep below a package search folder a ``package.xml`` is looked for
PACKAGE_SEARCH_DEPTH = 4
_PACKAGE_NAME = re.compile(rb"<name>\s*([^<\s]+)\s*</name>")


@functools.lru_cache(maxsize=1024)
def _package_name(folder: str) -> str | None:
    """The ``<name>`` in ``folder/package.xml`` (None without one)."""
    try:
        text = (Path(folder) / "package.xml").read_bytes()[:65536]
    except OSError:
        return None
    m = _PACKAGE_NAME.search(text)
    return m.group(1).decode(errors="replace") if m else None


@functools.lru_cache(maxsize=256)
def _packages_below(folder: str, depth: int) -> tuple[tuple[str, str], ...]:
    """``(name, folder)`` of the ROS packages at or below ``folder``: folders
    holding a ``package.xml`` (whose subfolders are not searched, as rospack
    does), at most ``depth`` levels down."""
    name = _package_name(folder)
    if name is not None:
        return ((name, folder),)
    if depth <= 0:
        return ()
    try:
        children = sorted(p for p in Path(folder).iterdir() if p.is_dir())
    except OSError:
        return ()
    out: list[tuple[str, str]] = []
    for child in children:
        if not child.name.startswith("."):
            out += _packages_below(str(child), depth - 1)
    return tuple(out)


def package_roots(
    pkg: str, urdf_dir: Path, package_paths: Sequence[Path] = ()
) -> list[Path]:
    """The folders a ``package://PKG/...`` URI may point into, most likely first.

    As ROS looks packages up: the URDF's folder or one above it that is the
    package (named ``PKG``, or holding a ``package.xml`` whose ``<name>`` is
    ``PKG``) or that holds a folder named ``PKG``; then each folder of
    ``package_paths`` and of ``$ROS_PACKAGE_PATH`` (folders that contain
    packages, searched :data:`PACKAGE_SEARCH_DEPTH` levels deep).
    """
    out: list[Path] = []
    here = Path(urdf_dir).absolute()
    for d in (here, *here.parents):
        if d.name == pkg or _package_name(str(d)) == pkg:
            out.append(d)
        elif (d / pkg).is_dir():
            out.append(d / pkg)
    env = os.environ.get("ROS_PACKAGE_PATH", "")
    for base in [*package_paths, *(Path(p) for p in env.split(os.pathsep) if p)]:
        base = Path(base).expanduser().absolute()
        if (base / pkg).is_dir():
            out.append(base / pkg)
        out += [
            Path(f)
            for name, f in _packages_below(str(base), PACKAGE_SEARCH_DEPTH)
            if name == pkg
        ]
    return list(dict.fromkeys(out))


def resolve_mesh(
    filename: str, urdf_dir: Path, package_paths: Sequence[Path] = ()
) -> Path | None:
    """Find a mesh file named in a URDF: absolute, relative to the URDF, a
    ``file://`` URI, or a ``package://PKG/rel`` URI: ``rel`` in the folders of
    :func:`package_roots`, else beside the URDF or in its three parent folders."""
    name = filename.strip()
    if name.startswith("file://"):
        name = name[len("file://") :]
    candidates: list[Path] = []
    if name.startswith("package://"):
        rest = name[len("package://") :]
        pkg, _, rel_text = rest.partition("/")
        rel = Path(rel_text) if rel_text else Path(rest)
        candidates += [r / rel for r in package_roots(pkg, urdf_dir, package_paths)]
        for d in (urdf_dir, *urdf_dir.parents[:3]):
            candidates += [d / rel, d / rest]
    else:
        p = Path(name)
        candidates.append(p if p.is_absolute() else urdf_dir / p)
    for c in candidates:
        if c.is_file():
            return c
    return None


def shape_mesh(shape: Shape, *, frame: str = "link") -> Any:
    """The shape as a ``trimesh.Trimesh`` (meshes loaded now, scaled), in its link
    frame, or with ``frame="shape"`` in its own (before ``T_link_shape``)."""
    if shape.kind in PRIMITIVES:
        mesh = primitive_mesh(shape.kind, shape.size)
    else:
        assert shape.mesh_path is not None
        mesh = load_mesh(shape.mesh_path, f"link {shape.link!r}")
        mesh.apply_transform(np.diag([*shape.mesh_scale, 1.0]))
    if frame == "link":
        mesh.apply_transform(shape.T_link_shape)
    elif frame != "shape":
        raise ValueError(f"frame must be 'link' or 'shape', not {frame!r}")
    return mesh


def link_mesh(kin: Kinematics, link: str) -> Any:
    """All of a link's shapes as one ``trimesh.Trimesh`` in its frame (the link
    must have geometry)."""
    import trimesh

    return trimesh.util.concatenate([shape_mesh(s) for s in kin.shapes[link]])


def load_mesh(path: Path, what: str) -> Any:
    """A mesh file as one ``trimesh.Trimesh``, a copy (a scene's geometry, as
    GLB/GLTF and COLLADA files hold, concatenated in the file's frame).

    Raises
    ------
    GripperError
        The file cannot be read or holds no triangles; ``what`` names its user.
    """
    import trimesh

    try:
        mesh = trimesh.load(str(path), force="mesh")
    except ImportError as exc:
        raise GripperError(
            f"mesh {str(path)!r} of {what} needs a reader that is not installed "
            f"({exc})",
            hint="pip install pycollada for COLLADA (.dae) meshes, or convert the "
            "mesh to STL, OBJ or PLY",
        ) from None
    except Exception as exc:  # noqa: BLE001 - unreadable mesh file
        raise GripperError(
            f"mesh {str(path)!r} of {what} cannot be read: {type(exc).__name__}: {exc}",
            hint="convert the mesh to STL, OBJ or PLY",
        ) from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise GripperError(
            f"mesh {str(path)!r} of {what} holds no triangles",
            hint="export the part as a triangle mesh (STL, OBJ, PLY, GLB or DAE)",
        )
    return mesh.copy()
