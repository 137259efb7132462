"""``wsgrasp eval``: physics grasp trials in MuJoCo, the paper's Table II."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer

from wsgrasp.cli._common import console, err_console, number, print_json

if TYPE_CHECKING:
    from wsgrasp.sim.objects import ObjectList
    from wsgrasp.sim.params import SimParams


def register(app: typer.Typer) -> None:
    """Add this module's commands to ``app``."""
    app.command("eval")(eval_command)


def eval_command(
    grippers: list[str] = typer.Option(
        ["franka_hand"],
        "--gripper",
        "-g",
        help="Registered gripper name or gripper YAML; repeat for several.",
    ),
    objects: list[str] = typer.Option(
        ["paper13"],
        "--objects",
        help="Object set (paper13; random: pybullet_data's 1,000 objects, or a "
        "range random:000-299, random:7), object names of paper13, or mesh files "
        "(OBJ/STL/PLY, metres); repeat for several.",
    ),
    trials: int = typer.Option(10, "--trials", "-n", min=1, help="Trials per object."),
    seed: int = typer.Option(0, "--seed", help="Random seed of drops and cameras."),
    specs: list[str] = typer.Option(
        [],
        "--spec",
        "-s",
        help="Pipeline spec FILE or LABEL=FILE (its gripper is replaced by each "
        "--gripper); repeat to compare. Default: wsgrasp's default spec and the "
        "paper's centroid_distance alone.",
    ),
    paper: bool = typer.Option(
        True,
        "--paper/--no-paper",
        help="Also run the paper's sampling and scorer alone (without --spec).",
    ),
    followup: bool = typer.Option(
        False,
        "--followup",
        help="Also run the authors' follow-up sampling (xyz orientations, the "
        "gripper's specs/followup.yaml; without --spec).",
    ),
    protocol: str = typer.Option(
        "strict",
        "--protocol",
        help="strict: execution error, six disturbances of the object's weight "
        "after the lift, slip in the grip fails, friction 0.5; lift: lift 20 cm "
        "and hold 10 s, friction 0.8 (the earlier protocol).",
    ),
    mass: float | None = typer.Option(
        None,
        "--mass",
        callback=number(0.0, 100.0, above=True),
        help="Object mass (kg) for every object, overriding the objects' own.",
    ),
    density: float | None = typer.Option(
        None,
        "--density",
        callback=number(0.0, 100000.0, above=True),
        help="Density (kg/m³) of objects without a mass of their own (mesh files "
        "without masses.json, the random set): mass = density × volume. "
        "Default 1200.",
    ),
    friction: float | None = typer.Option(
        None,
        "--friction",
        callback=number(0.0, 10.0, above=True),
        help="Object friction coefficient, overriding the protocol's.",
    ),
    sim: list[str] = typer.Option(
        [],
        "--sim",
        help="KEY=VALUE: set a simulation parameter (a field of "
        "wsgrasp.sim.params.SimParams, e.g. kp_revolute=10, the finger joints' "
        "gain in N·m/rad) over the protocol's; repeat for several. The report's "
        "params give what the trials used.",
    ),
    baseline: str | None = typer.Option(
        None,
        "--baseline",
        help="random: beside each plan's choice, execute uniformly random feasible "
        "candidates of the same plan, finished as the choice is; the report "
        "gives chosen, random and their paired difference. With --scene "
        "pile/packed: each scene is cleared a second time, every step executing "
        "a random feasible candidate of its plan.",
    ),
    baseline_n: int = typer.Option(
        3,
        "--baseline-n",
        min=1,
        help="With --baseline random: random candidates per plan (single "
        "objects; a clutter scene is cleared once by random candidates).",
    ),
    drop: str = typer.Option(
        "natural",
        "--drop",
        help="natural: objects put down upright as modelled (random position, "
        "yaw, tilt up to 15°); random: any orientation.",
    ),
    workers: int = typer.Option(
        0, "--workers", "-j", min=0, help="Processes (0: one per CPU core)."
    ),
    engine: str = typer.Option(
        "local",
        "--engine",
        help="local: a process pool on this machine; ray: Ray tasks (extra "
        "'ray'), the same outcomes trial for trial.",
    ),
    address: str | None = typer.Option(
        None, "--address", help="Ray cluster address; local Ray without it."
    ),
    as_json: bool = typer.Option(False, "--json", help="Print the report as JSON."),
    json_out: Path | None = typer.Option(
        None, "--json-out", help="Write the report as JSON here."
    ),
    md_out: Path | None = typer.Option(
        None, "--md-out", help="Write the tables as Markdown here."
    ),
    record_dir: Path | None = typer.Option(
        None, "--record-dir", help="Record every plan to MCAP files in this folder."
    ),
    film_dir: Path | None = typer.Option(
        None,
        "--film",
        help="Draw every executed grasp's trial step by step (approach, closing, "
        "lift, hold, each pull) as a PNG in this folder, named as --record-dir "
        "names its plan (a clutter run: a folder per scene, a PNG per step).",
    ),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bar."),
    scene: str = typer.Option(
        "single",
        "--scene",
        help="single: one object per trial; pile or packed: clutter removal "
        "(objects dropped together, or upright side by side; pick until clear).",
    ),
    objects_per_scene: int = typer.Option(
        5, "--objects-per-scene", min=1, max=20, help="With --scene pile/packed."
    ),
    scenes: int = typer.Option(
        10, "--scenes", min=1, help="With --scene pile/packed: scenes per gripper."
    ),
    max_steps: int | None = typer.Option(
        None,
        "--max-steps",
        min=1,
        help="With --scene pile/packed: attempts per scene (default twice the "
        "objects).",
    ),
) -> None:
    """Grasp trials in MuJoCo: drop, look (3 depth views), plan, approach, close,
    lift 20 cm, then (strict) disturb the object along six directions; success
    rate and plan time per object and gripper, beside chance with --baseline."""
    from wsgrasp.batch.engine import make_engine
    from wsgrasp.errors import InputError
    from wsgrasp.sim import (
        EvalConfig,
        build_report,
        load_sim_gripper,
        report_markdown,
        report_table,
        require_mujoco,
        run_eval,
        spec_entries,
    )
    from wsgrasp.sim.objects import resolve_objects

    require_mujoco()
    eng = make_engine(engine, workers, address)  # a bad --engine: before any work
    if drop not in ("natural", "random"):
        raise InputError(
            f"--drop {drop!r} is unknown, expected natural or random",
            hint="pass --drop natural",
        )
    if baseline not in (None, "random"):
        raise InputError(
            f"--baseline {baseline!r} is unknown, expected random",
            hint="pass --baseline random, or leave it out",
        )
    params = sim_params(
        protocol,
        drop=drop,
        mass=mass,
        density=density,
        friction=friction,
        sim=sim,
    )
    if scene != "single":
        from wsgrasp.cli._clutter import clutter_eval

        clutter_eval(
            scene=scene,
            grippers=list(grippers),
            objects=list(objects),
            objects_per_scene=objects_per_scene,
            scenes=scenes,
            max_steps=max_steps,
            seed=seed,
            specs=list(specs),
            params=params,
            record_dir=record_dir,
            as_json=as_json,
            json_out=json_out,
            quiet=quiet,
            baseline=baseline == "random",
            sim=sim,
            film_dir=film_dir,
        )
        return
    resolved = resolve_objects(
        list(objects), workers=workers, progress=not quiet and not as_json
    )
    objs = resolved.objects
    skipped_note = _skipped_note(resolved)
    if not as_json:
        for note in (skipped_note, _decomposition_note(resolved)):
            if note:
                err_console.print(note)
    # fail early (unknown gripper, URDF, no closed posture); the report lists
    # what each took from its URDF and what was repaired
    sim_grippers = {g: load_sim_gripper(g, params).notes_json() for g in grippers}
    if not as_json:
        for g, notes in sim_grippers.items():
            for line in gains_not_applied(sim, g, notes.get("gains") or {}):
                err_console.print(line)
            for line in notes.get("warnings", []):
                err_console.print(f"warning: {line}", markup=False, highlight=False)
    entries = spec_entries(
        list(grippers), list(specs) or None, paper=paper, followup=followup
    )
    for folder in (record_dir, film_dir):
        if folder is not None:
            folder.mkdir(parents=True, exist_ok=True)
    config = EvalConfig(
        objects=objs,
        specs=entries,
        trials=trials,
        seed=seed,
        params=params,
        workers=workers,
        record_dir=record_dir,
        baseline=baseline_n if baseline == "random" else 0,
        film_dir=film_dir,
    )
    with eng:  # Ray starts (and stops) here
        records, wall = run_eval(config, progress=not quiet and not as_json, engine=eng)
    import os

    primary = entries[0].label
    report = build_report(
        records,
        primary=primary,
        meta={
            "objects": ", ".join(objects)
            + (f" ({len(objs)} objects; {skipped_note})" if skipped_note else ""),
            "objects_skipped": {k.name: k.reason for k in resolved.skipped},
            "decomposition": _decomposition_meta(resolved),
            "grippers": list(grippers),
            "sim_grippers": sim_grippers,
            "specs": _spec_sources(entries),
            "trials_per_object": trials,
            "seed": seed,
            "workers": eng.workers if eng.name == "ray" else workers or os.cpu_count(),
            "engine": eng.name,
            "wall_s": round(wall, 1),
            "params": params.to_json(),
            "object_masses": object_masses(objs, params),
            "baseline_per_plan": config.baseline,
        },
    )
    text = json.dumps(report, indent=2)
    if json_out is not None:
        json_out.parent.mkdir(parents=True, exist_ok=True)
        json_out.write_text(text + "\n")
    if md_out is not None:
        md_out.parent.mkdir(parents=True, exist_ok=True)
        md_out.write_text(report_markdown(report))
    if as_json:
        print_json(report)
        return
    for table in report_table(report):
        console.print(table)
    for g, sources in report["specs"].items():
        used = ", ".join(f"{label} = {src}" for label, src in sources.items())
        console.print(f"specs of {g}: {used}", highlight=False)
    console.print(
        f"{report['trials']} trials with spec {primary!r} under the "
        f"{params.protocol} protocol: success rate "
        f"{100 * report['success_rate']:.1f} %, median plan time "
        f"{(report['plan_ms_median'] or 0) / 1e3:.2f} s; wall-clock {wall:.0f} s",
        highlight=False,
    )
    for path in (json_out, md_out):
        if path is not None:
            err_console.print(f"wrote {path}")


def sim_params(
    protocol: str,
    *,
    drop: str = "natural",
    mass: float | None = None,
    density: float | None = None,
    friction: float | None = None,
    sim: list[str] | None = None,
) -> SimParams:
    """The trials' parameters: the protocol's, with the command line's
    overrides (those not given keep the protocol's values; ``sim``: ``--sim``
    KEY=VALUE settings)."""
    from wsgrasp.sim.params import SimParams, parse_overrides

    over: dict[str, Any] = {**parse_overrides(sim or ()), "drop_pose": drop}
    for key, value in (
        ("object_mass", mass),
        ("density", density),
        ("friction", friction),
    ):
        if value is not None:
            over[key] = value
    return SimParams.for_protocol(protocol, **over)


def gains_not_applied(
    sim: list[str] | None, gripper: str, gains: dict[str, dict[str, Any]]
) -> list[str]:
    """A warning per finger gain that ``--sim`` sets and the gripper's YAML
    sets too (``drive``), which wins: the run does not use the ``--sim`` value
    for that gripper. ``gains`` is :meth:`SimGripper.notes_json`'s."""
    from wsgrasp.sim.params import parse_overrides

    over = parse_overrides(sim or ())
    lines = []
    for kind, unit in (("revolute", "N·m/rad"), ("prismatic", "N/m")):
        key, own = f"kp_{kind}", gains.get(kind) or {}
        if key in over and own.get("source") == "gripper":
            lines.append(
                f"warning: --sim {key}={over[key]:g} does not apply to {gripper}: "
                f"its YAML's drive sets {key} {own['kp']:g} {unit}, which the "
                "trials use (to compare gains, evaluate a copy of the YAML with "
                "its drive changed)"
            )
    return lines


def object_masses(objects: list[Any], params: SimParams) -> dict[str, dict[str, Any]]:
    """Each object's mass in the trials (kg) and where it came from: ``forced``
    (``--mass``), ``set`` (its own: a set's table, ``masses.json``) or
    ``density`` (``params.density`` × the volume of its collision parts)."""
    from wsgrasp.sim.objects import trial_mass

    def source(o: Any) -> str:
        if params.object_mass is not None:
            return "forced"
        return "set" if o.mass_given else "density"

    return {
        o.name: {"kg": round(trial_mass(o, params), 6), "from": source(o)}
        for o in objects
    }


def _spec_sources(entries: list[Any]) -> dict[str, dict[str, str]]:
    """Per gripper, each spec label and the file (or built-in) it came from."""
    out: dict[str, dict[str, str]] = {}
    for e in entries:
        out.setdefault(e.gripper, {})[e.label] = e.source
    return out


def _skipped_note(resolved: ObjectList) -> str:
    """One line on the objects of a set left out, by reason."""
    from collections import Counter

    if not resolved.skipped:
        return ""
    by_reason = Counter(k.reason for k in resolved.skipped)
    names = [k.name for k in resolved.skipped]
    return (
        f"skipped {len(names)} objects: "
        + ", ".join(f"{n} {reason}" for reason, n in sorted(by_reason.items()))
        + f" ({', '.join(names[:8])}{', ...' if len(names) > 8 else ''})"
    )


def _decomposition_note(resolved: ObjectList) -> str:
    """One line on the meshes decomposed (none when all came from the cache)."""
    d = _decomposition_meta(resolved)
    if not d["computed"]:
        return ""
    return (
        f"coacd decomposed {d['computed']} meshes ({d['compute_s_total']:.0f} s "
        f"in all, median {d['compute_s_median']:.2f} s, {d['parts_median']:.0f} "
        f"parts); {d['cached']} from the cache"
    )


def _decomposition_meta(resolved: ObjectList) -> dict[str, Any]:
    """Counts and times of the mesh objects' convex decompositions."""
    import numpy as np

    ds = list(resolved.decompositions.values())
    computed = [d.seconds for d in ds if d.status in ("miss", "off", "convex")]
    parts = [len(d.hulls) for d in ds]
    return {
        "meshes": len(ds),
        "computed": len(computed),
        "cached": sum(d.status == "hit" for d in ds),
        "compute_s_total": round(float(np.sum(computed)), 2) if computed else 0.0,
        "compute_s_median": round(float(np.median(computed)), 3) if computed else 0.0,
        "parts_median": float(np.median(parts)) if parts else 0.0,
        "parts_max": max(parts, default=0),
    }
