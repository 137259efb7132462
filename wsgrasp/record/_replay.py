"""Replaying a run: re-plan its inputs and compare the results bit for bit."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from wsgrasp.errors import RecordingError, WsgraspError
from wsgrasp.geometry import rotation_angle_deg
from wsgrasp.record._reader import open_run
from wsgrasp.record._run import Run
from wsgrasp.record._summary import reason_counts
from wsgrasp.record._writer import RunRecorder, check_record_path

if TYPE_CHECKING:
    from wsgrasp.planning.result import PlanResult
    from wsgrasp.spec import PipelineSpec

__all__ = ["ReplayReport", "compare_results", "replay_run"]


@dataclass
class ReplayReport:
    """How a replay compares with the recorded run: ``identical`` when every
    compared field of the result (:func:`compare_results`) is equal bit for bit;
    ``differences`` names those that are not; ``recorded`` and ``replayed``
    outline each (``found``, ``score``, ``candidates``, ``feasible``,
    ``histogram``, ``T_world_ee``, ``error``); ``pose_delta`` is the translation
    (m) and angle (deg) between the chosen poses when both found one."""

    identical: bool
    same_spec: bool
    differences: list[str]
    recorded: dict[str, Any]
    replayed: dict[str, Any]
    pose_delta: dict[str, float] | None
    record_path: Path | None = None
    notes: list[str] = field(default_factory=list)

    def to_json(self) -> dict[str, Any]:
        """Plain data: what ``wsgrasp replay --json`` prints."""
        a, b = self.recorded["histogram"], self.replayed["histogram"]
        hist = {k: {"recorded": a.get(k, 0), "replayed": b.get(k, 0)} for k in a | b}
        return {
            "identical": self.identical,
            "same_spec": self.same_spec,
            "differences": self.differences,
            "recorded": self.recorded,
            "replayed": self.replayed,
            "pose_delta": self.pose_delta,
            "score_delta": None
            if None in (self.recorded["score"], self.replayed["score"])
            else float(self.replayed["score"]) - float(self.recorded["score"]),
            "histogram": hist,
            "record": None if self.record_path is None else str(self.record_path),
            "notes": self.notes,
        }


# -- bit-for-bit comparison -----------------------------------------------------------
_CANON = {"f": "<f8", "i": "<i8", "u": "<i8", "b": "|b1"}  # dtype kind → compared as


def _canon(a: Any) -> np.ndarray[Any, Any]:
    x = np.asarray(a)
    return x.astype(_CANON[x.dtype.kind]) if x.dtype.kind in _CANON else x


def _same(a: Any, b: Any) -> bool:
    """Bit-for-bit equality of arrays, floats, dicts and lists (NaN equals NaN)."""
    if a is None or b is None:
        return a is None and b is None
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, (str, bool)) or isinstance(b, (str, bool)):
        return bool(a == b) and type(a) is type(b)
    x, y = _canon(a), _canon(b)
    return x.shape == y.shape and x.dtype == y.dtype and x.tobytes() == y.tobytes()


_ERROR = ("type", "message")  # what of an error is compared
_COMPARED = (
    "found gripper T_world_ee T_world_gwc T_world_tcp pregrasp closed score "
    "score_terms best_index rejections hint T_world_object object_extents "
    "T_world_pregrasp joints_pregrasp joints_grasp finger_targets"
).split()
_CANDIDATE_FIELDS = "T_world_gwc T_world_ee sample theta orientation reason "
_CANDIDATE_FIELDS += "contacts score terms"


def compare_results(a: PlanResult, b: PlanResult) -> list[str]:
    """Names of the fields in which two results differ, bit for bit (timings and
    ``info`` are not compared). An empty list means identical."""
    diff = [f for f in _COMPARED if not _same(getattr(a, f), getattr(b, f))]
    for f in _CANDIDATE_FIELDS.split():
        if not _same(getattr(a.candidates, f), getattr(b.candidates, f)):
            diff.append(f"candidates.{f}")
    parts = {
        "contacts": lambda r: [(c.finger, c.points, c.spheres) for c in r.contacts],
        "alternatives": lambda r: [
            (x.index, x.T_world_ee, x.score, x.terms) for x in r.alternatives
        ],
    }
    return diff + [k for k, of in parts.items() if not _same(of(a), of(b))]


def _pose_delta(a: PlanResult | None, b: PlanResult | None) -> dict[str, float] | None:
    if a is None or b is None or a.T_world_ee is None or b.T_world_ee is None:
        return None
    A = np.asarray(a.T_world_ee, dtype=np.float64)
    B = np.asarray(b.T_world_ee, dtype=np.float64)
    return {
        "translation_m": float(np.linalg.norm(B[:3, 3] - A[:3, 3])),
        "angle_deg": rotation_angle_deg(A[:3, :3], B[:3, :3]),
    }


def _outline(r: PlanResult | None, error: dict[str, Any] | None) -> dict[str, Any]:
    score = None if r is None or r.score is None else float(r.score)
    return {
        "found": r is not None and bool(r.found),
        "score": score if score is None or math.isfinite(score) else None,
        "candidates": 0 if r is None else len(r.candidates),
        "feasible": 0 if r is None else int(r.candidates.feasible.sum()),
        "histogram": {} if r is None else reason_counts(r.candidates, r.rejections),
        "T_world_ee": None
        if r is None or r.T_world_ee is None
        else np.asarray(r.T_world_ee).tolist(),
        "error": error,
    }


# -- replay ---------------------------------------------------------------------
def replay_run(
    run: Run | str | Path,
    *,
    spec: PipelineSpec | str | Path | None = None,
    record: str | Path | None = None,
    force: bool = False,
) -> ReplayReport:
    """Re-plan a recorded run's inputs and compare with its recorded result.

    Parameters
    ----------
    run
        A :class:`Run` or the path of a run file.
    spec
        Re-plan with this spec instead of the recorded one. The recorded gripper
        model is used when the spec names the same gripper, so the gripper plugin
        need not be installed.
    record
        Record the replay to this new file.
    force
        Replace ``record`` if it exists.

    Raises
    ------
    RecordingError
        The run lacks what a replay needs (inputs, spec, gripper model), or the
        replay's own recording cannot be written.
    """
    from wsgrasp.api import Pipeline

    if not isinstance(run, Run):
        run = open_run(run)
    if record is not None:  # never the run itself (an input of the replay)
        check_record_path(record, force=force, inputs=[run.path])
    recorded_spec, gripper, scene = run.spec, run.gripper, run.scene
    notes: list[str] = []
    if isinstance(spec, (str, Path)):
        from wsgrasp.spec import load_spec

        # the recorded gripper needs no plugin: check plugin names only when the
        # spec names another gripper (the Pipeline checks segmenter and scorers)
        use_spec = load_spec(spec, check_plugins=False)
        if use_spec.gripper != recorded_spec.gripper:
            use_spec = load_spec(spec)
    else:
        use_spec = recorded_spec if spec is None else spec
    model = gripper if use_spec.gripper == recorded_spec.gripper else None
    if model is None:
        notes.append(
            f"the spec names gripper {use_spec.gripper!r}, the run used "
            f"{recorded_spec.gripper!r}: the new spec's gripper is built"
        )
    if run.truncated and run.result_data is None and run.error is None:
        notes.append("the run is truncated before its result: nothing to compare")

    # a run that took a candidate by choice (plan --choose) is replayed taking it;
    # another spec's candidates are others, so that re-plan takes its own best
    chosen = (run.stages.get("choice") or {}).get("candidate")
    choose = None if chosen is None or spec is not None else int(chosen)
    if chosen is not None and spec is not None:
        notes.append(
            f"the run took candidate {int(chosen)} by choice; the re-plan with "
            "another spec takes its own best"
        )
    observers = [] if record is None else [RunRecorder(record, force=force)]
    new: PlanResult | None = None
    new_error: dict[str, Any] | None = None
    try:
        new = Pipeline(use_spec, gripper=model).plan(
            scene, observers=observers, choose=choose
        )
    except RecordingError:
        # the replay's own recording failed (its file cannot be written): that
        # is the user's error to fix, not a result of the replay
        raise
    except WsgraspError as exc:
        new_error = {"type": type(exc).__name__, "message": exc.message}
    finally:
        for recorder in observers:
            recorder.close()

    old = run.result
    old_error = None if run.error is None else {k: run.error.get(k) for k in _ERROR}
    if old is not None and new is not None:
        differences = compare_results(old, new)
    elif old is None and new is None and old_error is not None:
        differences = [] if old_error == new_error else ["error"]
    else:
        differences = ["result"]
    if new_error is not None and old_error is None:
        notes.append(f"the replay failed: {new_error['type']}: {new_error['message']}")
    return ReplayReport(
        identical=not differences and (old is not None or old_error is not None),
        same_spec=spec is None,
        differences=differences,
        recorded=_outline(old, old_error),
        replayed=_outline(new, new_error),
        pose_delta=_pose_delta(old, new),
        record_path=None if record is None else Path(record),
        notes=notes,
    )
