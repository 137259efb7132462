"""What ``wsgrasp inspect`` shows of a run, as plain data."""

from __future__ import annotations

from typing import Any

import numpy as np

from wsgrasp.record._run import Run

__all__ = ["reason_counts", "summarize_run"]


def reason_counts(cs: Any, rejections: dict[str, Any] | None) -> dict[str, int]:
    """Reason → count of the candidates ``cs`` (codes past the known reasons, from
    a newer recorder, as ``unknown``), or the result's ``rejections`` when there
    are no candidates."""
    if cs is None or len(cs) == 0:
        return {k: int(v) for k, v in (rejections or {}).items()}
    from wsgrasp.planning.result import REASONS

    reason = np.asarray(cs.reason)
    counts = np.bincount(reason, minlength=len(REASONS))[: len(REASONS)].tolist()
    hist = dict(zip(REASONS, counts, strict=True))
    if extra := int((reason >= len(REASONS)).sum()):
        hist["unknown"] = extra
    return hist


def _histogram(run: Run) -> tuple[int, int, dict[str, int]]:
    """``(candidates, feasible, rejections)``; rejections excludes ``feasible``."""
    hist = reason_counts(run.candidates, (run.result_data or {}).get("rejections"))
    feasible = hist.pop("feasible", 0)
    return feasible + sum(hist.values()), feasible, hist


def _top(run: Run, k: int) -> list[dict[str, Any]]:
    """The ``k`` best feasible candidates (the feasible reason, code 0)."""
    cs = run.candidates
    if cs is None or len(cs) == 0:
        return []
    score = np.asarray(cs.score, dtype=np.float64)
    feasible = np.flatnonzero(np.asarray(cs.reason) == 0)
    order = feasible[np.argsort(-score[feasible], kind="stable")][:k]
    return [
        {
            "index": i,
            "score": float(score[i]),
            "terms": {n: float(np.asarray(t)[i]) for n, t in cs.terms.items()},
            "sample": int(np.asarray(cs.sample)[i]),
            "theta_deg": float(np.degrees(np.asarray(cs.theta)[i])),
            "contacts": np.asarray(cs.contacts)[i].tolist(),
            "position": np.asarray(cs.T_world_ee)[i, :3, 3].tolist(),
            "reason": "feasible",
        }
        for i in order.tolist()
    ]


def summarize_run(run: Run, *, top_k: int = 5) -> dict[str, Any]:
    """Inputs, versions, timings, the rejection histogram, the top-k candidates and
    the result of a run, as JSON-ready data.

    Always has ``found``, ``candidates``, ``feasible``, ``rejections`` and
    ``truncated``, also for a truncated run.
    """
    n, feasible, rejections = _histogram(run)
    meta = run.metadata.get("wsgrasp", {})
    res = run.result_data or {}
    inputs: dict[str, Any] | None = None
    if run.inputs is not None:
        scene = run.scene
        views = [
            {"name": v.name, "points": len(v.points), "T_world_camera": T.tolist()}
            for v in scene.views
            for T in [np.asarray(v.T_world_camera)]
        ]
        inputs = {"views": views, "points": len(scene.points)}
        inputs["dropped_nonfinite"] = scene.dropped_nonfinite
        inputs["dropped_no_depth"] = scene.dropped_no_depth
        flying = run.stages.get("preprocess", {}).get("flying_pixels")
        if flying is not None:
            inputs["flying_pixels"] = int(flying)

    def mat(key: str) -> Any:
        v = res.get(key)
        return None if v is None else np.asarray(v).tolist()

    return {
        "path": str(run.path),
        "status": run.status,
        "found": bool(res.get("found", False)),
        "candidates": n,
        "feasible": feasible,
        "rejections": rejections,
        "truncated": run.truncated,
        "truncated_at": run.truncated_at,
        "missing": run.missing,
        "error": run.error,
        "gripper": meta.get("gripper"),
        "format_version": run.format_version,
        "versions": {
            "wsgrasp": run.wsgrasp_version,
            "python": meta.get("python"),
            "numpy": meta.get("numpy"),
            "platform": meta.get("platform"),
            "plugins": [
                {k: p.get(k) for k in ("name", "distribution", "version")}
                for p in run.plugins
            ],
        },
        "seed": None if "seed" not in meta else int(meta["seed"]),
        "created_utc": meta.get("created_utc"),
        "spec": run.spec_data,
        "inputs": inputs,
        "timing_ms": run.timing_ms,
        "score": res.get("score"),
        "score_terms": res.get("score_terms", {}),
        "T_world_ee": mat("T_world_ee"),
        "T_world_tcp": mat("T_world_tcp"),
        "hint": res.get("hint", ""),
        "warnings": list(res.get("warnings", [])),
        "top": _top(run, top_k),
        "topics": {
            t: {"schema": s, "messages": c} for t, (s, c) in run.topics().items()
        },
        "attachments": {k: len(v) for k, v in run.attachments.items()},
    }
