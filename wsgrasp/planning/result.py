"""Plan results: the chosen grasp, every candidate and why it was rejected."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp.planning._fields import BuiltOnRead
from wsgrasp.planning.poses import PoseArray, PoseRows

__all__ = [
    "REASONS",
    "CandidateSet",
    "Contact",
    "Alternative",
    "PlanResult",
    "translation_quaternion",
]

#: Rejection reasons, by code (0 feasible): a candidate gets the first that applies,
#: in Algorithm 1's order, then ``finger_sweeps_table`` (fingers that would pass
#: through the table before the object however far, up to 3 cm, it backs off).
REASONS: tuple[str, ...] = (
    "feasible",
    "table_collision",
    "object_collision",
    "obstacle_collision",
    "finger_without_contact",
    "finger_sweeps_table",
)


class PoseField(BuiltOnRead):
    """A dataclass field of ``(C, 4, 4)`` poses kept as a
    :class:`~wsgrasp.planning.poses.PoseArray` (or, for some of a set's
    candidates, :class:`~wsgrasp.planning.poses.PoseRows`): set as an array or
    either of those, read as the whole array (built on first read, then kept).
    """

    def read(self, stored: PoseArray | PoseRows) -> NDArray[np.float64]:
        return stored.whole()

    def keep(
        self, value: NDArray[np.float64] | PoseArray | PoseRows
    ) -> PoseArray | PoseRows:
        return value if isinstance(value, PoseArray | PoseRows) else PoseArray(value)


@dataclass
class CandidateSet:
    """Every candidate evaluated, as arrays over candidates ``C``.

    The poses of a searched set are built whole only when read whole
    (``T_world_gwc``, ``T_world_ee``); :meth:`ee_at` and :meth:`gwc_at` give
    some of them without building the rest.

    Attributes
    ----------
    T_world_gwc, T_world_ee : (C, 4, 4) float
    sample : (C,) int
        Index of the bounding-box sample point.
    theta : (C,) float
        The orientation's angle within its sampling mode (rad): about the
        object's major axis, or the roll about the approach direction.
    reason : (C,) int
        Code into :data:`REASONS`.
    contacts : (C, nf) int
        Object points inside each finger's spheres (0 where not evaluated).
    score : (C,) float
        Combined score; NaN for rejected candidates.
    terms : dict of str to (C,) float
        Each scorer's term; NaN for rejected candidates.
    flipped : (C,) bool
        Turned half a turn about the approach axis (``sampling.flip``).
    orientation : (C,) int
        Index of the candidate's orientation in the sampled set (candidates are
        samples outer, orientations inner).
    """

    if TYPE_CHECKING:  # read as arrays; set as arrays or PoseArrays
        T_world_gwc: NDArray[np.float64]
        T_world_ee: NDArray[np.float64]
    else:
        T_world_gwc: NDArray[np.float64] = PoseField()
        T_world_ee: NDArray[np.float64] = PoseField()
    sample: NDArray[np.int64]
    theta: NDArray[np.float64]
    reason: NDArray[np.int64]
    contacts: NDArray[np.int64]
    score: NDArray[np.float64]
    terms: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    flipped: NDArray[np.bool_] | None = None
    orientation: NDArray[np.int64] | None = None

    def __post_init__(self) -> None:
        if self.flipped is None:
            self.flipped = np.zeros(len(self.reason), dtype=bool)
        if self.orientation is None:  # a recording from before orientation sets
            self.orientation = np.zeros(len(self.reason), dtype=np.int64)

    def __len__(self) -> int:
        return int(self.reason.shape[0])

    def ee_at(self, index: Any) -> NDArray[np.float64]:
        """``T_world_ee[index]`` (an integer, integers or a mask), without
        building every pose."""
        return self._kept("T_world_ee").at(index)

    def gwc_at(self, index: Any) -> NDArray[np.float64]:
        """``T_world_gwc[index]``, without building every pose."""
        return self._kept("T_world_gwc").at(index)

    def set_pose(
        self,
        index: int,
        T_world_ee: NDArray[np.float64],
        T_world_gwc: NDArray[np.float64],
    ) -> None:
        """Set candidate ``index``'s two poses (a choice as the plan takes it)."""
        self._kept("T_world_ee").set(index, T_world_ee)
        self._kept("T_world_gwc").set(index, T_world_gwc)

    def poses(self) -> tuple[PoseArray, PoseArray]:
        """The pose fields as they are kept: ``(T_world_ee, T_world_gwc)``."""
        return self._kept("T_world_ee"), self._kept("T_world_gwc")

    def _kept(self, name: str) -> PoseArray:
        """The ``PoseArray`` the pose field ``name`` keeps."""
        return type(self).__dict__[name].stored(self)  # type: ignore[no-any-return]

    def replaced(self, **changes: Any) -> CandidateSet:
        """``dataclasses.replace`` that passes the poses on as they are kept
        (the same ``PoseArray``, unless ``changes`` gives others), not built
        whole."""
        ee, gwc = self.poses()
        return replace(self, **{"T_world_ee": ee, "T_world_gwc": gwc, **changes})

    @property
    def feasible(self) -> NDArray[np.bool_]:
        return self.reason == 0

    def histogram(self) -> dict[str, int]:
        """Reason name → count, every reason listed (feasible included)."""
        counts = np.bincount(self.reason, minlength=len(REASONS))
        return {name: int(c) for name, c in zip(REASONS, counts, strict=True)}


@dataclass
class Contact:
    """What one finger holds at the chosen pose.

    Attributes
    ----------
    finger : str
    points : (k, 3) float
        Object points inside the finger's spheres, world frame.
    spheres : (m,) int
        Indices (into the model's spheres) of the spheres holding object points.
    """

    finger: str
    points: NDArray[np.float64]
    spheres: NDArray[np.int64]


@dataclass
class Alternative:
    """A runner-up grasp."""

    index: int
    T_world_ee: NDArray[np.float64]
    score: float
    terms: dict[str, float]


@dataclass
class PlanResult:
    """The outcome of one plan.

    ``found`` is False when no candidate was feasible: that is a normal result with
    the rejection histogram and a ``hint`` saying what stood in the way.
    """

    found: bool
    gripper: str
    T_world_ee: NDArray[np.float64] | None
    T_world_gwc: NDArray[np.float64] | None
    T_world_tcp: NDArray[np.float64] | None
    pregrasp: dict[str, float]
    closed: dict[str, float]
    contacts: list[Contact]
    score: float | None
    score_terms: dict[str, float]
    best_index: int | None
    alternatives: list[Alternative]
    candidates: CandidateSet
    rejections: dict[str, int]
    timing_ms: dict[str, float]
    hint: str = ""
    T_world_object: NDArray[np.float64] | None = None
    object_extents: NDArray[np.float64] | None = None
    info: dict[str, Any] = field(default_factory=dict)
    #: the grasp pose backed off along the approach axis by ``approach.distance``
    T_world_pregrasp: NDArray[np.float64] | None = None
    #: every actuated joint in the posture the gripper approaches in
    joints_pregrasp: dict[str, float] = field(default_factory=dict)
    #: every actuated joint in the posture it closes to: each finger's pad at its
    #: contacts and driven ``approach.squeeze`` through them, within the limits
    joints_grasp: dict[str, float] = field(default_factory=dict)
    #: per finger: contact posture, pad position, gap to the contacts, squeeze
    finger_targets: list[dict[str, Any]] = field(default_factory=list)
    #: what in the input looks wrong without stopping the plan (a table tilted
    #: far from the world's z axis in a scene whose views have poses)
    warnings: list[str] = field(default_factory=list)

    def to_json(self) -> dict[str, Any]:
        """Plain data: what ``wsgrasp plan --json`` prints."""

        def m(T: NDArray[np.float64] | None) -> list[Any] | None:
            return None if T is None else np.asarray(T).tolist()

        return {
            "found": self.found,
            "gripper": self.gripper,
            "T_world_ee": m(self.T_world_ee),
            "T_world_gwc": m(self.T_world_gwc),
            "T_world_tcp": m(self.T_world_tcp),
            "T_world_pregrasp": m(self.T_world_pregrasp),
            "joints_pregrasp": self.joints_pregrasp,
            "joints_grasp": self.joints_grasp,
            "finger_targets": self.finger_targets,
            "pregrasp": self.pregrasp,
            "closed": self.closed,
            "score": self.score,
            "score_terms": self.score_terms,
            "candidates": len(self.candidates),
            "feasible": int(self.candidates.feasible.sum()),
            "rejections": self.rejections,
            "contacts": {
                c.finger: {"points": int(len(c.points)), "spheres": c.spheres.tolist()}
                for c in self.contacts
            },
            "alternatives": [
                {"index": a.index, "T_world_ee": m(a.T_world_ee), "score": a.score}
                for a in self.alternatives
            ],
            "timing_ms": self.timing_ms,
            "hint": self.hint,
            "warnings": self.warnings,
            # where the spec's sampling found no grasp: sampling.fallback's are
            # the candidates, and the first search's rejections are here
            **({"fallback": self.info["fallback"]} if "fallback" in self.info else {}),
            "T_world_object": m(self.T_world_object),
            "object_extents": m(self.object_extents),
            # the same poses as a robot's messages take them (geometry_msgs/Pose)
            "poses": {
                name: translation_quaternion(T)
                for name, T in (
                    ("ee", self.T_world_ee),
                    ("tcp", self.T_world_tcp),
                    ("pregrasp", self.T_world_pregrasp),
                )
                if T is not None
            },
        }


def translation_quaternion(T: NDArray[np.float64]) -> dict[str, list[float]]:
    """A 4x4 pose as ``{translation: [x, y, z], quaternion_xyzw: [x, y, z, w]}``,
    the scalar last as ROS orders it (the form a scene YAML takes)."""
    from scipy.spatial.transform import Rotation

    T = np.asarray(T, dtype=np.float64)
    return {
        "translation": T[:3, 3].tolist(),
        "quaternion_xyzw": Rotation.from_matrix(T[:3, :3]).as_quat().tolist(),
    }
