"""Copying a URDF and its meshes for a scaffolded gripper plugin: mesh references
resolved (``package://`` URIs included) and rewritten beside the copy, mesh units
checked (and scaled on request), visual meshes that are missing or unreadable left
out with a warning (only the collision geometry is needed).
"""

from __future__ import annotations

import os
import re
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp.errors import GripperError
from wsgrasp.gripper._urdf import load_mesh, not_urdf, parse_xml, resolve_mesh

__all__ = [
    "MAX_MESH_EXTENT",
    "add_mimic",
    "collisions_from_visuals",
    "MESH_UNITS",
    "copy_urdf",
    "expand_xacro",
    "is_xacro",
    "narrow_limits",
    "prune_urdf",
    "set_limits",
    "unlimited_continuous",
    "xacro_args",
]

#: unit name -> metres per unit, for ``--mesh-units``
MESH_UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}
#: a single mesh larger than this (m) is taken to be in other units than metres
MAX_MESH_EXTENT = 1.0
#: a tag's name ends at white space, '/' or '>': ``<joint`` does not open
#: ``<joint:hinge>`` (a Gazebo element in the PR2's URDF) or ``<jointName>``
_END = r"(?=[\s/>])"
_MESH_TAG = re.compile(rf"<mesh{_END}[^>]*>", re.S)
_FILENAME = re.compile(r"""filename\s*=\s*(["'])(.*?)\1""", re.S)
_SCALE = re.compile(r"""scale\s*=\s*(["'])(.*?)\1""", re.S)
_JOINT = re.compile(rf"<joint{_END}[^>]*?(?<!/)>.*?</joint\s*>", re.S)
_NAME = re.compile(r"""\bname\s*=\s*(["'])(.*?)\1""", re.S)
_LIMIT = re.compile(rf"<limit{_END}[^>]*>", re.S)
_VISUAL = re.compile(rf"<visual{_END}[^>]*?(?<!/)>.*?</visual\s*>", re.S)
_COLLISION = re.compile(
    rf"<collision{_END}[^>]*?/>|<collision{_END}[^>]*?(?<!/)>.*?</collision\s*>", re.S
)
_MATERIAL = re.compile(
    rf"<material{_END}[^>]*?/>|<material{_END}[^>]*?(?<!/)>.*?</material\s*>", re.S
)
_LINK = re.compile(rf"<link{_END}[^>]*?/>|<link{_END}[^>]*?(?<!/)>.*?</link\s*>", re.S)
_CHILD = re.compile(rf"""<child{_END}[^>]*?\blink\s*=\s*(["'])(.*?)\1""", re.S)
_PARENT = re.compile(rf"""<parent{_END}[^>]*?\blink\s*=\s*(["'])(.*?)\1""", re.S)


def _mesh_uses(text: str) -> dict[str, list[tuple[str, bool]]]:
    """Mesh filename -> ``(link, shape)`` for each element naming it, where
    ``shape`` says whether wsgrasp takes the element as the link's shape (a
    collision element, or a visual one of a link without collision elements)."""
    out: dict[str, list[tuple[str, bool]]] = {}
    try:
        root = parse_xml(text.encode())
    except ET.ParseError:
        return out
    for link in root.iter("link"):
        has_collision = link.find("collision") is not None
        for kind in ("collision", "visual"):
            shape = kind == "collision" or not has_collision
            for el in link.findall(kind):
                for mesh in el.iter("mesh"):
                    name = mesh.get("filename")
                    if name:
                        use = (link.get("name", "?"), shape)
                        if use not in out.setdefault(name, []):
                            out[name].append(use)
    return out


def _find_mesh(
    name: str, urdf_dir: Path, mesh_dirs: list[Path], package_paths: list[Path]
) -> Path | None:
    found = resolve_mesh(name, urdf_dir, package_paths)
    for d in mesh_dirs:
        if found is not None:
            break
        found = resolve_mesh(name, d, package_paths)
        if found is None and (d / Path(name).name).is_file():
            found = d / Path(name).name
    return found


def _scale_of(tag: str) -> NDArray[np.float64]:
    m = _SCALE.search(tag)
    if m is None:
        return np.ones(3)
    vals = np.array([float(v) for v in m.group(2).split()], dtype=np.float64)
    return np.broadcast_to(vals, (3,)).copy()


def _drop_visuals(text: str, names: set[str]) -> str:
    """``<visual>`` elements that name a mesh of ``names`` replaced by a comment."""

    def drop(m: re.Match[str]) -> str:
        element = m.group(0)
        for fm in _FILENAME.finditer(element):
            if fm.group(2) in names:
                file = fm.group(2).replace("--", "- -")
                return f"<!-- wsgrasp gripper new: visual mesh {file} left out -->"
        return element

    return _VISUAL.sub(drop, text)


#: file endings of a xacro file (``model.urdf.xacro``, ``model.xacro``)
XACRO_SUFFIX = ".xacro"


def is_xacro(path: Path) -> bool:
    """Whether ``path`` is a xacro file: its name ends in ``.xacro``, or it holds
    xacro elements (``<xacro:...`` outside comments; a URDF that xacro wrote
    often keeps the namespace's declaration, and the Robotiq 3F's keeps a macro
    call in a comment)."""
    if path.name.lower().endswith(XACRO_SUFFIX):
        return True
    try:
        text = path.read_bytes()
    except OSError:
        return False
    return b"<xacro:" in re.sub(rb"<!--.*?-->", b"", text, flags=re.S)


def xacro_args(items: list[str]) -> dict[str, str]:
    """``NAME:=VALUE`` strings (as xacro's command line takes them) as a dict.

    Raises
    ------
    GripperError
        An item without ``:=`` or without a name.
    """
    out: dict[str, str] = {}
    for item in items:
        key, sep, value = item.partition(":=")
        if not sep or not key.strip():
            raise GripperError(
                f"xacro argument {item!r} is not NAME:=VALUE",
                hint="write it as xacro takes it, e.g. --xacro-arg prefix:=left_",
            )
        out[key.strip()] = value
    return out


def expand_xacro(
    path: Path,
    out_dir: Path,
    args: dict[str, str] | None = None,
    package_paths: list[Path] | None = None,
) -> Path:
    """Expand a xacro file into a URDF in ``out_dir`` (named after it, ending in
    ``.urdf``), with xacrodoc, as ROS's ``xacro`` would: ``args`` are its
    ``<xacro:arg>`` values, ``$(find PKG)`` is the package folder found above
    ``path`` (a ``package.xml`` naming it, or a folder of that name) or under
    ``package_paths``. Mesh files it names that are found (relative to ``path``,
    ``package://`` URIs, ``file://``) are written as absolute paths, so that the
    expanded URDF reads them from anywhere.

    Raises
    ------
    GripperError
        xacrodoc is not installed, or the file does not expand.
    """
    try:
        from xacrodoc import XacroDoc, packages
    except ImportError:
        raise GripperError(
            f"{path.name} is a xacro file, and expanding it needs xacrodoc",
            hint="pip install 'wsgrasp[xacro]', or expand it with ROS's xacro "
            "and pass the URDF",
        ) from None
    source = path.resolve()
    found: dict[str, Path] = {}
    for folder in [source.parent, *source.parent.parents]:
        found.setdefault(folder.name, folder)
    for root in package_paths or []:
        if Path(root).is_dir():
            for folder in sorted(Path(root).iterdir()):
                if folder.is_dir():
                    found.setdefault(folder.name, folder)
    packages.update_package_cache({k: v for k, v in found.items() if k})
    if package_paths:
        packages.look_in([str(p) for p in package_paths])
    here = os.getcwd()
    try:  # xacro reads an include's relative path from the working folder
        os.chdir(source.parent)
        doc = XacroDoc.from_file(source, subargs=args or {}, resolve_packages=False)
        text = doc.to_urdf_string()
    except Exception as exc:  # noqa: BLE001 - any xacro failure is the file's
        raise GripperError(
            f"xacro file {path.name} does not expand: {type(exc).__name__}: {exc}",
            hint="pass its arguments with --xacro-arg NAME:=VALUE and the folders "
            "holding the packages it names with --package-path",
        ) from None
    finally:
        os.chdir(here)

    def absolute(m: re.Match[str]) -> str:
        tag = m.group(0)
        name = _FILENAME.search(tag)
        if name is None:
            return tag
        where = resolve_mesh(name.group(2), source.parent, package_paths or [])
        if where is None:
            return tag  # the copy reports it
        return tag.replace(name.group(0), f'filename="{where.resolve()}"', 1)

    text = _MESH_TAG.sub(absolute, text)
    stem = path.name
    for suffix in (XACRO_SUFFIX, ".urdf"):
        if stem.lower().endswith(suffix):
            stem = stem[: -len(suffix)]
    dest = Path(out_dir) / f"{stem or 'robot'}.urdf"
    dest.write_text(text)
    return dest


def check_is_urdf(text: str, shown: Path) -> None:
    """Raise ``GripperError`` naming the file ``shown`` where ``text`` is not a
    URDF: not XML, or XML whose root element is not ``<robot>`` (an SDFormat or
    MJCF description, which ``gripper new`` does not read)."""
    try:
        root = parse_xml(text.encode())
    except ET.ParseError as exc:
        raise GripperError(
            f"{str(shown)!r} is not valid XML, so no URDF: {exc}",
            hint="pass the gripper's URDF (or .urdf.xacro) with --urdf",
        ) from None
    kind = not_urdf(root)
    if kind is not None:
        raise GripperError(
            f"{str(shown)!r} is {kind}, not a URDF (whose root element is <robot>)",
            hint="gripper new reads URDF and xacro files: pass the gripper's URDF "
            "(a ROS description package has one, often as .urdf.xacro), or convert "
            "this description to URDF first",
        )


def copy_urdf(
    urdf: Path,
    out_dir: Path,
    stem: str,
    *,
    mesh_dirs: list[Path] | None = None,
    mesh_units: str | None = None,
    package_paths: list[Path] | None = None,
    warnings: list[str] | None = None,
    oversized: list[tuple[set[str], GripperError]] | None = None,
) -> tuple[Path, list[str]]:
    """Copy a URDF and the meshes it references into ``out_dir``.

    Mesh references are rewritten to ``meshes/<file>`` beside the copy; with
    ``mesh_units`` every ``<mesh>`` gets ``scale`` multiplied by that unit in
    metres. Meshes larger than :data:`MAX_MESH_EXTENT` after scaling are taken to
    be in other units and raise (or, with ``mesh_units`` given, warn).

    Only the geometry wsgrasp uses is required: collision elements, and the
    visual ones of links without collision elements. A visual mesh of a link with
    collision geometry that is missing or unreadable is left out of the copy
    (its ``<visual>`` replaced by a comment) and reported in ``warnings``.

    Parameters
    ----------
    package_paths
        Folders holding ROS packages, for ``package://`` URIs (like
        ``ROS_PACKAGE_PATH``).
    warnings
        Appended to: one line per visual mesh left out or looking oversized.
    oversized
        Appended to, where given, instead of raising: per collision mesh that
        looks like millimetres, the links that use it and the error naming it
        (the caller raises it if one of those links is the gripper's: a robot's
        URDF may hold a mast or a body that is truly metres long above it).

    Returns
    -------
    path, notes
        The copied URDF and one line per mesh rewritten.

    Raises
    ------
    GripperError
        The URDF is missing, a collision mesh is not found or unreadable, or a
        mesh looks like millimetres.
    """
    urdf = Path(urdf)
    if not urdf.is_file():
        raise GripperError(
            f"URDF {str(urdf)!r} does not exist",
            hint="pass the path of the gripper's URDF file with --urdf",
        )
    text = urdf.read_text()
    dirs = [Path(d) for d in (mesh_dirs or [])]
    packages = [Path(d) for d in (package_paths or [])]
    warned = warnings if warnings is not None else []
    uses = _mesh_uses(text)
    factor = MESH_UNITS[mesh_units] if mesh_units else 1.0

    def links_of(name: str, shape: bool | None = None) -> str:
        return ", ".join(link for link, s in uses[name] if shape is None or s == shape)

    def is_shape(name: str) -> bool:
        return any(s for _, s in uses[name])

    missing: list[str] = []
    dropped: set[str] = set()
    sources: dict[str, Path] = {}
    for name in uses:
        src = _find_mesh(name, urdf.parent, dirs, packages)
        if src is not None:
            sources[name] = src
        elif is_shape(name):
            missing.append(f"{name!r} (link {links_of(name, True)})")
        else:
            dropped.add(name)
            warned.append(
                f"visual mesh {name!r} of link {links_of(name)} is not found; it is "
                "left out of the copied URDF (wsgrasp uses the link's collision "
                "geometry)"
            )
    if missing:
        looked = [str(urdf.parent)] + [str(d) for d in [*dirs, *packages]]
        raise GripperError(
            f"URDF {urdf.name}: mesh file(s) not found: {'; '.join(missing)} "
            f"(looked beside the URDF, in the ROS packages above it for "
            f"package:// paths, and in {', '.join(looked)})",
            hint="pass --mesh-dir DIR for the folder that holds the meshes, or "
            "--package-path DIR for the folder holding the ROS package, or fix the "
            "filename in the URDF",
        )
    # every mesh read once: unreadable visual meshes are left out too
    meshes: dict[str, Any] = {}
    for name, src in list(sources.items()):
        try:
            meshes[name] = load_mesh(src, f"link {links_of(name)}")
        except GripperError as exc:
            if is_shape(name):
                raise GripperError(
                    f"URDF {urdf.name}: {exc.message}", hint=exc.hint
                ) from None
            del sources[name]
            dropped.add(name)
            warned.append(
                f"visual mesh {name!r} of link {links_of(name)} cannot be read "
                f"({exc.message}); it is left out of the copied URDF (wsgrasp uses the "
                "link's collision geometry)"
            )
    target: dict[str, str] = {}  # filename in URDF -> meshes/<file>
    used: set[str] = set()
    for name, src in sources.items():
        base = src.name
        i = 1
        while base in used:
            base, i = f"{i}_{src.name}", i + 1
        used.add(base)
        target[name] = f"meshes/{base}"

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

    out_text = _MESH_TAG.sub(rewrite, _drop_visuals(text, dropped))
    notes: list[str] = []
    # size of every mesh as it will be used (URDF scale included)
    for tag in _MESH_TAG.findall(out_text):
        fm = _FILENAME.search(tag)
        if fm is None:
            continue
        rel = fm.group(2)
        orig = next((k for k, v in target.items() if v == rel), None)
        if orig is None:
            continue
        mesh = meshes[orig]
        extent = float(np.max(np.asarray(mesh.extents) * np.abs(_scale_of(tag))))
        if extent > MAX_MESH_EXTENT and is_shape(orig):
            error = GripperError(
                f"URDF {urdf.name}: mesh {sources[orig].name!r} of link "
                f"{links_of(orig)} is {extent:.1f} m across as the URDF scales "
                "it; its units look like millimetres (URDF lengths are metres)",
                hint="run `wsgrasp gripper new` again with --mesh-units mm (the copy "
                'of the URDF gets scale="0.001 0.001 0.001"), or add that scale to '
                "its <mesh> element",
            )
            if oversized is None:
                raise error
            oversized.append(({link for link, _ in uses[orig]}, error))
        if extent > MAX_MESH_EXTENT:
            warned.append(
                f"visual mesh {sources[orig].name!r} of link {links_of(orig)} is "
                f"{extent:.1f} m across as the URDF scales it (millimetres?); "
                "wsgrasp uses the link's collision geometry"
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
        root = parse_xml(path.read_bytes())
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


def _element_name(element: str) -> str | None:
    """The ``name`` attribute of the URDF element ``element`` (its text, the
    name's entities unescaped), or None where it has none."""
    import html

    name = _NAME.search(element)
    return None if name is None else html.unescape(name.group(2))


def narrow_limits(path: Path, limits: dict[str, tuple[float, float]]) -> None:
    """Rewrite the ``<limit lower upper>`` of the named joints in the URDF at
    ``path`` (values at full precision; the rest of the file as it was)."""
    set_limits(path, {j: {"lower": lo, "upper": hi} for j, (lo, hi) in limits.items()})


def set_limits(path: Path, values: dict[str, dict[str, float]]) -> None:
    """Set attributes of the ``<limit>`` of the named joints in the URDF at
    ``path`` (joint -> attribute -> value: ``lower``, ``upper``, ``effort``; at
    full precision), the rest of the file as it was."""

    if not values:
        return
    text = Path(path).read_text()

    def rewrite(m: re.Match[str]) -> str:
        element = m.group(0)
        name = _element_name(element)
        tag = _LIMIT.search(element)
        if name not in values or tag is None:
            return element
        new = tag.group(0)
        for attr, value in values[name].items():
            pat = re.compile(rf"""\b{attr}\s*=\s*(["']).*?\1""", re.S)
            if pat.search(new):
                new = pat.sub(f'{attr}="{float(value)!r}"', new, count=1)
            else:
                new = new.replace("<limit", f'<limit {attr}="{float(value)!r}"', 1)
        return element.replace(tag.group(0), new, 1)

    Path(path).write_text(_JOINT.sub(rewrite, text))


_MIMIC = re.compile(rf"""(<mimic{_END}[^>]*?\bjoint\s*=\s*)(["'])(.*?)\2""", re.S)


def joint_names(path: Path) -> list[str]:
    """The names of the joints of the URDF at ``path``, in file order."""
    return _joint_names(Path(path).read_text())


def _joint_names(text: str) -> list[str]:
    """The names of the joints of a URDF's ``text``, in file order."""
    import html

    return [
        html.unescape(n.group(2))
        for m in _JOINT.finditer(text)
        if (n := _NAME.search(m.group(0))) is not None
    ]


def repair_mimics(path: Path) -> dict[str, str]:
    """Point each ``<mimic joint>`` of the URDF at ``path`` that names no joint
    at the joint it clearly means (:func:`~wsgrasp.gripper._urdf.mimic_meant`:
    a robot's URDF whose hands' joints are prefixed, ``Left_index_q1``, and
    whose mimics are not, ``index_q1``), rewriting the file; one note per
    repair. A mimic without a clear meaning is left for the URDF's reader to
    refuse, naming the joint. Returns, per joint repaired, ``"'named' -> meant"``."""
    import html

    from wsgrasp.gripper._urdf import mimic_meant

    text = Path(path).read_text()
    names = _joint_names(text)
    known = set(names)
    notes: dict[str, str] = {}

    def rewrite(m: re.Match[str]) -> str:
        element = m.group(0)
        name, tag = _NAME.search(element), _MIMIC.search(element)
        if name is None or tag is None:
            return element
        target = html.unescape(tag.group(3))
        mine = html.unescape(name.group(2))
        meant = None if target in known else mimic_meant(target, mine, names)
        if meant is None:
            return element
        notes[mine] = f"{target!r} -> {meant}"
        new = f"{tag.group(1)}{tag.group(2)}{html.escape(meant)}{tag.group(2)}"
        return element.replace(tag.group(0), new, 1)

    new_text = _JOINT.sub(rewrite, text)
    if notes:
        Path(path).write_text(new_text)
    return notes


_TYPE = re.compile(r"""(\btype\s*=\s*)(["'])fixed\2""")


def free_fixed_mimics(path: Path) -> dict[str, str]:
    """Make each ``fixed`` joint of the URDF at ``path`` that carries a
    ``<mimic>`` of a moving joint, an ``<axis>`` and a ``<limit lower upper>``
    move again, as the type of the joint it follows (a model exported for a
    solver without mimic joints freezes a gripper's linkage this way, its
    mimics left in place: the other fingers would stand still while one
    closes), rewriting the file. Returns, per joint freed, its new type."""
    import html

    text = Path(path).read_text()
    kinds: dict[str, str] = {}
    for m in _JOINT.finditer(text):
        name = _element_name(m.group(0))
        head = m.group(0)[: m.group(0).index(">") + 1]
        kind = re.search(r"""\btype\s*=\s*(["'])(.*?)\1""", head)
        if name is not None and kind is not None:
            kinds[name] = kind.group(2)
    freed: dict[str, str] = {}

    def rewrite(m: re.Match[str]) -> str:
        element = m.group(0)
        name, tag = _element_name(element), _MIMIC.search(element)
        head = element[: element.index(">") + 1]
        if name is None or tag is None or not _TYPE.search(head):
            return element
        lim = _LIMIT.search(element)
        leader = kinds.get(html.unescape(tag.group(3)))
        if (
            leader not in ("revolute", "prismatic", "continuous")
            or lim is None
            or not re.search(r"\blower\s*=", lim.group(0))
            or not re.search(r"\bupper\s*=", lim.group(0))
            or not re.search(rf"<axis{_END}", element)
        ):
            return element
        kind = "prismatic" if leader == "prismatic" else "revolute"
        freed[name] = kind
        return element.replace(head, _TYPE.sub(rf"\g<1>\g<2>{kind}\g<2>", head), 1)

    new_text = _JOINT.sub(rewrite, text)
    if freed:
        Path(path).write_text(new_text)
    return freed


def add_mimic(
    path: Path, joint: str, leader: str, multiplier: float, offset: float
) -> None:
    """Make ``joint`` of the URDF at ``path`` follow ``leader`` (``<mimic>``:
    ``q = multiplier * q_leader + offset``), rewriting the file; the rest of
    the file as it was."""
    import html

    text = Path(path).read_text()
    tag = (
        f'<mimic joint="{html.escape(leader)}" multiplier="{float(multiplier)!r}" '
        f'offset="{float(offset)!r}"/>'
    )

    def rewrite(m: re.Match[str]) -> str:
        element = m.group(0)
        if _element_name(element) != joint:
            return element
        end = element.rindex("</joint")
        return element[:end] + f"  {tag}\n    " + element[end:]

    Path(path).write_text(_JOINT.sub(rewrite, text))


def collisions_from_visuals(path: Path, links: set[str]) -> list[str]:
    """Give each of ``links`` in the URDF at ``path`` its ``<visual>`` shapes
    as its ``<collision>`` shapes (materials left out), in place of the ones it
    had; a link without a visual keeps its own. Rewrites the file; returns the
    links changed."""

    text = Path(path).read_text()
    changed: list[str] = []

    def rewrite(m: re.Match[str]) -> str:
        element = m.group(0)
        name = _element_name(element)
        visuals = _VISUAL.findall(element)
        if name not in links or not visuals:
            return element
        changed.append(str(name))
        shapes = "".join(
            "\n    "
            + _MATERIAL.sub("", v)
            .replace("<visual", "<collision", 1)
            .replace("</visual", "</collision")
            for v in visuals
        )
        kept = _COLLISION.sub("", element)
        end = kept.rindex("</link")
        return kept[:end] + shapes + "\n  " + kept[end:]

    new_text = _LINK.sub(rewrite, text)
    if changed:
        Path(path).write_text(new_text)
    return changed


def prune_urdf(urdf: Path, keep: set[str]) -> tuple[list[str], list[str]]:
    """Leave out of a copied URDF every link not in ``keep`` and every joint
    that joins one (the arm above a gripper that ``gripper new`` found in a
    robot's URDF, and the joint that held the gripper to it), and delete the
    copied meshes nothing left references.

    Returns
    -------
    links, meshes
        The links left out; the mesh files deleted (names under ``meshes/``).
    """
    text = urdf.read_text()
    before = set(_mesh_uses(text))
    gone: list[str] = []

    def link(m: re.Match[str]) -> str:
        name = _NAME.search(m.group(0))
        if name is None or name.group(2) in keep:
            return m.group(0)
        gone.append(name.group(2))
        return ""

    def joint(m: re.Match[str]) -> str:
        child = _CHILD.search(m.group(0))  # a transmission's <joint> has none
        parent = _PARENT.search(m.group(0))
        if child is None or parent is None:
            return m.group(0)
        return m.group(0) if {child.group(2), parent.group(2)} <= keep else ""

    pruned = _JOINT.sub(joint, _LINK.sub(link, text))
    try:
        parse_xml(pruned.encode())
    except ET.ParseError as exc:
        raise GripperError(
            f"URDF {urdf.name}: leaving the arm's links out of the copy made "
            f"invalid XML ({exc})",
            hint="scaffold from the gripper's own URDF (and report the URDF to "
            "wsgrasp: the copy should stay valid)",
        ) from None
    text = pruned
    urdf.write_text(text)
    deleted = []
    for name in sorted(before - set(_mesh_uses(text))):
        path = urdf.parent / name
        if name.startswith("meshes/") and path.is_file():
            path.unlink()
            deleted.append(name.removeprefix("meshes/"))
    return gone, deleted
