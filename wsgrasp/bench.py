"""``wsgrasp bench``: timings of the whole plan, the search alone and the
loop-by-loop reference, side by side in one run, and how the search scales.

Figures are medians over repeated runs on the same inputs, after warm-up runs
(for the whole plan, past the process's choice of kernels); the speed-up is the
ratio of the reference's median to the search's median measured in the same run.
"""

from __future__ import annotations

import math
import statistics
import time
import tracemalloc
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from wsgrasp.api import Pipeline, as_scene
from wsgrasp.perception.frame import sample_box
from wsgrasp.planning import _compiled, kernels
from wsgrasp.planning.candidates import candidate_poses, orientation_set
from wsgrasp.planning.evaluate import (
    CandidateStructure,
    FingerSpheres,
    evaluate_candidates,
)
from wsgrasp.planning.reference import reference_search
from wsgrasp.spec import load_spec

__all__ = ["BenchCase", "run_bench", "default_cases"]

#: the paper's per-plan times (Table II averages), for comparison
PAPER_PLAN_S = {"franka_hand": 0.34, "allegro_right": 1.22}


@dataclass
class BenchCase:
    gripper: str
    spec: Path
    scene: Path
    label: str = ""
    #: fields of the spec's ``sampling`` to override (the paper's Table I setting)
    sampling: dict[str, Any] | None = None
    #: a dense case: the search and the evaluation only, alternating, with peak
    #: memory; no whole plan, no loop-by-loop reference
    dense: bool = False


#: the paper's Table I: 147 samples x 4 orientations about the major axis
TABLE_I = {
    "mode": "major_axis",
    "points": 147,
    "grid": None,
    "orientations": 4,
    "flip": False,
    # whatever the spec samples otherwise (allegro.yaml: approach directions)
    "directions": None,
    "steps": None,
    "depths": 1,
    "angles_from": "object",
}

#: the follow-up's densities: Panda 10 × 10 × 10 positions × 512 orientations,
#: Allegro 5 × 5 × 5 × 5832 (18³); as approach directions × rolls, since the
#: ``xyz`` grid keeps each rotation once and drops those from under the table
DENSE = {
    "franka_hand": {
        "mode": "approach_sphere",
        "grid": (10, 10, 10),
        "directions": 64,
        "orientations": 8,
        "flip": False,
    },
    "allegro_right": {
        "mode": "approach_sphere",
        "grid": (5, 5, 5),
        "directions": 324,
        "orientations": 18,
        "flip": False,
    },
}


@dataclass
class BenchResult:
    rows: dict[str, dict[str, float]] = field(default_factory=dict)
    scaling: list[dict[str, Any]] = field(default_factory=list)


def project_root() -> Path:
    """The source checkout holding ``examples/`` (the demo and bench data)."""
    here = Path(__file__).resolve().parent.parent
    for root in (here, Path.cwd()):
        if (root / "examples" / "specs").is_dir():
            return root
    return Path.cwd()


def default_cases() -> list[BenchCase]:
    root = project_root()
    scene = root / "examples" / "scenes" / "box_upright.npz"
    cases = []
    for gripper, spec in (("franka_hand", "franka"), ("allegro_right", "allegro")):
        path = root / "examples" / "specs" / f"{spec}.yaml"
        cases.append(BenchCase(gripper, path, scene))
        cases.append(BenchCase(gripper, path, scene, f"{gripper}_table1", TABLE_I))
    for gripper, spec in (("franka_hand", "franka"), ("allegro_right", "allegro")):
        path = root / "examples" / "specs" / f"{spec}.yaml"
        cases.append(
            BenchCase(gripper, path, scene, f"{gripper}_dense", DENSE[gripper], True)
        )
    return cases


def _median_ms(fn: Callable[[], Any], repeat: int, warmup: int = 1) -> float:
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append((time.perf_counter() - t) * 1e3)
    return statistics.median(times)


def run_bench(
    cases: list[BenchCase] | None = None,
    *,
    repeat: int = 15,
    reference_repeat: int = 3,
    scaling: bool = True,
    progress: Callable[[str], None] | None = None,
) -> BenchResult:
    """Measure every case; see the module docstring. Medians of ``repeat``
    runs (the search alone: ``7 * repeat``; the reference: ``reference_repeat``)."""
    say = progress or (lambda _msg: None)
    out = BenchResult()
    for case in cases or default_cases():
        label = case.label or case.gripper
        say(f"{label}: loading")
        spec = load_spec(case.spec)
        if case.sampling is not None:
            spec.sampling = spec.sampling.model_validate(
                {**spec.sampling.model_dump(), **case.sampling}
            )
        pipe = Pipeline(spec)
        scene = as_scene(case.scene)
        if case.dense:
            out.rows[label] = _dense_row(pipe, pipe.prepare(scene), label, say)
            continue
        say(f"{label}: whole plan ×{repeat}")
        # warmed up past the process's choice of kernels (numpy's for its first
        # searches, then the compiled loops: ``kernels``), so that every timed
        # plan runs the same ones; a fresh process's first plan is
        # benchmarks/open3d_import.py's
        settle = kernels.SMALL_BEFORE_LOADING + 1
        plan_ms = _median_ms(lambda: pipe.plan(scene), repeat, warmup=settle)
        prep = pipe.prepare(scene)
        stages = {k: [] for k in prep.timing_ms}  # type: dict[str, list[float]]
        for _ in range(repeat):
            for k, v in pipe.prepare(scene).timing_ms.items():
                stages[k].append(v)
        # a search takes milliseconds: seven times the runs cost little and keep
        # a burst of other work on a shared machine from moving the median
        say(f"{label}: search ×{7 * repeat}")
        search_ms = _median_ms(lambda: pipe.search(prep), 7 * repeat)
        inp = prep.search_input
        say(f"{label}: loop-by-loop reference ×{reference_repeat}")
        ref_ms = _median_ms(
            lambda: reference_search(
                inp.gripper,
                inp.T_world_object,
                inp.samples_object,
                inp.orientations.R_object_gwc,
                inp.object_points,
                inp.obstacle_points,
                inp.table,
                inp.orientations.depth,
            ),
            reference_repeat,
            warmup=0,
        )
        row = {
            "plan_ms": plan_ms,
            "search_ms": search_ms,
            "reference_search_ms": ref_ms,
            "speedup": ref_ms / search_ms,
            "candidates": float(inp.num_candidates),
            "orientations": float(len(inp.orientations)),
            "object_points": float(len(inp.object_points)),
            "scene_points": float(len(scene.points)),
            "paper_plan_ms": PAPER_PLAN_S.get(case.gripper, float("nan")) * 1e3,
        }
        row.update({f"{k}_ms": statistics.median(v) for k, v in stages.items()})
        out.rows[label] = row
        if scaling and not case.label:
            say(f"{label}: scaling")
            out.scaling += _scaling(pipe, prep, scene)
    return out


def _peak_mb(fn: Callable[[], Any]) -> float:
    """Peak memory (MiB) numpy and Python allocate while ``fn`` runs."""
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1] / 2**20
    finally:
        tracemalloc.stop()


def _evaluator(inp: Any) -> Callable[[], Any]:
    """The evaluation of every candidate of ``inp`` (the search's verdicts,
    without scoring and choice)."""
    g, o = inp.gripper, inp.orientations
    _, T_world_gripper, _, _ = candidate_poses(
        inp.T_world_object, inp.samples_object, o.R_object_gwc, g.T_gripper_gwc, o.depth
    )
    spheres = FingerSpheres(g)
    structure = CandidateStructure(
        inp.T_world_object, inp.samples_object, o.R_object_gwc, o.depth
    )
    args = (T_world_gripper, g, inp.object_points, inp.obstacle_points, inp.table)
    return lambda: evaluate_candidates(*args, spheres, structure=structure)


def _side_by_side(
    fns: dict[str, Callable[[], Any]],
    repeat: int,
    times: dict[str, list[float]] | None = None,
) -> dict[str, float]:
    """Medians (ms) of each of ``fns``, run alternately ``repeat`` times (with the
    times already in ``times``, which is extended)."""
    times = times if times is not None else {}
    for _ in range(repeat):
        for k, fn in fns.items():
            t = time.perf_counter()
            fn()
            times.setdefault(k, []).append((time.perf_counter() - t) * 1e3)
    return {k: statistics.median(v) for k, v in times.items()}


def _dense_row(
    pipe: Pipeline, prep: Any, label: str, say: Callable[[str], None]
) -> dict[str, float]:
    """A dense case: the search as wired (``pipe.search``) and the evaluation
    alone, alternating; peak memory of each."""
    inp = prep.search_input
    C = inp.num_candidates
    evaluate = _evaluator(inp)
    say(f"{label}: {C} candidates, evaluation")
    evaluate()  # warm-up (caches, page faults, the compiled loops' loading)
    pipe.search(prep)  # the same for the search (its own sphere index's grids)
    say(f"{label}: search and evaluation, alternating")
    search = lambda: pipe.search(prep)  # noqa: E731
    ms = _side_by_side({"search": search, "evaluate": evaluate}, 5)
    return {
        "candidates": float(C),
        "samples": float(len(inp.samples_object)),
        "orientations": float(len(inp.orientations)),
        "object_points": float(len(inp.object_points)),
        "search_ms": ms["search"],
        "evaluate_ms": ms["evaluate"],
        "us_per_candidate": ms["evaluate"] * 1e3 / max(C, 1),
        "peak_mb": _peak_mb(lambda: pipe.search(prep)),
        "evaluate_peak_mb": _peak_mb(evaluate),
        # 1 where the compiled loops ran (numba, unless WSGRASP_NUMBA=0)
        "compiled": float(_compiled.loaded()),
    }


def dense_scaling(
    pipe: Pipeline,
    prep: Any,
    counts: tuple[int, ...] = (10_000, 100_000, 1_000_000),
    repeat: int = 3,
) -> list[dict[str, Any]]:
    """Evaluation time and cost per candidate against the number of candidates.
    The candidates are the case's orientations times the smallest cubic grid of
    samples in the object's box that reaches each count."""
    from wsgrasp.perception.frame import object_frame

    inp = prep.search_input
    frame = object_frame(inp.object_points, pipe.spec.object_frame.method)
    rows = []
    for n in counts:
        per_axis = max(1, math.ceil((n / len(inp.orientations)) ** (1.0 / 3.0)))
        sampling = pipe.spec.sampling.model_copy(
            update={"grid": (per_axis, per_axis, per_axis)}
        )
        case = replace(inp, samples_object=sample_box(frame, sampling))
        evaluate = _evaluator(case)
        evaluate()
        ms = _side_by_side({"evaluate": evaluate}, repeat)
        C = case.num_candidates
        rows.append(
            {
                "gripper": pipe.gripper.name,
                "candidates": C,
                "evaluate_ms": ms["evaluate"],
                "us_per_candidate": ms["evaluate"] * 1e3 / C,
                "peak_mb": _peak_mb(evaluate),
                "compiled": _compiled.loaded(),
            }
        )
    return rows


def _scaling(pipe: Pipeline, prep: Any, scene: Any) -> list[dict[str, Any]]:
    """Search time over sample counts × orientations and object point counts."""
    from wsgrasp.perception.frame import object_frame

    rows = []
    inp = prep.search_input
    # a denser object cloud for the point-count sweep: the scene at 2 mm voxels
    dense_spec = pipe.spec.model_copy(deep=True)
    dense_spec.preprocess.voxel_size = 0.002
    dense_spec.preprocess.max_object_points = 100_000
    dense = Pipeline(dense_spec, gripper=pipe.gripper).prepare(scene)
    dense_points = dense.search_input.object_points
    rng = np.random.default_rng(0)
    frame = object_frame(inp.object_points, pipe.spec.object_frame.method)
    for ns, nos in ((147, 4), (500, 8), (1000, 8), (2000, 16)):
        sampling = pipe.spec.sampling.model_validate(
            {**pipe.spec.sampling.model_dump(), **TABLE_I, "points": ns}
        ).model_copy(update={"orientations": nos})
        case = replace(
            inp,
            samples_object=sample_box(frame, sampling),
            orientations=orientation_set(
                sampling,
                inp.T_world_object,
                inp.table.T_world_table[:3, 2],
                object_points=inp.object_points,
            ),
        )
        p = replace(prep, search_input=case)
        ms = _median_ms(lambda: pipe.search(p), 5)
        rows.append(
            {
                "gripper": pipe.gripper.name,
                "samples": len(case.samples_object),
                "orientations": len(case.orientations),
                "object_points": len(inp.object_points),
                "search_ms": ms,
            }
        )
    for n in (300, 800, 2000, 5000):
        take = min(n, len(dense_points))
        pts = dense_points[np.sort(rng.choice(len(dense_points), take, replace=False))]
        case = replace(inp, object_points=pts)
        p = replace(prep, search_input=case)
        ms = _median_ms(lambda: pipe.search(p), 5)
        rows.append(
            {
                "gripper": pipe.gripper.name,
                "samples": len(inp.samples_object),
                "orientations": len(inp.orientations),
                "object_points": take,
                "search_ms": ms,
            }
        )
    return rows
