"""The search: candidates → evaluation → scores → the chosen grasp.

It works on arrays in the world frame; ``wsgrasp.api`` turns a scene into them and
a ``PlanResult`` out of what this returns, after backing off the feasible
candidates whose fingers' closing sweeps would pass through the table
(``wsgrasp.planning.sweeps``): every pose here stays as generated.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp.geometry import invert_transforms, spheres_hit_by_points, transform_points
from wsgrasp.gripper.model import GripperModel
from wsgrasp.planning.candidates import Orientations
from wsgrasp.planning.evaluate import (
    CandidateStructure,
    FingerSpheres,
    TableSE,
    evaluate_candidates,
)
from wsgrasp.planning.poses import PoseArray, PoseRows, StructuredPoses
from wsgrasp.planning.result import REASONS, Alternative, CandidateSet, Contact
from wsgrasp.planning.scoring import CandidateBatch, combine_scores

__all__ = ["SearchInput", "SearchOutput", "run_search", "no_grasp_hint"]

Array = NDArray[np.float64]


@dataclass
class SearchInput:
    """Everything the search needs, world frame.

    Attributes
    ----------
    gripper : GripperModel
    T_world_object : (4, 4) float
    extents : (3,) float
    samples_object : (ns, 3) float
    orientations : Orientations
        ``O`` orientations of the GWC frame in the object frame.
    object_points : (no, 3) float
    obstacle_points : (k, 3) float
    table : TableSE
    viewpoints : (k, 3) float
        The centres of the cameras whose poses were given (none: ``(0, 3)``).
    """

    gripper: GripperModel
    T_world_object: Array
    extents: Array
    samples_object: Array
    orientations: Orientations
    object_points: Array
    obstacle_points: Array
    table: TableSE
    viewpoints: Array = field(default_factory=lambda: np.zeros((0, 3)))

    @property
    def num_candidates(self) -> int:
        return len(self.samples_object) * len(self.orientations)


@dataclass
class SearchOutput:
    candidates: CandidateSet
    best: int | None
    alternatives: list[Alternative]
    contacts: list[Contact]
    score_terms: dict[str, float]
    timing_ms: dict[str, float]


def run_search(
    inp: SearchInput,
    scorers: Sequence[tuple[str, Any, Any, float]],
    *,
    top_k: int = 5,
    spheres: FingerSpheres | None = None,
    normals_fn: Callable[[Array], Array] | None = None,
    normals_of: Callable[[Array, NDArray[np.int64]], Array] | None = None,
) -> SearchOutput:
    """Generate, evaluate and score all candidates; pick the best.

    ``normals_fn`` gives the object points' outward normals to the scorers;
    ``normals_of(points, rows)``, when given, the normals of some of them alone,
    bit for bit those of ``normals_fn`` (see ``CandidateBatch``).
    """
    g = inp.gripper
    t0 = time.perf_counter()
    spheres = spheres or FingerSpheres(g)  # built once: scorers may test more poses
    o = inp.orientations
    # the candidates as candidate_poses lays them out (samples outer), their
    # poses built from the structure where read (PoseArray)
    structure = CandidateStructure(
        inp.T_world_object, inp.samples_object, o.R_object_gwc, o.depth
    )
    T_world_gwc = PoseArray(StructuredPoses.build(structure))
    T_world_gripper = PoseArray(StructuredPoses.build(structure, g.T_gripper_gwc))
    sample, orientation = structure.indices()
    theta = o.theta[orientation]
    scene = (inp.object_points, inp.obstacle_points, inp.table, spheres)
    ev = evaluate_candidates(T_world_gripper, g, *scene, structure=structure)
    t1 = time.perf_counter()
    C = len(sample)
    score = np.full(C, np.nan)
    terms_all: dict[str, Array] = {}
    best: int | None = None
    alternatives: list[Alternative] = []
    contacts: list[Contact] = []
    best_terms: dict[str, float] = {}
    if ev.feasible.size:
        f = ev.feasible
        batch = CandidateBatch(
            gripper=g,
            # as PoseRows: built only if a scorer reads them whole
            T_world_gwc=PoseRows(T_world_gwc, f),  # type: ignore[arg-type]
            T_world_gripper=PoseRows(T_world_gripper, f),  # type: ignore[arg-type]
            theta=theta[f],
            # as Holdings: the mask is built only if a scorer reads it
            holding=ev.holdings,  # type: ignore[arg-type]
            object_points=inp.object_points,
            T_world_object=inp.T_world_object,
            extents=inp.extents,
            table_normal=inp.table.T_world_table[:3, 2],
            min_table_height=ev.min_table_height,
            normals_fn=normals_fn,
            normals_of=normals_of,
            T_world_table=inp.table.T_world_table,
            feasible_fn=lambda T: evaluate_candidates(T, g, *scene).reason == 0,
            viewpoints=inp.viewpoints,
        )
        total, terms = combine_scores(batch, scorers)
        score[f] = total
        for name, values in terms.items():
            terms_all[name] = column = np.full(C, np.nan)
            column[f] = values
        # stable: ties keep the earlier candidate, as Algorithm 1's strict "<"
        order = np.argsort(-total, kind="stable")
        ranked = [  # the best, then the next top_k
            Alternative(
                index=int(f[j]),
                T_world_ee=T_world_gripper.at(f[j]),
                score=float(total[j]),
                terms={k: float(v[j]) for k, v in terms.items()},
            )
            for j in order[: top_k + 1]
        ]
        best, best_terms, alternatives = ranked[0].index, ranked[0].terms, ranked[1:]
        holding = ev.holdings.rows([int(order[0])])[0]  # (no, nf)
        contacts = _contacts(g, ranked[0].T_world_ee, inp.object_points, holding)
    t2 = time.perf_counter()
    cands = CandidateSet(
        # as PoseArrays: built whole only if read whole (a recording)
        T_world_gwc=T_world_gwc,  # type: ignore[arg-type]
        T_world_ee=T_world_gripper,  # type: ignore[arg-type]
        sample=sample,
        theta=theta,
        reason=ev.reason,
        contacts=ev.contacts,
        score=score,
        terms=terms_all,
        flipped=o.flipped[orientation],
        orientation=orientation,
    )
    return SearchOutput(
        candidates=cands,
        best=best,
        alternatives=alternatives,
        contacts=contacts,
        score_terms=best_terms,
        timing_ms={"search": (t1 - t0) * 1e3, "scoring": (t2 - t1) * 1e3},
    )


def _contacts(
    g: GripperModel,
    T_world_gripper: Array,
    object_points: Array,
    holding: NDArray[np.bool_],
) -> list[Contact]:
    """Per finger: the object points its spheres hold and the spheres holding them.

    ``holding`` ``(no, nf)`` is the search's answer for this pose; only the held
    points are tested, against the spheres within their radius of the points' box
    along every axis (exact: a point is at least as far from a centre along one
    axis as the box is; every sphere took about 0.2 ms a finger on the Allegro
    hand's 77 spheres and some 300 held points; about half are dropped).
    """
    p = transform_points(invert_transforms(T_world_gripper), object_points)  # (no, 3)
    out = []
    for f, name in enumerate(g.finger_names):
        mine = np.flatnonzero(g.sphere_finger == f)
        held_points = holding[:, f]
        held = p[held_points]  # (k, 3)
        if len(held):
            c = g.sphere_centers[mine]  # (m, 3)
            gap = np.maximum(held.min(axis=0) - c, c - held.max(axis=0)).max(axis=1)
            mine = mine[~(gap > g.sphere_radii[mine] + _BOX_MARGIN)]
        hit = spheres_hit_by_points(held, g.sphere_centers[mine], g.sphere_radii[mine])
        spheres = mine[hit].astype(np.int64)
        out.append(Contact(name, object_points[held_points], spheres))
    return out


#: a sphere whose centre lies this far (m) past its radius from the held points'
#: bounding box, along one axis, holds none of them, whatever the rounding
_BOX_MARGIN = 1e-9


#: each rejection reason as the hint for a table-bound search words it
_REJECTED = {
    "object_collision": "with the body in the object",
    "obstacle_collision": "blocked by neighbouring objects",
    "finger_without_contact": "with a finger that touches nothing",
    "finger_sweeps_table": "with fingers that sweep through the table",
}


def no_grasp_hint(
    histogram: dict[str, int],
    extents: Array,
    gripper: GripperModel,
    height: float,
    width: float | None = None,
) -> str:
    """Why no candidate was feasible, in one sentence a user can act on.
    ``width``: the object's narrowest width seen from above the table
    (:func:`wsgrasp.perception.footprint.narrowest_width`), named first where
    the gripper does not open as wide (only an edge or a rim then fits between
    its fingers: an object lying flat, as wide as a box of pudding, holds none
    for a Franka hand)."""
    total = sum(histogram.values())
    if total == 0:
        return "no candidates were generated; raise sampling.points or orientations"
    worst = max((r for r in REASONS if r != "feasible"), key=lambda r: histogram[r])
    wide = ""
    if width is not None and width > gripper.max_opening:
        wide = (
            f"the object is {width:.3f} m across at its narrowest seen from above, "
            f"more than the gripper opens ({gripper.max_opening:.3f} m), so only an "
            "edge or a rim of it fits between the fingers; "
        )
    cross = float(np.min(extents))  # the object's narrowest extent
    if worst == "finger_without_contact" and cross > gripper.max_opening:
        return (
            f"object is wider ({cross:.3f} m across its major axis) than the "
            f"gripper opening ({gripper.max_opening:.3f} m)"
        )
    if worst == "table_collision":
        others = sorted(
            (r for r in REASONS if r not in ("feasible", worst) and histogram[r]),
            key=lambda r: -histogram[r],
        )
        listed = ", ".join(f"{histogram[r]} {_REJECTED[r]}" for r in others)
        why = f"; of the other {total - histogram[worst]}, {listed}" if others else ""
        return wide + (
            f"the gripper hits the table at {histogram[worst]} of {total} poses "
            f"(the object stands {height:.3f} m tall){why}; sample approach "
            "directions from the side (sampling.directions) or more orientations, "
            "or lower table.clearance"
        )
    if worst == "object_collision":
        return wide + (
            f"the gripper body hits the object at {histogram[worst]} of {total} "
            "poses; the object may be larger than the gripper can hold, or try more "
            "samples and orientations"
        )
    if worst == "obstacle_collision":
        return (
            f"neighbouring objects block {histogram[worst]} of {total} poses; "
            "pick another target or clear the scene"
        )
    return (
        f"no pose puts object points in every finger's workspace "
        f"({histogram[worst]} of {total} poses); the object may be too small or "
        "too large for this gripper, or raise sampling.points"
    )
