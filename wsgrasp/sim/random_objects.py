"""The ``random`` object set: pybullet_data's 1,000 procedurally generated objects.

The ``pybullet`` wheel on PyPI ships ``pybullet_data/random_urdfs/NNN/NNN.urdf``
with ``NNN.obj``: blobs, rings and branched shapes, each a union of a few convex
pieces. Only the files are used (``pybullet`` itself is never imported); they come
with ``pip install 'wsgrasp[sim]'``.

Each object is read with the project's URDF reader (yourdfpy): its collision mesh,
the mesh scale and the inertial mass (0.1 kg for every object: a placeholder, so a
trial weighs the object by the protocol's density, :func:`wsgrasp.sim.objects.
trial_mass`). The mesh is scaled by the URDF's scale and
then by ``RANDOM_SCALE`` (2/3: 6-10 cm across, the size of the objects the paper's
grippers hold); objects whose largest extent is under ``MIN_EXTENT`` (3 cm) after
scaling are skipped, as are unreadable meshes (``random_168``'s vertices are NaN).
They are named ``random_NNN`` and collide as their coacd decomposition
(:mod:`wsgrasp.sim._meshes`).

Selections: ``random`` (all), ``random:000-299`` (``DEV_RANGE``, for tuning),
``random:300-999`` (``HELD_OUT_RANGE``, for reporting), ``random:7``, or a comma
list of both (``random:0-9,20``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from wsgrasp.errors import InputError, SimulationError, WsgraspError
from wsgrasp.sim._meshes import MeshSource

__all__ = [
    "DEV_RANGE",
    "HELD_OUT_RANGE",
    "MIN_EXTENT",
    "RANDOM_COUNT",
    "RANDOM_SCALE",
    "RANDOM_SET",
    "Skipped",
    "parse_selection",
    "random_objects",
    "random_urdfs_dir",
]

#: the set's name in ``--objects``
RANDOM_SET = "random"
#: objects in pybullet_data/random_urdfs (000-999)
RANDOM_COUNT = 1000
#: applied after the URDF's mesh scale
RANDOM_SCALE = 2.0 / 3.0
#: metres: objects whose largest extent is smaller are skipped
MIN_EXTENT = 0.03
#: development range (tune on these) and held-out range (report these)
DEV_RANGE = (0, 299)
HELD_OUT_RANGE = (300, 999)

_ITEM = re.compile(r"^\s*(\d+)\s*(?:-\s*(\d+)\s*)?$")
_HINT = (
    f"write {RANDOM_SET}, {RANDOM_SET}:N or {RANDOM_SET}:A-B with "
    f"0 <= A <= B <= {RANDOM_COUNT - 1}, e.g. {RANDOM_SET}:000-299 (development) "
    f"or {RANDOM_SET}:300-999 (held out)"
)


@dataclass(frozen=True)
class Skipped:
    """An object of a set that is left out, and why."""

    name: str
    reason: str


def parse_selection(selection: str, count: int = RANDOM_COUNT) -> list[int]:
    """Object numbers of a selection: ``""`` (all), ``"7"``, ``"000-299"``, or a
    comma list of these; sorted, without repeats.

    Raises
    ------
    InputError
        Not numbers or ranges, a range from high to low, or beyond ``count - 1``.
    """
    if selection.strip() == "":
        return list(range(count))
    ids: set[int] = set()
    for item in selection.split(","):
        m = _ITEM.match(item)
        name = f"{RANDOM_SET}:{selection}"
        if m is None:
            raise InputError(
                f"object set {name!r}: {item.strip()!r} is not a number or a range A-B",
                hint=_HINT,
            )
        lo = int(m.group(1))
        hi = int(m.group(2)) if m.group(2) is not None else lo
        if lo > hi:
            raise InputError(
                f"object set {name!r}: range {item.strip()!r} runs backwards",
                hint=_HINT,
            )
        if hi >= count:
            raise InputError(
                f"object set {name!r}: {hi} is beyond the last object "
                f"({count - 1:03d})",
                hint=_HINT,
            )
        ids.update(range(lo, hi + 1))
    return sorted(ids)


def random_urdfs_dir() -> Path:
    """``pybullet_data/random_urdfs``, located without importing ``pybullet``.

    Raises
    ------
    SimulationError
        ``pybullet`` (which ships the data) is not installed.
    """
    import importlib.util

    spec = importlib.util.find_spec("pybullet_data")
    locations = list(spec.submodule_search_locations or []) if spec else []
    for loc in locations:
        d = Path(loc) / "random_urdfs"
        if d.is_dir():
            return d
    raise SimulationError(
        f"object set {RANDOM_SET!r} needs pybullet_data/random_urdfs, which ships "
        "in the pybullet wheel, and "
        + ("pybullet is not installed" if not locations else "it has no random_urdfs"),
        hint="pip install 'wsgrasp[sim]'",
    )


def _source(number: int, root: Path) -> MeshSource | Skipped:
    """Object ``number`` as a mesh to decompose, or why it is skipped."""
    import trimesh

    from wsgrasp.gripper._urdf import load_kinematics

    name = f"{RANDOM_SET}_{number:03d}"
    urdf = root / f"{number:03d}" / f"{number:03d}.urdf"
    try:
        kin = load_kinematics(urdf, name)
    except WsgraspError as exc:
        raise InputError(
            f"object {name}: {exc.message}",
            hint="reinstall pybullet (pip install --force-reinstall pybullet)",
        ) from None
    meshes = [s for shapes in kin.shapes.values() for s in shapes if s.kind == "mesh"]
    if len(meshes) != 1 or meshes[0].mesh_path is None:
        return Skipped(name, f"{len(meshes)} collision meshes, expected 1")
    shape = meshes[0]
    mass = float(sum(i.mass for i in kin.inertials.values()))
    if mass <= 0:
        return Skipped(name, "no inertial mass")
    mesh = trimesh.load(str(shape.mesh_path), force="mesh")
    vertices = np.asarray(getattr(mesh, "vertices", np.empty((0, 3))), dtype=float)
    if len(vertices) == 0 or not np.isfinite(vertices).all():
        return Skipped(name, "unreadable mesh")
    # every collision <origin> of the set is zero (checked on pybullet 3.2.7)
    scale = np.asarray(shape.mesh_scale, dtype=np.float64) * RANDOM_SCALE  # (3,)
    extent = float(np.max(np.ptp(vertices * scale, axis=0)))
    if extent < MIN_EXTENT:
        return Skipped(name, f"under {100 * MIN_EXTENT:.0f} cm")
    # the same 0.1 kg for every object of the set: a placeholder, not a mass
    return MeshSource(name, mesh, scale, mass=mass, origin=str(urdf), mass_given=False)


def random_objects(selection: str = "") -> tuple[list[MeshSource], list[Skipped]]:
    """The objects of ``random:<selection>`` as meshes to decompose, and the
    skipped ones (see the module docstring)."""
    ids = parse_selection(selection)
    root = random_urdfs_dir()
    sources: list[MeshSource] = []
    skipped: list[Skipped] = []
    for number in ids:
        src = _source(number, root)
        if isinstance(src, Skipped):
            skipped.append(src)
        else:
            sources.append(src)
    return sources, skipped
