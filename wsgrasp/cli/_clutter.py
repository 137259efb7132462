"""``wsgrasp eval --scene pile|packed``: the clutter-removal benchmark
(:mod:`wsgrasp.sim.clutter`)."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

from wsgrasp.cli._common import console, err_console, print_json

__all__ = ["baseline_pairs", "clutter_eval", "clutter_spec"]


def clutter_spec(gripper: str, spec_file: str | None = None) -> dict[str, Any]:
    """The spec data a clutter run plans with: ``spec_file``'s as it is (its
    gripper replaced), or the gripper's default spec with the ``clutter``
    segmenter (the default segmenter's options kept when it was
    ``ransac_dbscan``, whose options ``clutter`` extends) and the ``highest``
    target rule."""
    from wsgrasp._loading import load_document
    from wsgrasp._names import gripper_ref
    from wsgrasp.default_specs import spec_for
    from wsgrasp.sim.specs import spec_arg
    from wsgrasp.spec import load_spec

    if spec_file is not None:
        _, path = spec_arg(spec_file)
        data, _ = load_document(path)
        data = dict(data)
    else:
        data, _ = spec_for("default", gripper)
        seg = dict(data.get("segmenter") or {})
        options = seg.get("options") if seg.get("name") == "ransac_dbscan" else None
        data["segmenter"] = {"name": "clutter", "options": dict(options or {})}
        data["target"] = {"rule": "highest"}
    data["gripper"] = gripper_ref(gripper, Path.cwd())
    data["record"] = {**(data.get("record") or {}), "enabled": False}
    load_spec(data)  # a bad spec fails before any scene is built
    return data


def clutter_eval(
    *,
    scene: str,
    grippers: list[str],
    objects: list[str],
    objects_per_scene: int,
    scenes: int,
    max_steps: int | None,
    seed: int,
    specs: list[str],
    params: Any,
    record_dir: Path | None,
    as_json: bool,
    json_out: Path | None,
    quiet: bool,
    baseline: bool = False,
    sim: list[str] | None = None,
    film_dir: Path | None = None,
) -> dict[str, Any]:
    """Run ``scenes`` clutter scenes of ``objects_per_scene`` objects drawn from
    ``objects`` for each gripper (the same objects and seeds for every
    gripper), print the table (or the JSON) and write the report. With
    ``baseline``, each scene is cleared a second time by random feasible
    candidates (``run_clutter_scene(pick="random")``), reported beside the
    choice with the paired differences over scenes (:func:`baseline_pairs`)."""
    from wsgrasp._version import library_versions
    from wsgrasp.api import Pipeline
    from wsgrasp.cli._eval import gains_not_applied
    from wsgrasp.errors import InputError
    from wsgrasp.sim import load_sim_gripper
    from wsgrasp.sim.clutter import (
        CLUTTER_SCENES,
        clutter_summary,
        run_clutter_scene,
        scene_draws,
    )
    from wsgrasp.sim.objects import resolve_objects
    from wsgrasp.spec import load_spec

    if scene not in CLUTTER_SCENES:
        raise InputError(
            f"--scene {scene!r} is unknown, expected single, "
            + ", ".join(CLUTTER_SCENES),
            hint="pass --scene pile, --scene packed, or leave it out",
        )
    if len(specs) > 1:
        raise InputError(
            f"a clutter run takes one --spec, got {len(specs)}",
            hint="run once per spec",
        )
    resolved = resolve_objects(list(objects), progress=not quiet and not as_json)
    pool = resolved.objects
    if len(pool) < objects_per_scene:
        raise InputError(
            f"--objects-per-scene {objects_per_scene} needs at least that many "
            f"objects, --objects gave {len(pool)}",
            hint="give a larger object range, e.g. --objects random:000-299",
        )
    draws = scene_draws(len(pool), objects_per_scene, scenes, seed)
    report: dict[str, Any] = {
        "kind": "clutter",
        "libraries": library_versions(),
        "scene": scene,
        "objects": ", ".join(objects),
        "objects_per_scene": objects_per_scene,
        "scenes": scenes,
        "max_steps": max_steps,
        "seed": seed,
        "baseline": "random" if baseline else None,
        "params": params.to_json(),
        "grippers": {},
    }
    t_all = time.perf_counter()
    for g in grippers:
        data = clutter_spec(g, specs[0] if specs else None)
        pipeline = Pipeline(load_spec(data))
        sim_gripper = load_sim_gripper(g, params)
        if not as_json:
            for line in gains_not_applied(sim, g, sim_gripper.notes_json()["gains"]):
                err_console.print(line)
        results: dict[str, list[dict[str, Any]]] = {"plan": [], "random": []}
        for i, draw in enumerate(draws):
            for pick in ("plan", "random") if baseline else ("plan",):
                sub = f"{scene}-{i:03d}" + ("-random" if pick == "random" else "")
                folder = film = None
                if record_dir is not None:
                    folder = record_dir / g.replace("/", "_") / sub
                if film_dir is not None:
                    film = film_dir / g.replace("/", "_") / sub
                r = run_clutter_scene(
                    [pool[k] for k in draw],
                    scene,
                    pipeline,
                    sim_gripper,
                    params,
                    seed + i,
                    max_steps=max_steps,
                    record_dir=folder,
                    pick=pick,
                    film_dir=film,
                )
                results[pick].append(r)
                if not quiet and not as_json:
                    err_console.print(
                        f"{g} {scene} {i + 1}/{scenes}"
                        + (" (random feasible)" if pick == "random" else "")
                        + f": {r['successes']}/{r['attempts']} grasps, "
                        f"{r['removed']}/{len(r['objects'])} removed ({r['end']})",
                        highlight=False,
                    )
        report["grippers"][g] = {
            "spec": {k: v for k, v in data.items() if k != "record"},
            "summary": clutter_summary(results["plan"]),
            "scenes": results["plan"],
        }
        if baseline:
            report["grippers"][g]["baseline"] = {
                "summary": clutter_summary(results["random"]),
                "paired": baseline_pairs(results["plan"], results["random"]),
                "scenes": results["random"],
            }
    report["wall_s"] = round(time.perf_counter() - t_all, 1)
    if json_out is not None:
        json_out.parent.mkdir(parents=True, exist_ok=True)
        json_out.write_text(json.dumps(report, indent=1) + "\n")
    if as_json:
        print_json(report)
    else:
        _print_table(report)
        if json_out is not None:
            err_console.print(f"wrote {json_out}")
    return report


#: the rates of one scene that a clutter run compares with chance: key in the
#: paired report, and the key of :func:`~wsgrasp.sim.clutter.clutter_summary`
#: that gives it (None where the scene had no attempt, or no object)
_SCENE_RATES = {
    "grasp_success": "grasp_success_rate",
    "target_lifted": "lift_rate",
    "declutter": "declutter_rate",
}


def baseline_pairs(
    chosen: list[dict[str, Any]], random: list[dict[str, Any]]
) -> dict[str, Any]:
    """The choice against chance over the same scenes: per rate (grasp
    success, target lifted, declutter; each a scene's own), the mean over the
    scenes where both runs have it, of the choice's, of chance's and of their
    difference, with the difference's 95 % interval
    (:func:`wsgrasp.sim.report.paired_difference`)."""
    from wsgrasp.sim.clutter import clutter_summary
    from wsgrasp.sim.report import INTERVAL, paired_difference

    each = [
        (clutter_summary([c]), clutter_summary([r]))
        for c, r in zip(chosen, random, strict=True)
    ]
    out: dict[str, Any] = {"interval": INTERVAL}
    for key, rate in _SCENE_RATES.items():
        pairs = [
            (c[rate], r[rate])
            for c, r in each
            if c[rate] is not None and r[rate] is not None
        ]
        n = len(pairs)
        diff, low, high = paired_difference([a - b for a, b in pairs])
        out[key] = {
            "scenes": n,
            "chosen": sum(a for a, _ in pairs) / n if n else None,
            "random": sum(b for _, b in pairs) / n if n else None,
            "difference": diff if n else None,
            "ci95": [low, high] if n else None,
        }
    return out


def _print_table(report: dict[str, Any]) -> None:
    from rich.table import Table

    table = Table(
        title=f"clutter removal: {report['scene']}, {report['objects_per_scene']} "
        f"objects per scene, {report['scenes']} scenes ({report['objects']}; "
        f"{report['params']['protocol']} protocol)"
    )
    for col in (
        "gripper",
        "attempts",
        "grasp success",
        "target lifted",
        "declutter",
        "plan ms (median / p90)",
        "failures",
        "touched a neighbour (before the target)",
    ):
        table.add_column(col)
    rows = []
    for g, r in report["grippers"].items():
        rows.append((g, r["summary"]))
        if "baseline" in r:
            rows.append((f"{g} (random feasible)", r["baseline"]["summary"]))
    for g, s in rows:
        gs, dr = s["grasp_success_rate"], s["declutter_rate"]
        lr = s.get("lift_rate")
        table.add_row(
            g,
            str(s["attempts"]),
            "-" if gs is None else f"{100 * gs:.1f} % ({s['successes']})",
            "-" if lr is None else f"{100 * lr:.1f} % ({s['target_lifted']})",
            "-" if dr is None else f"{100 * dr:.1f} % ({s['removed']}/{s['objects']})",
            "-"
            if s["first_plan_ms_median"] is None
            else f"{s['first_plan_ms_median']:.0f} / {s['first_plan_ms_p90']:.0f}",
            ", ".join(f"{k} {v}" for k, v in sorted(s["failure_kinds"].items())),
            f"{s.get('touched_neighbour', '-')} "
            f"({s.get('touched_neighbour_first', '-')})",
        )
    console.print(table)
    for g, r in report["grippers"].items():
        if "baseline" not in r:
            continue
        parts = []
        for key, label in (
            ("grasp_success", "grasp success"),
            ("target_lifted", "target lifted"),
            ("declutter", "declutter"),
        ):
            d = r["baseline"]["paired"][key]
            if d["difference"] is not None:
                lo, hi = d["ci95"]
                parts.append(
                    f"{label} {100 * d['difference']:+.1f} points "
                    f"[{100 * lo:+.1f}, {100 * hi:+.1f}]"
                )
        console.print(
            f"{g}: choice less random feasible, mean over scenes (95 % interval): "
            + "; ".join(parts),
            highlight=False,
        )
