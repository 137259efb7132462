"""Guessing a gripper description from a URDF (``wsgrasp gripper new``).

Every guess is made by forward kinematics of the URDF and comes with a note saying
how it was made; :func:`guess_description` runs the steps in order: the base link
and the joints that can move (:func:`_read`), the fingers (:func:`_fingers`), the
open and closed postures (:func:`_postures`), the pads (:func:`_pads`), the axes
and tool frame (:func:`_axes`) and the sampling settings (:func:`_settings`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp.errors import GripperError
from wsgrasp.gripper._scaffold_urdf import unlimited_continuous
from wsgrasp.gripper._urdf import Kinematics, load_kinematics, shape_mesh

__all__ = ["Scaffold", "fit_sphere_count", "guess_description"]

Array = NDArray[np.float64]
Boxes = dict[str, tuple[Array, Array]]

#: a whole gripper larger than this (m) is taken to be in other units than metres
MAX_GRIPPER_EXTENT = 1.5
#: a whole gripper smaller than this (m) is implausible too
MIN_GRIPPER_EXTENT = 0.01
#: an axis within this angle (degrees) of a base-frame axis is snapped onto it
SNAP_DEG = 15.0
#: a joint that moves the tips less than this fraction of its finger's strongest
#: closer is a posture joint (ab/adduction): held in place, not opened
POSTURE_FRACTION = 0.25
#: configurations sampled per finger when sizing joint_samples
CONFIG_BUDGET = 6000
#: sphere coverage of every finger workspace the scaffolder aims for
TARGET_COVERAGE = 0.45
#: ... with at most this many spheres per finger
MAX_SPHERES = 40
#: pad depth into the distal link (m), at most
PAD_DEPTH = 0.004


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
    build_error : str or None
        Why the guessed description does not build into a model, if it does not.
    """

    data: dict[str, Any]
    notes: dict[str, str] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    build_error: str | None = None


@dataclass
class _Urdf:
    """What every step needs: the kinematics below the base and its geometry."""

    path: Path
    kin: Kinematics
    base: str
    below: list[str]
    actuated: list[str]
    boxes: Boxes  # link -> (lo, hi) of its geometry, link frame
    default: dict[str, float]  # every actuated joint at 0, clipped into limits
    extent: float  # size (m) of the gripper at ``default``
    notes: dict[str, str] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    def centroids(self, links: list[str], posture: dict[str, float]) -> Array:
        """Geometry-box centres of ``links`` in the base frame: ``(L, 3)``."""
        poses = self.kin.link_poses(self.base, posture)
        pts = []
        for link in links:
            lo, hi = self.boxes[link]
            T = poses[link]
            pts.append(T[:3, :3] @ (0.5 * (lo + hi)) + T[:3, 3])
        return np.array(pts)


# ------------------------------------------------------------------------------
# Helpers
# ------------------------------------------------------------------------------
def _link_boxes(kin: Kinematics, links: list[str]) -> Boxes:
    """Axis-aligned bounds ``(lo, hi)`` of each link's geometry in its own frame."""
    out = {}
    for link in links:
        shapes = kin.shapes.get(link, [])
        if not shapes:
            continue
        verts = np.concatenate([np.asarray(shape_mesh(s).vertices) for s in shapes])
        out[link] = (verts.min(axis=0), verts.max(axis=0))
    return out


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
    """Rounded floats (lists kept), without ``-0.0``."""
    if isinstance(v, np.ndarray | list | tuple):
        return [_r(x, nd) for x in v]
    out = round(float(v), nd)
    return 0.0 if out == 0 else out


# ------------------------------------------------------------------------------
# The steps
# ------------------------------------------------------------------------------
def _read(path: Path, name: str, base_link: str | None) -> _Urdf:
    """The URDF: base link, actuated joints, link geometry, plausible size."""
    kin = load_kinematics(path, name)
    notes: dict[str, str] = {}
    warnings: list[str] = []
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

    movable = [j for j in kin.joints.values() if j.kind != 0 and j.child in below]
    actuated = [j.name for j in movable if j.mimic is None]
    if not actuated:
        kinds = ", ".join(
            f"{j.name} ({'mimic' if j.mimic else 'fixed'})" for j in kin.joints.values()
        )
        raise GripperError(
            f"URDF {path.name}: no actuated joint below {base!r} (joints: "
            f"{kinds or 'none'}); the fingers cannot move",
            hint="make the finger joints revolute or prismatic with <limit lower "
            "upper>; a <mimic> joint needs an actuated joint to follow",
        )

    boxes = _link_boxes(kin, below)
    if not boxes:
        raise GripperError(
            f"URDF {path.name}: no link below {base!r} has collision or visual "
            "geometry",
            hint="add <collision> geometry to the gripper's links",
        )
    default = {
        j: float(np.clip(0.0, kin.joints[j].lower, kin.joints[j].upper))
        for j in actuated
    }
    poses = kin.link_poses(base, default)
    corners = []
    for link, (lo, hi) in boxes.items():
        c = np.array(np.meshgrid(*zip(lo, hi, strict=True), indexing="ij"))
        c = c.reshape(3, -1).T  # (8, 3)
        T = poses[link]
        corners.append(c @ T[:3, :3].T + T[:3, 3])
    allc = np.concatenate(corners)  # (8 L, 3)
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
    return _Urdf(
        path, kin, base, below, actuated, boxes, default, extent, notes, warnings
    )


def _fingers(u: _Urdf) -> dict[str, list[str]]:
    """Distal link -> the actuated joints (mimics replaced by their masters) on the
    chain from the base, in tree order. Raises on a finger moved by a continuous
    joint without limits."""
    kin = u.kin
    chains = {link: kin.chain(u.base, link) for link in u.boxes}
    candidates = {k: c for k, c in chains.items() if any(j.kind != 0 for j in c)}
    # distal: no other candidate below it
    distal = [
        link
        for link in candidates
        if not any(
            other != link and link in [j.parent for j in candidates[other]]
            for other in candidates
        )
    ]
    masters: dict[str, list[str]] = {}
    moving: dict[str, int] = {}
    for link in distal:
        chain = [j for j in candidates[link] if j.kind != 0]
        masters[link] = list(dict.fromkeys(kin.master(j.name) for j in chain))
        moving[link] = len(chain)
    # linkage bars: moved by a subset of a longer chain's joints
    bars = [
        link
        for link in distal
        if any(
            set(masters[link]) <= set(masters[o]) and moving[o] > moving[link]
            for o in distal
            if o != link
        )
    ]
    distal = sorted((k for k in distal if k not in bars), key=u.below.index)
    if not distal:
        raise GripperError(
            f"URDF {u.path.name}: found no fingertip (a link with geometry moved by "
            f"a joint) below {u.base!r}",
            hint="give the finger links <collision> geometry",
        )
    u.notes["fingers"] = (
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
        u.warnings.append(
            f"only one finger found (link {distal[0]!r}); the planner needs fingers "
            "that close against each other or against the palm"
        )
    used = {m for link in distal for m in masters[link]}
    for j in unlimited_continuous(u.path):
        if j in used:
            raise GripperError(
                f"URDF {u.path.name}: continuous joint {j!r} moves a finger but has "
                "no <limit lower upper>, so its workspace would be a full turn",
                hint=f"give joint {j!r} <limit lower=... upper=...> in the URDF (or "
                "make it revolute) with the range the finger really uses",
            )
        u.warnings.append(
            f"continuous joint {j!r} has no limits and moves no finger; it is held at 0"
        )
    return {link: masters[link] for link in distal}


def _postures(
    u: _Urdf, fingers: dict[str, list[str]]
) -> tuple[dict[str, float], dict[str, float]]:
    """Pre-grasp and closed postures; joints held in both are dropped from the
    fingers' joints (when a finger keeps another).

    The grasp axis runs from the base origin through the fingertips' centre with
    every joint at 0 (clipped into its limits). Per joint, starting from there,
    "closing" is the direction in which the fingertips first move nearer that
    axis; "closed" is the limit that way, "open" (pre-grasp) the other limit.
    """
    kin, default = u.kin, u.default
    distal = list(fingers)
    masters_all = list(dict.fromkeys(m for ms in fingers.values() for m in ms))
    c0 = u.centroids(distal, default).mean(axis=0)
    a0 = c0 / max(float(np.linalg.norm(c0)), 1e-12)

    def off_axis(post: dict[str, float]) -> float:
        d = u.centroids(distal, post) - c0  # (F, 3)
        d -= np.outer(d @ a0, a0)
        return float(np.linalg.norm(d, axis=1).sum())

    delta: dict[str, float] = {}  # tip motion towards (-) the axis per 10 % range
    ends: dict[str, tuple[float, float]] = {}
    for m in masters_all:
        j = kin.joints[m]
        h = 0.1 * (j.upper - j.lower)
        qa, qb = max(j.lower, default[m] - h), min(j.upper, default[m] + h)
        s = [off_axis({**default, m: q}) for q in (qa, qb)]
        delta[m] = (s[1] - s[0]) / max(qb - qa, 1e-12) * h
        ends[m] = (j.upper, j.lower) if s[1] > s[0] else (j.lower, j.upper)
    # a joint is compared with the strongest closer of its own finger
    strongest = {
        m: max(abs(delta[x]) for ms in fingers.values() if m in ms for x in ms)
        for m in masters_all
    }
    pregrasp: dict[str, float] = {}
    closed: dict[str, float] = {}
    how: list[str] = []
    held: set[str] = set()
    for m in masters_all:
        small = abs(delta[m]) < max(POSTURE_FRACTION * strongest[m], 2e-4)
        sharing = [ms for ms in fingers.values() if m in ms]
        # shared by several fingers that each close more with a joint of their own:
        # a spread / ab-adduction joint, set once for the grasp, not a closer
        shared = len(sharing) > 1 and all(
            any(abs(delta[x]) > abs(delta[m]) for x in ms if x != m) for ms in sharing
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
    for m in u.actuated:
        if m not in masters_all:
            pregrasp[m] = closed[m] = default[m]
            how.append(f"{m} moves no fingertip: held at {default[m]:g}")
    u.notes["pregrasp"] = (
        "per joint, the limit away from which the fingertips first move nearer the "
        "grasp axis (base origin -> fingertips' centre with all joints at 0; FK of "
        "the distal links): " + "; ".join(how)
    )
    u.notes["closed"] = "per joint, the other limit: towards the grasp axis"
    dropped = set()
    for link, ms in fingers.items():
        keep = [m for m in ms if m not in held]
        if keep and len(keep) < len(ms):
            dropped |= set(ms) - set(keep)
            fingers[link] = keep
    if dropped:
        u.notes["fingers"] += (
            "; joints held in pregrasp are not sampled for the workspaces: "
            + ", ".join(sorted(dropped))
        )
    return pregrasp, closed


def _pads(
    u: _Urdf,
    distal: list[str],
    names: list[str],
    pregrasp: dict[str, float],
    closed: dict[str, float],
) -> list[dict[str, Any]]:
    """One pad per distal link, on the face that leads when the finger starts to
    close (towards the grasp axis when it does not move), at the fingertip end."""
    mid = {m: 0.9 * pregrasp[m] + 0.1 * closed[m] for m in pregrasp}
    poses_mid = u.kin.link_poses(u.base, mid)
    tips_open = u.centroids(distal, pregrasp)  # (F, 3)
    tips_mid = u.centroids(distal, mid)  # (F, 3)
    c0 = u.centroids(distal, u.default).mean(axis=0)
    a0 = c0 / max(float(np.linalg.norm(c0)), 1e-12)
    pads, notes = [], []
    for i, link in enumerate(distal):
        lo, hi = u.boxes[link]
        size, c = hi - lo, 0.5 * (lo + hi)
        d_base = tips_mid[i] - tips_open[i]
        if np.linalg.norm(d_base) < 1e-6:
            d_base = c0 - tips_mid[i]
            d_base -= (d_base @ a0) * a0
        R = poses_mid[link][:3, :3]
        d_link = R.T @ d_base
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
        out_link = R.T @ tips_mid[i]
        out_link[k] = 0.0
        v = int(np.argmax(np.abs(out_link)))
        half = ""
        if np.abs(out_link[v]) > 1e-9 and size[v] > 2.0 * PAD_DEPTH:
            pad_size[v] = 0.4 * size[v]
            pad_c[v] = c[v] + np.sign(out_link[v]) * 0.25 * size[v]
            half = f", its half towards {'+' if out_link[v] > 0 else '-'}{'xyz'[v]}"
        pads.append(
            {"link": link, "center": _r(pad_c), "size": _r(pad_size), "samples": 3}
        )
        notes.append(
            f"{names[i]}: the {'+' if sign > 0 else '-'}{'xyz'[k]} face of "
            f"{link}'s geometry box (the largest face leading when it closes)"
            f"{half}, 80 % wide, {depth * 1000:.1f} mm deep"
        )
    u.notes["pad"] = "; ".join(notes)
    return pads


def _axes(
    u: _Urdf,
    pads: list[dict[str, Any]],
    pregrasp: dict[str, float],
    closed: dict[str, float],
) -> tuple[Array, Array, Array]:
    """Approach axis, closing axis and TCP position from the pads' motion."""

    def pad_points(posture: dict[str, float]) -> Array:
        ps = u.kin.link_poses(u.base, posture)
        out = []
        for p in pads:
            T = ps[p["link"]]
            out.append(T[:3, :3] @ np.asarray(p["center"]) + T[:3, 3])
        return np.array(out)  # (F, 3)

    p_open, p_closed = pad_points(pregrasp), pad_points(closed)
    mean_open = p_open.mean(axis=0)
    if np.linalg.norm(mean_open) < 1e-6:
        raise GripperError(
            f"URDF {u.path.name}: the fingertips' centre coincides with the origin "
            f"of base link {u.base!r}, so no approach direction can be read from it",
            hint="pass --base-link with the link the arm's flange holds",
        )
    approach, u.notes["approach_axis"] = _snap(
        mean_open, "from the base link's origin towards the pads' centre (open)"
    )
    motion = p_closed - p_open  # (F, 3)
    motion -= np.outer(motion @ approach, approach)
    what = "principal direction in which the pads move when closing"
    if float(np.linalg.norm(motion)) < 1e-6:
        motion = p_open - mean_open
        motion -= np.outer(motion @ approach, approach)
        what = "principal direction of the pads' positions across the approach axis"
    if float(np.linalg.norm(motion)) < 1e-9:
        helper = np.eye(3)[int(np.argmin(np.abs(approach)))]
        closing = np.cross(approach, helper)
        what = "any axis perpendicular to the approach axis (the pads do not move)"
        u.warnings.append("the pads do not move across the approach axis when closing")
    else:
        closing = np.linalg.eigh(motion.T @ motion)[1][:, -1]
    closing = closing - (closing @ approach) * approach
    closing, u.notes["closing_axis"] = _snap(closing, what)
    if abs(float(closing @ approach)) > 1e-6:  # the snap broke orthogonality
        closing = closing - (closing @ approach) * approach
        closing /= np.linalg.norm(closing)
    if closing[int(np.argmax(np.abs(closing)))] < 0:
        closing = -closing
    u.notes["tool_frame"] = "midway between the pads' centres open and closed"
    return approach, closing, 0.5 * (mean_open + p_closed.mean(axis=0))


def _settings(
    u: _Urdf, fingers: dict[str, list[str]], pads: list[dict[str, Any]]
) -> dict[str, Any]:
    """joint_samples, spheres_per_finger, workspace_voxel, pad samples."""
    dof = max(len(ms) for ms in fingers.values())
    samples = int(np.clip(np.floor(CONFIG_BUDGET ** (1.0 / dof)), 4, 33))
    spheres = {1: 10, 2: 20, 3: 30}.get(dof, 40)
    voxel = float(np.clip(np.round(u.extent / 100 / 0.0005) * 0.0005, 0.001, 0.004))
    u.notes["joint_samples"] = (
        f"up to {dof} actuated joints per finger: {samples}^{dof} configurations "
        f"(about {CONFIG_BUDGET})"
    )
    u.notes["spheres_per_finger"] = f"{spheres} for fingers of {dof} joint(s)"
    u.notes["workspace_voxel"] = f"1 % of the gripper's size ({u.extent * 1000:.0f} mm)"
    # pad samples about a voxel apart, so the swept samples close into a volume
    cap = 12 if dof <= 2 else 6
    for pad in pads:
        edge = float(max(pad["size"]))
        pad["samples"] = int(np.clip(np.ceil(edge / voxel) + 1, 3, cap))
    u.notes["pad"] += (
        f"; samples: pad points about one workspace voxel apart (at most {cap} per "
        "edge)"
    )
    return {
        "joint_samples": samples,
        "spheres_per_finger": spheres,
        "workspace_voxel": voxel,
        "min_sphere_radius": voxel,
    }


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
    u = _read(path, name, base_link)
    fingers = _fingers(u)
    distal = list(fingers)
    names = _finger_names(distal)
    pregrasp, closed = _postures(u, fingers)
    pads = _pads(u, distal, names, pregrasp, closed)
    approach, closing, tcp = _axes(u, pads, pregrasp, closed)
    data: dict[str, Any] = {
        "version": 1,
        "name": name,
        "urdf": urdf_field or path.name,
        "base_link": u.base,
        "tool_frame": {"link": u.base, "xyz": _r(tcp)},
        "approach_axis": _r(approach, 6),
        "closing_axis": _r(closing, 6),
        "fingers": [
            {"name": n, "joints": fingers[link], "pad": pad}
            for n, link, pad in zip(names, distal, pads, strict=True)
        ],
        **_settings(u, fingers, pads),
        "ellipsoids": {"count": 5, "exponent": 10.0},
        "cloud_points": 500,
        "pregrasp": {k: _r(v, 6) for k, v in pregrasp.items()},
        "closed": {k: _r(v, 6) for k, v in closed.items()},
    }
    return Scaffold(data, u.notes, u.warnings)


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
