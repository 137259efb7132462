"""How the structured (dense) evaluation grows with the number of candidates.

The README's dense scaling table: per gripper, the bench's dense orientations times
the smallest cubic grid of box samples reaching each count, evaluation medians (the
unstructured path alternating up to ``--old-up-to`` candidates), cost per candidate
and peak memory (``wsgrasp.bench.dense_scaling``). Run from the repository root::

    .venv/bin/python benchmarks/dense_scaling.py
    .venv/bin/python benchmarks/dense_scaling.py --counts 10000 100000 1000000 --json
"""

from __future__ import annotations

import argparse
import json

from wsgrasp.api import Pipeline, as_scene
from wsgrasp.bench import DENSE, dense_scaling, project_root
from wsgrasp.planning import _dense_numba
from wsgrasp.spec import load_spec


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grippers", nargs="+", default=["franka_hand", "allegro_right"])
    ap.add_argument(
        "--counts", nargs="+", type=int, default=[10_000, 100_000, 1_000_000]
    )
    ap.add_argument("--old-up-to", type=int, default=160_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", action="store_true", help="print JSON rows")
    args = ap.parse_args()
    root = project_root()
    scene = as_scene(root / "examples" / "scenes" / "box_upright.npz")
    specs = {"franka_hand": "franka", "allegro_right": "allegro"}
    rows = []
    for gripper in args.grippers:
        spec = load_spec(root / "examples" / "specs" / f"{specs[gripper]}.yaml")
        spec.sampling = spec.sampling.model_validate(
            {**spec.sampling.model_dump(), **DENSE[gripper]}
        )
        pipe = Pipeline(spec)
        rows += dense_scaling(
            pipe,
            pipe.prepare(scene),
            tuple(args.counts),
            old_up_to=args.old_up_to,
            repeat=args.repeat,
        )
    for r in rows:
        r["compiled"] = _dense_numba.available()
    if args.json:
        print(json.dumps(rows, indent=1))
        return
    print(
        "| gripper | candidates | old (per candidate) | structured (per candidate) "
        "| ratio | peak (structured) |"
    )
    print("|---|---:|---:|---:|---:|---:|")
    for r in rows:
        old = (
            f"{r['evaluate_ms']:.0f} ms ({r['us_per_candidate']:.1f} µs)"
            if r["evaluate_ms"] == r["evaluate_ms"]
            else "not run"
        )
        ratio = (
            f"{r['evaluate_ms'] / r['evaluate_structured_ms']:.1f}×"
            if r["evaluate_ms"] == r["evaluate_ms"]
            else ""
        )
        print(
            f"| {r['gripper']} | {r['candidates']:,} | {old} | "
            f"{r['evaluate_structured_ms']:.0f} ms "
            f"({r['structured_us_per_candidate']:.2f} µs) | {ratio} | "
            f"{r['peak_mb']:.0f} MB |"
        )


if __name__ == "__main__":
    main()
