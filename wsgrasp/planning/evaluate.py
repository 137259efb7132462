"""The search's verdicts as a pipeline (Algorithm 1, lines 8-24): table → body →
fingers → holdings, each stage a module with one function taking the candidate
structure (samples × orientations) and the candidates the stage before left
(the docs' search pipeline page describes each).

Each candidate gets the first rejection reason that applies, in Algorithm 1's
order (``result.REASONS``). Which kernel runs behind the body and finger stages is
decided once per evaluation (``kernels``); the verdicts are the loop-by-loop
reference's (``reference``) whichever runs.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp.gripper.model import GripperModel
from wsgrasp.planning._grids import FingerSpheres
from wsgrasp.planning.body import body_verdicts
from wsgrasp.planning.fingers import finger_verdicts
from wsgrasp.planning.holdings import HoldingField, Holdings, feasible_holdings
from wsgrasp.planning.kernels import choose_kernels
from wsgrasp.planning.poses import (
    CandidateStructure,
    PoseArray,
    StructuredPoses,
    TableSE,
)
from wsgrasp.planning.table import table_verdicts

__all__ = [
    "CandidateStructure",
    "FingerSpheres",
    "Evaluation",
    "evaluate_candidates",
    "TableSE",
]

Array = NDArray[np.float64]


@dataclass
class Evaluation:
    """What evaluation found, per candidate ``C`` and for the feasible ones ``F``.

    Attributes
    ----------
    reason : (C,) int
        Code into ``REASONS`` (0 feasible).
    contacts : (C, nf) int
        Object points held per finger (candidates the finger test reached,
        else 0).
    feasible : (F,) int
        Indices of the feasible candidates.
    holding : (F, no, nf) bool
        Which object points each finger's spheres hold, per feasible candidate,
        built when read (see :attr:`holdings`).
    min_table_height : (F,) float
        Lowest gripper-cloud point above the table surface, per feasible candidate.
    """

    reason: NDArray[np.int64]
    contacts: NDArray[np.int64]
    feasible: NDArray[np.int64]
    if TYPE_CHECKING:  # read as the array; set as the array or Holdings
        holding: NDArray[np.bool_]
    else:
        holding: NDArray[np.bool_] = HoldingField()
    min_table_height: Array

    @property
    def holdings(self) -> Holdings:
        """``holding`` as :class:`~wsgrasp.planning.holdings.Holdings` (counts,
        blocks of rows, sums over the held points), without building the mask."""
        return type(self).__dict__["holding"].holdings_of(self)  # type: ignore[no-any-return]


def evaluate_candidates(
    T_world_gripper: Array | PoseArray,
    gripper: GripperModel,
    object_points: Array,
    obstacle_points: Array,
    table: TableSE,
    spheres: FingerSpheres | None = None,
    *,
    structure: CandidateStructure | None = None,
) -> Evaluation:
    """Evaluate every candidate pose.

    Parameters
    ----------
    T_world_gripper : (C, 4, 4) float, or a PoseArray of them
    gripper : GripperModel
    object_points : (no, 3) float
        World frame.
    obstacle_points : (k, 3) float
        Points of other objects, world frame (may be empty).
    table : TableSE
    spheres : FingerSpheres, optional
        Prebuilt sphere index of ``gripper`` (built here when omitted).
    structure : CandidateStructure, optional
        How ``T_world_gripper`` was built (``candidate_poses``: samples outer,
        orientations inner): a search's candidate set. Without it the poses are
        taken one by one (one sample, an orientation each), and the evaluation
        does not count as a search in the kernel choice (``kernels``).
    """
    spheres = spheres or FingerSpheres(gripper)
    if structure is not None:
        poses = StructuredPoses.checked(
            structure, gripper.T_gripper_gwc, T_world_gripper
        )
    elif isinstance(T_world_gripper, PoseArray):
        poses = StructuredPoses.of_transforms(T_world_gripper.whole())
    else:
        poses = StructuredPoses.of_transforms(T_world_gripper)
    C, nf, no = poses.num_candidates, gripper.num_fingers, len(object_points)
    reason = np.zeros(C, dtype=np.int64)
    contacts = np.zeros((C, nf), dtype=np.int64)
    # 1. table
    table_v = table_verdicts(poses, gripper, table)
    reason[table_v.hit] = 1
    alive = np.flatnonzero(~table_v.hit)
    # 2. body: the object, then obstacles
    kernels = choose_kernels(len(alive) * no, search=structure is not None)
    reason[alive] = body_verdicts(
        poses, alive, gripper, object_points, obstacle_points, kernels
    )
    # 3. fingers, for the candidates clear of every body
    live = alive[reason[alive] == 0]
    fingers = finger_verdicts(poses, live, gripper, spheres, object_points, kernels)
    contacts[live] = fingers.counts
    holds = gripper.feasible_contacts(fingers.counts)  # (k,) the contact fingers
    ok = np.flatnonzero(holds)  # positions in live
    reason[live] = np.where(holds, 0, 4)
    feasible = live[ok]
    # 4. holdings, of the feasible candidates (as Holdings: built when read)
    holdings: Any = feasible_holdings(fingers, ok)
    return Evaluation(
        reason, contacts, feasible, holdings, table_v.lowest_heights(feasible)
    )
