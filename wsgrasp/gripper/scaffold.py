"""A gripper plugin package scaffolded from a URDF (``wsgrasp gripper new``).

:func:`guess_description` reads a URDF and guesses the gripper YAML: the base link,
the fingers (kinematic chains from the base to the distal links, with their actuated
joints), each fingertip pad (the inner face of the distal link), the approach and
closing axes, the open (pre-grasp) and closed postures, and sampling settings. Every
guess carries a note saying how it was made; :func:`render_yaml` writes the notes as
comments beside the fields. :func:`scaffold_plugin` writes a pip-installable package
around it (URDF and meshes copied in, ``pyproject.toml`` with a ``wsgrasp`` entry
point, a module implementing ``wsgrasp_register_grippers``, a test and a README).
"""

from __future__ import annotations

import re
import shutil
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp.errors import GripperError
from wsgrasp.gripper._urdf import Kinematics, load_kinematics, resolve_mesh, shape_mesh

__all__ = [
    "MESH_UNITS",
    "Scaffold",
    "guess_description",
    "render_yaml",
    "scaffold_plugin",
]

Array = NDArray[np.float64]

#: unit name -> metres per unit, for ``--mesh-units``
MESH_UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}
#: a single mesh larger than this (m) is taken to be in other units than metres
MAX_MESH_EXTENT = 1.0
#: a whole gripper larger than this (m) is taken to be in other units than metres
MAX_GRIPPER_EXTENT = 1.5
#: a whole gripper smaller than this (m) is implausible too
MIN_GRIPPER_EXTENT = 0.01
#: an axis within this angle (degrees) of a base-frame axis is snapped onto it
SNAP_DEG = 15.0
#: a joint whose fingertip spread changes less than this fraction of the largest
#: change is a posture joint (ab/adduction, spread): held in place, not opened
POSTURE_FRACTION = 0.25
#: configurations sampled per finger when sizing joint_samples
CONFIG_BUDGET = 6000
#: sphere coverage of every finger workspace the scaffolder aims for
TARGET_COVERAGE = 0.45
#: ... with at most this many spheres per finger
MAX_SPHERES = 40
#: the scaffolder tries up to this many body superellipsoids
MAX_ELLIPSOIDS = 9
#: pad depth into the distal link (m), at most
PAD_DEPTH = 0.004
_NAME_RE = re.compile(r"^[A-Za-z][A-Za-z0-9_\-]*$")
_MESH_TAG = re.compile(r"<mesh\b[^>]*>", re.S)
_FILENAME = re.compile(r"""filename\s*=\s*(["'])(.*?)\1""", re.S)
_SCALE = re.compile(r"""scale\s*=\s*(["'])(.*?)\1""", re.S)


@dataclass
class Scaffold:
    """A guessed gripper description with the notes that explain it.

    Attributes
    ----------
    data : dict
        The gripper YAML as plain data (validates as ``GripperDescription``).
    notes : dict of str to str
        Field name -> how its value was guessed (written as YAML comments).
    warnings : list of str
        Things the user should look at, naming the link or joint and the fix.
    """

    data: dict[str, Any]
    notes: dict[str, str] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)


# ------------------------------------------------------------------------------
# URDF and meshes
# ------------------------------------------------------------------------------
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


def _unlimited_continuous(path: Path) -> list[str]:
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


# ------------------------------------------------------------------------------
# Geometry helpers
# ------------------------------------------------------------------------------
def _link_boxes(kin: Kinematics, links: list[str]) -> dict[str, tuple[Array, Array]]:
    """Axis-aligned bounds ``(lo, hi)`` of each link's geometry in its own frame."""
    out = {}
    for link in links:
        shapes = kin.shapes.get(link, [])
        if not shapes:
            continue
        verts = np.concatenate([np.asarray(shape_mesh(s).vertices) for s in shapes])
        out[link] = (verts.min(axis=0), verts.max(axis=0))
    return out


def _default_posture(kin: Kinematics, joints: list[str]) -> dict[str, float]:
    return {
        j: float(np.clip(0.0, kin.joints[j].lower, kin.joints[j].upper)) for j in joints
    }


def _centroids(
    kin: Kinematics,
    base: str,
    links: list[str],
    boxes: dict[str, tuple[Array, Array]],
    posture: dict[str, float],
) -> Array:
    """Geometry-box centres of ``links`` in the base frame: ``(L, 3)``."""
    poses = kin.link_poses(base, posture)
    pts = []
    for link in links:
        lo, hi = boxes[link]
        c = 0.5 * (lo + hi)
        T = poses[link]
        pts.append(T[:3, :3] @ c + T[:3, 3])
    return np.array(pts)


def _spread(points: Array) -> float:
    return float(np.mean(np.linalg.norm(points - points.mean(axis=0), axis=1)))


def _snap(v: Array, what: str) -> tuple[Array, str]:
    """Snap a unit vector onto the nearest base axis if within SNAP_DEG."""
    v = v / np.linalg.norm(v)
    k = int(np.argmax(np.abs(v)))
    angle = float(np.degrees(np.arccos(min(1.0, abs(v[k])))))
    names = "xyz"
    if angle <= SNAP_DEG:
        s = np.zeros(3)
        s[k] = np.sign(v[k])
        sign = "+" if v[k] > 0 else "-"
        return s, f"{what}; snapped to {sign}{names[k]} ({angle:.0f} deg off)"
    return (
        v,
        f"{what}; not near a base axis (nearest {names[k]} is {angle:.0f} deg off)",
    )


def _finger_names(links: list[str]) -> list[str]:
    """Short, unique finger names from the distal link names."""
    tokens = [re.split(r"[_\-.]", link.lower()) for link in links]
    common = set(tokens[0]).intersection(*tokens[1:]) if len(tokens) > 1 else set()
    names = []
    for i, toks in enumerate(tokens):
        rest = [t for t in toks if t and t not in common]
        name = "_".join(rest) if rest else f"finger{i + 1}"
        if name[0].isdigit():
            name = f"finger{name}"
        names.append(re.sub(r"[^0-9A-Za-z_]", "_", name))
    if len(set(names)) != len(names):
        names = [f"finger{i + 1}" for i in range(len(links))]
    return names


def _r(v: Any, nd: int = 4) -> Any:
    if isinstance(v, np.ndarray | list | tuple):
        return [_r(x, nd) for x in v]
    out = round(float(v), nd)
    return 0.0 if out == 0 else out


# ------------------------------------------------------------------------------
# The guess
# ------------------------------------------------------------------------------
def guess_description(
    urdf: str | Path,
    name: str,
    *,
    base_link: str | None = None,
    urdf_field: str | None = None,
) -> Scaffold:
    """Guess a gripper description from a URDF (meshes must resolve from it).

    Parameters
    ----------
    urdf
        The URDF file.
    name
        The gripper's registered name.
    base_link
        The link the arm's flange holds; the URDF's root if omitted.
    urdf_field
        Value of the ``urdf`` field (relative to the YAML); the file name if omitted.

    Raises
    ------
    GripperError
        No actuated joint, several disconnected trees (without ``base_link``), an
        implausible size, a continuous joint without limits on a finger, no finger.
    """
    path = Path(urdf)
    kin = load_kinematics(path, name)
    notes: dict[str, str] = {}
    warnings: list[str] = []

    # -- base link ---------------------------------------------------------------
    roots = [link for link in kin.links if link not in kin.parent_joint]
    if base_link is not None:
        kin.check_link(base_link, name, "--base-link")
        base = base_link
        notes["base_link"] = "given with --base-link"
        outside = sorted(set(kin.links) - set(kin.subtree(base)))
        if outside:
            warnings.append(
                f"links not below base link {base!r} are ignored: "
                + ", ".join(outside[:8])
                + (" ..." if len(outside) > 8 else "")
            )
    elif len(roots) > 1:
        sizes = ", ".join(f"{r!r} ({len(kin.subtree(r))} links)" for r in roots)
        raise GripperError(
            f"URDF {path.name} has {len(roots)} disconnected trees, with root links "
            f"{sizes}; a gripper is one tree below the link the arm holds",
            hint="join the trees with a <joint type='fixed'> in the URDF, or pass "
            "--base-link LINK to use the tree below LINK",
        )
    else:
        base = roots[0]
        notes["base_link"] = "the root link of the URDF tree"
    below = kin.subtree(base)

    # -- actuated joints ---------------------------------------------------------
    movable = [j for j in kin.joints.values() if j.kind != 0 and j.child in below]
    actuated = [j.name for j in movable if j.mimic is None]
    if not actuated:
        raise GripperError(
            f"URDF {path.name}: no actuated joint below {base!r} (joints: "
            + (
                ", ".join(
                    f"{j.name} ({'mimic' if j.mimic else 'fixed'})"
                    for j in kin.joints.values()
                )
                or "none"
            )
            + "); the fingers cannot move",
            hint="make the finger joints revolute or prismatic with <limit lower "
            "upper>; a <mimic> joint needs an actuated joint to follow",
        )
    unlimited = set(_unlimited_continuous(path))

    # -- geometry and size -------------------------------------------------------
    boxes = _link_boxes(kin, below)
    if not boxes:
        raise GripperError(
            f"URDF {path.name}: no link below {base!r} has collision or visual "
            "geometry",
            hint="add <collision> geometry to the gripper's links",
        )
    default = _default_posture(kin, actuated)
    poses = kin.link_poses(base, default)
    corners = []
    for link, (lo, hi) in boxes.items():
        c = np.array(np.meshgrid(*zip(lo, hi, strict=True), indexing="ij"))
        c = c.reshape(3, -1).T  # (8, 3)
        T = poses[link]
        corners.append(c @ T[:3, :3].T + T[:3, 3])
    allc = np.concatenate(corners)
    extent = float(np.max(allc.max(axis=0) - allc.min(axis=0)))
    if extent > MAX_GRIPPER_EXTENT:
        big = max(boxes, key=lambda k: float(np.max(boxes[k][1] - boxes[k][0])))
        raise GripperError(
            f"URDF {path.name}: the gripper is {extent:.1f} m across (largest link "
            f"{big!r}); its lengths look like millimetres, but URDF lengths are "
            "metres",
            hint="for meshes, rerun with --mesh-units mm; for origins and "
            "primitive sizes, convert the URDF to metres",
        )
    if extent < MIN_GRIPPER_EXTENT:
        raise GripperError(
            f"URDF {path.name}: the gripper is only {extent * 1000:.2f} mm across; "
            "its meshes are probably scaled twice",
            hint="check the scale of the <mesh> elements (--mesh-units m if the "
            "meshes are already in metres)",
        )

    # -- distal links and fingers --------------------------------------------------
    def chain_of(link: str) -> list[Any]:
        return kin.chain(base, link)

    candidates = {
        link: chain_of(link)
        for link in boxes
        if any(j.kind != 0 for j in chain_of(link))
    }
    # distal: no other candidate below it
    distal = [
        link
        for link in candidates
        if not any(
            other != link and link in [j.parent for j in candidates[other]]
            for other in candidates
        )
    ]
    info = {}
    for link in distal:
        chain = candidates[link]
        masters = []
        for j in chain:
            if j.kind != 0:
                m = kin.master(j.name)
                if m not in masters:
                    masters.append(m)
        info[link] = (masters, sum(1 for j in chain if j.kind != 0))
    # linkage bars: moved by a subset of a longer chain's joints
    bars = [
        link
        for link in distal
        if any(
            set(info[link][0]) <= set(info[o][0]) and info[o][1] > info[link][1]
            for o in distal
            if o != link
        )
    ]
    distal = [link for link in distal if link not in bars]
    distal.sort(key=lambda k: below.index(k))
    if not distal:
        raise GripperError(
            f"URDF {path.name}: found no fingertip (a link with geometry moved by a "
            f"joint) below {base!r}",
            hint="give the finger links <collision> geometry",
        )
    finger_names = _finger_names(distal)
    finger_joints = {link: info[link][0] for link in distal}
    notes["fingers"] = (
        "one finger per distal link (a link with geometry that a joint moves and "
        "that carries no further moving link): "
        + ", ".join(distal)
        + (
            "; skipped as linkage bars (moved by a subset of a longer finger's "
            "joints): " + ", ".join(bars)
            if bars
            else ""
        )
    )
    if len(distal) == 1:
        warnings.append(
            f"only one finger found (link {distal[0]!r}); the planner needs fingers "
            "that close against each other or against the palm"
        )
    used = [m for link in distal for m in finger_joints[link]]
    for j in unlimited:
        if j in used:
            raise GripperError(
                f"URDF {path.name}: continuous joint {j!r} moves a finger but has no "
                "<limit lower upper>, so its workspace would be a full turn",
                hint=f"give joint {j!r} <limit lower=... upper=...> in the URDF (or "
                "make it revolute) with the range the finger really uses",
            )
        warnings.append(
            f"continuous joint {j!r} has no limits and moves no finger; it is held at 0"
        )

    # -- open and closed: the ends of each joint that spread / gather the tips -----
    # The grasp axis: from the base origin through the fingertips' centre with
    # every joint at 0 (clipped into its limits). Per joint, starting from there,
    # "closing" is the direction in which the fingertips first move nearer that
    # axis; "closed" is the limit that way, "open" (pre-grasp) the other limit.
    masters_all = list(dict.fromkeys(used))
    tips0 = _centroids(kin, base, distal, boxes, default)  # (F, 3)
    c0 = tips0.mean(axis=0)
    a0 = c0 / max(float(np.linalg.norm(c0)), 1e-12)

    def off_axis(post: dict[str, float]) -> float:
        d = _centroids(kin, base, distal, boxes, post) - c0  # (F, 3)
        d -= np.outer(d @ a0, a0)
        return float(np.linalg.norm(d, axis=1).sum())

    delta: dict[str, float] = {}
    ends: dict[str, tuple[float, float]] = {}
    for m in masters_all:
        j = kin.joints[m]
        h = 0.1 * (j.upper - j.lower)
        qa = max(j.lower, default[m] - h)
        qb = min(j.upper, default[m] + h)
        s = [off_axis({**default, m: q}) for q in (qa, qb)]
        delta[m] = (s[1] - s[0]) / max(qb - qa, 1e-12) * h  # per 10 % of range
        ends[m] = (j.upper, j.lower) if s[1] > s[0] else (j.lower, j.upper)
    # a joint is compared with the strongest closer of its own finger
    biggest = {
        m: max(
            abs(delta[x])
            for link in distal
            for x in finger_joints[link]
            if m in finger_joints[link]
        )
        for m in masters_all
    }
    pregrasp: dict[str, float] = {}
    closed: dict[str, float] = {}
    how: list[str] = []
    held: set[str] = set()
    for m in masters_all:
        small = abs(delta[m]) < max(POSTURE_FRACTION * biggest[m], 2e-4)
        sharing = [link for link in distal if m in finger_joints[link]]
        # shared by several fingers that each close more with a joint of their own:
        # a spread / ab-adduction joint, set once for the grasp, not a closer
        shared = len(sharing) > 1 and all(
            any(abs(delta[x]) > abs(delta[m]) for x in finger_joints[link] if x != m)
            for link in sharing
        )
        if len(distal) > 1 and (small or shared):
            pregrasp[m] = closed[m] = default[m]
            held.add(m)
            why = (
                f"it spreads {len(sharing)} fingers that close with other joints"
                if shared
                else "10 % of its range moves the tips to or from the axis by only "
                f"{abs(delta[m]) * 1000:.1f} mm"
            )
            how.append(f"{m} held at {default[m]:g} ({why})")
        else:
            pregrasp[m], closed[m] = ends[m]
            how.append(f"{m} opens at {ends[m][0]:g}, closes at {ends[m][1]:g}")
    for m in actuated:
        if m not in masters_all:
            pregrasp[m] = closed[m] = default[m]
            how.append(f"{m} moves no fingertip: held at {default[m]:g}")
    notes["pregrasp"] = (
        "per joint, the limit away from which the fingertips first move nearer the "
        "grasp axis (base origin -> fingertips' centre with all joints at 0; FK of "
        "the distal links): " + "; ".join(how)
    )
    notes["closed"] = "per joint, the other limit: towards the grasp axis"
    dropped = []
    for link in distal:
        keep = [m for m in finger_joints[link] if m not in held]
        if keep and len(keep) < len(finger_joints[link]):
            dropped += [m for m in finger_joints[link] if m in held]
            finger_joints[link] = keep
    if dropped:
        notes["fingers"] += (
            "; joints held in pregrasp are not sampled for the workspaces: "
            + ", ".join(sorted(set(dropped)))
        )

    # -- pads: the distal links' faces towards the hand's centre -------------------
    # The inner face leads when the finger starts to close: the pad faces the
    # direction in which its link's geometry centre moves from the open posture
    # (towards the grasp axis when it does not move).
    mid = {m: 0.9 * pregrasp[m] + 0.1 * closed[m] for m in pregrasp}
    poses_mid = kin.link_poses(base, mid)
    tips_open = _centroids(kin, base, distal, boxes, pregrasp)
    tips_mid = _centroids(kin, base, distal, boxes, mid)
    pads = []
    pad_notes = []
    for i, link in enumerate(distal):
        lo, hi = boxes[link]
        size = hi - lo
        c = 0.5 * (lo + hi)
        d_base = tips_mid[i] - tips_open[i]
        if np.linalg.norm(d_base) < 1e-6:
            d_base = c0 - tips_mid[i]
            d_base -= (d_base @ a0) * a0
        d_link = poses_mid[link][:3, :3].T @ d_base
        n = np.linalg.norm(d_link)
        d_link = d_link / n if n > 1e-12 else np.array([1.0, 0.0, 0.0])
        # the face whose outward normal best matches, weighted by the face's area
        # (so a finger's long side wins over its end)
        area = np.array([size[1] * size[2], size[0] * size[2], size[0] * size[1]])
        k = int(np.argmax(np.abs(d_link) * area))
        sign = float(np.sign(d_link[k]) or 1.0)
        depth = min(PAD_DEPTH, 0.5 * float(size[k]))
        pad_size = size * 0.8
        pad_size[k] = depth
        pad_c = c.copy()
        pad_c[k] = c[k] + sign * (0.5 * size[k] - 0.5 * depth)
        # keep the fingertip end: the far half along the in-face axis that points
        # most away from the base
        out_link = poses_mid[link][:3, :3].T @ tips_mid[i]
        out_link[k] = 0.0
        u = int(np.argmax(np.abs(out_link)))
        half = ""
        if np.abs(out_link[u]) > 1e-9 and size[u] > 2.0 * PAD_DEPTH:
            pad_size[u] = 0.4 * size[u]
            pad_c[u] = c[u] + np.sign(out_link[u]) * 0.25 * size[u]
            half = f", its half towards {'+' if out_link[u] > 0 else '-'}{'xyz'[u]}"
        pads.append(
            {
                "link": link,
                "center": _r(pad_c),
                "size": _r(pad_size),
                "samples": 3,
            }
        )
        pad_notes.append(
            f"{finger_names[i]}: the {'+' if sign > 0 else '-'}{'xyz'[k]} face of "
            f"{link}'s geometry box (the largest face leading when it closes)"
            f"{half}, 80 % wide, {depth * 1000:.1f} mm deep"
        )
    notes["pad"] = "; ".join(pad_notes)

    # -- axes and tool frame ------------------------------------------------------
    def pad_points(posture: dict[str, float]) -> Array:
        ps = kin.link_poses(base, posture)
        out = []
        for p in pads:
            T = ps[p["link"]]
            out.append(T[:3, :3] @ np.asarray(p["center"]) + T[:3, 3])
        return np.array(out)  # (F, 3)

    p_open, p_closed = pad_points(pregrasp), pad_points(closed)
    mean_open = p_open.mean(axis=0)
    if np.linalg.norm(mean_open) < 1e-6:
        raise GripperError(
            f"URDF {path.name}: the fingertips' centre coincides with the origin of "
            f"base link {base!r}, so no approach direction can be read from it",
            hint="pass --base-link with the link the arm's flange holds",
        )
    approach, notes["approach_axis"] = _snap(
        mean_open, "from the base link's origin towards the pads' centre (open)"
    )
    motion = p_closed - p_open  # (F, 3)
    motion -= np.outer(motion @ approach, approach)
    if float(np.linalg.norm(motion)) < 1e-6:
        motion = p_open - mean_open
        motion -= np.outer(motion @ approach, approach)
        what = "principal direction of the pads' positions across the approach axis"
    else:
        what = "principal direction in which the pads move when closing"
    if float(np.linalg.norm(motion)) < 1e-9:
        helper = np.eye(3)[int(np.argmin(np.abs(approach)))]
        closing = np.cross(approach, helper)
        what = "any axis perpendicular to the approach axis (the pads do not move)"
        warnings.append("the pads do not move across the approach axis when closing")
    else:
        w, v = np.linalg.eigh(motion.T @ motion)
        closing = v[:, -1]
    closing = closing - (closing @ approach) * approach
    closing, note = _snap(closing, what)
    if abs(float(closing @ approach)) > 1e-6:  # the snap broke orthogonality
        closing = closing - (closing @ approach) * approach
        closing /= np.linalg.norm(closing)
    if closing[int(np.argmax(np.abs(closing)))] < 0:
        closing = -closing
    notes["closing_axis"] = note
    tcp = 0.5 * (mean_open + p_closed.mean(axis=0))
    notes["tool_frame"] = "midway between the pads' centres open and closed"

    # -- sampling settings --------------------------------------------------------
    dof = max(len(finger_joints[link]) for link in distal)
    samples = int(np.clip(np.floor(CONFIG_BUDGET ** (1.0 / dof)), 4, 33))
    spheres = {1: 10, 2: 20, 3: 30}.get(dof, 40)
    voxel = float(np.clip(np.round(extent / 100 / 0.0005) * 0.0005, 0.001, 0.004))
    notes["joint_samples"] = (
        f"up to {dof} actuated joints per finger: {samples}^{dof} configurations "
        f"(about {CONFIG_BUDGET})"
    )
    notes["spheres_per_finger"] = f"{spheres} for fingers of {dof} joint(s)"
    notes["workspace_voxel"] = f"1 % of the gripper's size ({extent * 1000:.0f} mm)"
    # pad samples about a voxel apart, so the swept samples close into a volume
    cap = 12 if dof <= 2 else 6
    for pad in pads:
        edge = float(max(pad["size"]))
        pad["samples"] = int(np.clip(np.ceil(edge / voxel) + 1, 3, cap))
    notes["pad"] += (
        "; samples: pad points about one workspace voxel apart "
        f"(at most {cap} per edge)"
    )

    data: dict[str, Any] = {
        "version": 1,
        "name": name,
        "urdf": urdf_field or path.name,
        "base_link": base,
        "tool_frame": {"link": base, "xyz": _r(tcp)},
        "approach_axis": _r(approach, 6),
        "closing_axis": _r(closing, 6),
        "fingers": [
            {"name": fname, "joints": finger_joints[link], "pad": pad}
            for fname, link, pad in zip(finger_names, distal, pads, strict=True)
        ],
        "joint_samples": samples,
        "spheres_per_finger": spheres,
        "workspace_voxel": voxel,
        "min_sphere_radius": voxel,
        "ellipsoids": {"count": 5, "exponent": 10.0},
        "cloud_points": 500,
        "pregrasp": {k: _r(v, 6) for k, v in pregrasp.items()},
        "closed": {k: _r(v, 6) for k, v in closed.items()},
    }
    return Scaffold(data, notes, warnings)


def fit_sphere_count(scaffold: Scaffold, base_dir: Path) -> None:
    """Size ``spheres_per_finger`` (and the voxel) to the sampled workspaces: halve
    the voxel while a workspace is too thin for spheres, lower the count to what
    fits, raise it (up to :data:`MAX_SPHERES`) until the spheres cover
    :data:`TARGET_COVERAGE` of every workspace; note what was changed."""
    from wsgrasp.gripper._workspace import fill_spheres, sample_workspace
    from wsgrasp.spec import GripperDescription

    data = scaffold.data
    note = scaffold.notes
    for _ in range(3):
        desc = GripperDescription.model_validate(data)
        kin = load_kinematics(Path(base_dir) / desc.urdf, desc.name)
        spaces = [sample_workspace(kin, desc, f) for f in desc.fingers]
        counts = [
            int(
                np.count_nonzero(
                    (ws.distance - 1.0) * ws.voxel >= desc.min_sphere_radius - 1e-12
                )
            )
            for ws in spaces
        ]
        fewest = min(counts)
        if fewest >= 3:
            break
        data["workspace_voxel"] = max(0.0005, data["workspace_voxel"] / 2)
        data["min_sphere_radius"] = data["workspace_voxel"]
        note["workspace_voxel"] += (
            f"; halved to {data['workspace_voxel'] * 1000:.2f} mm (a workspace was "
            "too thin for spheres)"
        )
    else:
        return  # the check will report it
    n = data["spheres_per_finger"]
    if fewest < 3 * n:
        data["spheres_per_finger"] = max(1, fewest // 3)
        note["spheres_per_finger"] += (
            f"; lowered to {data['spheres_per_finger']} (the thinnest workspace "
            f"holds {fewest} sphere centres)"
        )
        return
    while True:
        cover = min(
            fill_spheres(ws, n, desc.min_sphere_radius, desc.name).covered_fraction
            for ws in spaces
        )
        if cover >= TARGET_COVERAGE or 2 * n > min(MAX_SPHERES, fewest // 3):
            break
        n *= 2
    if n != data["spheres_per_finger"]:
        data["spheres_per_finger"] = n
        note["spheres_per_finger"] += (
            f"; doubled to {n} so the spheres cover {cover:.0%} of every workspace"
        )


# ------------------------------------------------------------------------------
# Writing
# ------------------------------------------------------------------------------
def _flow(v: Any) -> str:
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k}: {_flow(x)}" for k, x in v.items()) + "}"
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_flow(x) for x in v) + "]"
    if isinstance(v, float):
        return repr(v)
    return str(v)


def _comment(text: str, indent: str = "") -> str:
    import textwrap

    lines = textwrap.wrap(text, 84 - len(indent))
    return "".join(f"{indent}# {line}\n" for line in lines)


def render_yaml(scaffold: Scaffold, header: list[str] | None = None) -> str:
    """The gripper YAML with each guess explained in a comment above its field."""
    d, n = scaffold.data, scaffold.notes
    out = [
        f"# Gripper {d['name']!r}, scaffolded by `wsgrasp gripper new` from "
        f"{d['urdf']}.\n",
        "# Every value below is a guess from the URDF; the comment above it says how "
        "it was\n# made. Check them with `wsgrasp gripper check <this file> -o "
        "gripper.png`.\n# Units: metres and radians; axes are in the base link's "
        "frame.\n",
    ]
    for line in header or []:
        out.append(_comment(line))
    for w in scaffold.warnings:
        out.append(_comment("WARNING: " + w))
    out.append(f"version: 1\nname: {d['name']}\nurdf: {d['urdf']}\n")
    for key in ("base_link", "tool_frame", "approach_axis", "closing_axis"):
        if key in n:
            out.append(_comment(n[key]))
        out.append(f"{key}: {_flow(d[key])}\n")
    out.append(_comment(n.get("fingers", "")))
    out.append(_comment("pads: " + n.get("pad", "")))
    out.append("fingers:\n")
    for f in d["fingers"]:
        out.append(f"  - name: {f['name']}\n")
        out.append(f"    joints: {_flow(f['joints'])}\n")
        out.append(f"    pad: {_flow(f['pad'])}\n")
    for key in (
        "joint_samples",
        "spheres_per_finger",
        "workspace_voxel",
        "min_sphere_radius",
    ):
        if key in n:
            out.append(_comment(n[key]))
        out.append(f"{key}: {_flow(d[key])}\n")
    out.append(
        _comment(n.get("ellipsoids", "body superellipsoids fitted to the links"))
    )
    out.append(f"ellipsoids: {_flow(d['ellipsoids'])}\n")
    out.append(f"cloud_points: {d['cloud_points']}\n")
    for key in ("pregrasp", "closed"):
        out.append(_comment(n.get(key, "")))
        out.append(f"{key}:\n")
        for j, v in d[key].items():
            out.append(f"  {j}: {_flow(v)}\n")
    return "".join(out)


def _refit_ellipsoids(
    scaffold: Scaffold, yaml_path: Path, header: list[str], report: Any
) -> Any:
    """While the check finds body superellipsoids in the finger workspaces, try
    more of them (up to :data:`MAX_ELLIPSOIDS`); keep the best count."""
    from wsgrasp.gripper.check import check_gripper

    def cost(r: Any) -> tuple[int, float]:
        bad = [p for p in r.problems if p.field == "ellipsoids"]
        return (len(bad), sum(i["fraction"] for i in r.intrusions))

    ell = scaffold.data["ellipsoids"]
    first = ell["count"]
    best, best_count = report, first
    count = first
    while cost(best)[0] and count + 2 <= MAX_ELLIPSOIDS:
        count += 2
        ell["count"] = count
        yaml_path.write_text(render_yaml(scaffold, header))
        trial = check_gripper(str(yaml_path))
        if cost(trial) < cost(best):
            best, best_count = trial, count
    ell["count"] = best_count
    if best_count != first:
        scaffold.notes["ellipsoids"] = (
            f"body superellipsoids fitted to the links (l = 10); {best_count} "
            f"rather than {first}, as fewer swallowed part of a finger workspace"
        )
    yaml_path.write_text(render_yaml(scaffold, header))
    return best


def module_name(name: str) -> str:
    """The Python package of a scaffolded plugin: ``wsgrasp_<name>``."""
    return "wsgrasp_" + re.sub(r"[^0-9a-zA-Z_]", "_", name).lower()


_PYPROJECT = """\
[build-system]
requires = ["setuptools>=69"]
build-backend = "setuptools.build_meta"

[project]
name = "{name}"
version = "0.1.0"
description = "wsgrasp gripper plugin: {name}"
readme = "README.md"
requires-python = ">=3.10"
dependencies = ["wsgrasp"]

# wsgrasp finds the gripper through this entry point
[project.entry-points.wsgrasp]
{name} = "{module}"

[tool.setuptools]
packages = ["{module}"]

[tool.setuptools.package-data]
{module} = ["*.urdf", "*.yaml", "meshes/*"]
"""

_MODULE = '''\
"""wsgrasp gripper plugin.

Registers the gripper {name!r} by its YAML (beside the URDF). Scaffolded by
`wsgrasp gripper new`.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from wsgrasp.plugins import hookimpl

HERE = Path(__file__).resolve().parent


@hookimpl
def wsgrasp_register_grippers(register: Callable[[str, Any], None]) -> None:
    """Register {name!r} by the path of its gripper YAML."""
    register("{name}", HERE / "{name}.yaml")
'''

_TEST = '''\
"""The gripper of this package.

It builds, `wsgrasp gripper check` finds no error in it, and it plans a grasp.
"""

from __future__ import annotations

from pathlib import Path

from wsgrasp import Pipeline
from wsgrasp.gripper.check import check_gripper
from wsgrasp.perception.io import scene_from_arrays
from wsgrasp.perception.synth import synth_scene
from wsgrasp.spec import load_spec

HERE = Path(__file__).resolve().parents[1]
YAML = HERE / "{module}" / "{name}.yaml"


def test_check_finds_no_errors():
    report = check_gripper(str(YAML))
    assert not report.errors, report.format()


def test_plans_a_grasp_on_a_cylinder():
    pipe = Pipeline(load_spec({{"gripper": str(YAML), "record": {{"enabled": False}}}}))
    radius = min(0.035, max(0.012, 0.2 * pipe.gripper.max_opening))
    scene = synth_scene("cylinder", size=(radius, 0.12), seed=0, width=160, height=120)
    result = pipe.plan(scene_from_arrays(scene.points))
    assert result.found, result.hint
'''

_README = """\
# {name}: a wsgrasp gripper plugin

Scaffolded from `{urdf}` by `wsgrasp gripper new`. The package holds the URDF (and
its meshes under `{module}/meshes/`), the gripper YAML `{module}/{name}.yaml` and a
module that registers it with wsgrasp through the `wsgrasp` entry-point group.

```sh
pip install -e .                      # register the gripper
wsgrasp grippers list                 # shows {name}
wsgrasp gripper check {name} -o gripper.png   # trust, but verify the guesses
pytest tests                          # builds, checks and plans a grasp
```

Then use it in a pipeline spec: `gripper: {name}`.

The YAML's comments say what `wsgrasp gripper new` guessed and how. Read the check's
report and its picture; fix the fields it names. To publish: `python -m build` and
upload the wheel, or install from your repository with `pip install git+URL`.
"""


def scaffold_plugin(
    name: str,
    urdf: str | Path,
    out_dir: str | Path,
    *,
    base_link: str | None = None,
    mesh_dirs: list[Path] | None = None,
    mesh_units: str | None = None,
    force: bool = False,
    check: bool = True,
) -> tuple[Path, Scaffold]:
    """Write a pip-installable gripper plugin package into ``out_dir``.

    Returns
    -------
    yaml_path, scaffold
        The gripper YAML written and the guesses (with warnings).

    Raises
    ------
    GripperError
        A bad name, an existing non-empty ``out_dir`` without ``force``, or a URDF
        that cannot be scaffolded (see :func:`guess_description`).
    """
    if not _NAME_RE.match(name):
        raise GripperError(
            f"gripper name {name!r} is not usable as a package name",
            hint="use letters, digits, '_' and '-', starting with a letter",
        )
    if mesh_units is not None and mesh_units not in MESH_UNITS:
        raise GripperError(
            f"--mesh-units {mesh_units!r} is unknown",
            hint="use one of " + ", ".join(MESH_UNITS),
        )
    out = Path(out_dir)
    if out.exists() and any(out.iterdir()) and not force:
        raise GripperError(
            f"output folder {str(out)!r} exists and is not empty",
            hint="choose a new --out folder, or pass --force to overwrite",
        )
    module = module_name(name)
    pkg = out / module
    pkg.mkdir(parents=True, exist_ok=True)
    urdf_copy, mesh_notes = copy_urdf(
        Path(urdf), pkg, name, mesh_dirs=mesh_dirs, mesh_units=mesh_units
    )
    scaffold = guess_description(urdf_copy, name, base_link=base_link)
    fit_sphere_count(scaffold, pkg)
    header = []
    if mesh_notes:
        header.append("meshes copied: " + "; ".join(mesh_notes))
    yaml_path = pkg / f"{name}.yaml"
    yaml_path.write_text(render_yaml(scaffold, header))
    if check:
        from wsgrasp.gripper.check import check_gripper

        report = check_gripper(str(yaml_path))
        report = _refit_ellipsoids(scaffold, yaml_path, header, report)
        lines = [
            f"`wsgrasp gripper check` on this guess: {p.severity}: {p.message} "
            f"(field {p.field}; fix: {p.fix})"
            for p in report.problems
        ] or ["`wsgrasp gripper check` on this guess found no problem"]
        yaml_path.write_text(render_yaml(scaffold, header + lines))
        scaffold.warnings += [
            f"{p.severity}: {p.message} (field {p.field})" for p in report.problems
        ]
    (out / "pyproject.toml").write_text(_PYPROJECT.format(name=name, module=module))
    (pkg / "__init__.py").write_text(_MODULE.format(name=name))
    (out / "tests").mkdir(exist_ok=True)
    (out / "tests" / f"test_{module}.py").write_text(
        _TEST.format(name=name, module=module)
    )
    (out / "README.md").write_text(
        _README.format(name=name, module=module, urdf=Path(urdf).name)
    )
    return yaml_path, scaffold
