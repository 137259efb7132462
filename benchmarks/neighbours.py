"""The closing-path test against neighbours (``wsgrasp.neighbours.
blocked_in_closing``) on simulated piles: numpy's per-finger passes against the
compiled pass, alternating calls on the same candidates and obstacles, with the
answers compared. Medians (ms) per pile and overall.

    .venv/bin/python benchmarks/neighbours.py [--gripper allegro_right]
        [--objects random:000-299] [--scenes 5] [--repeat 7]

Needs the ``sim`` extra (the piles are MuJoCo scenes, as ``wsgrasp eval --scene
pile`` builds them).
"""

from __future__ import annotations

import argparse
import statistics
import time
import types

import numpy as np

import wsgrasp.neighbours as nb
from wsgrasp.api import Pipeline
from wsgrasp.cli._clutter import clutter_spec
from wsgrasp.planning import _compiled
from wsgrasp.sim.clutter import ClutterWorld, place_objects, render_world
from wsgrasp.sim.objects import load_objects
from wsgrasp.sim.params import SimParams
from wsgrasp.spec import load_spec


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gripper", default="allegro_right")
    ap.add_argument("--objects", default="random:000-299")
    ap.add_argument("--scenes", type=int, default=5)
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()

    p = SimParams.for_protocol("strict")
    pool = load_objects([args.objects])
    pipe = Pipeline(load_spec(clutter_spec(args.gripper)))
    _compiled.load()
    real = nb._compiled
    numpy_only = types.SimpleNamespace(loaded=lambda: False)
    calls: list[tuple] = []
    closing = nb.blocked_in_closing

    def spy(*a, **k):  # the plan's own call, kept to be timed again
        calls.append((a, k))
        return closing(*a, **k)

    nb.blocked_in_closing = spy
    rows = []
    for seed in range(args.scenes):
        rng = np.random.default_rng(seed)
        picked = [pool[int(i)] for i in rng.choice(len(pool), 5, replace=False)]
        world = ClutterWorld.build(picked, p)
        place_objects(world, "pile", rng, p)
        scene, _, _ = render_world(world, rng, p)
        calls.clear()
        pipe.plan(scene)
        if not calls:
            continue
        a, k = calls[-1]
        times: dict[str, list[float]] = {"numpy": [], "compiled": []}
        answers = {}
        for i in range(2 * args.repeat):
            name = "numpy" if i % 2 else "compiled"
            nb._compiled = numpy_only if name == "numpy" else real
            t = time.perf_counter()
            answers[name] = closing(*a, **k)
            times[name].append((time.perf_counter() - t) * 1e3)
        nb._compiled = real
        pairs = len(a[1]) * sum(len(o) for o in a[2])
        same = bool(np.array_equal(answers["numpy"], answers["compiled"]))
        row = (seed, len(a[1]), pairs, *(statistics.median(times[n]) for n in times))
        rows.append(row)
        print(
            f"pile {seed}: {row[1]} candidates, {pairs} pairs: numpy {row[3]:.1f} ms, "
            f"compiled {row[4]:.1f} ms, same answers: {same}"
        )
        if not same:
            raise SystemExit("the compiled pass answered differently")
    if rows:
        ratio = statistics.median(r[3] / r[4] for r in rows)
        print(
            f"{args.gripper}, {len(rows)} piles: numpy "
            f"{statistics.median(r[3] for r in rows):.1f} ms, compiled "
            f"{statistics.median(r[4] for r in rows):.1f} ms (median ratio {ratio:.1f})"
        )


if __name__ == "__main__":
    main()
