"""Commands about recorded runs: ``inspect``, ``replay``, ``view``."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer
from rich.table import Table

from wsgrasp.cli._common import console, print_json


def register(app: typer.Typer) -> None:
    """Add this module's commands to ``app``."""
    app.command("inspect")(inspect)
    app.command("replay")(replay)
    app.command("view")(view)


def _fmt(x: Any, nd: int = 4) -> str:
    if x is None:
        return "—"
    if isinstance(x, float):
        return f"{x:.{nd}g}"
    return str(x)


def inspect(
    run: Path = typer.Argument(..., help="A recorded run (.mcap)."),
    top: int = typer.Option(5, "--top", "-k", help="Candidates to list."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON."),
) -> None:
    """Show a recorded run: inputs, versions, timings, why candidates were
    rejected, the best candidates and the result."""
    from wsgrasp.record import open_run, summarize_run

    s = summarize_run(open_run(run), top_k=top)
    if as_json:
        print_json(s)
        return
    status = {
        "ok": "[green]grasp found[/]" if s["found"] else "[yellow]no grasp found[/]",
        "error": "[red]the plan failed[/]",
        "truncated": "[red]truncated[/]",
    }[s["status"]]
    console.print(f"[bold]{s['path']}[/]: {status}", highlight=False)
    if s["truncated"]:
        console.print(
            f"[red]the file is truncated[/] at byte {s['truncated_at']}: it stops "
            "before its end (the process was killed or the copy was cut)"
            + (f"; missing: {', '.join(s['missing'])}" if s["missing"] else ""),
            highlight=False,
        )
    if s["error"]:
        e = s["error"]
        console.print(f"[red]error:[/] {e.get('type')}: {e.get('message')}")
        if e.get("hint"):
            console.print(f"  fix: {e['hint']}")

    v = s["versions"]
    info = Table(show_header=False, box=None, pad_edge=False)
    info.add_column(style="bold")
    info.add_column()
    info.add_row("gripper", _fmt(s["gripper"]))
    info.add_row("recorded", f"{_fmt(s['created_utc'])} by wsgrasp {v['wsgrasp']}")
    info.add_row("python", f"{_fmt(v['python'])}, numpy {_fmt(v['numpy'])}")
    info.add_row("platform", _fmt(v["platform"]))
    info.add_row(
        "plugins",
        ", ".join(f"{p['distribution']} {p['version']}" for p in v["plugins"]) or "—",
    )
    info.add_row("seed", _fmt(s["seed"]))
    if s["inputs"]:
        inp = s["inputs"]
        views = ", ".join(f"{x['name'] or '?'} ({x['points']})" for x in inp["views"])
        info.add_row(
            "inputs",
            f"{inp['points']} points from {len(inp['views'])} view(s): {views}"
            + (
                f"; {inp['dropped_nonfinite']} NaN/inf dropped"
                if inp["dropped_nonfinite"]
                else ""
            ),
        )
    if s["timing_ms"]:
        info.add_row(
            "timing (ms)",
            ", ".join(f"{k} {val:.1f}" for k, val in s["timing_ms"].items()),
        )
    console.print(info)

    hist = Table(title="candidates")
    hist.add_column("outcome")
    hist.add_column("count", justify="right")
    hist.add_column("share", justify="right")
    n = max(s["candidates"], 1)
    hist.add_row("[green]feasible[/]", str(s["feasible"]), f"{s['feasible'] / n:.0%}")
    for reason, count in s["rejections"].items():
        hist.add_row(reason.replace("_", " "), str(count), f"{count / n:.0%}")
    hist.add_row("[bold]total[/]", f"[bold]{s['candidates']}[/]", "")
    console.print(hist)

    if s["top"]:
        top_table = Table(title=f"best {len(s['top'])} feasible candidates")
        top_table.add_column("#", justify="right")
        top_table.add_column("score", justify="right")
        terms = list(s["top"][0]["terms"])
        for t in terms:
            top_table.add_column(t, justify="right")
        top_table.add_column("θ (deg)", justify="right")
        top_table.add_column("contacts")
        top_table.add_column("position (m)")
        for c in s["top"]:
            top_table.add_row(
                str(c["index"]),
                f"{c['score']:.4f}",
                *(f"{c['terms'][t]:.4f}" for t in terms),
                f"{c['theta_deg']:.0f}",
                "/".join(str(x) for x in c["contacts"]),
                "(" + ", ".join(f"{x:.3f}" for x in c["position"]) + ")",
            )
        console.print(top_table)

    if s["found"] and s["T_world_ee"] is not None:
        T = s["T_world_ee"]
        console.print(f"[bold]result[/]: score {_fmt(s['score'])}")
        for row in T:
            console.print("  [" + "  ".join(f"{x:+.4f}" for x in row) + "]")
    elif s["status"] == "ok" and s["hint"]:
        console.print(f"[yellow]hint:[/] {s['hint']}")


def replay(
    run: Path = typer.Argument(..., help="A recorded run (.mcap)."),
    spec: Path | None = typer.Option(
        None, "--spec", help="Re-plan with this spec instead of the recorded one."
    ),
    record: Path | None = typer.Option(
        None, "--record", help="Record the replay to this new file."
    ),
    force: bool = typer.Option(False, "--force", help="Replace --record's file."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON."),
) -> None:
    """Re-plan a run's recorded inputs (with its gripper model, from the file) and
    compare with the recorded result. Exits 0 when identical, 1 when not."""
    from wsgrasp.record import replay_run

    report = replay_run(run, spec=spec, record=record, force=force)
    data = report.to_json()
    if as_json:
        print_json(data)
    else:
        _print_replay(data)
    if not report.identical:
        raise typer.Exit(1)


def _print_replay(d: dict[str, Any]) -> None:
    if d["identical"]:
        console.print(
            "[green]identical[/]: the replay reproduces the recorded result bit for "
            "bit" + ("" if d["same_spec"] else " (with the other spec)")
        )
    else:
        what = "recorded spec" if d["same_spec"] else "other spec"
        console.print(
            f"[red]different[/] ({what}): " + ", ".join(d["differences"]),
            highlight=False,
        )
    for note in d["notes"]:
        console.print(f"[yellow]note:[/] {note}")
    rec, rep = d["recorded"], d["replayed"]
    t = Table()
    t.add_column("")
    t.add_column("recorded", justify="right")
    t.add_column("replayed", justify="right")
    t.add_row("found", str(rec["found"]), str(rep["found"]))
    t.add_row("score", _fmt(rec["score"]), _fmt(rep["score"]))
    t.add_row("candidates", str(rec["candidates"]), str(rep["candidates"]))
    for reason, counts in d["histogram"].items():
        mark = "" if counts["recorded"] == counts["replayed"] else "[yellow]"
        t.add_row(
            f"{mark}{reason.replace('_', ' ')}",
            f"{mark}{counts['recorded']}",
            f"{mark}{counts['replayed']}",
        )
    console.print(t)
    if d["pose_delta"] is not None:
        pd = d["pose_delta"]
        console.print(
            f"chosen pose moved {pd['translation_m'] * 1000:.1f} mm and turned "
            f"{pd['angle_deg']:.1f}°"
        )
    if d["score_delta"] is not None:
        console.print(f"score changed by {d['score_delta']:+.4g}")
    for side in ("recorded", "replayed"):
        err = d[side].get("error")
        if err:
            console.print(f"[red]{side} error:[/] {err['type']}: {err['message']}")
    if d["record"]:
        console.print(f"recorded the replay to {d['record']}")


def view(
    run: Path = typer.Argument(..., help="A recorded run (.mcap)."),
    out: Path = typer.Option(
        ...,
        "--out",
        "-o",
        help="Picture (.png), interactive page (.html), or a copy of the run with "
        "its Foxglove views built again (.mcap).",
    ),
    force: bool = typer.Option(False, "--force", help="Replace an existing file."),
) -> None:
    """Draw a run: scene, table, object, candidates coloured by why they were
    rejected, and the chosen grasp with the spheres that hold the object. With
    -o FILE.mcap, write the run again with its Foxglove views (for a run whose
    process was killed before they were written)."""
    from wsgrasp.errors import RecordingError
    from wsgrasp.record import open_run

    suffix = out.suffix.lower()
    if suffix not in (".png", ".html", ".htm", ".mcap"):
        raise RecordingError(
            f"{out}: unknown picture type {out.suffix!r}",
            hint="use -o FILE.png for a picture, -o FILE.html for a 3D page, or "
            "-o FILE.mcap for a copy of the run that Foxglove shows",
        )
    if out.exists() and not force:
        raise RecordingError(
            f"{out}: exists already", hint="choose another name or pass --force"
        )
    r = open_run(run)
    if suffix == ".mcap":
        from wsgrasp.record import copy_with_views

        copy_with_views(r, out, force=force)
        note = " (the run is truncated: copied up to where it stops)"
        console.print(f"wrote {out}{note if r.truncated else ''}", highlight=False)
        return
    if suffix == ".png":
        from wsgrasp.view._run import render_png

        render_png(r, out)
    else:
        from wsgrasp.view._html import render_html

        render_html(r, out)
    note = " (the run is truncated: drawn up to where it stops)" if r.truncated else ""
    console.print(f"wrote {out}{note}", highlight=False)
