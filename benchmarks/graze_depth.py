"""How deep a sliding fingertip may graze the table: grasp trials at several depths.

The search lets the closing sweep of a finger whose tip slides along the table
(``wsgrasp.planning.sweeps.slides``) dip ``GRAZE_SLACK`` below the table plane
before it backs the candidate off. This runs ``wsgrasp eval`` on one gripper with
that depth set to each of ``--depths`` in turn, the same objects, drops and
execution errors each time, and writes one report (the depths as its specs,
``graze-8mm`` and so on, each paired with the first over the same scenes) to
``--out``, as ``benchmarks/publish_result.py`` publishes it.

    python benchmarks/graze_depth.py --gripper allegro_right --objects random:000-299 \\
        --depths 0.015 0.008 0.005 0.03 \\
        --out docs/results/graze-depth/allegro_right-strict-000-299.json

The depths are tried on the development range (``random:000-299``).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from publish_result import head_commit, publish  # noqa: E402

#: the depth (m) a trial process uses, set by the parent before it starts its
#: workers (spawned workers import this file as their main module, so the
#: setting below is made in each of them)
_ENV = "WSGRASP_BENCH_GRAZE_DEPTH"
if os.environ.get(_ENV):
    import wsgrasp.planning.sweeps as _sweeps

    _sweeps.GRAZE_SLACK = float(os.environ[_ENV])


def label(depth: float) -> str:
    return f"graze-{1000 * depth:g}mm"


def run_depth(
    depth: float, gripper: str, objects: str, params: Any, seed: int, workers: int
) -> list[dict[str, Any]]:
    """The trial records of one depth (the gripper's default spec; ``params``
    the protocol's ``SimParams``)."""
    from wsgrasp.sim import EvalConfig, run_eval, spec_entries
    from wsgrasp.sim.objects import resolve_objects

    os.environ[_ENV] = repr(depth)
    import wsgrasp.planning.sweeps as sweeps

    sweeps.GRAZE_SLACK = depth  # this process too (workers=1 runs here)
    objs = resolve_objects([objects], workers=workers, progress=False).objects
    entries = spec_entries([gripper], None, paper=False, followup=False)
    config = EvalConfig(
        objects=objs, specs=entries, trials=1, seed=seed, params=params, workers=workers
    )
    records, _ = run_eval(config, progress=True)
    for r in records:
        r["spec"] = label(depth)
    return records


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gripper", default="allegro_right")
    ap.add_argument("--objects", default="random:000-299")
    ap.add_argument("--depths", type=float, nargs="+", required=True)
    ap.add_argument("--protocol", default="strict")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--workers", type=int, default=0)
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args(argv)
    from wsgrasp.cli._eval import sim_params
    from wsgrasp.sim import build_report

    params = sim_params(
        args.protocol, drop="natural", mass=None, density=None, friction=None, sim=[]
    )
    records: list[dict[str, Any]] = []
    for depth in args.depths:
        records += run_depth(
            depth, args.gripper, args.objects, params, args.seed, args.workers
        )
    report = build_report(
        records,
        primary=label(args.depths[0]),
        meta={
            "objects": args.objects,
            "grippers": [args.gripper],
            "trials_per_object": 1,
            "seed": args.seed,
            "params": params.to_json(),
            "graze_depths_m": args.depths,
        },
    )
    command = "python benchmarks/graze_depth.py " + " ".join(
        argv if argv is not None else sys.argv[1:]
    )
    out = publish(report, commit=head_commit(), command=command)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(out, indent=2) + "\n")
    for res in out["results"]:
        print(res["spec"], res["successes"], "of", res["trials"])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
