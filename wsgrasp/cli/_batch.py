"""``wsgrasp batch`` (many scenes × specs to Parquet) and ``wsgrasp dataset``
(grasp candidates with simulated labels), locally or on Ray."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer
from rich.table import Table

from wsgrasp.cli._common import console, err_console, print_json
from wsgrasp.errors import InputError


def register(app: typer.Typer) -> None:
    """Add this module's commands to ``app``."""
    app.command("batch")(batch)
    app.command("dataset")(dataset)


_ENGINE_HELP = "local: a process pool on this machine; ray: Ray tasks (extra 'ray')."
_ADDRESS_HELP = "Ray cluster address (e.g. ray://head:10001); local Ray without it."
_WORKERS_HELP = "Processes or Ray CPUs (0: one per CPU core)."
_PROTOCOL_HELP = (
    "the trials' protocol: strict (execution error, disturbances, slip in the "
    "grip fails; wsgrasp eval's default) or lift (lift and hold 10 s)."
)


def _manifest(path: Path) -> dict[str, list[str]]:
    """``scenes``, ``specs`` and ``grippers`` of a manifest YAML, its paths
    relative to the manifest's folder."""
    from wsgrasp._loading import load_document

    data, _ = load_document(path)
    if not isinstance(data, dict):
        raise InputError(
            f"manifest {path} is not a mapping",
            hint="write scenes:, specs: and grippers: lists",
        )
    extra = sorted(set(data) - {"scenes", "specs", "grippers"})
    if extra:
        raise InputError(
            f"manifest {path} has unknown keys {extra}",
            hint="use scenes:, specs: and grippers:",
        )
    out: dict[str, list[str]] = {}
    for key in ("scenes", "specs", "grippers"):
        items = data.get(key) or []
        if not isinstance(items, list):
            raise InputError(
                f"manifest {path}: {key} is not a list", hint=f"write {key}: [a, b]"
            )
        out[key] = [str(i) for i in items]

    def rel(item: str, *, labelled: bool) -> str:
        label, sep, file = item.rpartition("=") if labelled else ("", "", item)
        p = Path(file)
        if not p.is_absolute() and (path.parent / p).exists():
            p = path.parent / p
        return f"{label}{sep}{p}"

    out["scenes"] = [rel(s, labelled=False) for s in out["scenes"]]
    out["specs"] = [rel(s, labelled=True) for s in out["specs"]]
    out["grippers"] = [
        rel(g, labelled=False) if Path(path.parent / g).exists() else g
        for g in out["grippers"]
    ]
    return out


def batch_specs(specs: list[str], grippers: list[str]) -> list[Any]:
    """The batch's specs: each ``[LABEL=]FILE`` (labelled by LABEL or the file's
    stem) with each gripper in place of its own (``LABEL@gripper``), or each
    gripper's default spec (labelled by the gripper) without ``--spec``."""
    from wsgrasp.batch import BatchSpec
    from wsgrasp.cli._plan import plan_spec
    from wsgrasp.sim.specs import spec_arg

    if not specs and not grippers:
        raise typer.BadParameter(
            "give spec files (--spec FILE) or grippers (--gripper NAME), or both",
            param_hint="--spec / --gripper",
        )
    out = []
    if not specs:
        out = [BatchSpec(Path(g).stem, plan_spec(None, g)) for g in grippers]
    for item in specs:
        label, path = spec_arg(item)
        replaced: list[str | None] = [*grippers] or [None]
        for g in replaced:
            name = label if g is None else f"{label}@{Path(g).stem}"
            out.append(BatchSpec(name, plan_spec(path, g)))
    return out


def batch(
    scenes: list[str] = typer.Argument(
        None,
        help="Scenes: cloud files, scene YAMLs, or folders of them; each is its "
        "own scene.",
    ),
    specs: list[str] = typer.Option(
        [], "--spec", "-s", help="Pipeline spec FILE or LABEL=FILE; repeat."
    ),
    grippers: list[str] = typer.Option(
        [],
        "--gripper",
        "-g",
        help="Gripper name or YAML: replaces each spec's gripper, or plans with "
        "its default spec without --spec; repeat.",
    ),
    out: Path = typer.Option(..., "--out", "-o", help="Output folder."),
    manifest: Path | None = typer.Option(
        None,
        "--manifest",
        help="YAML with scenes:, specs: and grippers: lists (added to the arguments).",
    ),
    engine: str = typer.Option("local", "--engine", help=_ENGINE_HELP),
    address: str | None = typer.Option(None, "--address", help=_ADDRESS_HELP),
    workers: int = typer.Option(0, "--workers", "-j", min=0, help=_WORKERS_HELP),
    resume: bool = typer.Option(
        False, "--resume", help="Continue a run in --out: plan only what is missing."
    ),
    record: bool = typer.Option(
        False, "--record", help="One MCAP recording per plan, in OUT/runs/<spec>/."
    ),
    row_group: int = typer.Option(
        64, "--row-group", min=1, help="Rows per Parquet part written."
    ),
    chunk: int = typer.Option(
        8, "--chunk", min=1, help="Plans per task (a crash costs one task)."
    ),
    simulate: bool = typer.Option(
        False,
        "--simulate",
        help="SCENES are objects (random:000-099, paper13, meshes): eval's MuJoCo "
        "trials, one row each in OUT/trials (needs --gripper).",
    ),
    trials: int = typer.Option(
        1, "--trials", "-n", min=1, help="With --simulate: trials per object."
    ),
    seed: int = typer.Option(0, "--seed", help="With --simulate: the trials' seed."),
    protocol: str = typer.Option(
        "strict", "--protocol", help="With --simulate: " + _PROTOCOL_HELP
    ),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bar."),
) -> None:
    """Plan every scene with every spec; one row per plan in OUT/plans (Parquet),
    written as plans finish, so --resume after a crash loses nothing."""
    from wsgrasp.batch import make_engine, run_batch, scene_paths

    scenes = list(scenes or [])
    specs, grippers = list(specs), list(grippers)
    if manifest is not None:
        m = _manifest(manifest)
        scenes += m["scenes"]
        specs += m["specs"]
        grippers += m["grippers"]
    if not scenes:
        raise typer.BadParameter(
            "give scenes (files or folders) or a --manifest", param_hint="SCENES"
        )
    if simulate:
        _simulate(
            scenes,
            specs,
            grippers,
            out,
            engine,
            address,
            workers,
            trials,
            seed,
            resume,
            record,
            row_group,
            as_json,
            quiet,
            protocol,
        )
        return
    entries = batch_specs(specs, grippers)
    paths = scene_paths(scenes)
    with make_engine(engine, workers, address) as eng:
        summary = run_batch(
            paths,
            entries,
            out,
            eng,
            resume=resume,
            record=record,
            row_group=row_group,
            chunk=chunk,
            progress=not quiet and not as_json,
        )
    data: dict[str, Any] = {
        "plans": summary.planned,
        "found": summary.found,
        "resumed": summary.resumed,
        "wall_s": round(summary.wall_s, 2),
        "plans_per_s": round(summary.plans_per_s, 2),
        "engine": eng.name,
        "workers": eng.workers,
        "out": str(out / "plans"),
        "failures": [
            {"spec": s, "reason": r, "count": n, "scene": sc}
            for s, r, n, sc in summary.failure_counts()
        ],
    }
    if as_json:
        print_json(data)
        return
    _print_failures(data["failures"])
    console.print(
        f"{summary.planned} plans ({summary.found} found) in {summary.wall_s:.1f} s "
        f"on {eng.name} × {eng.workers}: {summary.plans_per_s:.2f} plans/s"
        + (f"; {summary.resumed} already in {out}" if summary.resumed else "")
        + f"; rows in {out / 'plans'}",
        highlight=False,
    )


def _simulate(
    objects: list[str],
    specs: list[str],
    grippers: list[str],
    out: Path,
    engine: str,
    address: str | None,
    workers: int,
    trials: int,
    seed: int,
    resume: bool,
    record: bool,
    row_group: int,
    as_json: bool,
    quiet: bool,
    protocol: str = "strict",
) -> None:
    """``batch --simulate``: eval's trials on the engine, rows to OUT/trials."""
    from wsgrasp.batch import make_engine, run_trials
    from wsgrasp.sim import SimParams, load_sim_gripper, require_mujoco, spec_entries
    from wsgrasp.sim.objects import resolve_objects

    require_mujoco()
    if not grippers:
        raise typer.BadParameter(
            "--simulate needs the grippers to execute: give --gripper NAME",
            param_hint="--gripper",
        )
    params = SimParams.for_protocol(protocol)
    for g in grippers:  # fail early: unknown gripper, URDF, no closed posture
        load_sim_gripper(g, params)
    entries = spec_entries(grippers, specs or None, paper=False)
    resolved = resolve_objects(objects, workers=workers, progress=not quiet)
    record_dir = out / "runs" if record else None
    if record_dir is not None:
        record_dir.mkdir(parents=True, exist_ok=True)
    with make_engine(engine, workers, address) as eng:
        s = run_trials(
            resolved.objects,
            entries,
            out,
            eng,
            trials=trials,
            seed=seed,
            params=params,
            resume=resume,
            record_dir=record_dir,
            row_group=row_group,
            progress=not quiet and not as_json,
        )
    data = {
        "trials": s.trials,
        "successes": s.successes,
        "outcomes": s.outcomes,
        "resumed_tasks": s.resumed,
        "wall_s": round(s.wall_s, 2),
        "trials_per_s": round(s.trials / s.wall_s, 3) if s.wall_s else 0.0,
        "protocol": params.protocol,
        "engine": eng.name,
        "workers": eng.workers,
        "out": str(out / "trials"),
    }
    if as_json:
        print_json(data)
        return
    console.print(
        f"{s.trials} trials ({s.successes} held; "
        + ", ".join(f"{k} {v}" for k, v in sorted(s.outcomes.items()))
        + f") in {s.wall_s:.1f} s on {eng.name} × {eng.workers}"
        + (f"; {s.resumed} tasks already in {out}" if s.resumed else "")
        + f"; rows in {out / 'trials'}",
        highlight=False,
    )


def _print_failures(failures: list[dict[str, Any]], limit: int = 12) -> None:
    if not failures:
        return
    t = Table(title="plans without a grasp")
    for c in ("spec", "count", "reason", "e.g. scene"):
        t.add_column(c, justify="right" if c == "count" else "left")
    for f in failures[:limit]:
        t.add_row(f["spec"], str(f["count"]), f["reason"][:100], f["scene"])
    console.print(t)
    if len(failures) > limit:
        err_console.print(f"... and {len(failures) - limit} more reasons (see --json)")


def dataset(
    objects: list[str] = typer.Argument(
        None,
        help="Objects: a set (random:000-099, paper13), paper13 names, or mesh "
        "files (metres).",
    ),
    object_sets: list[str] = typer.Option(
        [], "--objects", help="More objects, as the arguments; repeat."
    ),
    gripper: str = typer.Option(
        ..., "--gripper", "-g", help="Registered gripper name or gripper YAML."
    ),
    spec_file: Path | None = typer.Option(
        None,
        "--spec",
        "-s",
        help="Pipeline spec file (its gripper replaced); the gripper's default "
        "spec without it.",
    ),
    out: Path = typer.Option(..., "--out", "-o", help="Output folder."),
    trials: int = typer.Option(
        1, "--trials", "-n", min=1, help="Drops (scenes) per object."
    ),
    top_k: int = typer.Option(
        5, "--top-k", "-k", min=0, help="Best candidates of each scene simulated."
    ),
    random_k: int = typer.Option(
        0,
        "--random",
        min=0,
        help="Also simulate this many uniformly random feasible candidates of each "
        "scene (chance beside the choice; rows marked random_pick).",
    ),
    seed: int = typer.Option(0, "--seed", help="Random seed of drops and cameras."),
    protocol: str = typer.Option("strict", "--protocol", help=_PROTOCOL_HELP),
    views: bool = typer.Option(
        True,
        "--views/--no-views",
        help="Keep each scene's depth views (points) in OUT/scenes (~1.7 MB each).",
    ),
    engine: str = typer.Option("local", "--engine", help=_ENGINE_HELP),
    address: str | None = typer.Option(None, "--address", help=_ADDRESS_HELP),
    workers: int = typer.Option(0, "--workers", "-j", min=0, help=_WORKERS_HELP),
    resume: bool = typer.Option(
        False, "--resume", help="Continue a run in --out: only the missing scenes."
    ),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bar."),
) -> None:
    """Grasp-dataset generation: each object dropped (seeded) and seen in three
    depth views, every feasible candidate with its score terms, and MuJoCo
    success labels for the top K; Parquet tables OUT/candidates and OUT/scenes."""
    from wsgrasp.batch import make_engine, run_dataset
    from wsgrasp.cli._plan import plan_spec
    from wsgrasp.sim import SimParams, load_sim_gripper, require_mujoco
    from wsgrasp.sim.objects import resolve_objects

    require_mujoco()
    names = list(objects or []) + list(object_sets)
    if not names:
        raise typer.BadParameter(
            "give objects (random:000-099, paper13 or mesh files)",
            param_hint="OBJECTS",
        )
    spec = plan_spec(spec_file, gripper)
    params = SimParams.for_protocol(protocol)
    load_sim_gripper(gripper, params)  # fail early: no URDF, no closed posture
    resolved = resolve_objects(
        names, workers=workers, progress=not quiet and not as_json
    )
    with make_engine(engine, workers, address) as eng:
        summary = run_dataset(
            resolved.objects,
            spec,
            gripper,
            out,
            eng,
            trials=trials,
            top_k=top_k,
            random_k=random_k,
            seed=seed,
            params=params,
            resume=resume,
            views=views,
            progress=not quiet and not as_json,
        )
    data = {
        **summary.to_json(),
        "engine": eng.name,
        "workers": eng.workers,
        "protocol": params.protocol,
    }
    data["skipped_objects"] = {k.name: k.reason for k in resolved.skipped}
    if as_json:
        print_json(data)
        return
    console.print(
        f"{summary.scenes} scenes of {len(resolved.objects)} objects: "
        f"{summary.candidates} feasible candidates, {summary.labels} labels "
        f"({summary.successes} held) in {summary.wall_s:.0f} s on {eng.name} × "
        f"{eng.workers} ({summary.labels_per_hour:.0f} labels/h)"
        + (
            f"; choice held {summary.chosen_successes}/{summary.chosen}, random "
            f"feasible {summary.random_successes}/{summary.random_labels}"
            if summary.random_labels
            else ""
        )
        + (f"; {summary.resumed} scenes already in {out}" if summary.resumed else "")
        + f"; tables in {out}",
        highlight=False,
    )
