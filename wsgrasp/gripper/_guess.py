"""Guessing a gripper description from a URDF (``wsgrasp gripper new``).

Every guess is made by forward kinematics of the URDF and comes with a note saying
how it was made; :func:`guess_description` runs the steps in order: the base link
and the joints that can move (:func:`_read`), the fingers and the wrist or palm
joints that carry several of them (:func:`_fingers`), the open and closed postures
(:func:`_postures`), the pads (:func:`_pads`), the axes and tool frame
(:func:`_axes`) and the sampling settings (:func:`_settings`).
"""

from __future__ import annotations

import copy
import re
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp.errors import GripperError
from wsgrasp.geometry import JOINT_REVOLUTE, grid_configurations
from wsgrasp.gripper._scaffold_urdf import unlimited_continuous
from wsgrasp.gripper._urdf import Kinematics, link_mesh, load_kinematics, shape_mesh

__all__ = ["Scaffold", "fit_sphere_count", "guess_description"]

Array = NDArray[np.float64]
Boxes = dict[str, tuple[Array, Array]]

#: a whole gripper larger than this (m) is taken to be in other units than metres
MAX_GRIPPER_EXTENT = 1.5
#: a whole gripper smaller than this (m) is implausible too
MIN_GRIPPER_EXTENT = 0.01
#: this many movable joints above the link where the fingers branch are an arm,
#: not a hand's wrist (a hand's own wrist has at most two: the Shadow hand's
#: WRJ2 and WRJ1); without ``--base-link``, the gripper starts at that link
ARM_JOINTS = 3
#: the links below the point where a gripper's fingers part span at most this
#: (m): wider branchings are a robot's (its arms, its wheels)
MAX_HAND_EXTENT = 0.6
#: an axis within this angle (degrees) of a base-frame axis is snapped onto it
SNAP_DEG = 15.0
#: a hand of at least this many fingers may approach fingertips first, when the
#: way its open fingers point lies more than FINGERTIPS_FIRST_DEG from its palm's
#: normal (grippers of fewer fingers approach along them already)
FINGERTIPS_FIRST_MIN = 4
FINGERTIPS_FIRST_DEG = 30.0
#: a joint that brings its fingertip nearer the other fingers by less than this
#: fraction of its finger's strongest closer is a posture joint (ab/adduction):
#: held in place, not opened
POSTURE_FRACTION = 0.25
#: ... and so is a joint below this fraction that turns about (or slides along)
#: another axis than its finger's main closers, when they are several (the joints
#: sharing an axis that close the finger most together: its flexion joints); a
#: finger that closes with one joint keeps its others (a thumb's rotation)
CROSS_POSTURE_FRACTION = 0.5
#: joint axes whose directions' cosine is above this are parallel
PARALLEL_COS = 0.9
#: grid points per joint when sampling where each fingertip can go
TIP_SAMPLES = 3
#: steps along a finger's closing path when looking for where it meets the palm
PATH_STEPS = 33
#: a finger stopped by the palm before this fraction of its closing path keeps
#: its limits (the palm's box is too loose to tell)
MIN_STOP = 0.25
#: steps along the closing path when looking for where the pads meet
MEET_STEPS = 129
#: the pads' spread (m) must grow at least this much again past its least for
#: ``closed`` to stop where they meet, and a pinch must bring them this much nearer
MEET_MARGIN = 0.001
#: pads whose spread (m) on the closing line falls to this meet there
MEET_DISTANCE = 0.005
#: ``--close-past`` from a pinch: each finger's line is followed up to this many
#: times its length from ``pregrasp`` to the pinch, in this many steps
PAST_REACH = 2.0
PAST_STEPS = 201
#: postures per finger at most, and grid points per joint at most, when looking
#: for where the pads come nearest a common point; and the rounds of that search
PINCH_GRID = 4096
PINCH_SAMPLES = 17
PINCH_ROUNDS = 50
#: values tried per held joint when choosing where it holds its finger
HOLD_SAMPLES = 5
#: configurations per closing joint when measuring how near a finger gets
HOLD_CLOSE_SAMPLES = 5
#: (held values x closing configurations) per finger at most, for that measure
HOLD_BUDGET = 200_000
#: among held postures whose finger gets this fraction of the best gain near,
#: the one moving the held joints least is taken
HOLD_TIE = 0.1
#: a thumb whose held joints bring it no nearer the other fingers is held where
#: its closing motion turns at least this much (degrees) more against theirs
HOLD_OPPOSE_DEG = 20.0
#: configurations sampled per finger when sizing joint_samples
CONFIG_BUDGET = 6000
#: sphere coverage of every finger workspace the scaffolder aims for
TARGET_COVERAGE = 0.45
#: ... with at most this many spheres per finger
MAX_SPHERES = 40
#: pad depth into the distal link (m), at most
PAD_DEPTH = 0.004
#: pad points computed per finger at most (joint grid times pad samples) when a
#: pad is sampled a voxel apart along each edge
DENSE_PAD_BUDGET = 2_000_000
#: a hand's guessed drive: the stiffness (N/m) of its median finger's pad, half
#: closed, when each of the finger's joints gives way under its position actuator
PAD_STIFFNESS = 300.0
#: ... for a hand of three fingers, which holds each object with fewer pads.
#: Measured under the strict protocol (``random:000-119``, 1 trial, seed 0;
#: ``docs/results/drive-guess/hands-drive-x2-x4-strict-000-119.json``): twice
#: the stiffness held 94 against 83 of 120 objects (BarrettHand), 87 against 82
#: (D'Claw), 45 against 42 (Robotiq 3F); the five-finger hands gained nothing
PAD_STIFFNESS_THREE = 600.0
#: a gripper of at least this many fingers gets a drive guessed from its size:
#: a two-finger gripper's revolute jaws get ``PAD_STIFFNESS_THREE`` too. The
#: simulator's default gain (2 N·m/rad) gave the Robotiq 2F-C2's and the xArm
#: gripper's jaws, both on one joint, about 300 N/m each, and the PR2 gripper's
#: longer fingers, each on its own, 160 N/m; at the rule's gains (3.9, 3.6 and
#: 15 N·m/rad, the PR2's jaws then on one joint) the three held 264, 243 and 232
#: of ``random:000-299`` under the strict protocol, against 245, 228 and 138
#: (the gripper tables, rows re-run at 8e314d9 beside 383de2c)
DRIVE_MIN_FINGERS = 2
#: a moving link whose geometry is smaller than this (m) along every axis is no
#: finger (a placeholder box on an actuator's or a sensor's link)
MIN_FINGER_SIZE = 0.005
#: depth (m) of a rigid jaw's pad box, its workspace: how far the moving finger
#: may push an object across the table onto the jaw
RIGID_PAD_DEPTH = 0.01
#: the step (m) a rigid pad slides out by, off the body superellipsoids
RIGID_PAD_STEP = 0.0005
#: a lone moving finger that opens less than this (m) from still geometry
#: closes against no rigid jaw (a wrist turning beside the arm's last link)
MIN_JAW_OPENING = 0.01
#: points sampled on the still links' surfaces to find where a lone moving
#: finger meets them (about a millimetre apart on a jaw-sized link)
RIGID_SURFACE_SAMPLES = 20_000
#: points sampled on the moving finger's surface to test against them
RIGID_FINGER_POINTS = 4_000


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
    limits : dict of str to (float, float)
        Joint limits to narrow in the URDF the description uses: joints whose
        fingers would close into the palm, stopped where they meet it.
    """

    data: dict[str, Any]
    notes: dict[str, str] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    build_error: str | None = None
    limits: dict[str, tuple[float, float]] = field(default_factory=dict)
    #: a second approach for a hand, fingertips first: ``approach_axis``,
    #: ``closing_axis`` and their notes; :func:`choose_approach` picks one
    fingertips_first: dict[str, Any] | None = None
    #: a hand whose thumb is held opposed: the same guess with the thumb's
    #: opposition joints closing with it instead, from where they were held
    #: (``data`` and ``notes`` as the guess's, and ``turned``: joint -> (open,
    #: closed)); :func:`~wsgrasp.gripper._approach.choose_thumb` picks one
    thumb_turning: dict[str, Any] | None = None
    #: the URDF's links below ``base_link`` (it included), and those above or
    #: beside it, which are no part of the gripper (an arm), in file order
    links_below: list[str] = field(default_factory=list)
    links_outside: list[str] = field(default_factory=list)

    @property
    def approaches_fingertips_first(self) -> bool:
        """Whether the guess approaches fingertips first: its approach axis is
        the fingertips-first one (which :func:`choose_approach` kept)."""
        alt = self.fingertips_first
        return alt is not None and self.data["approach_axis"] == alt["approach_axis"]


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
    wrist: dict[str, float] = field(default_factory=dict)  # held upstream joints

    def centroids(self, links: list[str], posture: dict[str, float]) -> Array:
        """Geometry-box centres of ``links`` in the base frame: ``(L, 3)``."""
        poses = self.kin.link_poses(self.base, posture)
        pts = []
        for link in links:
            lo, hi = self.boxes[link]
            T = poses[link]
            pts.append(T[:3, :3] @ (0.5 * (lo + hi)) + T[:3, 3])
        return np.array(pts)

    def tips(self, link: str, values: dict[str, Any]) -> Array:
        """Geometry-box centre of ``link`` in the base frame for (a batch of)
        actuated-joint values: ``(..., 3)``."""
        T = self.kin.chain_poses(self.base, link, values)  # (..., 4, 4)
        lo, hi = self.boxes[link]
        return (
            np.einsum("...ij,j->...i", T[..., :3, :3], 0.5 * (lo + hi)) + T[..., :3, 3]
        )


# ------------------------------------------------------------------------------
# Helpers
# ------------------------------------------------------------------------------
def _fixed_chain(
    kin: Kinematics, root: str, *, to_branch: bool = False
) -> tuple[list[str], Array]:
    """The links below ``root`` down to the first with geometry (or, with
    ``to_branch``, the first where several joints part: a holder drawn only,
    its fingers hanging from it), where ``root`` and each link on the way has
    no geometry and one child joint, a fixed one; with the translation (m) the
    chain moves that link by, in the root's frame. Empty (and no translation)
    where a link on the way branches or moves."""
    chain: list[str] = []
    link = root
    moved = np.zeros(3)  # the chain's translation, in the root's frame
    turn = np.eye(3)
    while not kin.shapes.get(link):
        down = kin.child_joints(link)
        if to_branch and len(down) > 1 and chain:
            break
        if len(down) != 1 or down[0].kind != 0:
            return [], np.zeros(3)
        T = np.asarray(down[0].origin, dtype=np.float64)
        moved = moved + turn @ T[:3, 3]
        turn = turn @ T[:3, :3]
        link = down[0].child
        chain.append(link)
    return chain, moved


def _placement_chain(kin: Kinematics, root: str) -> list[str]:
    """The links below ``root`` down to the hand's first link
    (:func:`_fixed_chain`), where they only place the hand: ``root`` is the
    ``world`` link of Gazebo's convention that places the hand in a simulation
    and the chain moves the hand away from the world's origin, or ``root``,
    under any name, stands where the fingers reach (:func:`_on_fingers_side`:
    the floor of the TriFinger's stage, 29 cm below the holder its fingers hang
    from). The gripper's frame is then the hand's own link, not where the world
    or the stage put it (the guesses measured from the base's origin went wrong
    there: the Franka hand's pads on the wrong half of its fingers; the
    TriFinger's base 29 cm below its holder). Empty otherwise: a root without
    geometry under another name behind the hand (the Ability hand's
    ``base_link``, turned 90 degrees from its palm) is the mount the arm holds,
    and a world that only turns the hand about its origin changes no guess."""
    world = root.lower() == "world"
    chain, moved = _fixed_chain(kin, root, to_branch=not world)
    if not chain or float(np.linalg.norm(moved)) <= _PLACED_AWAY:
        # a world that only turns the hand about its own origin (the Shadow
        # hand's, 90 degrees about z) leaves the guesses as they are
        return []
    if world or _on_fingers_side(kin, root, chain[-1]):
        return chain
    return []


#: a world link whose fixed joints move the hand this far (m) from its origin
#: places it elsewhere (a simulator's spawn point)
_PLACED_AWAY = 1e-3


def _on_fingers_side(kin: Kinematics, root: str, hand: str) -> bool:
    """Whether ``root``'s origin lies on the side of link ``hand`` (below it,
    :func:`_fixed_chain`) that its moving links reach to: beyond the plane
    through the centre of ``hand``'s geometry (its origin, where it has none),
    within 60 degrees (:data:`_STAGE_COS`) of the way from there to the
    centre of the geometry of the links its joints move (every joint at 0,
    clipped into its limits). An arm holds a hand from behind its palm (or
    beside it); an origin among or beyond the fingers is a stage's or a
    table's."""
    below = kin.subtree(hand)
    moving = [
        link
        for link in below
        if link != hand
        and kin.shapes.get(link)
        and any(j.kind != 0 for j in kin.chain(hand, link))
    ]
    if not moving:
        return False
    poses = kin.link_poses(root, {})
    boxes = _link_boxes(kin, [hand, *moving])

    def centre(link: str) -> Array:
        T = poses[link]
        if link not in boxes:
            return T[:3, 3]
        lo, hi = boxes[link]
        return T[:3, :3] @ (0.5 * (lo + hi)) + T[:3, 3]

    p_hand = centre(hand)  # (3,) in the root's frame
    forward = np.mean([centre(link) for link in moving], axis=0) - p_hand  # (3,)
    size = float(np.linalg.norm(p_hand) * np.linalg.norm(forward))
    return size > 0.0 and float(-p_hand @ forward) > _STAGE_COS * size


#: a root's origin within this cosine's angle (60 degrees) of the way from the
#: hand to its moving links lies where they reach (:func:`_on_fingers_side`)
_STAGE_COS = 0.5


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
    """Short, unique finger names from the distal link names: the words of each
    name that not every name has; where that leaves a name empty or two alike
    (``gripper_right_fingertip_left_link`` and ``..._right_link``: "right" is in
    both), the words that differ at their place in names of as many words."""
    tokens = [re.split(r"[_\-./:]", link.lower()) for link in links]
    common = set(tokens[0]).intersection(*tokens[1:]) if len(tokens) > 1 else set()
    rests = [[t for t in toks if t and t not in common] for toks in tokens]
    if len({len(t) for t in tokens}) == 1 and (
        not all(rests) or len({tuple(r) for r in rests}) != len(rests)
    ):
        same = [len(set(column)) == 1 for column in zip(*tokens, strict=True)]
        rests = [
            [t for t, s in zip(toks, same, strict=True) if t and not s]
            for toks in tokens
        ]
    names = []
    for i, rest in enumerate(rests):
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
def _outside(kin: Kinematics, below: list[str]) -> list[str]:
    """The URDF's links not in ``below``, in file order."""
    inside = set(below)
    return [link for link in kin.links if link not in inside]


def _read(
    path: Path,
    name: str,
    base_link: str | None,
    *,
    why: str = "given with --base-link",
    kin: Kinematics | None = None,
) -> _Urdf:
    """The URDF: base link (``why`` says how ``base_link`` was chosen), actuated
    joints, link geometry; its size is checked by :func:`_check_extent`."""
    kin = kin or load_kinematics(path, name, below=base_link)
    notes: dict[str, str] = {}
    warnings: list[str] = []
    roots = [link for link in kin.links if link not in kin.parent_joint]
    if base_link is not None:
        kin.check_link(base_link, name, "--base-link")
        base = base_link
        notes["base_link"] = why
        outside = _outside(kin, kin.subtree(base))
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
        placed = _placement_chain(kin, base)
        if placed:
            base = placed[-1]
            notes["base_link"] = (
                "the hand's first link below the URDF's root (the first with "
                "geometry, or where a drawn-only holder's joints part): "
                + ", ".join(repr(link) for link in [roots[0], *placed[:-1]])
                + (
                    " only place it (no geometry, one fixed joint down, as a "
                    "simulator's world link does)"
                    if roots[0].lower() == "world"
                    else " only place it (no geometry, one fixed joint down, "
                    "its origin on the side of the hand its fingers reach to, "
                    "as a stage's or a table's is: an arm holds a hand from "
                    "behind; --base-link LINK chooses another link)"
                )
            )
    below = kin.subtree(base)

    movable = [j for j in kin.joints.values() if j.kind != 0 and j.parent in below]
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
    extent = _extent(kin, boxes, base, default)
    return _Urdf(
        path, kin, base, below, actuated, boxes, default, extent, notes, warnings
    )


def _check_extent(u: _Urdf) -> None:
    """Refuse a gripper of implausible size: lengths in other units than metres."""
    if u.extent > MAX_GRIPPER_EXTENT:
        boxes = u.boxes
        big = max(boxes, key=lambda k: float(np.max(boxes[k][1] - boxes[k][0])))
        raise GripperError(
            f"URDF {u.path.name}: the gripper is {u.extent:.1f} m across (largest "
            f"link {big!r}); its lengths look like millimetres, but URDF lengths "
            "are metres",
            hint="for meshes, rerun with --mesh-units mm; for origins and "
            "primitive sizes, convert the URDF to metres; if the URDF holds more "
            "than the gripper, pass --base-link LINK (the link the arm holds)",
        )
    if u.extent < MIN_GRIPPER_EXTENT:
        raise GripperError(
            f"URDF {u.path.name}: the gripper is only {u.extent * 1000:.2f} mm "
            "across; its meshes are probably scaled twice",
            hint="check the scale of the <mesh> elements (--mesh-units m if the "
            "meshes are already in metres)",
        )


def _extent(
    kin: Kinematics, boxes: Boxes, base: str, posture: dict[str, float]
) -> float:
    """Size (m) of the geometry boxes of the links below ``base`` at
    ``posture``: the largest side of the box that holds them all."""
    poses = kin.link_poses(base, posture)
    corners = []
    for link, T in poses.items():
        if link in boxes:
            lo, hi = boxes[link]
            c = np.array(np.meshgrid(*zip(lo, hi, strict=True), indexing="ij"))
            corners.append(c.reshape(3, -1).T @ T[:3, :3].T + T[:3, 3])
    if not corners:
        return 0.0
    allc = np.concatenate(corners)
    return float(np.max(allc.max(axis=0) - allc.min(axis=0)))


def _grippers_in(
    u: _Urdf, distal: list[str], chains: dict[str, list[Any]]
) -> list[tuple[str, list[str]]]:
    """Where grippers hang in the URDF's tree, outermost first: each link at
    which the chains of two or more fingertips part, a joint below it moving
    each, whose links below it span at most :data:`MAX_HAND_EXTENT` (wider
    branchings are a robot's: its arms, its wheels), and that holds no two such
    links side by side below it (a robot small enough for that test, with a
    hand on each arm); one inside another is the same gripper. With the
    fingertips below each. ``distal`` and ``chains``: :func:`_distal_links`."""
    below: dict[str, list[str]] = {}  # link -> fingertips a joint below it moves
    child: dict[tuple[str, str], str] = {}  # (link, fingertip) -> next link
    for tip in distal:
        joints = chains[tip]
        moving = False
        for joint in reversed(joints):
            moving = moving or joint.kind != 0
            if moving:
                below.setdefault(joint.parent, []).append(tip)
                child[joint.parent, tip] = joint.child
    found = [
        link
        for link, tips in below.items()
        if len({child[link, t] for t in tips}) > 1
        and _extent(u.kin, u.boxes, link, u.default) <= MAX_HAND_EXTENT
    ]
    under = {link: set(u.kin.subtree(link)) - {link} for link in found}

    def outermost(links: list[str]) -> list[str]:
        return [a for a in links if not any(a in under[b] for b in links if b != a)]

    # a branching with two or more grippers below it is a robot's (its two
    # small arms), not one gripper
    kept = [
        link
        for link in found
        if len(outermost([o for o in found if o in under[link]])) < 2
    ]
    return [(link, below[link]) for link in outermost(kept)]


def _hand_on_arm(u: _Urdf, name: str) -> _Urdf:
    """``u`` itself, or, where the gripper hangs below an arm or on a robot (at
    least :data:`ARM_JOINTS` movable joints above the link where its fingers'
    chains part), the URDF read again from that link: the arm is no part of the
    gripper. A URDF that holds several grippers (a robot's two arms) is refused,
    naming them."""
    distal, chains, _, _, _ = _distal_links(u)
    found = _grippers_in(u, distal, chains)
    path = u.path.name
    if len(found) > 1:
        listed = ", ".join(f"{link!r} ({len(tips)} fingers)" for link, tips in found)
        raise GripperError(
            f"URDF {path} holds {len(found)} grippers, below links {listed}; "
            "a gripper plugin is one of them",
            hint=f"pass --base-link with the one to scaffold (e.g. --base-link "
            f"{found[0][0]})",
        )
    lone = None
    if found:
        hand = found[0][0]
        arm = [j.name for j in u.kin.chain(u.base, hand) if j.kind != 0]
    elif len(distal) == 1:  # one moving finger on an arm: a jaw against a rigid one
        moving = [j for j in chains[distal[0]] if j.kind != 0]
        if len(moving) <= ARM_JOINTS:
            return u
        hand = moving[-1].parent
        arm = [j.name for j in moving[:-1]]
        lone = moving[-1].name
    else:  # no joint below where the chains part: a rigid tool on an arm?
        if len(distal) < 2:
            return u
        shared: list[Any] = []  # the joints every fingertip's chain passes
        for joints in zip(*(chains[link] for link in distal), strict=False):
            if any(j.name != joints[0].name for j in joints):
                break
            shared.append(joints[0])
        arm = [j.name for j in shared if j.kind != 0]
        hand = shared[-1].child if shared else u.base
    if len(arm) < ARM_JOINTS:
        return u
    listed = ", ".join(arm[:3]) + (f" ... {arm[-1]}" if len(arm) > 3 else "")
    if not found and lone is None:
        under = set(u.kin.subtree(hand))
        if any(j.kind != 0 and j.parent in under for j in u.kin.joints.values()):
            return u  # no gripper found, but not a rigid tool either
        raise GripperError(
            f"URDF {path}: its {len(arm)} movable joints ({listed}) are an arm's, "
            f"above link {hand!r}, and nothing below that link moves: the tool it "
            "carries has no finger joints",
            hint="a gripper's finger joints are revolute or prismatic with <limit "
            "lower upper> (fixed ones cannot close); scaffold from a URDF whose "
            "fingers move, or pass --base-link LINK",
        )
    where = (
        f"the link that joint {lone!r} of the only moving finger turns on"
        if lone
        else "where the fingers' chains part"
    )
    return _read(
        u.path,
        name,
        hand,
        why=(
            f"{where}: the URDF's root {u.base!r} carries this link on an arm of "
            f"{len(arm)} joints ({listed}), which is left out (--base-link LINK "
            "chooses another link)"
        ),
        kin=u.kin,
    )


def _distal_links(
    u: _Urdf,
) -> tuple[list[str], dict[str, list[Any]], dict[str, list[str]], list[str], list[str]]:
    """The fingertips: links with geometry that a joint moves and that carry no
    further moving link, less linkage bars and links whose geometry is under
    :data:`MIN_FINGER_SIZE`, in tree order; with each moving link's chain of
    joints from the base, each fingertip's actuated joints (mimics replaced by
    their masters), the bars and the links too small."""
    kin = u.kin
    chains = {link: kin.chain(u.base, link) for link in u.boxes}
    candidates = {k: c for k, c in chains.items() if any(j.kind != 0 for j in c)}
    # geometry smaller than a fingertip anywhere: a placeholder on an actuator's
    # or a sensor's link, no finger
    tiny = [
        k
        for k in candidates
        if float(np.max(u.boxes[k][1] - u.boxes[k][0])) < MIN_FINGER_SIZE
    ]
    for k in tiny:
        del candidates[k]
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
    return distal, candidates, masters, bars, tiny


def _fingers(u: _Urdf) -> dict[str, list[str]]:
    """Distal link -> the actuated joints (mimics replaced by their masters) on the
    chain from the base, in tree order. Raises on a finger moved by a continuous
    joint without limits."""
    distal, candidates, masters, bars, tiny = _distal_links(u)
    if not distal:
        raise GripperError(
            f"URDF {u.path.name}: found no fingertip (a link with geometry moved by "
            f"a joint) below {u.base!r}",
            hint="give the finger links <collision> geometry",
        )
    # a link that only continuous joints without limits turn spins (a motor's
    # horn, a wheel): no fingertip, where two fingers are left besides
    unlimited = unlimited_continuous(u.path)
    spinning = [k for k in distal if masters[k] and set(masters[k]) <= set(unlimited)]
    if spinning and len(distal) - len(spinning) >= 2:
        distal = [k for k in distal if k not in spinning]
    else:
        spinning = []
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
        + (
            f"; skipped, their geometry under {MIN_FINGER_SIZE * 1000:.0f} mm "
            "across (placeholders on an actuator's or a sensor's link): "
            + ", ".join(tiny)
            if tiny
            else ""
        )
        + (
            "; skipped, turned only by continuous joints without limits (a "
            "motor's horn, a wheel): " + ", ".join(spinning)
            if spinning
            else ""
        )
    )
    _hold_upstream(u, distal, {k: candidates[k] for k in distal}, masters)
    used = {m for link in distal for m in masters[link]}
    for j in unlimited:
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
    for j in sorted(used - set(unlimited)):
        joint = u.kin.joints[j]
        if joint.kind == JOINT_REVOLUTE and joint.upper - joint.lower >= _FULL_TURN:
            raise GripperError(
                f"URDF {u.path.name}: joint {j!r} moves a finger through a full turn "
                f"or more ({joint.lower:g} to {joint.upper:g} rad), so its two ends "
                "meet: no end-stops to open from and close to (a thumb closed "
                "there lands on the back of the hand)",
                hint=f"give joint {j!r} <limit lower=... upper=...> in the URDF with "
                "the range the finger really uses",
            )
    return {link: masters[link] for link in distal}


#: a revolute finger joint whose limits span this much (rad) turns all the way
#: round, its ends within 3 degrees of each other (-3.14 to 3.14: 0.2 degrees)
_FULL_TURN = 2.0 * np.pi - 0.05


def _still_links(u: _Urdf) -> list[str]:
    """Links with geometry that no finger joint moves (held wrist joints aside):
    the palm, and a rigid jaw."""
    kin = u.kin
    return [
        link
        for link in u.boxes
        if not any(
            j.kind != 0 and kin.master(j.name) not in u.wrist
            for j in kin.chain(u.base, link)
        )
    ]


def _surface_points(mesh: Any, count: int) -> Array:
    """A mesh's vertices (at most ``count``) and ``count`` points sampled on
    its faces (seeded): its corners and edges, and its large flat faces'
    insides, which a few vertices leave bare."""
    from trimesh.sample import sample_surface

    verts = np.asarray(mesh.vertices)[:: max(1, len(mesh.vertices) // count)]
    return np.concatenate([verts, np.asarray(sample_surface(mesh, count, seed=0)[0])])


@dataclass
class _RigidJaw:
    """Where a lone moving finger meets still geometry (see :func:`_rigid_jaw`)."""

    link: str  # the still link it meets
    point: Array  # (3,) the still surface point nearest it there, base frame
    joints: dict[str, float]  # the finger's joint values there
    mesh: Any  # the still link's geometry, one trimesh in its frame


def _rigid_jaw(u: _Urdf, fingers: dict[str, list[str]]) -> _RigidJaw | None:
    """For a gripper of one moving finger: the still geometry it closes against.

    Many grippers close one moving jaw against a jaw fixed to their body. The
    finger's joints move together from their lower to their upper limits (and
    back); along each way, the first step at which the finger's surface comes
    within ``MEET_DISTANCE`` of a still link's surface is where it meets the
    rigid jaw, leaving out its hinge (the points that touch still geometry at
    both limits, and, for a turning joint, those nearer its axis than half the
    finger's length). The finger opens at the end from which it travels the
    longer way before meeting it. None for several fingers, where the finger
    meets no still geometry, where it meets some at both limits, or where it
    opens less than :data:`MIN_JAW_OPENING` from it.
    """
    from scipy.spatial import cKDTree

    if len(fingers) != 1:
        return None
    ((link, ms),) = fingers.items()
    still = [x for x in _still_links(u) if x != link]
    if not ms or not still:
        return None
    kin = u.kin
    poses = kin.link_poses(u.base, u.default)
    meshes = {x: link_mesh(u.kin, x) for x in still}
    total = sum(float(m.area) for m in meshes.values()) or 1.0
    points, owner = [], []
    for i, x in enumerate(still):
        share = int(RIGID_SURFACE_SAMPLES * float(meshes[x].area) / total)
        pts = _surface_points(meshes[x], max(200, share))
        T = poses[x]
        points.append(pts @ T[:3, :3].T + T[:3, 3])
        owner.append(np.full(len(pts), i))
    cloud, owners = np.concatenate(points), np.concatenate(owner)
    tree = cKDTree(cloud)
    verts = _surface_points(link_mesh(u.kin, link), RIGID_FINGER_POINTS)  # (V, 3)
    lower = np.array([kin.joints[m].lower for m in ms])
    upper = np.array([kin.joints[m].upper for m in ms])
    t = np.linspace(0.0, 1.0, PATH_STEPS)  # (S,)
    q = lower + t[:, None] * (upper - lower)  # (S, d)
    values: dict[str, Any] = dict(u.default)
    for i, m in enumerate(ms):
        values[m] = q[:, i]
    T = kin.chain_poses(u.base, link, values).reshape(-1, 4, 4)  # (S, 4, 4)
    moved = np.einsum("sij,vj->svi", T[:, :3, :3], verts) + T[:, None, :3, 3]
    dist, nearest = tree.query(moved.reshape(-1, 3))
    dist = dist.reshape(len(t), -1)  # (S, V)
    nearest = nearest.reshape(len(t), -1)
    # the hinge: points that touch still geometry at both limits, and those
    # nearer a turning joint's axis than half the finger's length
    free = ~((dist[0] <= MEET_DISTANCE) & (dist[-1] <= MEET_DISTANCE))  # (V,)
    first = next(j for j in kin.chain(u.base, link) if j.kind != 0)
    if first.kind == JOINT_REVOLUTE:
        A = poses[first.parent] @ first.origin
        axis, at = A[:3, :3] @ first.axis, A[:3, 3]
        rel = moved[0] - at  # (V, 3)
        r = np.linalg.norm(rel - np.outer(rel @ axis, axis), axis=1)  # (V,)
        free &= r >= 0.5 * r.max()
    if not free.any():
        return None
    gap = dist[:, free].min(axis=1)  # (S,)
    meets = np.flatnonzero(gap <= MEET_DISTANCE)
    if len(meets) == 0:
        return None
    if gap[0] <= MEET_DISTANCE and gap[-1] <= MEET_DISTANCE:
        return None  # it meets still geometry at both limits: no way to tell
    # opening at the lower limits, it travels to meets[0]; opening at the upper
    # ones, back to meets[-1]: it opens where it travels the longer way
    up, down = int(meets[0]), int(meets[-1])
    opens_at_lower = up >= len(t) - 1 - down
    step = up if opens_at_lower else down
    if gap[0 if opens_at_lower else -1] < MIN_JAW_OPENING:
        return None  # it hardly opens: a wrist turning beside its arm, no jaw
    v = int(np.flatnonzero(free)[np.argmin(dist[step, free])])
    k = int(nearest[step, v])
    met = still[int(owners[k])]
    return _RigidJaw(
        met, cloud[k], {m: float(q[step, i]) for i, m in enumerate(ms)}, meshes[met]
    )


def _rigid_pad(
    u: _Urdf,
    jaw: _RigidJaw,
    pad: dict[str, Any],
    pregrasp: dict[str, float],
    closed: dict[str, float],
) -> dict[str, Any]:
    """The rigid jaw's pad: a box on the jaw's link at the surface point nearest
    the moving pad closed, on the face of the link's frame whose normal best
    points at the moving pad open, as large as the moving pad closed and
    :data:`RIGID_PAD_DEPTH` deep (the object may lie that far from the jaw
    before the moving finger pushes it there)."""
    kin = u.kin
    p_open = _pad_centres(u, [pad], pregrasp)[0]
    p_closed = _pad_centres(u, [pad], closed)[0]
    poses = kin.link_poses(u.base, pregrasp)
    T = poses[jaw.link]
    R, o = T[:3, :3], T[:3, 3]
    near = np.asarray(jaw.mesh.nearest.on_surface([(p_closed - o) @ R])[0][0])
    n_link = R.T @ (p_open - (R @ near + o))
    k = int(np.argmax(np.abs(n_link)))
    sign = float(np.sign(n_link[k]) or 1.0)
    # the moving pad as it meets the jaw, closed (open, it may stand across it)
    R_pad = kin.link_poses(u.base, closed)[pad["link"]][:3, :3]
    size = np.abs(R.T @ R_pad) @ np.asarray(pad["size"], dtype=np.float64)
    size[k] = RIGID_PAD_DEPTH
    centre = near.copy()
    centre[k] += sign * 0.5 * RIGID_PAD_DEPTH
    u.notes["pad"] += (
        f"; rigid jaw: on {jaw.link}, at the point of its geometry nearest the "
        f"moving pad closed, facing {'+' if sign > 0 else '-'}{'xyz'[k]} (towards "
        f"the moving pad open), as large as the moving pad closed and "
        f"{RIGID_PAD_DEPTH * 1000:.0f} mm deep: its workspace, across which the "
        "moving finger pushes the object onto the jaw"
    )
    return {"link": jaw.link, "center": _r(centre), "size": _r(size), "samples": 3}


def _hold_value(lower: float, upper: float) -> float:
    """0 when the range holds it, else the middle of the range."""
    return 0.0 if lower <= 0.0 <= upper else 0.5 * (lower + upper)


def _hold_upstream(
    u: _Urdf,
    distal: list[str],
    chains: dict[str, list[Any]],
    masters: dict[str, list[str]],
) -> None:
    """Hold the wrist or palm joints: a joint on the chains of several fingers
    moves them together, so it closes none of them. Each such joint whose
    fingers all keep a joint of their own is held at 0 (or the middle of its
    range) and taken out of every finger; ``masters`` is updated in place."""
    if len(distal) < 2:
        return
    kin = u.kin
    on: dict[str, list[str]] = {}  # moving joint -> fingers whose chain holds it
    for link in distal:
        for j in chains[link]:
            if j.kind != 0:
                on.setdefault(j.name, []).append(link)
    upstream = {j for j, links in on.items() if len(links) > 1}
    # a master is held when every joint it drives on a finger chain is upstream
    drives: dict[str, set[str]] = {}
    for j in on:
        drives.setdefault(kin.master(j), set()).add(j)
    held = [m for m, js in drives.items() if js <= upstream]
    own = {link: [m for m in masters[link] if m not in held] for link in distal}
    held = [
        m
        for m in held
        if all(
            own[link]
            for link in distal
            if any(j in on and link in on[j] for j in drives[m])
        )
    ]
    if not held:
        return
    for m in held:
        j = kin.joints[m]
        u.wrist[m] = _hold_value(j.lower, j.upper)
        u.default[m] = u.wrist[m]
    for link in distal:
        masters[link] = [m for m in masters[link] if m not in u.wrist]
    u.notes["fingers"] += (
        "; joints upstream of several fingers (a wrist or palm) move them together, "
        "so they belong to no finger and are held: "
        + ", ".join(f"{m} at {v:g}" for m, v in u.wrist.items())
    )


def _targets(u: _Urdf, fingers: dict[str, list[str]]) -> dict[str, Array]:
    """Per finger of two or more, where it closes towards: the mean of the
    other fingertips' sampled positions (each finger's joints over a 3-point
    grid of their ranges, the rest at ``default``), finger by finger (a single
    finger closes towards its rigid jaw: :func:`_rigid_jaw`)."""
    kin = u.kin
    centres: dict[str, Array] = {}
    for link, ms in fingers.items():
        lower = [kin.joints[m].lower for m in ms]
        upper = [kin.joints[m].upper for m in ms]
        q = grid_configurations(lower, upper, TIP_SAMPLES)  # (3**d, d)
        values: dict[str, Any] = dict(u.default)
        for i, m in enumerate(ms):
            values[m] = q[:, i]
        centres[link] = u.tips(link, values).reshape(-1, 3).mean(axis=0)
    return {
        link: np.mean([c for k, c in centres.items() if k != link], axis=0)
        for link in fingers
    }


def _distance_change(u: _Urdf, link: str, m: str, target: Array) -> float:
    """How much farther (m) fingertip ``link`` is from ``target`` with joint ``m``
    at its upper limit than at its lower one, every other joint at ``default``."""
    j = u.kin.joints[m]
    values: dict[str, Any] = {**u.default, m: np.array([j.lower, j.upper])}
    lo, hi = np.linalg.norm(u.tips(link, values) - target, axis=-1)  # (2,)
    return float(hi - lo)


def _main_closers(
    u: _Urdf, link: str, joints: list[str], effect: dict[str, float]
) -> list[str]:
    """The finger's joints about (or along) the axis shared by the joints that
    together close it most: its flexion joints, not its ab/adduction."""
    kin = u.kin
    poses = kin.link_poses(u.base, u.default)
    axes = {}
    for j in kin.chain(u.base, link):
        m = kin.master(j.name) if j.kind != 0 else None
        if m in joints and m not in axes:
            T = poses[j.parent] @ j.origin
            axes[m] = T[:3, :3] @ j.axis
    groups: list[list[str]] = []
    for m in joints:
        for g in groups:
            if abs(float(axes[m] @ axes[g[0]])) > PARALLEL_COS:
                g.append(m)
                break
        else:
            groups.append([m])
    return max(groups, key=lambda g: sum(effect[x] for x in g))


def _postures(
    u: _Urdf, fingers: dict[str, list[str]], targets: dict[str, Array]
) -> tuple[dict[str, float], dict[str, float]]:
    """Pre-grasp and closed postures; joints held in both are dropped from the
    fingers' joints (when a finger keeps another).

    Per joint, with every other joint at ``default``: the limit at which the
    fingertips it moves are nearer their targets (:func:`_targets`, where the other
    fingers are) is ``closed``, the other limit ``pregrasp``. A joint that changes
    that distance much less than its finger's strongest closer is a posture joint
    (ab/adduction), held in both.
    """
    kin, default = u.kin, u.default
    distal = list(fingers)
    masters_all = list(dict.fromkeys(m for ms in fingers.values() for m in ms))
    # per joint and finger: distance to the target at the upper limit minus at the
    # lower limit (m); > 0: the finger closes towards the lower limit
    change: dict[str, dict[str, float]] = {}
    for m in masters_all:
        change[m] = {
            link: _distance_change(u, link, m, targets[link])
            for link in distal
            if m in fingers[link]
        }
    effect = {m: max(abs(v) for v in change[m].values()) for m in masters_all}
    # a joint is compared with the strongest closer of its own finger(s)
    strongest = {
        m: max(effect[x] for ms in fingers.values() if m in ms for x in ms)
        for m in masters_all
    }
    mains = {link: _main_closers(u, link, fingers[link], effect) for link in distal}
    # how many joints of the finger's chain its main closers turn, the joints
    # that follow them included: a BarrettHand's distal joint coupled to its
    # middle one by a mimic (its real 1:3 drive) is a closer still, and its
    # spread joint stays a spread joint
    turned = {
        link: sum(
            1
            for j in kin.chain(u.base, link)
            if j.kind != 0 and kin.master(j.name) in mains[link]
        )
        for link in distal
    }
    # about another axis than its finger's several main closers, in every finger
    cross = {
        m
        for m in masters_all
        if all(
            turned[link] > 1 and m not in mains[link]
            for link in distal
            if m in fingers[link]
        )
    }
    pregrasp: dict[str, float] = {}
    closed: dict[str, float] = {}
    how: list[str] = []
    held: set[str] = set()
    for m in masters_all:
        j = kin.joints[m]
        small = effect[m] < max(POSTURE_FRACTION * strongest[m], 2e-4) or (
            m in cross and effect[m] < CROSS_POSTURE_FRACTION * strongest[m]
        )
        sharing = [ms for ms in fingers.values() if m in ms]
        # shared by several fingers that each close more with a joint of their own:
        # a spread / ab-adduction joint, set once for the grasp, not a closer
        shared = len(sharing) > 1 and all(
            any(effect[x] > effect[m] for x in ms if x != m) for ms in sharing
        )
        if len(distal) > 1 and (small or shared):
            pregrasp[m] = closed[m] = default[m]
            held.add(m)
            why = (
                f"it spreads {len(sharing)} fingers that close with other joints"
                if shared
                else "over its range the fingertip gets nearer the other fingers "
                f"by only {effect[m] * 1000:.1f} mm"
                + (
                    ""
                    if m not in cross
                    else ", about another axis than the finger's main closers"
                )
            )
            how.append(f"{m} held at {default[m]:g} ({why})")
            continue
        towards_lower = sum(change[m].values()) > 0
        ends = (j.upper, j.lower) if towards_lower else (j.lower, j.upper)
        pregrasp[m], closed[m] = ends
        how.append(
            f"{m} opens at {ends[0]:g}, closes at {ends[1]:g} "
            f"({effect[m] * 1000:.0f} mm nearer)"
        )
    for m, v in u.wrist.items():
        pregrasp[m] = closed[m] = v
    for m in u.actuated:
        if m not in masters_all and m not in u.wrist:
            pregrasp[m] = closed[m] = default[m]
            how.append(f"{m} moves no fingertip: held at {default[m]:g}")
    u.notes["pregrasp"] = (
        "per joint, the limit at which its fingertips are farther from where the "
        "other fingers reach (the mean of their sampled tip positions; FK of the "
        "distal links, other joints at 0)"
        + (
            "; wrist and palm joints at "
            + ", ".join(map(str, u.wrist))
            + " held as in fingers"
            if u.wrist
            else ""
        )
        + ": "
        + "; ".join(how)
    )
    u.notes["closed"] = "per joint, the other limit: towards the other fingers"
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


def _joint_axes(u: _Urdf, link: str) -> dict[str, Array]:
    """Base-frame axis of each actuated joint (its master) on the chain to
    ``link``, at ``default``."""
    kin = u.kin
    poses = kin.link_poses(u.base, u.default)
    axes: dict[str, Array] = {}
    for j in kin.chain(u.base, link):
        if j.kind == 0:
            continue
        m = kin.master(j.name)
        if m not in axes:
            axes[m] = (poses[j.parent] @ j.origin)[:3, :3] @ j.axis
    return axes


def _nearest_approach(
    u: _Urdf,
    link: str,
    target: Array,
    held: dict[str, Array],
    closers: dict[str, tuple[float, float]],
) -> Array:
    """How near (m) fingertip ``link`` gets to ``target`` while closing, for each
    of a batch of held-joint values: the smallest distance over a grid of its
    closing joints between their pregrasp and closed values.

    Parameters
    ----------
    held : dict of str to (V,) float
        Held joint -> its value in each of ``V`` postures.
    closers : dict of str to (float, float)
        Closing joint -> (pregrasp, closed).

    Returns
    -------
    (V,) float
    """
    n = len(next(iter(held.values())))
    samples = HOLD_CLOSE_SAMPLES
    while samples > 2 and n * samples ** len(closers) > HOLD_BUDGET:
        samples -= 1
    q = grid_configurations(
        [a for a, _ in closers.values()], [b for _, b in closers.values()], samples
    )  # (K, c)
    values: dict[str, Any] = dict(u.default)
    for m, v in held.items():
        values[m] = np.repeat(v, len(q))  # (V K,) postures outer
    for i, m in enumerate(closers):
        values[m] = np.tile(q[:, i], n)  # (V K,)
    tips = u.tips(link, values).reshape(n, len(q), 3)  # (V, K, 3)
    return np.linalg.norm(tips - target, axis=-1).min(axis=1)  # (V,)


def _closing_directions(
    u: _Urdf,
    link: str,
    held: dict[str, Array],
    closers: dict[str, tuple[float, float]],
) -> Array:
    """Which way fingertip ``link`` moves while closing, for each of a batch of
    held-joint values: the unit vector from its position with its closing
    joints at pregrasp to that with them closed.

    Parameters
    ----------
    held : dict of str to (V,) float
        Held joint -> its value in each of ``V`` postures (may be empty: one
        posture, every other joint at ``default``).
    closers : dict of str to (float, float)
        Closing joint -> (pregrasp, closed).

    Returns
    -------
    (V, 3) float
    """
    n = len(next(iter(held.values()))) if held else 1
    values: dict[str, Any] = dict(u.default)
    for m, v in held.items():
        values[m] = np.repeat(v, 2)  # (V 2,) postures outer
    for m, (a, b) in closers.items():
        values[m] = np.tile([a, b], n)  # (V 2,)
    tips = u.tips(link, values).reshape(n, 2, 3)  # (V, open/closed, 3)
    d = tips[:, 1] - tips[:, 0]  # (V, 3)
    return d / np.maximum(np.linalg.norm(d, axis=-1, keepdims=True), 1e-12)


def _opposition_angles(
    u: _Urdf,
    link: str,
    joints: dict[str, list[str]],
    closing: dict[str, list[str]],
    held: dict[str, Array],
    ends: dict[str, tuple[float, float]],
) -> Array:
    """How far (degrees) finger ``link``'s closing motion is from straight
    against the other fingers' (the mean of their closing directions,
    :func:`_closing_directions`, each with its own closing joints from
    pregrasp to closed), for each of a batch of held-joint values: 0 where its
    pad closes head-on against theirs, 90 where it moves across them.

    Parameters
    ----------
    joints
        Distal link -> every actuated joint of the finger.
    closing
        Distal link -> its closing joints.
    held : dict of str to (V,) float
        ``link``'s held joints -> their value in each of ``V`` postures.
    ends : dict of str to (float, float)
        Closing joint -> (pregrasp, closed), for every finger's closing joints.

    Returns
    -------
    (V,) float
        180 for each posture where the other fingers' directions cancel out.
    """
    others = [
        _closing_directions(u, o, {}, {c: ends[c] for c in closing[o]})[0]
        for o in joints
        if o != link and closing[o]
    ]  # each (3,)
    n = len(next(iter(held.values())))
    theirs = np.mean(others, axis=0) if others else np.zeros(3)
    size = float(np.linalg.norm(theirs))
    if size < 1e-6:
        return np.full(n, 180.0)
    mine = _closing_directions(u, link, held, {c: ends[c] for c in closing[link]})
    cos = -(mine @ theirs) / size  # (V,)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def _hold_postures(
    u: _Urdf,
    joints: dict[str, list[str]],
    fingers: dict[str, list[str]],
    targets: dict[str, Array],
    pregrasp: dict[str, float],
    closed: dict[str, float],
) -> dict[str, dict[str, float]]:
    """Hold a thumb's posture joints where it, closing, gets nearest the other
    fingers: its opposition.

    A thumb here is a finger whose flexion (its closing joints about the axis
    that closes it most, :func:`_main_closers`) turns about (or slides along)
    an axis no other finger's flexion shares: fingers side by side, which flex
    about parallel axes, keep their held joints where they are (spreading them
    towards each other would make them collide). A held joint
    of a thumb alone (not a wrist, not a joint shared by fingers) that turns
    about another axis than every joint closing it decides where its closing
    goes: a thumb held in the plane of the palm curls beside the fingers, never
    against them. Over a grid of such joints' values (their limits, quarter
    points and hold value), the thumb's nearest approach to its target while
    its closing joints sweep from pregrasp to closed
    (:func:`_nearest_approach`) is measured; when the best brings it nearer
    than the hold value by at least ``POSTURE_FRACTION`` of its strongest
    closer's effect, the held joints take the values that gain nearly the
    most (``HOLD_TIE``) while moving least. When none does, a thumb closing
    across the palm beside the fingers and one closing against their pads may
    end as near where they reach: then the held joints take, among the values
    that bring it no farther, those whose closing motion is nearly the most
    straight against the other fingers' (:func:`_opposition_angles`), when
    that is at least ``HOLD_OPPOSE_DEG`` straighter than at the hold value
    (the F5D6 hand's thumb swing). Its closing joints keep the ends
    :func:`_postures` gave them. ``pregrasp``, ``closed`` and ``u.default`` are
    updated in place: the postures that follow are found with the thumb held
    opposed.

    Returns
    -------
    dict
        Per thumb, the held joints moved and the value each was held at:
        :func:`_turn_thumbs` makes them close with the thumb, from there.

    Parameters
    ----------
    joints
        Distal link -> every actuated joint of the finger, held ones included.
    fingers
        Distal link -> its closing joints (held ones dropped).
    """
    kin = u.kin
    owners: dict[str, int] = {}
    for ms in joints.values():
        for m in ms:
            owners[m] = owners.get(m, 0) + 1
    closing = {
        link: [m for m in fingers[link] if pregrasp[m] != closed[m]] for link in joints
    }
    all_axes = {link: _joint_axes(u, link) for link in joints}
    # each finger's flexion: its closing joints about the axis that closes it most
    flexion = {
        link: _main_closers(
            u,
            link,
            closing[link],
            {
                c: abs(_distance_change(u, link, c, targets[link]))
                for c in closing[link]
            },
        )
        for link in joints
        if closing[link]
    }

    def side_by_side(a: str, b: str) -> bool:
        """Whether fingers ``a`` and ``b`` flex about parallel axes."""
        return any(
            abs(float(all_axes[a][x] @ all_axes[b][y])) > PARALLEL_COS
            for x in flexion.get(a, [])
            for y in flexion.get(b, [])
        )

    how = []
    turned: dict[str, dict[str, float]] = {}
    for link, ms in joints.items():
        closers = closing[link]
        if not closers or any(side_by_side(link, o) for o in joints if o != link):
            continue
        axes = all_axes[link]
        own = [
            m
            for m in ms
            if m not in closers
            and m not in u.wrist
            and owners[m] == 1
            and pregrasp[m] == closed[m]
            and all(abs(float(axes[m] @ axes[c])) <= PARALLEL_COS for c in closers)
        ]
        if not own:
            continue
        target = targets[link]
        # every closer's effect, as _postures measures it: the finger's yardstick
        strongest = max(abs(_distance_change(u, link, c, target)) for c in closers)
        grids = []
        for m in own:
            j = kin.joints[m]
            grid = np.linspace(j.lower, j.upper, HOLD_SAMPLES)
            grids.append(np.unique(np.append(grid, u.default[m])))
        mesh = np.meshgrid(*grids, indexing="ij")
        held = {m: g.reshape(-1) for m, g in zip(own, mesh, strict=True)}  # (V,)
        ends = {c: (pregrasp[c], closed[c]) for c in closers}
        near = _nearest_approach(u, link, target, held, ends)  # (V,)
        every = {c: (pregrasp[c], closed[c]) for cs in closing.values() for c in cs}
        now = np.all(
            [held[m] == u.default[m] for m in own], axis=0
        )  # (V,) the hold values
        start = float(near[now][0])
        gain = start - float(near.min())
        span = np.array([kin.joints[m].upper - kin.joints[m].lower for m in own])
        moved = sum(
            np.abs(held[m] - u.default[m]) / max(s, 1e-12)
            for m, s in zip(own, span, strict=True)
        )  # (V,) how far each posture moves the held joints, in ranges
        if gain >= max(POSTURE_FRACTION * strongest, 2e-4):
            good = near <= near.min() + HOLD_TIE * gain
            pick = int(np.argmin(np.where(good, moved, np.inf)))
            why = (
                f"closing, the fingertip gets within {near[pick] * 1000:.0f} mm "
                f"of where the other fingers reach, {start * 1000:.0f} mm before"
            )
        else:
            # nearer by too little: a thumb that closes across the palm, beside
            # the fingers, and one that closes against their pads may end as
            # near where they reach; which way it moves tells them apart
            angle = _opposition_angles(u, link, joints, closing, held, every)  # (V,)
            angle = np.where(near <= start, angle, np.inf)  # none farther
            turn = float(angle[now][0] - angle.min())
            if turn < HOLD_OPPOSE_DEG:
                continue
            good = angle <= angle.min() + HOLD_TIE * turn
            pick = int(np.argmin(np.where(good, moved, np.inf)))
            why = (
                f"no value brings it {POSTURE_FRACTION:g} of its strongest "
                "closer's effect nearer, so where it closes most straight against "
                "the other fingers' closing without getting farther: its fingertip "
                f"moves {angle[pick]:.0f} deg off straight, {angle[now][0]:.0f} deg "
                f"before; it gets within {near[pick] * 1000:.0f} mm of where they "
                f"reach, {start * 1000:.0f} mm before"
            )
        turned[link] = {}
        for m in own:
            value = float(held[m][pick])
            if value != u.default[m]:
                turned[link][m] = u.default[m]
            pregrasp[m] = closed[m] = u.default[m] = value
        how.append(", ".join(f"{m} at {u.default[m]:g}" for m in own) + f" ({why})")
    if how:
        u.notes["pregrasp"] += (
            "; a thumb's held joints (a finger flexing about an axis no other "
            "finger's flexion shares; held about another axis than its closing "
            "joints: its opposition) are held where it, closing, gets nearest "
            "where the others reach: " + "; ".join(how)
        )
    return turned


def _turn_thumbs(
    turned: dict[str, dict[str, float]],
    joints: dict[str, list[str]],
    fingers: dict[str, list[str]],
    pregrasp: dict[str, float],
) -> None:
    """Make a thumb's opposition joints (:func:`_hold_postures`' ``turned``)
    close with it: open at the value they were held at, closed where they
    oppose it, so that the open hand's thumb lies beside the palm rather than
    in front of it. Held opposed, the vendor Allegro URDF's thumb stuck out
    in front of the palm, into the table under a low object: 7 of
    ``random:000-059`` held (strict protocol), 31 without a grasp; turning in
    as it closes, 36. ``pregrasp`` and ``fingers`` (the joints in the chain's
    order) are updated in place, after every posture was found with the thumb
    opposed; :func:`~wsgrasp.gripper._approach.choose_thumb` decides whether
    the guess takes it."""
    for link, hold in turned.items():
        for m, value in hold.items():
            pregrasp[m] = value
        fingers[link] = [m for m in joints[link] if m in fingers[link] or m in hold]


def _stop_at_palm(
    u: _Urdf,
    fingers: dict[str, list[str]],
    pregrasp: dict[str, float],
    closed: dict[str, float],
) -> dict[str, tuple[float, float]]:
    """Stop each finger where it meets the palm on its way from pregrasp to closed.

    URDF limits often let a finger fold through the palm (placeholder limits such
    as 0..pi, or a curl past contact); the workspace sampled over them then lies
    partly inside the body, where no grasp can use it. Along the closing path (all
    of the finger's joints moving together), the first step at which the
    fingertip's geometry-box centre is inside the geometry box of a palm link (a
    link no finger joint moves) ends the path: ``closed`` is set to the step
    before, in place, and the joint's limit on that side is returned, to be
    narrowed in the URDF copy.

    Returns
    -------
    dict of str to (float, float)
        Joint -> its narrowed ``(lower, upper)``.
    """
    kin = u.kin
    closers = {m for ms in fingers.values() for m in ms}
    palm = _still_links(u)
    if not palm or not closers:
        return {}
    poses = kin.link_poses(u.base, pregrasp)
    t = np.linspace(0.0, 1.0, PATH_STEPS)  # (S,)
    stop: dict[str, float] = {}
    for link, ms in fingers.items():
        values: dict[str, Any] = dict(pregrasp)
        for m in ms:
            values[m] = pregrasp[m] + t * (closed[m] - pregrasp[m])  # (S,)
        tip = u.tips(link, values).reshape(-1, 3)  # (S, 3)
        inside = np.zeros(len(t), dtype=bool)
        for other in palm:
            lo, hi = u.boxes[other]
            T = poses[other]
            p = (tip - T[:3, 3]) @ T[:3, :3]  # (S, 3), in the palm link's frame
            inside |= np.all((p >= lo) & (p <= hi), axis=1)
        if not inside.any() or inside[0]:
            continue
        end = float(t[int(np.argmax(inside)) - 1])
        if end < MIN_STOP:
            continue
        for m in ms:
            stop[m] = min(stop.get(m, 1.0), end)
    limits: dict[str, tuple[float, float]] = {}
    how = []
    for m, end in stop.items():
        j = kin.joints[m]
        value = pregrasp[m] + end * (closed[m] - pregrasp[m])
        closed[m] = value
        if closed[m] > pregrasp[m]:
            limits[m] = (j.lower, value)
        else:
            limits[m] = (value, j.upper)
        how.append(f"{m} at {value:g} ({end:.0%} of the way)")
    if how:
        u.notes["closed"] += (
            "; stopped where the fingertip meets the palm (its geometry-box centre "
            "enters the box of a link no finger joint moves), the joint's limit "
            "narrowed to it in the copied URDF: " + ", ".join(how)
        )
    return limits


def _stop_at_jaw(
    u: _Urdf, jaw: _RigidJaw, pregrasp: dict[str, float], closed: dict[str, float]
) -> dict[str, tuple[float, float]]:
    """Stop a lone moving finger where its geometry meets the rigid jaw's
    (:func:`_rigid_jaw`): ``closed`` is set there, in place, and each joint's
    limit on that side is returned, to be narrowed in the URDF copy (past it,
    the finger's workspace lies inside the jaw)."""
    limits: dict[str, tuple[float, float]] = {}
    how = []
    for m, value in jaw.joints.items():
        if m not in closed or closed[m] == pregrasp[m]:
            continue
        way = (value - pregrasp[m]) / (closed[m] - pregrasp[m])
        if not 0.0 < way < 1.0:
            continue
        j = u.kin.joints[m]
        closed[m] = value
        limits[m] = (j.lower, value) if value > pregrasp[m] else (value, j.upper)
        how.append(f"{m} at {value:g} ({way:.0%} of the way)")
    if how:
        u.notes["closed"] += (
            f"; stopped where the finger's geometry meets the rigid jaw's (on "
            f"{jaw.link!r}, within {MEET_DISTANCE * 1000:.0f} mm), the joint's "
            "limit narrowed to it in the copied URDF: " + ", ".join(how)
        )
    return limits


def _stop_where_pads_meet(
    u: _Urdf,
    fingers: dict[str, list[str]],
    pads: list[dict[str, Any]],
    pregrasp: dict[str, float],
    closed: dict[str, float],
    past: float = 0.0,
) -> None:
    """Close the hand only to where its pads meet (and ``past`` metres on).

    A hand closes all its joints together, along the straight line in joint space
    from ``pregrasp`` to ``closed`` (what a position-controlled hand ramping its
    targets does). Driven on to its limits, a claw's or a three-finger hand's
    fingertips cross and part again, a hand's fingers curl into a fist: a small
    object is pushed out of the grip or closed over. ``closed`` is set, in place,
    to the posture at which the pads meet:

    - on that line, at the first least value of the pads' spread (their mean
      distance from their centroid) past which it grows again by ``MEET_MARGIN``,
      when the pads come within ``MEET_DISTANCE`` there (they meet);
    - else, for fingers that share no joint, the posture at which they come
      nearest a common point, each finger's joints searched over a grid between
      their pregrasp and closed values (:func:`_pinch`), when that brings the
      pads ``MEET_MARGIN`` nearer together than the line does: a hand's
      fingertips meeting its thumb's rather than curling past it;
    - else at the line's least spread, where there is one.

    A jaw whose pads get nearer all the way to its limits, or a single finger,
    keeps its ``closed``. With ``past`` (``gripper new --close-past``), ``closed``
    moves on from there until the pads have travelled ``past`` more on average
    (on the line) or each pad has (from the pinch, along each finger's own line
    from ``pregrasp`` through it), within the joints' ranges.
    """
    if len(pads) < 2:
        return
    moving = [m for m in pregrasp if closed[m] != pregrasp[m]]
    if not moving:
        return
    t = np.linspace(0.0, 1.0, MEET_STEPS)  # (S,)
    values: dict[str, Any] = dict(pregrasp)
    for m in moving:
        values[m] = pregrasp[m] + t * (closed[m] - pregrasp[m])  # (S,)
    P = np.stack([_pad_points(u, p, values, len(t)) for p in pads])  # (F, S, 3)
    spread = np.linalg.norm(P - P.mean(axis=0), axis=2).mean(axis=0)  # (S,)
    # the first local minimum after which the pads part by MEET_MARGIN at least
    rising = (
        np.flatnonzero((spread[1:-1] <= spread[:-2]) & (spread[1:-1] < spread[2:])) + 1
    )
    parted = [j for j in rising if spread[j:].max() - spread[j] >= MEET_MARGIN]
    k = int(parted[0]) if parted else None
    least = float(spread[k]) if k is not None else float(spread.min())
    if k is None or least > MEET_DISTANCE:
        start = P[:, k if k is not None else int(np.argmin(spread))]  # (F, 3)
        pinch = _pinch(u, fingers, pads, pregrasp, closed, start.mean(axis=0))
        if pinch is not None and pinch[1] <= least - MEET_MARGIN:
            posture, gap, point = pinch
            if past > 0.0:
                posture = _past_pinch(u, fingers, pads, pregrasp, closed, posture, past)
            closed.update(posture)
            u.notes["closed"] += (
                "; stopped where the pads meet: the posture at which they come "
                "nearest a common point (each finger's joints searched between "
                f"their pregrasp and closed values), {_r(point * 1000, 1)} mm, the "
                f"pads {gap * 1000:.1f} mm from it on average ({least * 1000:.1f} mm "
                "at best closing all joints together)" + _past_note(past)
            )
            return
    if k is None:
        return
    end = k
    if past > 0.0:  # on along the line until the pads' mean travel reaches it
        step = np.linalg.norm(np.diff(P, axis=1), axis=2).mean(axis=0)  # (S - 1,)
        end = k + _travelled(step[k:], past)
    for m in moving:
        closed[m] = float(pregrasp[m] + t[end] * (closed[m] - pregrasp[m]))
    u.notes["closed"] += (
        f"; stopped where the pads meet: closing all joints together, the pads' "
        f"centres come nearest each other {t[k]:.0%} of the way (their mean "
        f"distance from their centroid {spread[k] * 1000:.1f} mm, "
        f"{spread[-1] * 1000:.1f} mm at the end), past which the fingers part "
        "again or close over the object" + _past_note(past)
    )
    if least > MEET_DISTANCE and past <= 0.0:
        # measured on five development hands (docs/results/closed-past-meet/,
        # docs/results/tune/): closing further held more for the Robotiq 3F and
        # fewer for the BarrettHand, whose pads pass apart too, so the guess
        # stays and the comment says how to measure it
        u.notes["closed"] += (
            "; they pass each other without meeting, so an object narrower than "
            "their gap is pressed only as far as the fingers wrap it: `wsgrasp "
            "gripper tune` on this YAML tries closing on to the joints' limits "
            "on the same drops and keeps what holds more (docs: Add a gripper, "
            "Tune the closing)"
        )


def _past_note(past: float) -> str:
    """The comment's words for ``--close-past``; empty without it."""
    if past <= 0.0:
        return ""
    return (
        f"; then on past it until the pads had travelled {past * 1000:.0f} mm more "
        f"(gripper new --close-past {past:g}), within the joints' ranges"
    )


def _past_pinch(
    u: _Urdf,
    fingers: dict[str, list[str]],
    pads: list[dict[str, Any]],
    pregrasp: dict[str, float],
    closed: dict[str, float],
    posture: dict[str, float],
    past: float,
) -> dict[str, float]:
    """``posture`` (the pinch, each finger's closing joints) moved on along each
    finger's own line from ``pregrasp`` through it until its pad has travelled
    ``past`` (m) more, or to where the line leaves the joints' range between
    ``pregrasp`` and ``closed``."""
    out = dict(posture)
    scale = np.linspace(0.0, PAST_REACH, PAST_STEPS)[:, None]  # (A, 1)
    for p in pads:
        js = [m for m in fingers[p["link"]] if m in posture]
        if not js:
            continue
        q0 = np.array([pregrasp[m] for m in js])
        qp = np.array([posture[m] for m in js])
        qc = np.array([closed[m] for m in js])
        Q = np.clip(qp + scale * (qp - q0), np.minimum(q0, qc), np.maximum(q0, qc))
        values: dict[str, Any] = {**pregrasp, **posture}
        values.update({m: Q[:, i] for i, m in enumerate(js)})
        P = _pad_points(u, p, values, len(Q))  # (A, 3)
        j = _travelled(np.linalg.norm(np.diff(P, axis=0), axis=1), past)
        out.update({m: float(Q[j, i]) for i, m in enumerate(js)})
    return out


def _travelled(steps: Array, distance: float) -> int:
    """The first point of a path, given the lengths of its ``steps`` ``(n,)``,
    at least ``distance`` along it from its start; its last point (``n``) when
    the path is shorter."""
    far = np.flatnonzero(np.cumsum(steps) >= distance)
    return int(far[0]) + 1 if len(far) else len(steps)


def _pad_points(u: _Urdf, pad: dict[str, Any], values: dict[str, Any], n: int) -> Array:
    """The centre of ``pad`` in the base frame for a batch of ``n`` joint values,
    ``(n, 3)``."""
    T = np.broadcast_to(u.kin.chain_poses(u.base, pad["link"], values), (n, 4, 4))
    c = np.asarray(pad["center"], dtype=np.float64)
    return np.asarray(np.einsum("sij,j->si", T[:, :3, :3], c) + T[:, :3, 3])


def _pinch(
    u: _Urdf,
    fingers: dict[str, list[str]],
    pads: list[dict[str, Any]],
    pregrasp: dict[str, float],
    closed: dict[str, float],
    start: Array,
) -> tuple[dict[str, float], float, Array] | None:
    """The posture at which the pads come nearest a common point.

    Each finger's closing joints (those whose pregrasp and closed values differ)
    are sampled on a grid between those values (``PINCH_GRID`` postures at most);
    from ``start`` ``(3,)``, each finger takes the posture whose pad centre lies
    nearest the point and the point moves to their mean, until it stays. Returns
    the fingers' joint values, the pads' mean distance from the point and the
    point; None when fingers share a closing joint (a coupled jaw) or one has
    none.
    """
    joints = [[m for m in fingers[p["link"]] if closed[m] != pregrasp[m]] for p in pads]
    flat = [m for js in joints for m in js]
    if any(not js for js in joints) or len(flat) != len(set(flat)):
        return None
    grids, points = [], []
    for p, js in zip(pads, joints, strict=True):
        n = max(2, min(PINCH_SAMPLES, int(PINCH_GRID ** (1.0 / len(js)))))
        q = grid_configurations(
            np.array([pregrasp[m] for m in js]), np.array([closed[m] for m in js]), n
        )  # (K, d); each joint's values from pregrasp to closed
        values: dict[str, Any] = dict(pregrasp)
        values.update({m: q[:, i] for i, m in enumerate(js)})
        grids.append(q)
        points.append(_pad_points(u, p, values, len(q)))  # (K, 3)
    point = np.asarray(start, dtype=np.float64)
    nearest = [-1] * len(pads)
    for _ in range(PINCH_ROUNDS):
        now = [int(np.argmin(np.linalg.norm(q - point, axis=1))) for q in points]
        if now == nearest:
            break
        nearest = now
        point = np.mean([q[k] for q, k in zip(points, now, strict=True)], axis=0)
    chosen = np.array([q[k] for q, k in zip(points, nearest, strict=True)])
    gap = float(np.linalg.norm(chosen - point, axis=1).mean())
    posture = {
        m: float(g[k, i])
        for js, g, k in zip(joints, grids, nearest, strict=True)
        for i, m in enumerate(js)
    }
    return posture, gap, point


def _pads(
    u: _Urdf,
    distal: list[str],
    names: list[str],
    pregrasp: dict[str, float],
    closed: dict[str, float],
    targets: dict[str, Array],
) -> list[dict[str, Any]]:
    """One pad per distal link, on the face that leads when the finger starts to
    close (towards the other fingers when it does not move), at the fingertip
    end."""
    mid = {m: 0.9 * pregrasp[m] + 0.1 * closed[m] for m in pregrasp}
    poses_mid = u.kin.link_poses(u.base, mid)
    tips_open = u.centroids(distal, pregrasp)  # (F, 3)
    tips_mid = u.centroids(distal, mid)  # (F, 3)
    pads, notes = [], []
    for i, link in enumerate(distal):
        lo, hi = u.boxes[link]
        size, c = hi - lo, 0.5 * (lo + hi)
        d_base = tips_mid[i] - tips_open[i]
        if np.linalg.norm(d_base) < 1e-6:
            d_base = targets[link] - tips_mid[i]
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


def _enclosing_centre(points: Array) -> Array:
    """Centre of the smallest ball holding ``points`` ``(F, 3)``: where a grasp
    between the pads centres, whatever the number of fingers on each side (two
    fingers against one do not pull it their way, as the mean does).

    Exact, by trying the balls through every 1 to 4 of the points: the pads are a
    handful (trimesh's ``minimum_nsphere`` needs 5 or more in general position).
    """
    from itertools import combinations

    best, best_r = points.mean(axis=0), np.inf
    for k in range(1, min(4, len(points)) + 1):
        for idx in combinations(range(len(points)), k):
            p = points[list(idx)]  # (k, 3)
            A = (p[1:] - p[0]).T  # (3, k - 1)
            if k == 1:
                c = p[0]
            else:
                b = 0.5 * np.sum((p[1:] - p[0]) ** 2, axis=1)  # (k - 1,)
                lam = np.linalg.lstsq(A.T @ A, b, rcond=None)[0]
                c = p[0] + A @ lam
            r = float(np.linalg.norm(points - c, axis=1).max())
            if r < best_r - 1e-12:
                best, best_r = c, r
    return best


def _palm_link(u: _Urdf, distal: list[str]) -> str | None:
    """The palm: the last link on every finger's chain from the base that no
    finger joint moves (where the fingers branch), or its nearest ancestor with
    geometry; None when neither it nor any link above it has geometry."""
    chains = [[u.base] + [j.child for j in u.kin.chain(u.base, d)] for d in distal]
    palm = u.base
    for links in zip(*chains, strict=False):
        if len(set(links)) > 1 or links[0] == u.base:
            if len(set(links)) > 1:
                break
            continue
        joint = u.kin.joints[u.kin.parent_joint[links[0]]]
        if joint.kind != 0 and u.kin.master(joint.name) not in u.wrist:
            break
        palm = links[0]
    while palm not in u.boxes:
        if palm == u.base:
            return None
        palm = u.kin.joints[u.kin.parent_joint[palm]].parent
    return palm


def _palm_face(
    u: _Urdf, distal: list[str], pregrasp: dict[str, float], pads: Array
) -> tuple[Array, str, str] | None:
    """The outward normal (base frame) of the face of the palm's geometry box
    through which the box's centre sees the centre of ``pads`` ``(F, 3)``, with
    the face's name and the palm link; None without a palm with geometry, or
    when that centre lies inside the palm's box."""
    palm = _palm_link(u, distal)
    if palm is None:
        return None
    lo, hi = u.boxes[palm]
    T = u.kin.link_poses(u.base, pregrasp)[palm]
    centre = _enclosing_centre(pads)
    p = T[:3, :3].T @ (centre - T[:3, 3]) - 0.5 * (lo + hi)  # (3,) palm frame
    ratio = np.abs(p) / np.maximum(0.5 * (hi - lo), 1e-9)  # (3,) 1 on the box
    k = int(np.argmax(ratio))
    if ratio[k] <= 1.0:
        return None
    sign = float(np.sign(p[k]))
    name = f"{'+' if sign > 0 else '-'}{'xyz'[k]}"
    return sign * T[:3, k], name, palm


def _axes(
    u: _Urdf,
    pads: list[dict[str, Any]],
    pregrasp: dict[str, float],
    closed: dict[str, float],
    rigid: bool = False,
) -> tuple[Array, Array, Array, dict[str, Any] | None]:
    """Approach axis, closing axis, TCP position and, for a hand, a second
    approach fingertips first (:attr:`Scaffold.fingertips_first`).

    The approach axis is the side of the palm that grasps: the outward normal of
    the face of the palm's geometry box (:func:`_palm_link`) through which its
    centre sees the pads half-closed (each joint midway between pregrasp and
    closed; their centre is that of the smallest ball holding them, so that two
    fingers against one do not pull it their way). A jaw's fingers hold an
    object beyond the palm's end, so it approaches along them; a hand's fingers
    curl in front of the palm, so it may approach palm first, whatever the
    forearm or wrist above it. Without a palm with geometry, or with that
    centre inside the palm's box, the axis points from the base origin to the
    pads' centre (open; closed for a jaw against a ``rigid`` one, which may open
    far to one side). The closing axis is the main direction across it in
    which the pads move relative to each other (their closing motions less the
    motion they share, such as curling towards the palm).

    The last value approaches along the fingers' direction
    (:func:`_finger_direction`), with its own closing axis, where that lies more
    than :data:`FINGERTIPS_FIRST_DEG` from the approach axis: a hand can also
    approach fingertips first, and :func:`choose_approach` decides; else None.
    """

    p_open, p_closed = _pad_centres(u, pads, pregrasp), _pad_centres(u, pads, closed)
    mid = {m: 0.5 * (pregrasp[m] + closed[m]) for m in pregrasp}
    half_closed = _pad_centres(u, pads, mid)
    face = _palm_face(u, [p["link"] for p in pads], pregrasp, half_closed)
    if face is not None:
        approach, u.notes["approach_axis"] = _snap(
            face[0],
            f"the side of the palm that grasps: the outward normal of the "
            f"{face[1]} face of palm link {face[2]!r}'s geometry box, the one its "
            "centre sees the pads' centre through (half-closed; the centre of the "
            "smallest ball holding them)",
        )
    else:
        # a jaw closing on a rigid one holds the object where they meet; open,
        # the moving jaw may stand far out to one side
        centre = _enclosing_centre(p_closed if rigid else p_open)
        if np.linalg.norm(centre) < 1e-6:
            raise GripperError(
                f"URDF {u.path.name}: the fingertips' centre coincides with the "
                f"origin of base link {u.base!r}, so no approach direction can be "
                "read from it",
                hint="pass --base-link with the link the arm's flange holds",
            )
        approach, u.notes["approach_axis"] = _snap(
            centre,
            "from the base link's origin towards the pads' centre ("
            + ("closed, where the jaws meet" if rigid else "open")
            + "; the centre of the smallest ball holding them), as no palm link "
            "with geometry faces them",
        )
    closing, u.notes["closing_axis"], moves = _closing_axis(approach, p_open, p_closed)
    if not moves:
        u.warnings.append("the pads do not move across the approach axis when closing")
    u.notes["tool_frame"] = "midway between the pads' centres open and closed"
    tcp = 0.5 * (p_open.mean(axis=0) + p_closed.mean(axis=0))
    tips = _finger_direction(u, [p["link"] for p in pads], pregrasp)
    if (
        tips is None
        or np.degrees(np.arccos(np.clip(tips @ approach, -1.0, 1.0)))
        <= FINGERTIPS_FIRST_DEG
    ):
        return approach, closing, tcp, None
    closing_tips, closing_note, _ = _closing_axis(tips, p_open, p_closed)
    alternative = {
        "approach_axis": _r(tips, 6),
        "closing_axis": _r(closing_tips, 6),
        "notes": {
            "approach_axis": "fingertips first: the way the open fingers point (the "
            "mean of the directions from each finger's first joint to its tip, at "
            "pregrasp)",
            "closing_axis": closing_note,
        },
    }
    return approach, closing, tcp, alternative


def _pad_centres(
    u: _Urdf, pads: list[dict[str, Any]], posture: dict[str, float]
) -> Array:
    """The pads' centres in the base frame at ``posture``: ``(F, 3)``."""
    ps = u.kin.link_poses(u.base, posture)
    out = []
    for p in pads:
        T = ps[p["link"]]
        out.append(T[:3, :3] @ np.asarray(p["center"]) + T[:3, 3])
    return np.array(out)


def _closing_axis(
    approach: Array, p_open: Array, p_closed: Array
) -> tuple[Array, str, bool]:
    """The closing axis across ``approach`` from the pads open and closed
    ``(F, 3)``, its note (see :func:`_axes`), and whether the pads move across
    ``approach`` at all."""

    def across(v: Array) -> Array:
        return v - np.outer(v @ approach, approach)  # (F, 3)

    motion = across(p_closed - p_open)  # (F, 3)
    relative = motion - motion.mean(axis=0)
    what = "principal direction in which the pads move towards each other"
    if float(np.linalg.norm(relative)) < 1e-6:
        relative = motion
        what = "principal direction in which the pads move when closing"
    if float(np.linalg.norm(relative)) < 1e-6:
        relative = across(p_open - p_open.mean(axis=0))
        what = "principal direction of the pads' positions across the approach axis"
    if float(np.linalg.norm(relative)) < 1e-9:
        helper = np.eye(3)[int(np.argmin(np.abs(approach)))]
        closing = np.cross(approach, helper)
        what = "any axis perpendicular to the approach axis (the pads do not move)"
        moves = False
    else:
        closing = np.linalg.eigh(relative.T @ relative)[1][:, -1]
        moves = True
    closing = closing - (closing @ approach) * approach
    closing, note = _snap(closing, what)
    if abs(float(closing @ approach)) > 1e-6:  # the snap broke orthogonality
        closing = closing - (closing @ approach) * approach
        closing /= np.linalg.norm(closing)
    if closing[int(np.argmax(np.abs(closing)))] < 0:
        closing = -closing
    return closing, note, moves


#: a hand of this many fingers or more grasps between its thumb and the fingers
#: that meet it (``contact_fingers``); fewer: every finger holds the object
_TRIPOD_FROM = 4


def _contact_fingers(
    u: _Urdf,
    pads: list[dict[str, Any]],
    names: list[str],
    pregrasp: dict[str, float],
    closed: dict[str, float],
    closing: Array,
) -> list[str] | None:
    """For a hand of ``_TRIPOD_FROM`` fingers or more, the fingers a grasp
    needs (``contact_fingers``): its thumb, the one finger whose pad moves the
    other way along ``closing`` from all the others' as the hand closes, and
    the two fingers whose pads lie nearest the thumb's in the open hand (a
    tripod; the other fingers close with them and may miss a small object).
    None, every finger, for fewer fingers or without one finger alone on its
    side. The note says which and why."""
    if len(names) < _TRIPOD_FROM:
        return None
    p_open = _pad_centres(u, pads, pregrasp)  # (F, 3)
    p_closed = _pad_centres(u, pads, closed)
    along = (p_closed - p_open) @ closing  # (F,) each pad's way along closing
    side = np.sign(np.where(np.abs(along) > 1e-4, along, 0.0))
    lone = [
        f for f in range(len(names)) if side[f] != 0 and (side == side[f]).sum() == 1
    ]
    others = [f for f in range(len(names)) if side[f] == -side[lone[0]]] if lone else []
    if len(lone) != 1 or len(others) < 2:
        u.notes["contact_fingers"] = (
            "left out: every finger must hold the object (no one finger's pad "
            "moves against all the others' along the closing axis, as a thumb's)"
        )
        return None
    thumb = lone[0]
    gap = np.linalg.norm(p_open[others] - p_open[thumb], axis=1)
    pair = [others[i] for i in np.argsort(gap, kind="stable")[:2]]
    chosen = sorted([thumb, *pair])
    u.notes["contact_fingers"] = (
        f"a grasp needs the thumb ({names[thumb]}: its pad alone moves the "
        "other way along the closing axis) and the two fingers whose pads lie "
        f"nearest it at `pregrasp` ({names[pair[0]]}, {names[pair[1]]}: "
        f"{gap.min() * 1000:.0f} and {np.sort(gap)[1] * 1000:.0f} mm); the "
        "others close with them and may miss a small object. Remove the field "
        "to need every finger"
    )
    return [names[f] for f in chosen]


def _finger_direction(
    u: _Urdf, distal: list[str], pregrasp: dict[str, float]
) -> Array | None:
    """The way a hand's open fingers point (base frame, unit): the mean over the
    fingers of the unit vector from the finger's first joint to its distal
    link's geometry-box centre, at ``pregrasp``. None for fewer than
    :data:`FINGERTIPS_FIRST_MIN` fingers (a jaw or a claw approaches along its
    fingers already) or where the fingers point every way (the mean is short)."""
    if len(distal) < FINGERTIPS_FIRST_MIN:
        return None
    poses = u.kin.link_poses(u.base, pregrasp)
    tips = u.centroids(distal, pregrasp)  # (F, 3)
    directions = []
    for link, tip in zip(distal, tips, strict=True):
        first = next(
            (
                j
                for j in u.kin.chain(u.base, link)
                if j.kind != 0 and u.kin.master(j.name) not in u.wrist
            ),
            None,
        )
        if first is None:
            return None
        v = tip - poses[first.child][:3, 3]
        if float(np.linalg.norm(v)) < 1e-9:
            return None
        directions.append(v / np.linalg.norm(v))
    mean = np.mean(directions, axis=0)  # (3,)
    if float(np.linalg.norm(mean)) < 0.5:
        return None
    return _snap(mean, "")[0]


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
    if dof > 1:
        u.notes["pad"] += (
            "; on_table is left out: the search guesses whether each finger's tip "
            "slides along the table or sticks where its closing sweep meets it "
            "(`gripper check` prints the guess); set it on a finger whose tip "
            "`wsgrasp eval` shows doing otherwise"
        )
    return {
        "joint_samples": samples,
        "spheres_per_finger": spheres,
        "workspace_voxel": voxel,
        "min_sphere_radius": voxel,
    }


def pad_stiffness(n_fingers: int) -> float:
    """The pad stiffness (N/m) a gripper of ``n_fingers`` fingers gets its
    drive guessed for: :data:`PAD_STIFFNESS_THREE` for two or three,
    :data:`PAD_STIFFNESS` for more."""
    return PAD_STIFFNESS_THREE if n_fingers <= 3 else PAD_STIFFNESS


def _drive(
    u: _Urdf,
    fingers: dict[str, list[str]],
    pads: list[dict[str, Any]],
    names: list[str],
    pregrasp: dict[str, float],
    closed: dict[str, float],
) -> dict[str, float] | None:
    """The revolute finger joints' position gain (N·m/rad) of a gripper of
    :data:`DRIVE_MIN_FINGERS` or more fingers, from the size of its fingers; None
    for a gripper of fewer fingers or without revolute finger joints.

    A position actuator of gain ``kp`` on each of a finger's joints lets its pad
    give way by ``sum_j k_j |dp/dq_j|^2 / kp`` metres per newton, where
    ``dp/dq_j`` (m/rad, mimics following their master) is how fast joint ``j``
    moves the pad and ``k_j`` how many fingers it moves (two jaws on one joint
    share its actuator: pressed together, each is held with half its gain):
    the same gain makes a long finger soft and a short one stiff. The guess gives
    the median finger's pad :data:`PAD_STIFFNESS` (:data:`PAD_STIFFNESS_THREE`
    for a gripper of two or three fingers), measured half closed (among the fingers that
    have revolute joints: a prismatic finger keeps ``kp_prismatic``).
    """
    if len(fingers) < DRIVE_MIN_FINGERS:
        return None
    stiffness = pad_stiffness(len(fingers))
    mid = {
        j: 0.5 * (pregrasp.get(j, 0.0) + closed.get(j, pregrasp.get(j, 0.0)))
        for j in u.actuated
    }
    h = 1e-4
    # a joint that moves several fingers (two jaws one drive moves) holds each
    # of their pads with its gain divided among them
    shared = Counter(j for js in fingers.values() for j in set(js))
    compliance = []  # (F,) m²/rad², each finger's sum_j k_j |dp/dq_j|^2
    for link, pad in zip(fingers, pads, strict=True):
        total = 0.0
        for j in fingers[link]:
            if u.kin.joints[j].kind != JOINT_REVOLUTE:
                continue
            lo, hi = _pad_points(u, pad, {**mid, j: mid[j] + np.array([-h, h])}, 2)
            d = (hi - lo) / (2 * h)  # (3,) m/rad
            total += shared[j] * float(d @ d)
        compliance.append(total)
    revolute = [c for c in compliance if c > 0.0]  # fingers a revolute joint moves
    if not revolute:
        return None
    kp = float(f"{stiffness * float(np.median(revolute)):.2g}")
    each = ", ".join(
        f"{n} {c * 1e4:.0f}" for n, c in zip(names, compliance, strict=True)
    )
    u.notes["drive"] = (
        "the fingers' position gains in simulation (`wsgrasp eval`; planning does "
        "not read them). A URDF carries no controller gains, so kp_revolute "
        f"(N·m/rad) is guessed from the fingers' size: {kp:g} gives the median "
        f"finger's pad, half closed, a stiffness of {stiffness:g} N/m when each "
        "of its joints gives way under its actuator (the sum over its joints of "
        "the squared speed at which each moves the pad, cm²/rad²: "
        f"{each}); the same gain on every hand would make long fingers soft and "
        "short ones stiff. Where the hand's own controller or grip force is known, "
        "set it to match; to compare gains, evaluate copies of this YAML with "
        "other drives (this drive wins over `wsgrasp eval --sim kp_revolute`)"
    )
    return {"kp_revolute": kp}


def guess_description(
    urdf: str | Path,
    name: str,
    *,
    base_link: str | None = None,
    urdf_field: str | None = None,
    close_past: float = 0.0,
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
    close_past
        Where the fingers are stopped where their pads meet, close on until the
        pads have travelled this much more (m; ``gripper new --close-past``).

    Raises
    ------
    GripperError
        No actuated joint, several disconnected trees (without ``base_link``), an
        implausible size, a continuous joint without limits on a finger, no finger.
    """
    path = Path(urdf)
    u = _read(path, name, base_link)
    if base_link is None:
        u = _hand_on_arm(u, name)
    _check_extent(u)
    fingers = _fingers(u)
    jaw = _rigid_jaw(u, fingers)
    distal = list(fingers)
    names = _finger_names(distal)
    if jaw is None:
        if len(distal) == 1:
            moved = ", ".join(fingers[distal[0]])
            raise GripperError(
                f"URDF {u.path.name}: one finger moves below {u.base!r} (link "
                f"{distal[0]!r}, joints {moved}), and it closes against no still "
                "geometry (a rigid jaw): a grasp needs two fingers that close "
                "against each other, or a finger and a rigid jaw (an arm without "
                "its gripper has neither)",
                hint="scaffold from the URDF of the gripper, or of the arm with its "
                "gripper mounted; or pass --base-link LINK",
            )
        targets = _targets(u, fingers)
    else:
        targets = {distal[0]: jaw.point}
    joints = {link: list(ms) for link, ms in fingers.items()}
    pregrasp, closed = _postures(u, fingers, targets)
    turned = _hold_postures(u, joints, fingers, targets, pregrasp, closed)
    if jaw is None:
        limits = _stop_at_palm(u, fingers, pregrasp, closed)
    else:
        limits = _stop_at_jaw(u, jaw, pregrasp, closed)
    pads = _pads(u, distal, names, pregrasp, closed, targets)
    if jaw is not None:
        pads.append(_rigid_pad(u, jaw, pads[0], pregrasp, closed))
        names.append("rigid_jaw" if "rigid_jaw" not in names else "rigid_jaw2")
        distal.append(jaw.link)
        fingers[jaw.link] = []
        u.notes["fingers"] += (
            f"; {names[-1]}: a rigid jaw, the part of {jaw.link!r} (a link no "
            f"joint moves) that {names[0]} closes against"
        )
    _stop_where_pads_meet(u, fingers, pads, pregrasp, closed, close_past)
    approach, closing, tcp, alternative = _axes(
        u, pads, pregrasp, closed, rigid=jaw is not None
    )
    contact = _contact_fingers(u, pads, names, pregrasp, closed, np.asarray(closing))

    def assemble(
        fingers: dict[str, list[str]], pregrasp: dict[str, float]
    ) -> tuple[dict[str, Any], dict[str, str]]:
        """The YAML's data for these finger joints and pre-grasp posture, and
        the notes as they then read (sizes and the drive follow the joints);
        ``u.notes`` is left as it was."""
        before = dict(u.notes)
        own_pads = copy.deepcopy(pads)
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
                for n, link, pad in zip(names, distal, own_pads, strict=True)
            ],
            **_settings(u, fingers, own_pads),
            "ellipsoids": {"count": 5, "exponent": 10.0},
            "cloud_points": 500,
            # full precision: a rounded limit may fall outside the joint's range
            "pregrasp": {k: float(v) for k, v in pregrasp.items()},
            "closed": {k: float(v) for k, v in closed.items()},
        }
        if contact is not None:
            data["contact_fingers"] = contact
        drive = _drive(u, fingers, own_pads, names, pregrasp, closed)
        if drive is not None:
            data["drive"] = drive
        notes, u.notes = u.notes, before
        return data, notes

    thumb_turning = None
    if any(turned.values()):
        turned_fingers = {link: list(ms) for link, ms in fingers.items()}
        turned_pregrasp = dict(pregrasp)
        _turn_thumbs(turned, joints, turned_fingers, turned_pregrasp)
        alt, alt_notes = assemble(turned_fingers, turned_pregrasp)
        thumb_turning = {
            "data": alt,
            "notes": alt_notes,
            "turned": {
                m: (v, closed[m]) for hold in turned.values() for m, v in hold.items()
            },
        }
    data, notes = assemble(fingers, pregrasp)
    return Scaffold(
        data,
        notes,
        u.kin.warnings
        + [u.kin.misplaced[link] for link in u.below if link in u.kin.misplaced]
        + u.warnings,
        limits=limits,
        fingertips_first=alternative,
        thumb_turning=thumb_turning,
        links_below=list(u.below),
        links_outside=_outside(u.kin, u.below),
    )


def _covered(spaces: list[Any], count: int, desc: Any) -> float:
    """The least fraction of a moving finger's workspace that ``count`` spheres
    cover (0 where none fits)."""
    from wsgrasp.gripper._workspace import fill_spheres

    least = 1.0
    for ws, finger in zip(spaces, desc.fingers, strict=True):
        if not finger.joints:
            continue
        try:
            fill = fill_spheres(ws, count, desc.min_sphere_radius, desc.name)
        except GripperError:
            return 0.0
        least = min(least, fill.covered_fraction)
    return least


def _dense_pad_samples(data: dict[str, Any], kin: Any, desc: Any) -> bool:
    """Give each moving finger's pad in ``data`` a count of points per edge that
    puts them about a voxel apart along that edge (within
    :data:`DENSE_PAD_BUDGET` points over the finger's joint grid, and never
    fewer than it had); whether any pad got more. One count for every edge
    spaces a wide pad's points far wider than a voxel along its long edges, and
    their sweep then stays a lattice of separate points that no sphere fits
    in."""
    from wsgrasp.gripper._workspace import finger_joints
    from wsgrasp.spec import MAX_EDGE_SAMPLES

    voxel = float(data["workspace_voxel"])
    changed = False
    for f, finger in zip(data["fingers"], desc.fingers, strict=True):
        if not finger.joints:
            continue  # a rigid jaw's box is filled a voxel apart already
        sizes = np.asarray(f["pad"]["size"], dtype=np.float64)
        per = np.where(sizes > 0, np.ceil(sizes / voxel - 1e-9) + 1, 1)
        per = np.clip(per, 1, MAX_EDGE_SAMPLES)
        configs = float(desc.joint_samples) ** len(finger_joints(kin, desc, finger))
        over = configs * float(np.prod(per)) / DENSE_PAD_BUDGET
        if over > 1.0:  # thin every edge alike to the budget
            per = np.maximum(np.where(per > 1, 2, 1), np.floor(per / over ** (1 / 3)))
        old = np.broadcast_to(np.asarray(f["pad"].get("samples", 3)), (3,))
        if np.any(per > old):  # never fewer points along an edge than before
            f["pad"]["samples"] = [int(k) for k in np.maximum(per, old)]
            changed = True
    return changed


def clear_rigid_pads(scaffold: Scaffold, yaml_path: Path) -> bool:
    """Move each rigid jaw's pad box off the body superellipsoids of the model
    built from ``yaml_path``: the box starts at the jaw's surface, but the
    superellipsoid fitted round the jaw's link stands a few millimetres proud of
    it, and object points inside a superellipsoid reject the grasp, so that part
    of the box can hold nothing. The box slides out along its face's normal (in
    steps of :data:`RIGID_PAD_STEP`, at most :data:`RIGID_PAD_DEPTH`) until the
    superellipsoids hold at most ``INTRUSION_WARN`` of its points. Whether any
    pad moved; the move is noted under ``pad``."""
    from wsgrasp.geometry import box_grid_points, points_in_superellipsoids
    from wsgrasp.gripper import load_gripper
    from wsgrasp.gripper.check import INTRUSION_WARN
    from wsgrasp.spec import GripperDescription

    data = scaffold.data
    rigid = [f for f in data["fingers"] if not f["joints"]]
    if not rigid:
        return False
    model = load_gripper(str(yaml_path))
    desc = GripperDescription.model_validate(data)
    kin = load_kinematics(Path(yaml_path).parent / desc.urdf, desc.name)
    posture = dict(desc.pregrasp)
    # where the moving pads stand open: the side the rigid pad faces
    moving = [
        kin.chain_poses(desc.base_link, f.pad.link, posture)
        @ np.append(f.pad.center, 1)
        for f in desc.fingers
        if f.joints
    ]
    towards = np.mean([m[:3] for m in moving], axis=0)  # (3,) base frame
    moved = False
    for f in rigid:
        pad = f["pad"]
        T = np.asarray(kin.chain_poses(desc.base_link, pad["link"], posture))
        centre = np.asarray(pad["center"], dtype=np.float64)
        n_link = T[:3, :3].T @ (towards - (T[:3, :3] @ centre + T[:3, 3]))
        k = int(np.argmax(np.abs(n_link)))
        sign = float(np.sign(n_link[k]) or 1.0)
        box = box_grid_points(centre, pad["size"], 5)  # (m, 3) link frame
        shift = 0.0
        while True:
            pts = box.copy()
            pts[:, k] += sign * shift
            base = pts @ T[:3, :3].T + T[:3, 3]
            inside = points_in_superellipsoids(
                base, model.se_centers, model.se_semi_axes, model.se_exponent
            )
            if float(np.mean(inside)) <= INTRUSION_WARN:
                break
            if shift + RIGID_PAD_STEP > RIGID_PAD_DEPTH + 1e-12:
                shift = 0.0  # the body swallows it whatever: the check says so
                break
            shift += RIGID_PAD_STEP
        if shift > 0.0:
            centre[k] += sign * shift
            pad["center"] = _r(centre)
            scaffold.notes["pad"] += (
                f"; the rigid pad moved {shift * 1000:.1f} mm out along "
                f"{'+' if sign > 0 else '-'}{'xyz'[k]}, off the body "
                f"superellipsoid fitted round {pad['link']}, which stands proud "
                "of the jaw's surface (object points inside it reject the grasp)"
            )
            moved = True
    return moved


def fit_sphere_count(scaffold: Scaffold, base_dir: Path) -> None:
    """Size ``spheres_per_finger`` (and the pad samples and the voxel) to the
    sampled workspaces: where a workspace is too thin for spheres, or the most
    spheres it may get cover under ``MIN_COVERAGE`` of it, first sample the pads
    a voxel apart along each edge (:func:`_dense_pad_samples`), then halve the
    voxel while it stays too thin; lower the count to what fits, raise it (up to
    :data:`MAX_SPHERES`) until the spheres cover :data:`TARGET_COVERAGE` of every
    workspace; note what was changed."""
    from wsgrasp.gripper._workspace import fill_spheres, sample_workspace
    from wsgrasp.gripper.check import MIN_COVERAGE
    from wsgrasp.spec import GripperDescription

    data = scaffold.data
    note = scaffold.notes
    dense = False
    for _ in range(4):
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
        most = max(1, min(MAX_SPHERES, fewest // 3))  # the most spheres it may get
        if fewest >= 3 and (dense or _covered(spaces, most, desc) >= MIN_COVERAGE):
            break
        if not dense:  # first the pads a voxel apart along every edge
            dense = _dense_pad_samples(data, kin, desc)
            if dense:
                note["pad"] += (
                    "; a pad's points a voxel apart along each edge where one count "
                    "for every edge left its sweep too sparse to close into a "
                    "volume (pad.samples per edge x, y, z)"
                )
                continue
            if fewest >= 3:
                break
        data["workspace_voxel"] = max(0.0005, data["workspace_voxel"] / 2)
        data["min_sphere_radius"] = data["workspace_voxel"]
        note["workspace_voxel"] += (
            f"; halved to {data['workspace_voxel'] * 1000:.2f} mm (a workspace was "
            "too thin for spheres)"
        )
        if dense:
            _dense_pad_samples(data, kin, GripperDescription.model_validate(data))
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
