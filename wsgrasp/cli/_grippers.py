"""``wsgrasp gripper list`` and ``gripper show``: the installed grippers, and one
drawn (``grippers`` is a hidden alias of the ``gripper`` group)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import typer
from rich.table import Table

from wsgrasp.cli._common import console, err_console, print_json
from wsgrasp.cli._scaffold import gripper_app


def register(app: typer.Typer) -> None:
    """Add this module's commands to the ``gripper`` group, and the group's old
    plural name as a hidden alias (``_scaffold`` adds the group itself)."""
    app.add_typer(gripper_app, name="grippers", hidden=True)


def _load(name: str, rebuild: bool, cache_dir: Path | None) -> Any:
    """Load (or build, with a status line) one gripper model."""
    from wsgrasp.gripper import load_gripper

    with err_console.status(f"loading gripper {name}") as status:

        def progress(label: str) -> None:
            if label:
                status.update(label)

        return load_gripper(
            name, rebuild=rebuild, cache_dir=cache_dir, progress=progress
        )


def _row(name: str, distribution: str, model: Any) -> dict[str, Any]:
    stats = model.stats
    fingers = stats.get("fingers", [])
    return {
        "name": name,
        "fingers": model.num_fingers,
        "spheres_per_finger": model.spheres_per_finger,
        "ellipsoids": int(len(model.se_centers)),
        "cloud_points": int(len(model.cloud)),
        "distribution": distribution,
        "finger_names": list(model.finger_names),
        "max_opening": model.max_opening,
        "covered_fraction": [f.get("covered_fraction") for f in fingers],
        "cloud_inside_se": stats.get("cloud_inside_se"),
        "build_s": stats.get("build_s"),
        "load_s": stats.get("load_s"),
        "cache": stats.get("cache"),
    }


@gripper_app.command("list")
def list_grippers(
    as_json: bool = typer.Option(False, "--json", help="Print JSON."),
    rebuild: bool = typer.Option(False, "--rebuild", help="Ignore cached models."),
    cache_dir: Path | None = typer.Option(
        None, "--cache-dir", help="Model cache (default: $WSGRASP_CACHE_DIR)."
    ),
) -> None:
    """List the registered grippers with their model sizes (builds on first use)."""
    from wsgrasp.errors import WsgraspError
    from wsgrasp.plugins import get_registry

    reg = get_registry()
    rows = []
    for name in reg.names("grippers"):
        entry = reg.get("grippers", name)
        try:
            model = _load(name, rebuild, cache_dir)
        except WsgraspError as exc:
            rows.append(
                {
                    "name": name,
                    "distribution": entry.plugin.distribution,
                    "error": str(exc),
                }
            )
            continue
        rows.append(_row(name, entry.plugin.distribution, model))
    if as_json:
        print_json(rows)
        return
    table = Table(title="wsgrasp grippers")
    table.add_column("name", no_wrap=True)
    for col in ("nf", "nsp", "ne", "ng", "opening", "cover", "build"):
        table.add_column(col, justify="right", no_wrap=True)
    table.add_column("load", justify="right", no_wrap=True)
    dists = sorted({r["distribution"] for r in rows})
    table.caption = "from " + ", ".join(dists) + "; build/load times in seconds"
    for r in rows:
        if "error" in r:
            table.add_row(
                r["name"], f"[red]{r['error']}[/]", *[""] * 7, r["distribution"]
            )
            continue
        counts = r["spheres_per_finger"]
        spheres = (
            f"{len(counts)}x{counts[0]}"
            if len(set(counts)) == 1
            else ",".join(map(str, counts))
        )
        load = f"{r['load_s']:.3f}" if r["load_s"] is not None else "-"
        table.add_row(
            r["name"],
            str(r["fingers"]),
            spheres,
            str(r["ellipsoids"]),
            str(r["cloud_points"]),
            f"{r['max_opening'] * 1000:.0f}mm",
            f"{float(np.mean(np.asarray(r['covered_fraction'], float))):.0%}",
            f"{r['build_s']:.2f}",
            load,
        )
    console.print(table)


@gripper_app.command("show")
def show(
    name: str = typer.Argument(..., help="Registered gripper name or gripper YAML."),
    output: Path = typer.Option(
        ..., "--out", "-o", "--output", help="PNG file to write."
    ),
    rebuild: bool = typer.Option(False, "--rebuild", help="Ignore cached models."),
    cache_dir: Path | None = typer.Option(
        None, "--cache-dir", help="Model cache (default: $WSGRASP_CACHE_DIR)."
    ),
) -> None:
    """Draw a gripper model: cloud, superellipsoids and workspace spheres."""
    from wsgrasp.view import render_gripper

    model = _load(name, rebuild, cache_dir)
    path = render_gripper(model, output)
    fingers = ", ".join(
        f"{f['name']} {f['covered_fraction']:.0%}" for f in model.stats["fingers"]
    )
    console.print(
        f"[green]wrote[/] {path}: {model.name}, {model.num_fingers} fingers "
        f"(coverage {fingers}), {len(model.se_centers)} superellipsoids holding "
        f"{model.stats['cloud_inside_se']:.0%} of the cloud",
        highlight=False,
    )


@gripper_app.command("tune")
def tune(
    gripper: Path = typer.Argument(
        ..., help="Gripper YAML (as `gripper new` wrote it, or your own)."
    ),
    objects: list[str] = typer.Option(
        ["random:000-119"],
        "--objects",
        help="Object set the closings are tried on (as for `wsgrasp eval`); keep "
        "the objects you report on out of it. 120 objects tell apart closings "
        "about 10 points apart; 60 (random:000-059, half the time) about 20.",
    ),
    trials: int = typer.Option(1, "--trials", "-n", min=1, help="Trials per object."),
    seed: int = typer.Option(0, "--seed", help="Random seed of drops and cameras."),
    protocol: str = typer.Option(
        "strict", "--protocol", help="Trial protocol (as for `wsgrasp eval`)."
    ),
    workers: int = typer.Option(
        0, "--workers", "-j", min=0, help="Processes (0: one per CPU core)."
    ),
    dry_run: bool = typer.Option(
        False, "--dry-run", help="Measure and report; write nothing."
    ),
    as_json: bool = typer.Option(False, "--json", help="Print JSON."),
    json_out: Path | None = typer.Option(
        None, "--json-out", help="Also write the JSON report here."
    ),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bar."),
) -> None:
    """Choose how a hand closes by grasp trials in MuJoCo: the same drops with
    closed as it is and at the joints' limits, each to closed and 2 cm past the
    contacts; the one that holds the most is written into the YAML (closed) and
    its specs/default.yaml (approach) when it beats the hand as it is."""
    from wsgrasp.cli._eval import sim_params
    from wsgrasp.sim import require_mujoco
    from wsgrasp.sim.tune import tune_closing, write_tuned

    require_mujoco()
    params = sim_params(protocol)
    result = tune_closing(
        str(gripper),
        objects=list(objects),
        trials=trials,
        seed=seed,
        params=params,
        workers=workers,
        progress=not quiet and not as_json,
        say=None if quiet or as_json else lambda m: err_console.print(m),
    )
    written = [] if dry_run else write_tuned(result)
    report = {**result.to_json(), "written": [str(p) for p in written]}
    if json_out is not None:
        import json

        json_out.parent.mkdir(parents=True, exist_ok=True)
        json_out.write_text(json.dumps(report, indent=2) + "\n")
    if as_json:
        print_json(report)
        return
    table = Table(title=f"closings of {gripper.name}, the same drops")
    for col in ("closing", "closed", "targets", "held", "+/-", "diff, points"):
        table.add_column(col, no_wrap=True)
    for v in result.variants:
        at_limits = v.name.startswith("limits")
        targets = (
            "closed"
            if v.approach.get("close_to") == "closed"
            else f"contacts +{100 * float(v.approach.get('squeeze', 0.0)):g} cm"
        )
        diff = (
            ""
            if v.name == "as_is"
            else f"{100 * v.difference:+.0f} ({100 * v.ci95[0]:+.0f}, "
            f"{100 * v.ci95[1]:+.0f})"
        )
        table.add_row(
            v.name + (" *" if v.name == result.chosen else ""),
            "limits" if at_limits else "as is",
            targets,
            f"{v.successes}/{v.trials}",
            "" if v.name == "as_is" else f"{v.gained}/{v.lost}",
            diff,
        )
    table.caption = (
        "* chosen; +/-: drops gained/lost against as_is; diff: 95 % interval"
    )
    console.print(table)
    console.print(result.summary(), highlight=False, markup=False)
    for path in written:
        console.print(f"[green]wrote[/] {path}")
    if dry_run and result.chosen != "as_is":
        console.print("--dry-run: nothing written")
