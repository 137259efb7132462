"""Which scorers pick grasps that hold: every score term against simulated labels.

For each gripper, ``wsgrasp dataset`` labels, in every scene of ``--objects``, the
plan's choice and ``--random`` uniformly random feasible candidates under the
trial protocol (strict by default), with every registered scorer's term recorded
(the gripper's default spec, each scorer it lacks added with weight 0, so the
choice is the default spec's). Then, over the random picks of each scene:

- a term's *concordance*: of the pairs (a candidate that held, one that did not)
  in the same scene, the share in which the term ranks the one that held higher
  (ties count half): 0.5 is no better than a coin, 1 a perfect ranking;
- a term's *pick rate*: the success of the random pick the term alone would
  choose in each scene (ties averaged), beside the random picks' rate (chance)
  and the choice's own rate; the same for the default spec's weights.
- a term's *margin concordance*: of the pairs of random picks that both held in
  the same scene, the share in which the term ranks higher the one whose grip
  used less of its friction at the end of the hold (the label's
  ``friction_use``): where almost every grasp holds, as a jaw's on small
  objects, this ranks the held grasps by how far they were from slipping.

The summary goes to ``--out`` (``docs/results/scorers.json``, where the
documentation renders it) with the commit, machine, protocol and object range.

    python benchmarks/scorer_concordance.py --objects random:000-059 --random 15
    python benchmarks/scorer_concordance.py --from-dataset franka_hand=runs/ds_franka

The object range is the development range (``random:000-299``): choose weights
here, report success on the held-out range.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from publish_result import head_commit, machine  # noqa: E402


def all_terms_spec(gripper: str) -> dict[str, Any]:
    """The gripper's default spec with every registered scorer it lacks at
    weight 0: the same choice, every term recorded."""
    from wsgrasp.default_specs import default_spec
    from wsgrasp.plugins import get_registry

    data, _ = default_spec(gripper)
    data = {k: v for k, v in data.items() if k != "record"}
    have = {s["name"] for s in data["scorers"]}
    extra = [
        {"name": n, "weight": 0.0}
        for n in sorted(get_registry().names("scorers"))
        if n not in have
    ]
    return {**data, "scorers": [*data["scorers"], *extra]}


def label(gripper: str, objects: str, random_k: int, protocol: str, out: Path) -> None:
    """Run the dataset of ``gripper`` into ``out`` (candidates and scenes)."""
    from wsgrasp.batch import LocalEngine, run_dataset
    from wsgrasp.sim.objects import resolve_objects
    from wsgrasp.sim.params import SimParams
    from wsgrasp.spec import load_spec

    spec = load_spec(all_terms_spec(gripper))
    objs = resolve_objects([objects]).objects
    run_dataset(
        objs,
        spec,
        gripper,
        out,
        LocalEngine(0),
        top_k=1,
        random_k=random_k,
        params=SimParams.for_protocol(protocol),
        views=False,
        progress=True,
    )


def analyse(folder: Path) -> dict[str, Any]:
    """Concordance and pick rate of every term in the dataset at ``folder``."""
    import pyarrow.parquet as pq

    rows = pq.read_table(folder / "candidates").to_pylist()
    scenes: dict[tuple[str, int], list[dict[str, Any]]] = {}
    for r in rows:
        if r["random_pick"] and r["label"] is not None:
            scenes.setdefault((r["object"], r["trial"]), []).append(r)
    chosen = [r for r in rows if r["chosen"] and r["label"] is not None]
    terms = sorted(dict(rows[0]["score_terms"])) if rows else []
    weights = _weights(folder)

    def value(r: dict[str, Any], w: dict[str, float]) -> float:
        t = dict(r["score_terms"])
        return sum(wt * t[name] for name, wt in w.items())

    def pick_rate(w: dict[str, float]) -> float:
        rates = []
        for picks in scenes.values():
            v = np.array([value(r, w) for r in picks])
            best = np.flatnonzero(v == v.max())
            rates.append(np.mean([picks[i]["success"] for i in best]))
        return float(np.mean(rates)) if rates else float("nan")

    def concordance(name: str) -> tuple[float, int]:
        agree = pairs = 0.0
        for picks in scenes.values():
            held = np.array(
                [dict(r["score_terms"])[name] for r in picks if r["success"]]
            )
            lost = np.array(
                [dict(r["score_terms"])[name] for r in picks if not r["success"]]
            )
            if len(held) and len(lost):
                diff = held[:, None] - lost[None, :]
                agree += float((diff > 0).sum() + 0.5 * (diff == 0).sum())
                pairs += diff.size
        return (agree / pairs if pairs else float("nan")), int(pairs)

    def margin_concordance(name: str) -> tuple[float, int]:
        """Over pairs of held picks in one scene: the share in which the term
        ranks higher the one whose grip used less of its friction (ties half)."""
        agree = pairs = 0.0
        for picks in scenes.values():
            held = [
                r for r in picks if r["success"] and r.get("friction_use") is not None
            ]
            if len(held) < 2:
                continue
            term = np.array([dict(r["score_terms"])[name] for r in held])
            use = np.array([float(r["friction_use"]) for r in held])
            firmer = use[:, None] < use[None, :]  # (i, j): i held more firmly
            diff = term[:, None] - term[None, :]
            agree += float(
                ((diff > 0) & firmer).sum() + 0.5 * ((diff == 0) & firmer).sum()
            )
            pairs += float(firmer.sum())
        return (agree / pairs if pairs else float("nan")), int(pairs)

    random_all = [r["success"] for picks in scenes.values() for r in picks]
    out_terms = {}
    for name in terms:
        c, n = concordance(name)
        mc, mn = margin_concordance(name)
        out_terms[name] = {
            "concordance": round(c, 4),
            "pairs": n,
            "margin_concordance": None if mn == 0 else round(mc, 4),
            "margin_pairs": mn,
            "pick_rate": round(pick_rate({name: 1.0}), 4),
            "default_weight": weights.get(name, 0.0),
        }
    return {
        "scenes": len(scenes),
        "random_labels": len(random_all),
        "random_success": round(float(np.mean(random_all)), 4) if random_all else None,
        "chosen_labels": len(chosen),
        "chosen_success": round(float(np.mean([r["success"] for r in chosen])), 4)
        if chosen
        else None,
        "default_pick_rate": round(
            pick_rate({k: v for k, v in weights.items() if v}), 4
        ),
        "terms": out_terms,
    }


def _weights(folder: Path) -> dict[str, float]:
    meta = folder / "scorer_weights.json"
    return json.loads(meta.read_text()) if meta.is_file() else {}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gripper", action="append", default=None)
    ap.add_argument("--objects", default="random:000-059")
    ap.add_argument("--random", type=int, default=15, dest="random_k")
    ap.add_argument("--protocol", default="strict")
    ap.add_argument("--work", type=Path, default=ROOT / "eval-results" / "scorers")
    ap.add_argument(
        "--from-dataset",
        action="append",
        default=[],
        metavar="GRIPPER=FOLDER",
        help="analyse a dataset already labelled (with --random) instead",
    )
    ap.add_argument(
        "--out", type=Path, default=ROOT / "docs" / "results" / "scorers.json"
    )
    ap.add_argument("--commit", default=None)
    args = ap.parse_args(argv)
    commit = args.commit or head_commit()
    folders: dict[str, Path] = {}
    for item in args.from_dataset:
        g, _, f = item.partition("=")
        folders[g] = Path(f)
    for g in args.gripper or ([] if folders else ["franka_hand", "allegro_right"]):
        folder = args.work / Path(g).stem  # a gripper's name, or its YAML's
        spec = all_terms_spec(g)
        t0 = time.perf_counter()
        label(g, args.objects, args.random_k, args.protocol, folder)
        print(f"{g}: labelled in {time.perf_counter() - t0:.0f} s", flush=True)
        weights = {s["name"]: float(s.get("weight", 1.0)) for s in spec["scorers"]}
        (folder / "scorer_weights.json").write_text(json.dumps(weights))
        folders[g] = folder
    report = {
        "commit": commit,
        "machine": machine(),
        "date": time.strftime("%Y-%m-%d"),
        "command": "python benchmarks/scorer_concordance.py "
        + " ".join(argv or sys.argv[1:]),
        "objects": args.objects,
        "protocol": args.protocol,
        "random_per_scene": args.random_k,
        "grippers": {g: analyse(f) for g, f in folders.items()},
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(report, indent=1) + "\n")
    for g, r in report["grippers"].items():
        print(
            f"{g}: {r['scenes']} scenes, choice {r['chosen_success']}, chance "
            f"{r['random_success']}, default weights' pick {r['default_pick_rate']}"
        )
        for name, t in sorted(r["terms"].items(), key=lambda kv: -kv[1]["concordance"]):
            margin = t.get("margin_concordance")
            print(
                f"  {name:20s} concordance {t['concordance']:.3f} ({t['pairs']} pairs)"
                f"  pick {t['pick_rate']:.3f}"
                + (
                    ""
                    if margin is None
                    else f"  margin {margin:.3f} ({t['margin_pairs']} pairs)"
                )
            )
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
