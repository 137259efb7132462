"""Throughput of ``wsgrasp batch`` plans and of simulated labels on 1 and 2 workers,
local pool and Ray: medians of repeated rounds, with the load average around them.

    .venv/bin/python benchmarks/batch_scaling.py --plans 320 --repeat 3
    .venv/bin/python benchmarks/batch_scaling.py --what labels --objects 6

Each round runs every configuration once (local x1, x2, Ray x1, x2), so that all
see the same changes of a shared machine's load. ``wall`` counts the whole run
(processes started, a pipeline built per worker, the rows written); ``steady``
counts from the moment every worker has delivered its first result to the last
(what a long run approaches). The local 1-worker run is a pool of one process
(one OpenMP thread), like every worker. A Ray instance of ``workers`` CPUs is
started for each run outside the timings (its workers import wsgrasp inside
them, as the local pool's processes do). ``median task`` is the plans' own
``plan_ms`` (or a label's simulation seconds): when it grows on 2 workers, the
workers did not each get a core. ``CPU s`` is a task's CPU time in its worker
(for a label: its scene's drop, views, plan and simulations over its labels),
``driver`` the command's own CPU time per task (receiving and writing rows), and
``CPU share`` the tasks' CPU time over the run's wall time × workers: the part of
its cores a run got (1.0 on an idle machine).
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]


def _scenes(folder: Path, n: int) -> list[Path]:
    """``n`` scene files: copies of the bundled example scenes, in turn."""
    src = sorted((ROOT / "examples" / "scenes").glob("*.npz"))
    out = []
    for i in range(n):
        p = folder / f"s{i:04d}_{src[i % len(src)].name}"
        shutil.copy(src[i % len(src)], p)
        out.append(p)
    return out


def _engine(kind: str, workers: int) -> Any:
    """The engine; a local 1-worker run is a pool of one process too (in this
    process, open3d's OpenMP threads would use every core)."""
    from wsgrasp.batch import LocalEngine, make_engine

    if kind == "local":
        return LocalEngine(workers, in_process=False)
    return make_engine(kind, workers)


def _rates(times: list[float], start: float, workers: int) -> tuple[float, float]:
    """(wall, steady) results per second of one run."""
    times = sorted(times)
    wall = len(times) / (times[-1] - start)
    w = min(workers, len(times) - 1)
    steady = (len(times) - w) / max(times[-1] - times[w - 1], 1e-9)
    return wall, steady


def plans_once(
    engine: Any, workers: int, scenes: list[Path], out: Path, chunk: int
) -> dict[str, Any]:
    """One batch run: (wall rate, steady rate, the plans' own times in s)."""
    from wsgrasp.batch import BatchSpec, run_batch
    from wsgrasp.cli._plan import plan_spec

    specs = [BatchSpec("franka", plan_spec(None, "franka_hand"))]
    stamps: list[float] = []
    task_s: list[float] = []
    cpu_s: list[float] = []
    start, cpu0 = time.perf_counter(), time.process_time()
    run_batch(
        scenes,
        specs,
        out,
        engine,
        chunk=chunk,
        progress=False,
        on_row=lambda row: (
            stamps.append(time.perf_counter()),
            task_s.append(row["plan_ms"] / 1e3),
            cpu_s.append(row["cpu_ms"] / 1e3),
        ),
    )
    wall, steady = _rates(stamps, start, workers)
    return {
        "wall": wall,
        "steady": steady,
        "task_s": task_s,
        "cpu_s": cpu_s,
        "share": sum(cpu_s) / ((stamps[-1] - start) * workers),
        "driver_cpu_s": (time.process_time() - cpu0) / len(stamps),
    }


def labels_once(
    engine: Any, workers: int, objs: list[Any], out: Path, top_k: int
) -> dict[str, Any]:
    """One dataset run: labels per second (wall), the labels' own times in s."""
    import pyarrow.parquet as pq

    from wsgrasp.batch import run_dataset
    from wsgrasp.cli._plan import plan_spec

    spec = plan_spec(None, "franka_hand")
    stamps: list[tuple[float, int]] = []  # (arrival, labels) per scene
    start, cpu0 = time.perf_counter(), time.process_time()
    s = run_dataset(
        objs,
        spec,
        "franka_hand",
        out,
        engine,
        top_k=top_k,
        views=False,
        progress=False,
        on_scene=lambda row: stamps.append(
            (time.perf_counter(), row.get("labels") or 0)
        ),
    )
    wall = s.labels / (stamps[-1][0] - start)
    w = min(workers, len(stamps) - 1)
    later = sum(n for _, n in stamps[w:])
    steady = later / max(stamps[-1][0] - stamps[w - 1][0], 1e-9)
    driver = time.process_time() - cpu0
    rows = pq.read_table(out / "scenes").to_pylist()
    task_s = [x["sim_s"] / x["labels"] for x in rows if x["labels"]]
    return {
        "wall": wall,
        "steady": steady,
        "task_s": task_s,
        # a label's CPU: its scene's (drop, views, plan, labels) over its labels
        "cpu_s": [x["cpu_s"] / x["labels"] for x in rows if x["labels"]],
        "share": sum(x["cpu_s"] for x in rows) / ((stamps[-1][0] - start) * workers),
        "driver_cpu_s": driver / max(s.labels, 1),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--what", choices=("plans", "labels"), default="plans")
    ap.add_argument("--plans", type=int, default=320)
    ap.add_argument("--chunk", type=int, default=8)
    ap.add_argument("--objects", type=int, default=6)
    ap.add_argument("--top-k", type=int, default=3)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--engines", default="local,ray")
    args = ap.parse_args()
    configs = [(k, w) for k in args.engines.split(",") for w in (1, 2)]
    got: dict[tuple[str, int], list[dict[str, Any]]] = {c: [] for c in configs}
    with tempfile.TemporaryDirectory() as tmp:
        if args.what == "plans":
            work: Any = _scenes(Path(tmp), args.plans)
        else:
            from wsgrasp.sim.objects import resolve_objects

            work = resolve_objects([f"random:000-{args.objects - 1:03d}"]).objects
        # round after round, every configuration once each: the machine's load
        # changes over minutes, and each configuration sees the same changes
        for r in range(args.repeat):
            for kind, workers in configs:
                engine = _engine(kind, workers)
                try:
                    if kind == "ray":  # the Ray instance, outside the timings
                        engine._init()
                    load0 = os.getloadavg()[0]
                    out = Path(tmp) / f"{kind}{workers}-{r}"
                    if args.what == "plans":
                        res = plans_once(engine, workers, work, out, args.chunk)
                    else:
                        res = labels_once(engine, workers, work, out, args.top_k)
                finally:
                    engine.close()
                res["load"] = (load0 + os.getloadavg()[0]) / 2
                got[(kind, workers)].append(res)
                print(
                    f"round {r} {kind} x{workers}: {res['wall']:.2f}/s wall, "
                    f"{res['steady']:.2f} steady, CPU share {res['share']:.2f}, "
                    f"load {res['load']:.1f}",
                    flush=True,
                )
    unit = "plans/s" if args.what == "plans" else "labels/s"
    print(f"\n{os.cpu_count()} CPUs; medians of {args.repeat} rounds")
    rows = {}
    for (kind, workers), runs in got.items():
        row = {
            "wall": statistics.median(x["wall"] for x in runs),
            "steady": statistics.median(x["steady"] for x in runs),
            "task_s": statistics.median(t for x in runs for t in x["task_s"]),
            "cpu_s": statistics.median(t for x in runs for t in x["cpu_s"]),
            "share": statistics.median(x["share"] for x in runs),
            "driver_cpu_s": statistics.median(x["driver_cpu_s"] for x in runs),
            "load": statistics.median(x["load"] for x in runs),
        }
        rows[(kind, workers)] = row
        print(
            f"{kind:5s} x{workers}: {row['wall']:.2f} {unit} wall, "
            f"{row['steady']:.2f} steady, median task {row['task_s']:.3f} s "
            f"({row['cpu_s']:.3f} CPU s; driver {1e3 * row['driver_cpu_s']:.1f} ms), "
            f"CPU share {row['share']:.2f} of {workers} cores, "
            f"load average {row['load']:.1f}"
        )
    for kind in args.engines.split(","):
        one, two = rows[(kind, 1)], rows[(kind, 2)]
        print(
            f"{kind}: 1 -> 2 workers x{two['wall'] / one['wall']:.2f} wall, "
            f"x{two['steady'] / one['steady']:.2f} steady; a task took "
            f"x{two['task_s'] / one['task_s']:.2f} as long on 2 workers"
        )


if __name__ == "__main__":
    main()
