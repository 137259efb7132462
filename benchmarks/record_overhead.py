"""What recording a run costs: plan time with and without a ``RunRecorder``.

Runs ``Pipeline(spec).plan(scene)`` alternately without and with a recorder (to a
temporary file, deleted after each run), so that load on a shared machine hits both
alike, and prints medians: plan time, recording overhead (ms and %), file size and
the recorder's own time (``RunRecorder.overhead_ms``).

    .venv/bin/python benchmarks/record_overhead.py [--runs 15] [--spec S ...]
        [--scene S ...] [--json]

The time with a recorder is the wall time of ``plan`` including finishing the file
(``on_result`` waits for everything queued to be written).
"""

from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SPECS = ["examples/specs/franka.yaml", "examples/specs/allegro.yaml"]
SCENES = ["examples/scenes/box_upright.npz", "examples/scenes/cone_views/scene.yaml"]


def measure(spec_path: str, scene_path: str, runs: int) -> dict[str, object]:
    from wsgrasp import Pipeline, load_spec
    from wsgrasp.perception.io import load_scene
    from wsgrasp.record import RunRecorder

    pipe = Pipeline(load_spec(ROOT / spec_path))
    scene = load_scene(ROOT / scene_path)
    plain: list[float] = []
    recorded: list[float] = []
    inside: list[float] = []
    sizes: list[int] = []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(runs + 2):  # the first two warm up
            t0 = time.perf_counter()
            pipe.plan(scene)
            t1 = time.perf_counter()
            path = Path(tmp) / f"run{i}.mcap"
            rec = RunRecorder(path)
            t2 = time.perf_counter()
            pipe.plan(scene, observers=[rec])
            rec.close()
            t3 = time.perf_counter()
            if i >= 2:
                plain.append((t1 - t0) * 1e3)
                recorded.append((t3 - t2) * 1e3)
                inside.append(rec.overhead_ms)
                sizes.append(path.stat().st_size)
            path.unlink()
    p, r = statistics.median(plain), statistics.median(recorded)
    # median of the paired differences: robust to drifting load
    d = statistics.median(b - a for a, b in zip(plain, recorded, strict=True))
    return {
        "spec": spec_path,
        "gripper": pipe.gripper.name,
        "scene": scene_path,
        "points": int(scene.points.shape[0]),
        "views": len(scene.views),
        "runs": runs,
        "plan_ms": round(p, 2),
        "recorded_ms": round(r, 2),
        "overhead_ms": round(r - p, 2),
        "overhead_pct": round(100 * (r - p) / p, 1),
        "paired_overhead_ms": round(d, 2),
        "recorder_ms": round(statistics.median(inside), 2),
        "file_mb": round(statistics.median(sizes) / 1e6, 3),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=15)
    ap.add_argument("--spec", action="append")
    ap.add_argument("--scene", action="append")
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    rows = [
        measure(spec, scene, a.runs)
        for spec in a.spec or SPECS
        for scene in a.scene or SCENES
    ]
    if a.json:
        print(json.dumps(rows, indent=2))
        return
    head = (
        f"{'gripper':<14}{'scene':<24}{'points':>8}{'plan ms':>9}{'+rec ms':>9}"
        f"{'%':>7}{'paired':>8}{'inside':>8}{'MB':>8}"
    )
    print(head)
    for row in rows:
        print(
            f"{row['gripper']!s:<14}{Path(str(row['scene'])).parent.name + '/' + Path(str(row['scene'])).name:<24.24}"
            f"{row['points']:>8}{row['plan_ms']:>9}{row['overhead_ms']:>9}"
            f"{row['overhead_pct']:>7}{row['paired_overhead_ms']:>8}"
            f"{row['recorder_ms']:>8}{row['file_mb']:>8}"
        )


if __name__ == "__main__":
    main()
