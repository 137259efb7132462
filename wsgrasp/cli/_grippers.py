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
