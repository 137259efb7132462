"""What recording a run costs: plan time with and without a ``RunRecorder``.

Runs ``Pipeline(spec).plan(scene)`` without and with a recorder (to a temporary
file, deleted after each run), alternating, so that load on a shared machine hits
both alike, and prints medians: plan time, recording overhead (ms and %), file size
and the time the planner's thread spent in the recorder. ``--baseline MODULE``
(repeatable) adds another recorder (``MODULE.RunRecorder``, e.g. an older copy of
``wsgrasp.record`` importable under another name) to the same alternation.

    .venv/bin/python benchmarks/record_overhead.py [--runs 15] [--spec S ...]
        [--scene S ...] [--baseline MODULE] [--hooks] [--json]

Two overheads are measured on every recorded run:

- ``plan``: the wall time of ``plan`` (the inputs, every stage and the result are
  written and flushed when it returns): what a robot waiting for its grasp sees;
- ``+close``: ``plan`` and then ``close``, which waits for the writer thread to add
  the Foxglove views and finish the file: the whole cost, when plans run back to
  back (a new recording waits for the previous one anyway).

``paired`` is the median of the per-round differences, ``min`` the difference of
the fastest runs: both are steadier than the difference of medians on a loaded
machine. ``cpu`` (JSON only) is the process's CPU time, all threads.

``--hooks`` measures the recorders alone, by CPU time, which load on a shared
machine disturbs far less than wall-clock time: the hooks of one captured plan are
replayed into each recorder in turn (alternating, as above), and the medians are
the planner's thread's CPU time in the hooks (``thread``) and the writer thread's
until ``close`` returns (``writer``: the process's CPU time less the planner's
thread's). The load average is printed before and after.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
SPECS = ["examples/specs/franka.yaml", "examples/specs/allegro.yaml"]
SCENES = ["examples/scenes/box_upright.npz", "examples/scenes/cone_views/scene.yaml"]


def measure(
    spec_path: str, scene_path: str, runs: int, recorders: dict[str, Any]
) -> list[dict[str, Any]]:
    """One row per recorder: medians over ``runs`` rounds (after 2 warm-ups)."""
    from wsgrasp import Pipeline, load_spec
    from wsgrasp.perception.io import load_scene

    pipe = Pipeline(load_spec(ROOT / spec_path))
    scene = load_scene(ROOT / scene_path)
    names = list(recorders)
    wall: dict[str, list[float]] = {n: [] for n in ["none", *names]}
    latency: dict[str, list[float]] = {n: [] for n in names}
    cpu: dict[str, list[float]] = {n: [] for n in ["none", *names]}
    inside: dict[str, list[float]] = {n: [] for n in names}
    sizes: dict[str, list[int]] = {n: [] for n in names}
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(runs + 2):
            order = ["none", *names]
            k = i % len(order)
            order = order[k:] + order[:k]  # each variant goes first in turn
            for name in order:
                path = Path(tmp) / f"{name}{i}.mcap"
                obs = [] if name == "none" else [recorders[name](path)]
                c0, t0 = time.process_time(), time.perf_counter()
                pipe.plan(scene, observers=obs)
                t1 = time.perf_counter()
                for o in obs:
                    o.close()
                dt = (time.perf_counter() - t0) * 1e3
                dc = (time.process_time() - c0) * 1e3
                if i < 2:
                    continue
                wall[name].append(dt)
                cpu[name].append(dc)
                if obs:
                    latency[name].append((t1 - t0) * 1e3)
                    inside[name].append(obs[0].overhead_ms)
                    sizes[name].append(path.stat().st_size)
                    path.unlink()
    plain = statistics.median(wall["none"])
    rows = []
    for name in names:
        rec = statistics.median(wall[name])
        paired = statistics.median(
            b - a for a, b in zip(wall["none"], wall[name], strict=True)
        )
        lat = statistics.median(latency[name])
        lat_paired = statistics.median(
            b - a for a, b in zip(wall["none"], latency[name], strict=True)
        )
        fastest = min(wall[name]) - min(wall["none"])
        plain_cpu = statistics.median(cpu["none"])
        cpu_extra = statistics.median(cpu[name]) - plain_cpu
        rows.append(
            {
                "recorder": name,
                "spec": spec_path,
                "gripper": pipe.gripper.name,
                "scene": scene_path,
                "points": int(scene.points.shape[0]),
                "views": len(scene.views),
                "runs": runs,
                "plan_ms": round(plain, 2),
                "plan_recorded_ms": round(lat, 2),
                "plan_overhead_ms": round(lat - plain, 2),
                "plan_overhead_pct": round(100 * (lat - plain) / plain, 1),
                "plan_paired_ms": round(lat_paired, 2),
                "plan_paired_pct": round(100 * lat_paired / plain, 1),
                "recorded_ms": round(rec, 2),
                "overhead_ms": round(rec - plain, 2),
                "overhead_pct": round(100 * (rec - plain) / plain, 1),
                "paired_ms": round(paired, 2),
                "paired_pct": round(100 * paired / plain, 1),
                "min_plan_ms": round(min(wall["none"]), 2),
                "min_overhead_ms": round(fastest, 2),
                "min_pct": round(100 * fastest / min(wall["none"]), 1),
                "plan_cpu_ms": round(plain_cpu, 2),
                "cpu_overhead_ms": round(cpu_extra, 2),
                "cpu_pct": round(100 * cpu_extra / plain_cpu, 1),
                "recorder_ms": round(statistics.median(inside[name]), 2),
                "file_mb": round(statistics.median(sizes[name]) / 1e6, 3),
            }
        )
    return rows


class _Capture:
    """A plan observer that keeps every hook call, to replay it into recorders."""

    def __init__(self) -> None:
        self.calls: list[tuple[str, tuple[Any, ...]]] = []

    def __getattr__(self, hook: str) -> Any:
        if not hook.startswith("on_"):
            raise AttributeError(hook)
        return lambda *args: self.calls.append((hook, args))


def measure_hooks(
    spec_path: str, scene_path: str, runs: int, recorders: dict[str, Any]
) -> list[dict[str, Any]]:
    """One row per recorder: medians over ``runs`` rounds (after 2 warm-ups) of the
    CPU time of one captured plan's hooks replayed into it, and of its writer
    thread's work until ``close`` returns."""
    from wsgrasp import Pipeline, load_spec
    from wsgrasp.perception.io import load_scene

    pipe = Pipeline(load_spec(ROOT / spec_path))
    scene = load_scene(ROOT / scene_path)
    capture = _Capture()
    pipe.plan(scene, observers=[capture])
    names = list(recorders)
    thread: dict[str, list[float]] = {n: [] for n in names}
    writer: dict[str, list[float]] = {n: [] for n in names}
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(runs + 2):
            k = i % len(names)
            for name in names[k:] + names[:k]:
                path = Path(tmp) / f"{name}{i}.mcap"
                rec = recorders[name](path)
                c0, t0 = time.process_time(), time.thread_time()
                for hook, args in capture.calls:
                    getattr(rec, hook)(*args)
                t1 = time.thread_time()
                rec.close()
                c1, t2 = time.process_time(), time.thread_time()
                path.unlink()
                if i >= 2:
                    thread[name].append((t1 - t0) * 1e3)
                    writer[name].append(((c1 - c0) - (t2 - t0)) * 1e3)
    rows = []
    for name in names:
        a, b = statistics.median(thread[name]), statistics.median(writer[name])
        rows.append(
            {
                "recorder": name,
                "spec": spec_path,
                "gripper": pipe.gripper.name,
                "scene": scene_path,
                "points": int(scene.points.shape[0]),
                "runs": runs,
                "thread_ms": round(a, 2),
                "writer_ms": round(b, 2),
                "cpu_ms": round(a + b, 2),
            }
        )
    return rows


def _load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--runs", type=int, default=15)
    ap.add_argument("--spec", action="append")
    ap.add_argument("--scene", action="append")
    ap.add_argument(
        "--baseline", action="append", help="module with another RunRecorder"
    )
    ap.add_argument("--hooks", action="store_true", help="the recorders' CPU time")
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    from wsgrasp.record import RunRecorder

    recorders: dict[str, Any] = {"wsgrasp": RunRecorder}
    for name in a.baseline or []:
        recorders[name] = importlib.import_module(name).RunRecorder
    load_before = _load()
    rows = [
        row
        for spec in a.spec or SPECS
        for scene in a.scene or SCENES
        for row in (measure_hooks if a.hooks else measure)(
            spec, scene, a.runs, recorders
        )
    ]
    if a.json:
        print(json.dumps(rows, indent=2))
        return
    print(f"load average {load_before} before, {_load()} after")
    head = f"{'recorder':<12}{'gripper':<14}{'scene':<22}{'points':>7}"
    if a.hooks:
        print(f"{head} | {'thread ms':>9}{'writer ms':>10}{'cpu ms':>8}")
        for r in rows:
            print(
                f"{_who(r)} | {r['thread_ms']:>9.2f}{r['writer_ms']:>10.2f}"
                f"{r['cpu_ms']:>8.2f}"
            )
        return
    print(
        f"{head}{'plan ms':>8}"
        f" | {'plan +ms':>8}{'%':>5}{'paired':>7}{'%':>5}"
        f" | {'+close ms':>9}{'%':>5}{'paired':>7}{'%':>5}"
        f" | {'inside':>6}{'MB':>6}"
    )
    for r in rows:
        print(
            f"{_who(r)}{r['plan_ms']:>8.1f}"
            f" | {r['plan_overhead_ms']:>8.1f}{r['plan_overhead_pct']:>5.0f}"
            f"{r['plan_paired_ms']:>7.1f}{r['plan_paired_pct']:>5.0f}"
            f" | {r['overhead_ms']:>9.1f}{r['overhead_pct']:>5.0f}"
            f"{r['paired_ms']:>7.1f}{r['paired_pct']:>5.0f}"
            f" | {r['recorder_ms']:>6.1f}{r['file_mb']:>6.2f}"
        )


def _who(r: dict[str, Any]) -> str:
    """A row's first columns: recorder, gripper, scene (its last two path parts)
    and points."""
    scene = "/".join(Path(str(r["scene"])).parts[-2:])
    return f"{r['recorder']:<12.12}{r['gripper']:<14}{scene:<22.22}{r['points']:>7}"


if __name__ == "__main__":
    main()
