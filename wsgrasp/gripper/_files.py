"""The files a gripper YAML leads to: the YAML, its URDF, and the URDF's collision
meshes. ``wsgrasp spec check`` and loading a spec look them up before anything is
built, and name the first one missing with the path tried and what it is
relative to."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

__all__ = ["missing_gripper_file"]


def missing_gripper_file(ref: str, base: Path, base_label: str) -> str | None:
    """The first file the gripper YAML ``ref`` leads to that is missing, as a
    sentence naming what names it, the path tried and what that path is
    relative to; None when all are there.

    Parameters
    ----------
    ref
        The gripper YAML's path as written (absolute, or relative to ``base``).
    base
        The folder a relative ``ref`` is taken from.
    base_label
        What ``base`` is, for the message (``"the spec file's folder"``).

    Raises
    ------
    SpecError
        The YAML is there but is no valid gripper description.
    """
    from wsgrasp._names import gripper_ref
    from wsgrasp.gripper._build import urdf_path
    from wsgrasp.spec import load_gripper_description

    yaml_path = Path(gripper_ref(ref, base))
    if not yaml_path.is_file():
        relative = (
            "" if Path(ref).is_absolute() else f" (relative to {base_label} {base})"
        )
        return f"file {ref} is not found: tried {yaml_path}{relative}"
    desc, yaml_dir = load_gripper_description(yaml_path)
    urdf = urdf_path(desc, yaml_dir)
    if not urdf.is_file():
        return (
            f"{yaml_path} names urdf {desc.urdf}, which is not found: tried {urdf}"
            + (
                ""
                if Path(desc.urdf).expanduser().is_absolute()
                else f" (relative to the gripper YAML's folder {yaml_dir})"
            )
        )
    return _missing_mesh(urdf)


def _missing_mesh(urdf: Path) -> str | None:
    """The first collision mesh of ``urdf`` that is not found (what the build
    refuses; a missing visual mesh only warns), as a sentence; None when every
    one is there or the file does not parse (the build says why)."""
    from wsgrasp.gripper._urdf import parse_xml, resolve_mesh

    try:
        root = parse_xml(urdf.read_bytes())
    except (ET.ParseError, OSError):
        return None
    folder = urdf.parent
    for link in root.iter("link"):
        for mesh in link.findall("collision/geometry/mesh"):
            name = (mesh.get("filename") or "").strip()
            if not name or resolve_mesh(name, folder) is not None:
                continue
            what = f"{urdf} names collision mesh {name} (link {link.get('name')!r})"
            return f"{what}, which is not found: tried {_tried(name, folder)}"
    return None


def _tried(name: str, folder: Path) -> str:
    """Where a mesh ``name`` from a URDF in ``folder`` was looked for, in words,
    with what it is relative to."""
    plain = name.removeprefix("file://")
    if plain.startswith("package://"):
        pkg, _, rel = plain.removeprefix("package://").partition("/")
        return (
            f"{rel or pkg} in the folders of package {pkg!r} (the URDF's folder "
            f"{folder} and those above it, and ROS_PACKAGE_PATH), and beside the "
            "URDF and in its three parent folders"
        )
    path = Path(plain)
    if path.is_absolute():
        return str(path)
    return f"{folder / path} (relative to the URDF's folder {folder})"
