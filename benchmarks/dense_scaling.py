"""How the evaluation of a dense candidate set grows with the number of candidates.

Per gripper, the bench's dense orientations times the smallest cubic grid of box
samples reaching each count: evaluation medians, cost per candidate, peak memory
and whether the compiled loops ran (``wsgrasp.bench.dense_scaling``). Run from the
repository root::

    .venv/bin/python benchmarks/dense_scaling.py
    .venv/bin/python benchmarks/dense_scaling.py --counts 10000 100000 1000000 --json
"""

from __future__ import annotations

import argparse
import json

from wsgrasp.api import Pipeline, as_scene
from wsgrasp.bench import DENSE, dense_scaling, project_root
from wsgrasp.spec import load_spec


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grippers", nargs="+", default=["franka_hand", "allegro_right"])
    ap.add_argument(
        "--counts", nargs="+", type=int, default=[10_000, 100_000, 1_000_000]
    )
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
            pipe, pipe.prepare(scene), tuple(args.counts), repeat=args.repeat
        )
    if args.json:
        print(json.dumps(rows, indent=1))
        return
    print("| gripper | candidates | evaluation (per candidate) | peak | compiled |")
    print("|---|---:|---:|---:|:---:|")
    for r in rows:
        print(
            f"| {r['gripper']} | {r['candidates']:,} | {r['evaluate_ms']:.0f} ms "
            f"({r['us_per_candidate']:.2f} µs) | {r['peak_mb']:.0f} MB | "
            f"{'yes' if r['compiled'] else 'no'} |"
        )


if __name__ == "__main__":
    main()
