"""Two jaws that one drive moves, driven apart in their URDF.

A parallel gripper's jaws are nearly always geared together (a centric
gripper: one motor, a rack and pinion, a screw with two threads), yet a URDF
may give each jaw its own joint with no ``<mimic>`` (Schunk's EGK 40 in
airo-models). Planned and simulated as written, each jaw closes on its own:
the planner picks grasps whose jaws stop at different openings, which the real
gripper cannot make, and in simulation the two position-controlled jaws, both
at their force limit against the object, float together under a side push
(the EGK 40 under the strict protocol, ``random:000-019``: 14 of 20 grasps
crept 5-18 mm in the grip, 1 once coupled).

:func:`independent_jaws` finds such a pair in a guessed description: exactly
two fingers, each moved by one joint of its own, of one kind, whose ranges map
onto each other by ``q2 = ±q1 + offset``, such that the pads' paths mirror
each other: at every matched pair of values, the pads lie at one height along
the approach axis and their midpoint along the closing axis stays put.
``gripper new`` then couples them with a ``<mimic>`` in its copy of the URDF
(``--independent-jaws`` leaves them apart).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from wsgrasp.geometry import JOINT_PRISMATIC, JOINT_REVOLUTE
from wsgrasp.gripper._urdf import Kinematics

__all__ = ["JawCoupling", "independent_jaws"]

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

    def note(self) -> str:
        return (
            f"{self.follower} follows {self.leader} (a <mimic>, multiplier "
            f"{self.multiplier:g}, offset {self.offset:g}) in the copied URDF: the "
            "two jaws' paths mirror each other, as in a gripper whose jaws one "
            "drive moves, and the URDF drives them apart (planned apart, the jaws "
            "stop at different openings; simulated apart, both at their force "
            "limit, they float together under a side push). If yours are driven "
            "independently, run `wsgrasp gripper new` again with --independent-jaws"
        )


def independent_jaws(kin: Kinematics, data: dict[str, Any]) -> JawCoupling | None:
    """The coupling of the two jaws of the guessed description ``data`` (the
    gripper YAML as plain data, read from the URDF ``kin``), where they are
    driven apart and mirror each other (module docstring); else None."""
    fingers = data["fingers"]
    if len(fingers) != 2 or any(len(f["joints"]) != 1 for f in fingers):
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
    found = []
    for mult in (1.0, -1.0):
        offset = b.lower - a.lower if mult > 0 else b.upper + a.lower
        pads = [
            _pad_path(kin, base, f["pad"], n, values)
            for f, n, values in zip(fingers, names, (q, mult * q + offset), strict=True)
        ]
        if _mirrored(pads, approach, closing):
            at_pre = names[0] in pre and names[1] in pre
            agrees = at_pre and np.isclose(
                mult * pre[names[0]] + offset, pre[names[1]], atol=1e-6
            )
            found.append((not agrees, JawCoupling(names[0], names[1], mult, offset)))
    return min(found, key=lambda t: t[0])[1] if found else None


def _pad_path(
    kin: Kinematics, base: str, pad: dict[str, Any], joint: str, values: Any
) -> Any:
    """The pad centre in the base frame at each value of ``joint``: (n, 3)."""
    T = kin.chain_poses(base, pad["link"], {joint: values})  # (n, 4, 4)
    centre = np.asarray(pad["center"], dtype=np.float64)
    return np.einsum("nij,j->ni", T[:, :3, :3], centre) + T[:, :3, 3]


def _mirrored(pads: list[Any], approach: Any, closing: Any) -> bool:
    """Whether two pad paths (n, 3) each mirror the other across a plane
    across the closing axis: one height along ``approach`` and a midpoint
    along ``closing`` that stays put, while they close by ``_MIN_TRAVEL``."""
    p, r = pads
    gap = (p - r) @ closing  # (n,)
    travel = float(np.ptp(gap))
    if travel < _MIN_TRAVEL:
        return False
    tol = _TOLERANCE + _TOLERANCE_SHARE * travel
    height = np.abs((p - r) @ approach)
    middle = 0.5 * (p + r) @ closing
    return bool(height.max() <= tol and np.ptp(middle) <= tol)
