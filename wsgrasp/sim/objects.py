"""Objects for the grasp trials: the ``paper13`` set, generated in code, the
``random`` set (pybullet_data, :mod:`wsgrasp.sim.random_objects`), and meshes.

An object is a rigid body made of convex parts (MuJoCo collides convex shapes):
primitives (box, cylinder, capsule, sphere, ellipsoid) and convex hulls. The same
parts, as triangle meshes, are what the virtual depth cameras see. Hollow things
(mug, bin, cup, pot) are walls made of convex segments, so fingers can go inside.
Mesh objects (files, the ``random`` set) collide as their coacd convex
decomposition (:mod:`wsgrasp.sim._meshes`) and are seen as the mesh itself.

``paper13`` models the 13 objects of Sorour et al. (IROS 2019), Table II, with
plausible sizes and masses (metres, kilograms); the paper chose them "within the
grasping volume dimensions of each gripper", and notes some were too big (thermos
and cookies package for the Franka hand) or too low (banana, dish brush for the
Allegro hand).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp.errors import InputError
from wsgrasp.geometry import primitive_mesh
from wsgrasp.sim._meshes import (
    Decomposition,
    MeshSource,
    convex_decomposition,
    decompose_meshes,
)
from wsgrasp.sim._xml import attrs, fmt, pose_attrs
from wsgrasp.sim.params import SimParams
from wsgrasp.sim.random_objects import RANDOM_SET, Skipped, random_objects

__all__ = [
    "OBJECT_SETS",
    "ObjectList",
    "Part",
    "SimObject",
    "load_objects",
    "mesh_source",
    "object_from_mesh",
    "object_from_source",
    "paper13",
    "resolve_objects",
    "trial_friction",
    "trial_mass",
]

Array = NDArray[np.float64]

#: collision bits of objects and the table: they touch everything
OBJECT_CONTYPE, OBJECT_CONAFFINITY = 1, 3


def _T(xyz: tuple[float, float, float] = (0, 0, 0), R: Array | None = None) -> Array:
    T = np.eye(4)
    T[:3, 3] = xyz
    if R is not None:
        T[:3, :3] = R
    return T


def _rot(axis: str, angle: float) -> Array:
    from scipy.spatial.transform import Rotation

    return Rotation.from_euler(axis, angle).as_matrix()


@dataclass
class Part:
    """One convex piece of an object, in the object's frame.

    Attributes
    ----------
    kind : str
        box (size = full extents), cylinder (radius, height), capsule (radius,
        length of the straight part), sphere (radius), ellipsoid (semi-axes) or
        hull (``vertices``); cylinders and capsules run along their z.
    size : tuple of float
    T_object_part : (4, 4) float
    vertices : (n, 3) float, for hulls
    """

    kind: str
    size: tuple[float, ...] = ()
    T_object_part: Array = field(default_factory=lambda: np.eye(4))
    vertices: Array | None = None

    def to_trimesh(self) -> Any:
        """The part as a closed triangle mesh in the object frame."""
        import trimesh

        if self.kind == "hull":
            m = trimesh.Trimesh(vertices=self.vertices).convex_hull
        else:
            m = primitive_mesh(self.kind, self.size, subdivisions=2)
        m.apply_transform(self.T_object_part)
        return m

    def to_mjcf(self, name: str, assets: list[str]) -> tuple[str, str]:
        """``(type and size attributes, pose attributes)`` of the MJCF geom."""
        pose = pose_attrs(self.T_object_part)
        if self.kind == "box":
            return attrs(type="box", size=np.asarray(self.size) / 2.0), pose
        if self.kind == "cylinder":
            return attrs(type="cylinder", size=(self.size[0], self.size[1] / 2)), pose
        if self.kind == "capsule":
            return attrs(type="capsule", size=(self.size[0], self.size[1] / 2)), pose
        if self.kind == "sphere":
            return attrs(type="sphere", size=self.size[0]), pose
        if self.kind == "ellipsoid":
            return attrs(type="ellipsoid", size=self.size), pose
        assert self.vertices is not None
        vertex = fmt(np.asarray(self.vertices).reshape(-1))  # (3n,)
        assets.append(f'<mesh name="{name}" vertex="{vertex}"/>')
        return attrs(type="mesh", mesh=name), pose


@dataclass
class SimObject:
    """A rigid object: convex parts, a mass and a friction coefficient.

    Attributes
    ----------
    name : str
    parts : list of Part
    mass : float
        kg, spread uniformly over the parts' volume. What a trial uses is
        :func:`trial_mass`: a mass the protocol forces, else this one when
        ``mass_given``, else the protocol's density times :meth:`volume`.
    friction : float or None
        Sliding friction of every contact with the object; None (the default):
        the trial protocol's (:attr:`SimParams.friction`).
    render_mesh : trimesh.Trimesh or None
        What the cameras see; the union of the parts when None.
    mass_given : bool
        ``mass`` is the object's own (a set's table, ``masses.json``, a mass
        passed in); False where it is a placeholder (a mesh file without a mass,
        the ``random`` set's URDFs, which give all 1,000 objects 0.1 kg).
    """

    name: str
    parts: list[Part]
    mass: float
    friction: float | None = None
    render_mesh: Any = None
    mass_given: bool = True
    _volume: float | None = field(default=None, repr=False, compare=False)

    def mesh(self) -> Any:
        """The object's surface as one triangle mesh (object frame)."""
        import trimesh

        if self.render_mesh is not None:
            return self.render_mesh
        return trimesh.util.concatenate([p.to_trimesh() for p in self.parts])

    def volume(self) -> float:
        """Volume (m³) of the collision parts, as the inertia counts it
        (overlaps twice)."""
        if self._volume is None:
            import trimesh

            hulls: Any = trimesh.util.concatenate([p.to_trimesh() for p in self.parts])
            self._volume = float(hulls.volume)
        return self._volume

    def inertial(self, mass: float | None = None) -> tuple[Array, Array]:
        """Centre of mass ``(3,)`` and inertia ``(3, 3)`` about it, for uniform
        density over the parts (overlaps counted twice), at ``mass`` (kg;
        default ``self.mass``)."""
        import trimesh

        hulls: Any = trimesh.util.concatenate([p.to_trimesh() for p in self.parts])
        volume = float(hulls.volume)
        hulls.density = (self.mass if mass is None else mass) / volume
        return (
            np.asarray(hulls.center_mass, dtype=np.float64),
            np.asarray(hulls.moment_inertia, dtype=np.float64),
        )

    def size(self) -> Array:
        """Extents ``(3,)`` of the object's axis-aligned box in its frame."""
        return np.asarray(self.mesh().extents, dtype=np.float64)


def trial_mass(obj: SimObject, params: SimParams) -> float:
    """The mass (kg) a trial gives ``obj``: ``params.object_mass`` when it forces
    one, else the object's own when it has one (``mass_given``), else
    ``params.density`` times the volume of its collision parts."""
    if params.object_mass is not None:
        return float(params.object_mass)
    if obj.mass_given:
        return float(obj.mass)
    return float(params.density * obj.volume())


def trial_friction(obj: SimObject, params: SimParams) -> float:
    """The sliding friction a trial gives ``obj``'s contacts: its own when set,
    else the protocol's."""
    return float(params.friction if obj.friction is None else obj.friction)


# --------------------------------------------------------------------------------
# building blocks
# --------------------------------------------------------------------------------
def _wall(
    r_bottom: float,
    r_top: float,
    height: float,
    thickness: float,
    segments: int = 16,
    z0: float = 0.0,
    arc: tuple[float, float] = (0.0, 2.0 * np.pi),
) -> list[Part]:
    """A round wall (cylinder or frustum shell) as convex segments, base at z0."""
    parts = []
    edges = np.linspace(arc[0], arc[1], segments + 1)
    for a0, a1 in zip(edges[:-1], edges[1:], strict=True):
        ang = np.array([a0, a1])
        pts = []
        for r, z in ((r_bottom, z0), (r_top, z0 + height)):
            for rr in (r, r - thickness):
                pts.append(np.stack([rr * np.cos(ang), rr * np.sin(ang), [z, z]], 1))
        parts.append(Part("hull", vertices=np.concatenate(pts)))  # (8, 3)
    return parts


def _disk(radius: float, height: float, z0: float = 0.0) -> Part:
    return Part("cylinder", (radius, height), _T((0, 0, z0 + height / 2)))


def _box_wall(
    size: tuple[float, float, float], thickness: float, bottom: float
) -> list[Part]:
    """An open-top box: a bottom plate and four walls, base at z = 0."""
    x, y, z = size
    t = thickness
    return [
        Part("box", (x, y, bottom), _T((0, 0, bottom / 2))),
        Part("box", (t, y, z), _T((x / 2 - t / 2, 0, z / 2))),
        Part("box", (t, y, z), _T((-x / 2 + t / 2, 0, z / 2))),
        Part("box", (x - 2 * t, t, z), _T((0, y / 2 - t / 2, z / 2))),
        Part("box", (x - 2 * t, t, z), _T((0, -y / 2 + t / 2, z / 2))),
    ]


# --------------------------------------------------------------------------------
# paper13
# --------------------------------------------------------------------------------
def _storage_bin() -> SimObject:
    # a small open plastic bin, 13 x 9 x 7 cm, 4 mm walls
    return SimObject("storage_bin", _box_wall((0.13, 0.09, 0.07), 0.004, 0.004), 0.12)


def _mug() -> SimObject:
    r, h = 0.035, 0.09  # a 7 cm tea mug
    parts = [_disk(r - 0.001, 0.008)] + _wall(r, r, h, 0.005, 16)
    # handle: three bars in the x-z plane outside the wall at +x
    parts += [
        Part("box", (0.012, 0.012, 0.06), _T((r + 0.024, 0, 0.05))),
        Part("box", (0.032, 0.012, 0.012), _T((r + 0.012, 0, 0.074))),
        Part("box", (0.032, 0.012, 0.012), _T((r + 0.012, 0, 0.026))),
    ]
    return SimObject("mug", parts, 0.30)


def _thermos() -> SimObject:
    parts = [
        Part("cylinder", (0.035, 0.20), _T((0, 0, 0.10))),
        Part("cylinder", (0.028, 0.04), _T((0, 0, 0.22))),
    ]
    return SimObject("thermos", parts, 0.45)


def _realsense_box() -> SimObject:
    return SimObject(
        "realsense_box", [Part("box", (0.13, 0.07, 0.055), _T((0, 0, 0.0275)))], 0.2
    )


def _cookies_package() -> SimObject:
    # a roll of biscuits in a wrapper: a 21 cm long cylinder of 6.5 cm diameter
    return SimObject(
        "cookies_package",
        [Part("cylinder", (0.0325, 0.21), _T((0, 0, 0.0325), _rot("y", np.pi / 2)))],
        0.25,
    )


def _plant_pot() -> SimObject:
    rb, rt, h = 0.029, 0.036, 0.08
    parts = [_disk(rb - 0.001, 0.01)] + _wall(rb, rt, h, 0.005, 16)
    return SimObject("plant_pot", parts, 0.20)


def _plastic_cup() -> SimObject:
    rb, rt, h = 0.025, 0.035, 0.095
    parts = [_disk(rb - 0.001, 0.003)] + _wall(rb, rt, h, 0.002, 16)
    return SimObject("plastic_cup", parts, 0.03)


def _tooth_paste() -> SimObject:
    # toothpaste in its carton
    return SimObject(
        "tooth_paste", [Part("box", (0.19, 0.045, 0.04), _T((0, 0, 0.02)))], 0.13
    )


def _toilet_paper_roll() -> SimObject:
    parts = _wall(0.05, 0.05, 0.095, 0.03, 16)
    return SimObject("toilet_paper_roll", parts, 0.12)


def _doll() -> SimObject:
    # a small soft doll sitting: torso, head, arms, legs (ellipsoids, capsules)
    parts = [
        Part("ellipsoid", (0.035, 0.025, 0.045), _T((0, 0, 0.046))),
        Part("sphere", (0.028,), _T((0, 0, 0.115))),
        Part("capsule", (0.011, 0.05), _T((0, 0.042, 0.06), _rot("x", 0.4))),
        Part("capsule", (0.011, 0.05), _T((0, -0.042, 0.06), _rot("x", -0.4))),
        Part("capsule", (0.013, 0.06), _T((0.03, 0.016, 0.013), _rot("y", np.pi / 2))),
        Part("capsule", (0.013, 0.06), _T((0.03, -0.016, 0.013), _rot("y", np.pi / 2))),
    ]
    return SimObject("doll", parts, 0.15)


def _dish_brush() -> SimObject:
    parts = [
        Part("box", (0.17, 0.022, 0.016), _T((0.0, 0, 0.008))),
        Part("cylinder", (0.028, 0.045), _T((0.105, 0, 0.0225))),
    ]
    return SimObject("dish_brush", parts, 0.09)


def _banana() -> SimObject:
    # five capsules along an arc of radius 12 cm, 3.6 cm thick, lying on its side
    parts = []
    R, r = 0.12, 0.018
    angles = np.linspace(-0.65, 0.65, 6)
    for a0, a1 in zip(angles[:-1], angles[1:], strict=True):
        # lying on its side: the arc in the table plane, resting on z = 0
        p0 = np.array([R * np.sin(a0), R - R * np.cos(a0), r])
        p1 = np.array([R * np.sin(a1), R - R * np.cos(a1), r])
        mid, d = (p0 + p1) / 2, p1 - p0
        length = float(np.linalg.norm(d))
        z = d / length
        x = np.cross([0.0, 0.0, 1.0], z)
        Rm = np.stack([x, np.cross(z, x), z], axis=1)
        rr = r * (0.75 + 0.25 * np.cos(2.2 * (a0 + a1) / 2))  # thinner ends
        parts.append(Part("capsule", (rr, length), _T(tuple(mid), Rm)))
    return SimObject("banana", parts, 0.15)


def _sprayer() -> SimObject:
    parts = [
        Part("box", (0.07, 0.05, 0.14), _T((0, 0, 0.07))),
        Part("cylinder", (0.014, 0.035), _T((0, 0, 0.1575))),
        Part("box", (0.065, 0.028, 0.035), _T((0.012, 0, 0.1925))),
        Part("box", (0.012, 0.02, 0.04), _T((0.03, 0, 0.155))),
    ]
    return SimObject("sprayer", parts, 0.3)


#: name → builder, in the order of the paper's Table II
PAPER13: dict[str, Callable[[], SimObject]] = {
    "storage_bin": _storage_bin,
    "mug": _mug,
    "thermos": _thermos,
    "realsense_box": _realsense_box,
    "cookies_package": _cookies_package,
    "plant_pot": _plant_pot,
    "plastic_cup": _plastic_cup,
    "tooth_paste": _tooth_paste,
    "toilet_paper_roll": _toilet_paper_roll,
    "doll": _doll,
    "dish_brush": _dish_brush,
    "banana": _banana,
    "sprayer": _sprayer,
}


def paper13() -> list[SimObject]:
    """The 13 objects of the paper's Table II."""
    return [build() for build in PAPER13.values()]


# --------------------------------------------------------------------------------
# object sets and mesh files
# --------------------------------------------------------------------------------
#: what a set yields: objects (built) and meshes (to decompose), and the skipped
SetItems = tuple[Sequence[SimObject | MeshSource], Sequence[Skipped]]


def _paper13_set(selection: str) -> SetItems:
    if selection:
        raise InputError(
            f"object set 'paper13:{selection}': paper13 takes no selection",
            hint="name its objects one by one instead (--objects mug --objects "
            "thermos)",
        )
    return paper13(), []


#: named object sets for ``--objects``: ``NAME`` or ``NAME:SELECTION`` → items
OBJECT_SETS: dict[str, Callable[[str], SetItems]] = {
    "paper13": _paper13_set,
    RANDOM_SET: random_objects,
}
_SET_NAMES = f"paper13, {RANDOM_SET}, {RANDOM_SET}:000-299"


#: file endings read as object meshes
MESH_SUFFIXES = (".obj", ".stl", ".ply")
#: the file beside meshes that gives their masses (mesh name without suffix → kg)
MASSES_FILE = "masses.json"


def mesh_masses(folder: Path) -> dict[str, float]:
    """The masses (kg) that ``folder/masses.json`` gives, by mesh name (the file
    name without its suffix); empty without the file.

    Raises
    ------
    InputError
        The file is not a JSON object of positive numbers.
    """
    import json

    path = folder / MASSES_FILE
    if not path.is_file():
        return {}
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise InputError(
            f"{str(path)!r} cannot be read as JSON: {exc}",
            hint='write it as {"mesh_name": kilograms, ...}',
        ) from None
    bad = (
        [f"{k}: {v!r}" for k, v in data.items() if not _positive(v)]
        if isinstance(data, dict)
        else ["not a JSON object"]
    )
    if bad:
        raise InputError(
            f"{str(path)!r} must map mesh names to masses in kg above 0; found "
            + ", ".join(bad[:5]),
            hint='write it as {"mesh_name": kilograms, ...}',
        )
    return {str(k): float(v) for k, v in data.items()}


def _positive(v: Any) -> bool:
    return (
        isinstance(v, (int, float))
        and not isinstance(v, bool)
        and math.isfinite(v)
        and v > 0
    )


def mesh_folder(folder: Path) -> list[Path]:
    """The mesh files of an object set folder (OBJ/STL/PLY), by name.

    Raises
    ------
    InputError
        The folder holds no mesh file.
    """
    files = sorted(
        p for p in folder.iterdir() if p.suffix.lower() in MESH_SUFFIXES and p.is_file()
    )
    if not files:
        raise InputError(
            f"object folder {str(folder)!r} holds no mesh file "
            f"({', '.join(MESH_SUFFIXES)})",
            hint="pass a folder of meshes in metres, with masses.json beside them",
        )
    return files


def _path_is(name: str | Path, test: Any) -> bool:
    """``test(Path(name))``, False where the name cannot be a path at all (too
    long for the file system, say: a long ``random:`` selection)."""
    try:
        return bool(test(Path(name)))
    except (OSError, ValueError):
        return False


def mesh_source(
    path: str | Path, *, mass: float | None = None, friction: float | None = None
) -> MeshSource:
    """A mesh file (OBJ/STL/PLY, metres), checked, as a mesh to decompose.

    Its mass is ``mass``, else what a ``masses.json`` beside it gives for its
    name, else none (``mass_given`` False: the trial's density times its volume).

    Raises
    ------
    InputError
        The file is missing, not a mesh, open, or without volume.
    """
    import trimesh

    p = Path(path)
    if not _path_is(p, Path.exists):
        raise InputError(
            f"object mesh {str(p)!r} does not exist",
            hint=f"pass a named set ({_SET_NAMES}), OBJ/STL/PLY files or a "
            "folder of them",
        )
    try:
        mesh = trimesh.load(p, force="mesh")
    except Exception as exc:  # noqa: BLE001 - any reader failure
        raise InputError(f"object mesh {str(p)!r} cannot be read: {exc}") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise InputError(
            f"object mesh {str(p)!r} has no triangles",
            hint="export the object as a triangle mesh",
        )
    if not mesh.is_watertight:
        raise InputError(
            f"object mesh {str(p)!r} is not watertight ({len(mesh.faces)} faces, "
            "open edges): its mass and inside are undefined",
            hint="close the holes (e.g. trimesh.repair.fill_holes, or Blender's "
            "3D-print toolbox) and export it again",
        )
    if not mesh.is_volume or float(mesh.volume) <= 1e-9:
        raise InputError(
            f"object mesh {str(p)!r} encloses no volume "
            f"(volume {float(mesh.volume):.3g} m³)",
            hint="check the face orientation (normals outwards) and the units (metres)",
        )
    if float(np.max(mesh.extents)) > 1.0:
        raise InputError(
            f"object mesh {str(p)!r} is {np.max(mesh.extents):.4g} m across; "
            "probably millimetres",
            hint="scale the mesh to metres (divide by 1000)",
        )
    if (mass is not None and mass <= 0) or (friction is not None and friction <= 0):
        raise InputError(
            f"--mass {mass} and --friction {friction} must be positive",
            hint="e.g. --mass 0.2 --friction 0.8",
        )
    given = mesh_masses(p.parent).get(p.stem) if mass is None else mass
    # without a mass of its own: the default density's, until a trial's replaces it
    placeholder = SimParams().density * float(mesh.volume)
    return MeshSource(
        p.stem,
        mesh,
        np.ones(3),
        placeholder if given is None else given,
        friction,
        origin=str(p),
        mass_given=given is not None,
    )


def object_from_source(source: MeshSource, decomposition: Decomposition) -> SimObject:
    """The object of a mesh and its convex parts, placed base-down on z = 0 with
    its centroid over the origin; the cameras see the mesh itself."""
    mesh = source.scaled()
    lo = np.asarray(mesh.bounds[0], dtype=np.float64)
    shift = np.array([-mesh.centroid[0], -mesh.centroid[1], -lo[2]])  # (3,)
    mesh.apply_translation(shift)
    parts = [Part("hull", vertices=h + shift) for h in decomposition.hulls]
    return SimObject(
        source.name,
        parts,
        source.mass,
        source.friction,
        render_mesh=mesh,
        mass_given=source.mass_given,
    )


def object_from_mesh(
    path: str | Path, *, mass: float | None = None, friction: float | None = None
) -> SimObject:
    """An object from a mesh file (OBJ/STL/PLY, metres); its mass as
    :func:`mesh_source` finds it.

    The mesh must be watertight and enclose a volume; it collides as its coacd
    convex decomposition (:func:`wsgrasp.sim._meshes.convex_decomposition`,
    cached) and is seen by the cameras as it is.

    Raises
    ------
    InputError
        The file is missing, not a mesh, open, or without volume.
    SimulationError
        The mesh is concave and coacd is not installed.
    """
    source = mesh_source(path, mass=mass, friction=friction)
    return object_from_source(source, convex_decomposition(source.mesh, source.scale))


@dataclass
class ObjectList:
    """Objects resolved from ``--objects`` names.

    Attributes
    ----------
    objects : list of SimObject
    skipped : list of Skipped
        Objects of a set left out (too small, unreadable), with the reason.
    decompositions : dict of str to Decomposition
        The convex decomposition of each mesh object, by object name.
    """

    objects: list[SimObject]
    skipped: list[Skipped] = field(default_factory=list)
    decompositions: dict[str, Decomposition] = field(default_factory=dict)


def resolve_objects(
    names: list[str],
    *,
    mass: float | None = None,
    friction: float | None = None,
    workers: int = 0,
    progress: bool = False,
) -> ObjectList:
    """Objects from set names, paper13 object names and mesh files, in order.

    A name is a set (``paper13``, ``random``) or a set with a selection after a
    colon (``random:000-299``) when its part before the colon names a set and it
    is not an existing file; else a ``paper13`` object's name; else a folder of
    meshes (every OBJ/STL/PLY file in it, by name, with the masses of its
    ``masses.json``); else a mesh file (its mass from a ``masses.json`` beside
    it). The meshes of all names are decomposed together
    (:func:`decompose_meshes`: cached, cache misses in ``workers`` processes,
    with a progress bar when ``progress``). ``mass`` and ``friction`` override
    the objects' own values; a mesh without a mass weighs what the trial's
    density gives (:func:`trial_mass`).

    Raises
    ------
    InputError
        An unknown name, a missing or bad mesh, a bad selection, or no objects.
    SimulationError
        A set whose data or a library it needs is not installed.
    """
    for label, value in (("mass", mass), ("friction", friction)):
        if value is not None and not (math.isfinite(value) and value > 0.0):
            raise InputError(
                f"object {label} {value} is not a positive finite number",
                hint=f"give a {label} above 0, or leave it out to use the objects' own",
            )
    items: list[SimObject | MeshSource] = []
    skipped: list[Skipped] = []
    for name in names:
        base, sep, selection = name.partition(":")
        if base in OBJECT_SETS and not (sep and _path_is(name, Path.exists)):
            got, left_out = OBJECT_SETS[base](selection)
            items.extend(got)
            skipped.extend(left_out)
        elif name in PAPER13:
            items.append(PAPER13[name]())
        elif _path_is(name, Path.is_dir):
            items.extend(
                mesh_source(f, mass=mass, friction=friction)
                for f in mesh_folder(Path(name))
            )
        else:
            items.append(mesh_source(name, mass=mass, friction=friction))
    if not items:
        raise InputError(
            f"no objects given{' (all skipped)' if skipped else ''}",
            hint="pass --objects paper13 or --objects random:000-299",
        )
    sources = [it for it in items if isinstance(it, MeshSource)]
    decomposed = decompose_meshes(sources, workers=workers, progress=progress)
    by_source = {id(s): d for s, d in zip(sources, decomposed, strict=True)}
    out = ObjectList([])
    for it in items:
        if isinstance(it, MeshSource):
            d = by_source[id(it)]
            out.objects.append(object_from_source(it, d))
            out.decompositions[it.name] = d
        else:
            out.objects.append(it)
    out.skipped = skipped
    for o in out.objects:
        if mass is not None:
            o.mass, o.mass_given = mass, True
        if friction is not None:
            o.friction = friction
    return out


def load_objects(
    names: list[str],
    *,
    mass: float | None = None,
    friction: float | None = None,
    workers: int = 0,
    progress: bool = False,
) -> list[SimObject]:
    """The objects of :func:`resolve_objects` (without the skipped ones' list)."""
    return resolve_objects(
        names, mass=mass, friction=friction, workers=workers, progress=progress
    ).objects
