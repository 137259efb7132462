"""Commands about recorded runs: ``inspect``, ``replay``, ``view``."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer
from rich import box
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
    top: int = typer.Option(5, "--top-k", "-k", "--top", help="Candidates to list."),
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
        ", ".join(
            dict.fromkeys(f"{p['distribution']} {p['version']}" for p in v["plugins"])
        )
        or "—",
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
            )
            + (
                f"; {inp['dropped_no_depth']} without depth (0, 0, 0) dropped"
                if inp.get("dropped_no_depth")
                else ""
            )
            + (
                f"; {inp['flying_pixels']} flying pixels dropped"
                if inp.get("flying_pixels")
                else ""
            ),
        )
    if s["timing_ms"]:
        info.add_row(
            "timing (ms)",
            ", ".join(f"{k} {val:.1f}" for k, val in s["timing_ms"].items()),
        )
    console.print(info)

    hist = Table(title="candidates", box=box.SIMPLE_HEAD, pad_edge=False)
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
        # fits 80 columns: no outer box, term names wrap at their underscores,
        # the position as three signed numbers
        top_table = Table(
            title=f"best {len(s['top'])} feasible candidates",
            box=box.SIMPLE_HEAD,
            pad_edge=False,
        )
        top_table.add_column("#", justify="right", no_wrap=True)
        top_table.add_column("score", justify="right", no_wrap=True)
        terms = list(s["top"][0]["terms"])
        for t in terms:
            top_table.add_column(t.replace("_", " "), justify="right")
        top_table.add_column("θ°", justify="right", no_wrap=True)
        top_table.add_column("contacts", no_wrap=True)
        top_table.add_column("position (m)", no_wrap=True)
        for c in s["top"]:
            top_table.add_row(
                str(c["index"]),
                f"{c['score']:.3f}",
                *(f"{c['terms'][t]:.3f}" for t in terms),
                f"{c['theta_deg']:.0f}",
                "/".join(str(x) for x in c["contacts"]),
                " ".join(f"{x:+.3f}" for x in c["position"]),
            )
        console.print(top_table)

    if s["found"] and s["T_world_ee"] is not None:
        T = s["T_world_ee"]
        console.print(f"[bold]result[/]: score {_fmt(s['score'])}")
        for row in T:
            console.print("  [" + "  ".join(f"{x:+.4f}" for x in row) + "]")
    elif s["status"] == "ok" and s["hint"]:
        console.print(f"[yellow]hint:[/] {s['hint']}")
    for warning in s.get("warnings", []):
        console.print(f"[yellow]warning:[/] {warning}")


def replay(
    run: Path = typer.Argument(
        ..., help="A recorded run (.mcap), or a recorded clutter run's folder."
    ),
    spec: Path | None = typer.Option(
        None,
        "--spec",
        "-s",
        help="Re-plan with this spec instead of the recorded one.",
    ),
    expect_identical: bool = typer.Option(
        False,
        "--expect-identical",
        help="Exit 1 when the result differs, also with --spec (for scripts).",
    ),
    record: Path | None = typer.Option(
        None, "--record", help="Record the replay to this new file."
    ),
    force: bool = typer.Option(False, "--force", help="Replace --record's file."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON."),
) -> None:
    """Re-plan a run's recorded inputs (with its gripper model, from the file) and
    compare with the recorded result.

    With the recorded spec, the replay checks that the run reproduces: exit 0
    when identical, 1 when not. With --spec, the difference is the result: exit
    0 when the replay ran (1 on a difference only with --expect-identical).
    A clutter run's folder replays every plan of every step, in order."""
    from wsgrasp.record import replay_run

    if run.is_dir():
        _replay_sequence(run, spec, expect_identical, as_json)
        return
    report = replay_run(run, spec=spec, record=record, force=force)
    data = report.to_json()
    if as_json:
        print_json(data)
    else:
        _print_replay(data)
    if not report.identical and (spec is None or expect_identical):
        raise typer.Exit(1)


def _replay_sequence(
    folder: Path, spec: Path | None, expect_identical: bool, as_json: bool
) -> None:
    """Replay each plan of a recorded clutter run, step after step."""
    from wsgrasp.record import open_sequence, replay_run

    summary, steps = open_sequence(folder)
    rows: list[dict[str, Any]] = []
    identical = True
    for st in steps:
        reports = [replay_run(r, spec=spec).to_json() for r in st.records]
        identical &= all(r["identical"] for r in reports)
        rows.append({"step": st.info, "replays": reports})
        if not as_json:
            same = all(r["identical"] for r in reports)
            mark = "[green]identical[/]" if same else "[red]different[/]"
            console.print(f"{st.line()} — {mark}", highlight=False)
    if as_json:
        print_json({"clutter": summary, "identical": identical, "steps": rows})
    else:
        console.print(
            f"{summary.get('scene')} scene: {summary.get('successes')} of "
            f"{summary.get('attempts')} grasps held, {summary.get('removed')} of "
            f"{len(summary.get('objects') or [])} objects removed "
            f"({summary.get('end')})",
            highlight=False,
        )
    if not identical and (spec is None or expect_identical):
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
    run: Path = typer.Argument(
        ..., help="A recorded run (.mcap), or a recorded clutter run's folder."
    ),
    out: Path | None = typer.Option(
        None,
        "--out",
        "-o",
        help="Picture (.png), interactive page (.html), or a copy of the run with "
        "its Foxglove views built again (.mcap). Default: RUN.png and RUN.html "
        "beside the run.",
    ),
    force: bool = typer.Option(False, "--force", help="Replace existing files."),
) -> None:
    """Draw a run: the object on its table, the chosen grasp as the gripper's
    shape at pre-grasp and grasp, and the candidates coloured by why they were
    rejected. Writes RUN.png and RUN.html beside the run unless -o says where;
    -o FILE.mcap writes the run again with its Foxglove views (for a run whose
    process was killed before they were written). A clutter run's folder draws
    every plan of every step beside its file, in order."""
    from wsgrasp.errors import RecordingError
    from wsgrasp.record import open_run

    if run.is_dir():
        _view_sequence(run, out, force)
        return

    # beside the run itself, also when RUN is a link such as runs/latest.mcap
    outs = (
        [out]
        if out is not None
        else [run.resolve().with_suffix(s) for s in (".png", ".html")]
    )
    for o in outs:
        if o.suffix.lower() not in (".png", ".html", ".htm", ".mcap"):
            raise RecordingError(
                f"{o}: unknown picture type {o.suffix!r}",
                hint="use -o FILE.png for a picture, -o FILE.html for a 3D page, or "
                "-o FILE.mcap for a copy of the run that Foxglove shows",
            )
        if o.exists() and not force:
            raise RecordingError(
                f"{o}: exists already", hint="choose another name or pass --force"
            )
    r = open_run(run)
    for o in outs:
        suffix = o.suffix.lower()
        if suffix == ".mcap":
            from wsgrasp.record import copy_with_views

            copy_with_views(r, o, force=force)
            note = " (the run is truncated: copied up to where it stops)"
        elif suffix == ".png":
            from wsgrasp.view._png import render_png

            render_png(r, o)
            note = " (the run is truncated: drawn up to where it stops)"
        else:
            from wsgrasp.view._html import render_html

            render_html(r, o)
            note = " (the run is truncated: drawn up to where it stops)"
        console.print(f"wrote {o}{note if r.truncated else ''}", highlight=False)


def _view_sequence(folder: Path, out: Path | None, force: bool) -> None:
    """Draw each plan of a recorded clutter run beside its file, step by step."""
    from wsgrasp.errors import RecordingError
    from wsgrasp.record import open_run, open_sequence
    from wsgrasp.view._html import render_html
    from wsgrasp.view._png import render_png

    if out is not None:
        raise RecordingError(
            f"{folder}: -o names one file, and a clutter run draws one per plan",
            hint="leave -o out: each plan's STEP.png and STEP.html go beside it",
        )
    summary, steps = open_sequence(folder)
    for st in steps:
        console.print(st.line(), highlight=False)
        for rec in st.records:
            for suffix, render in ((".png", render_png), (".html", render_html)):
                o = rec.with_suffix(suffix)
                if o.exists() and not force:
                    raise RecordingError(
                        f"{o}: exists already",
                        hint="pass --force to draw the run again",
                    )
                render(open_run(rec), o)
                console.print(f"  wrote {o}", highlight=False)
