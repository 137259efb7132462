"""Two jaws that one drive moves, driven apart in their URDF.

A parallel gripper's jaws are nearly always geared together (a centric
gripper: one motor, a rack and pinion, a screw with two threads), yet a URDF
may give each jaw its own joint with no ``<mimic>`` (Schunk's EGK 40 in
airo-models). Planned and simulated as written, each jaw closes on its own:
the planner picks grasps whose jaws stop at different openings, which the real
gripper cannot make, and in simulation the two position-controlled jaws, both
at their force limit against the object, float together under a side push
(the EGK 40 under the strict protocol, ``random:000-099``: 59 of 100 grasps
crept past 5 mm in the grip, 9 once coupled).

:func:`independent_jaws` finds such a pair in a guessed description: exactly
two fingers, each moved by one joint of its own, of one kind, whose ranges map
onto each other by ``q2 = ±q1 + offset``, such that the second jaw moves as
the mirror image of the first: over the range, the first pad's centre,
mirrored across the plane midway between the two joints (or turned half a
turn about the approach axis there), stays on one point of the second jaw.
The test reads the joints alone, not where the guess put the second pad (two
mirrored fingertips whose meshes differ get pads a centimetre apart: the
PR2 gripper in pybullet_data). ``gripper new`` then couples them with a
``<mimic>`` in its copy of the URDF (``--independent-jaws`` leaves them
apart).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from wsgrasp.geometry import JOINT_PRISMATIC, JOINT_REVOLUTE
from wsgrasp.gripper._urdf import Kinematics

__all__ = ["JawCoupling", "independent_jaws", "summed_effort"]

#: matched values sampled over the leading jaw's range
_SAMPLES = 9
#: the pads mirror each other within this (m) plus this share of their travel
_TOLERANCE = 1e-3
_TOLERANCE_SHARE = 0.02
#: the jaws must close by at least this (m) over their range
_MIN_TRAVEL = 5e-3


@dataclass(frozen=True)
class JawCoupling:
    """``follower = multiplier * leader + offset``: the ``<mimic>`` that moves
    two jaws together."""

    leader: str
    follower: str
    multiplier: float
    offset: float

    def note(self, effort: float | None = None) -> str:
        """What ``gripper new`` did, for the YAML's header (``effort``: the
        leader's, summed)."""
        summed = (
            f", and {self.leader}'s effort is the two jaws' summed, {effort:g}, so "
            "that each presses as hard as on a joint of its own"
            if effort is not None
            else ""
        )
        return (
            f"{self.follower} follows {self.leader} (a <mimic>, multiplier "
            f"{self.multiplier:g}, offset {self.offset:g}) in the copied URDF"
            f"{summed}: the two jaws' paths mirror each other, as in a gripper "
            "whose jaws one drive moves, and the URDF drives them apart (planned "
            "apart, the jaws "
            "stop at different openings; simulated apart, both at their force "
            "limit, they float together under a side push). If yours are driven "
            "independently, run `wsgrasp gripper new` again with --independent-jaws"
        )


def independent_jaws(kin: Kinematics, data: dict[str, Any]) -> JawCoupling | None:
    """The coupling of the two jaws of the guessed description ``data`` (the
    gripper YAML as plain data, read from the URDF ``kin``), where they are
    driven apart and mirror each other (module docstring); else None, also
    where ``data`` lacks what the test reads (a simulator's description
    without fingers or axes)."""
    fingers = data.get("fingers") or []
    if len(fingers) != 2 or any(len(f.get("joints") or []) != 1 for f in fingers):
        return None
    if any(k not in data for k in ("base_link", "approach_axis", "closing_axis")):
        return None
    if any("link" not in (f.get("pad") or {}) for f in fingers):
        return None
    names = [f["joints"][0] for f in fingers]
    if names[0] == names[1] or any(n not in kin.joints for n in names):
        return None
    a, b = (kin.joints[n] for n in names)
    if a.mimic is not None or b.mimic is not None or a.kind != b.kind:
        return None
    if a.kind not in (JOINT_PRISMATIC, JOINT_REVOLUTE) or a.continuous or b.continuous:
        return None
    span = a.upper - a.lower
    if span <= 0 or not np.isclose(span, b.upper - b.lower, rtol=1e-3, atol=1e-6):
        return None
    base = data["base_link"]
    approach = np.asarray(data["approach_axis"], dtype=np.float64)
    closing = np.asarray(data["closing_axis"], dtype=np.float64)
    q = np.linspace(a.lower, a.upper, _SAMPLES)
    pre = data.get("pregrasp", {})
    # the plane across the closing axis midway between the two joints
    middle = 0.5 * (_joint_origin(kin, base, a.name) + _joint_origin(kin, base, b.name))
    lead = fingers[0]["pad"]
    centre = lead.get("center", (0.0, 0.0, 0.0))
    path = _pad_path(kin, base, lead["link"], centre, a.name, q)
    images = _images(path, middle, approach, closing)
    found = []
    for mult in (1.0, -1.0):
        offset = b.lower - a.lower if mult > 0 else b.upper + a.lower
        follow = kin.chain_poses(
            base, fingers[1]["pad"]["link"], {b.name: mult * q + offset}
        )  # (n, 4, 4)
        for image in images:
            # the point of the second jaw that lies at the image at the first
            # sample, followed over the range
            local = np.linalg.solve(follow[0], np.append(image[0], 1.0))[:3]
            moved = np.einsum("nij,j->ni", follow[:, :3, :3], local) + follow[:, :3, 3]
            if _mirrored(path, moved, image, closing):
                at_pre = a.name in pre and b.name in pre
                agrees = at_pre and np.isclose(
                    mult * pre[a.name] + offset, pre[b.name], atol=1e-6
                )
                found.append((not agrees, JawCoupling(a.name, b.name, mult, offset)))
                break
    return min(found, key=lambda t: t[0])[1] if found else None


def summed_effort(kin: Kinematics, coupling: JawCoupling) -> float | None:
    """The ``<limit effort>`` of the joint that moves both jaws of
    ``coupling``, so that each presses as hard as on a joint of its own: the
    two jaws' efforts summed through the multiplier (``kin``: the URDF before
    the coupling); None where the URDF gives either none. The gain needs no
    such care: the drive guessed for revolute jaws counts the jaws a joint
    moves (``wsgrasp.gripper._guess``)."""
    leader, follower = kin.joints[coupling.leader], kin.joints[coupling.follower]
    if leader.effort <= 0.0 or follower.effort <= 0.0:
        return None
    return leader.effort + abs(coupling.multiplier) * follower.effort


def _joint_origin(kin: Kinematics, base: str, joint: str) -> Any:
    """The origin of ``joint``'s frame in the base frame (3,): where it sits
    does not depend on its own value."""
    j = kin.joints[joint]
    T = kin.chain_poses(base, j.parent, {}) @ j.origin
    return T[:3, 3]


def _images(path: Any, middle: Any, approach: Any, closing: Any) -> list[Any]:
    """``path`` (n, 3) mirrored across the plane through ``middle`` normal to
    ``closing``, and turned half a turn about the line through ``middle``
    along ``approach`` (the two ways a second jaw mirrors a first)."""
    d = path - middle
    mirrored = path - 2.0 * np.outer(d @ closing, closing)
    along = np.outer(d @ approach, approach)
    turned = middle + 2.0 * along - d
    return [mirrored, turned]


def _pad_path(
    kin: Kinematics, base: str, link: str, centre: Any, joint: str, values: Any
) -> Any:
    """The point ``centre`` of ``link`` in the base frame at each value of
    ``joint``: (n, 3)."""
    T = kin.chain_poses(base, link, {joint: values})  # (n, 4, 4)
    c = np.asarray(centre, dtype=np.float64)
    return np.einsum("nij,j->ni", T[:, :3, :3], c) + T[:, :3, 3]


def _mirrored(path: Any, moved: Any, image: Any, closing: Any) -> bool:
    """Whether the second jaw's point ``moved`` (n, 3) follows ``image``, the
    first jaw's ``path`` mirrored, while the two close by ``_MIN_TRAVEL``."""
    travel = float(np.ptp((path - moved) @ closing))
    if travel < _MIN_TRAVEL:
        return False
    tol = _TOLERANCE + _TOLERANCE_SHARE * travel
    return bool(np.linalg.norm(moved - image, axis=1).max() <= tol)
