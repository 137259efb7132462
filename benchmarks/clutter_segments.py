"""How well the ``clutter`` segmenter splits simulated piles into their objects.

Each scene is built as ``wsgrasp eval --scene pile|packed`` builds it (the same
object draws and seeds: ``--seed`` and scene ``i`` give seed ``seed + i``),
settled in MuJoCo and rendered from the same cameras; the segmenter runs on the
cloud downsampled as the default spec does, and every instance is compared
with the meshes the points came from (each point belongs to the nearest
surface). Per option set it prints:

- ``merged``: instances whose second object holds ``WRONG_SPLIT_SHARE`` (20 %)
  of their points or more (what a clutter run counts as ``wrong_split`` when it
  is the target);
- ``target merged``: those among the ``highest`` instances, the target of a
  clutter run's first step;
- ``split``: objects with a quarter of their points or more in each of two
  instances or more (an object cut at a seam of its own);
- ``instances`` and ``objects`` seen (30 points or more).

Only the first step of each scene is measured (nothing has been picked yet).

    .venv/bin/python benchmarks/clutter_segments.py --objects random:000-299 \
        --scenes 40 --set min_instance_extent=0.02 --set min_instance_extent=0.015

Each ``--set`` is one option set (``KEY=VALUE[,KEY=VALUE...]``); without one,
the segmenter's defaults. ``--json-out`` writes the figures.
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from wsgrasp.errors import WsgraspError
from wsgrasp.perception.process import downsample
from wsgrasp.sim.clutter import (
    WRONG_SPLIT_SHARE,
    ClutterWorld,
    object_owners,
    place_objects,
    render_world,
    scene_draws,
)
from wsgrasp.sim.objects import resolve_objects
from wsgrasp.sim.params import SimParams

#: an object with this share of its points in each of two instances is split
SPLIT_SHARE = 0.25
#: an object with fewer points is not counted as seen
SEEN_POINTS = 30


def _options(text: str) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for item in filter(None, text.split(",")):
        key, _, value = item.partition("=")
        out[key.strip()] = json.loads(value)
    return out


def scenes(
    objects: str, kind: str, count: int, per_scene: int, seed: int
) -> list[dict[str, Any]]:
    """Rendered first steps: cloud (downsampled), viewpoints and each point's
    object, as ``wsgrasp eval --scene`` would build them."""
    p = SimParams.for_protocol("strict")
    pool = resolve_objects([objects], progress=False).objects
    out = []
    for i, draw in enumerate(scene_draws(len(pool), per_scene, count, seed)):
        objs = [pool[k] for k in draw]
        r = np.random.default_rng(seed + i)
        world = ClutterWorld.build(objs, p)
        place_objects(world, kind, r, p)
        world.set_poses(world.poses(), world.present)
        scene, _, meshes = render_world(world, r, p)
        points = downsample(scene.points, 0.005)
        out.append(
            {
                "points": points,
                "viewpoints": scene.viewpoints(),
                "owner": object_owners(points, meshes),
                "objects": len(meshes),
            }
        )
        print(f"{kind} {i + 1}/{count}", flush=True)
    return out


def score(data: list[dict[str, Any]], options: dict[str, Any]) -> dict[str, int]:
    """The counts of the module docstring for one option set."""
    from wsgrasp_segmenters.clutter import Clutter, ClutterOptions

    o = ClutterOptions(**options)
    totals = dict.fromkeys(
        ("merged", "target merged", "split", "instances", "objects", "refused"), 0
    )
    for s in data:
        try:
            seg = Clutter().segment(s["points"], o, seed=0, viewpoints=s["viewpoints"])
        except WsgraspError:  # no table, or nothing on it: counted
            totals["refused"] += 1
            continue
        tree = cKDTree(s["points"])
        n = s["objects"]
        share = np.zeros((len(seg.clusters), n))  # (instances, objects) points
        tops = []
        for a, c in enumerate(seg.clusters):
            _, idx = tree.query(c)
            share[a] = np.bincount(s["owner"][idx], minlength=n)
            tops.append(float(seg.table.signed_distance(c).max()))
        ranked = np.sort(share, axis=1)
        merged = (
            ranked[:, -2] >= WRONG_SPLIT_SHARE * share.sum(axis=1)
            if n > 1
            else np.zeros(len(share), dtype=bool)
        )
        per_object = share.sum(axis=0)
        seen = per_object >= SEEN_POINTS
        split = ((share >= SPLIT_SHARE * per_object).sum(axis=0) >= 2) & seen
        totals["merged"] += int(merged.sum())
        totals["target merged"] += int(merged[int(np.argmax(tops))]) if tops else 0
        totals["split"] += int(split.sum())
        totals["instances"] += len(seg.clusters)
        totals["objects"] += int(seen.sum())
    return totals


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--objects", default="random:000-299")
    ap.add_argument("--scene", action="append", choices=["pile", "packed"])
    ap.add_argument("--scenes", type=int, default=40)
    ap.add_argument("--objects-per-scene", type=int, default=5)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--set", action="append", default=[], dest="sets")
    ap.add_argument("--json-out", type=Path)
    args = ap.parse_args()
    kinds = args.scene or ["pile", "packed"]
    data = {
        k: scenes(args.objects, k, args.scenes, args.objects_per_scene, args.seed)
        for k in kinds
    }
    rows = []
    for text in args.sets or [""]:
        options = _options(text)
        for k in kinds:
            row = {"scene": k, "options": options, **score(data[k], options)}
            rows.append(row)
            print(
                f"{k:6s} {text or 'defaults':45s} "
                + "  ".join(
                    f"{key} {row[key]}"
                    for key in row
                    if key not in ("scene", "options")
                ),
                flush=True,
            )
    if args.json_out is not None:
        args.json_out.parent.mkdir(parents=True, exist_ok=True)
        report = {
            "objects": args.objects,
            "scenes": args.scenes,
            "objects_per_scene": args.objects_per_scene,
            "seed": args.seed,
            "load_average": list(os.getloadavg()),
            "rows": rows,
        }
        args.json_out.write_text(json.dumps(report, indent=1) + "\n")


if __name__ == "__main__":
    main()
