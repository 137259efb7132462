"""Copying a URDF and its meshes for a scaffolded gripper plugin: mesh references
resolved and rewritten beside the copy, mesh units checked (and scaled on request).
"""

from __future__ import annotations

import re
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from wsgrasp.errors import GripperError
from wsgrasp.gripper._urdf import resolve_mesh

__all__ = ["MAX_MESH_EXTENT", "MESH_UNITS", "copy_urdf", "unlimited_continuous"]

#: unit name -> metres per unit, for ``--mesh-units``
MESH_UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}
#: a single mesh larger than this (m) is taken to be in other units than metres
MAX_MESH_EXTENT = 1.0
_MESH_TAG = re.compile(r"<mesh\b[^>]*>", re.S)
_FILENAME = re.compile(r"""filename\s*=\s*(["'])(.*?)\1""", re.S)
_SCALE = re.compile(r"""scale\s*=\s*(["'])(.*?)\1""", re.S)


def _mesh_links(text: str) -> dict[str, list[str]]:
    """Mesh filename -> links that reference it."""
    out: dict[str, list[str]] = {}
    try:
        root = ET.fromstring(text)
    except ET.ParseError:
        return out
    for link in root.iter("link"):
        for mesh in link.iter("mesh"):
            name = mesh.get("filename")
            if name:
                out.setdefault(name, []).append(link.get("name", "?"))
    return out


def _find_mesh(name: str, urdf_dir: Path, mesh_dirs: list[Path]) -> Path | None:
    found = resolve_mesh(name, urdf_dir)
    for d in mesh_dirs:
        if found is not None:
            break
        found = resolve_mesh(name, d)
        if found is None and (d / Path(name).name).is_file():
            found = d / Path(name).name
    return found


def _scale_of(tag: str) -> NDArray[np.float64]:
    m = _SCALE.search(tag)
    if m is None:
        return np.ones(3)
    vals = np.array([float(v) for v in m.group(2).split()], dtype=np.float64)
    return np.broadcast_to(vals, (3,)).copy()


def copy_urdf(
    urdf: Path,
    out_dir: Path,
    stem: str,
    *,
    mesh_dirs: list[Path] | None = None,
    mesh_units: str | None = None,
) -> tuple[Path, list[str]]:
    """Copy a URDF and the meshes it references into ``out_dir``.

    Mesh references are rewritten to ``meshes/<file>`` beside the copy; with
    ``mesh_units`` every ``<mesh>`` gets ``scale`` multiplied by that unit in
    metres. Meshes larger than :data:`MAX_MESH_EXTENT` after scaling are taken to
    be in other units and raise (or, with ``mesh_units`` given, warn).

    Returns
    -------
    path, notes
        The copied URDF and one line per mesh rewritten.

    Raises
    ------
    GripperError
        The URDF is missing, a mesh is not found, or a mesh looks like millimetres.
    """
    import trimesh

    urdf = Path(urdf)
    if not urdf.is_file():
        raise GripperError(
            f"URDF {str(urdf)!r} does not exist",
            hint="pass the path of the gripper's URDF file with --urdf",
        )
    text = urdf.read_text()
    dirs = [Path(d) for d in (mesh_dirs or [])]
    links = _mesh_links(text)
    factor = MESH_UNITS[mesh_units] if mesh_units else 1.0
    missing: list[str] = []
    target: dict[str, str] = {}  # filename in URDF -> meshes/<file>
    sources: dict[str, Path] = {}
    used: set[str] = set()
    notes: list[str] = []
    for name in links:
        src = _find_mesh(name, urdf.parent, dirs)
        if src is None:
            missing.append(f"{name!r} (link {', '.join(links[name])})")
            continue
        base = src.name
        i = 1
        while base in used:
            base, i = f"{i}_{src.name}", i + 1
        used.add(base)
        target[name] = f"meshes/{base}"
        sources[name] = src
    if missing:
        looked = [str(urdf.parent)] + [str(d) for d in dirs]
        raise GripperError(
            f"URDF {urdf.name}: mesh file(s) not found: {'; '.join(missing)} "
            f"(looked beside the URDF, in its parent folders for package:// paths, "
            f"and in {', '.join(looked)})",
            hint="pass --mesh-dir DIR for the folder that holds the meshes (e.g. the "
            "ROS package's root), or fix the filename in the URDF",
        )

    def rewrite(m: re.Match[str]) -> str:
        tag = m.group(0)
        fm = _FILENAME.search(tag)
        if fm is None or fm.group(2) not in target:
            return tag
        tag = tag.replace(fm.group(0), f'filename="{target[fm.group(2)]}"')
        if factor != 1.0:
            s = _scale_of(tag) * factor
            new = 'scale="' + " ".join(f"{v:g}" for v in s) + '"'
            sm = _SCALE.search(tag)
            if sm is not None:
                tag = tag.replace(sm.group(0), new)
            else:
                tag = tag.replace("<mesh", f"<mesh {new}", 1)
        return tag

    out_text = _MESH_TAG.sub(rewrite, text)
    # size of every mesh as it will be used (URDF scale included)
    for tag in _MESH_TAG.findall(out_text):
        fm = _FILENAME.search(tag)
        if fm is None:
            continue
        rel = fm.group(2)
        orig = next((k for k, v in target.items() if v == rel), None)
        if orig is None:
            continue
        try:
            mesh = trimesh.load(str(sources[orig]), force="mesh")
        except Exception as exc:  # noqa: BLE001 - unreadable mesh
            raise GripperError(
                f"URDF {urdf.name}: mesh {str(sources[orig])!r} (link "
                f"{', '.join(links[orig])}) cannot be read: {exc}",
                hint="convert the mesh to STL, OBJ or PLY",
            ) from None
        extent = float(np.max(np.asarray(mesh.extents) * np.abs(_scale_of(tag))))
        if extent > MAX_MESH_EXTENT:
            raise GripperError(
                f"URDF {urdf.name}: mesh {sources[orig].name!r} of link "
                f"{', '.join(links[orig])} is {extent:.1f} m across as the URDF scales "
                "it; its units look like millimetres (URDF lengths are metres)",
                hint="run `wsgrasp gripper new` again with --mesh-units mm (the copy "
                'of the URDF gets scale="0.001 0.001 0.001"), or add that scale to '
                "its <mesh> element",
            )
        note = f"{orig} -> {rel} ({extent * 1000:.0f} mm across)"
        if note not in notes:
            notes.append(note)
    out_dir.mkdir(parents=True, exist_ok=True)
    if target:
        (out_dir / "meshes").mkdir(exist_ok=True)
    for name, rel in target.items():
        shutil.copyfile(sources[name], out_dir / rel)
    dest = out_dir / f"{stem}.urdf"
    dest.write_text(out_text)
    return dest, notes


def unlimited_continuous(path: Path) -> list[str]:
    """Continuous joints without ``<limit lower upper>``."""
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError:
        return []
    out = []
    for j in root.iter("joint"):
        if j.get("type") != "continuous":
            continue
        lim = j.find("limit")
        if lim is None or lim.get("lower") is None or lim.get("upper") is None:
            out.append(j.get("name", "?"))
    return out
