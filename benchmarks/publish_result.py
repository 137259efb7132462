"""Publish a run's result file under ``docs/results/``, where the docs render it.

Takes the JSON that ``wsgrasp bench --json`` prints or that ``wsgrasp eval
--json-out`` writes, and writes it to DEST with where it came from: the commit,
the machine, the date and the command. An eval report's per-trial records and
per-object masses are left out (they stay in the full report under
``eval-results/``); everything the docs' tables and charts read is kept.

    wsgrasp bench --json | python benchmarks/publish_result.py - docs/results/bench.json
    python benchmarks/publish_result.py eval-results/paper13.json \\
        docs/results/eval/paper13.json --command "make eval"

``--commit`` names the commit the run started from (the Makefile reads it when
``make`` starts); without it, the checkout's HEAD now.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
#: an eval report's keys that hold one entry per trial or per object
BULKY = ("trial_records", "object_masses")


def head_commit() -> str:
    """The checkout's HEAD, short; empty outside a git checkout."""
    return subprocess.run(
        ["git", "rev-parse", "--short", "HEAD"],
        capture_output=True,
        text=True,
        cwd=ROOT,
    ).stdout.strip()


def machine() -> str:
    """The CPU model, its architecture and the cores this process may use."""
    model = ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None
    cores = cores or os.cpu_count()
    return ", ".join(x for x in (model, platform.machine(), f"{cores} cores") if x)


def publish(
    report: dict[str, Any],
    *,
    commit: str,
    command: str,
    date: str | None = None,
    note: str = "",
) -> dict[str, Any]:
    """``report`` less its bulky per-trial parts, with its provenance first
    (and ``note``, what the figures alone do not say about the run, where
    given)."""
    out: dict[str, Any] = {
        "commit": commit,
        "machine": machine(),
        "date": date or time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
        "command": command,
        # how busy the machine was as the run ended (1, 5 and 15 minutes)
        "load_average": [round(x, 2) for x in os.getloadavg()],
    }
    if note:
        out["note"] = note
    out.update({k: v for k, v in report.items() if k not in BULKY and k not in out})
    return out


def _bench_summary(report: dict[str, Any]) -> str:
    lines = [f"{'entry':24} {'plan ms':>9} {'search ms':>10} {'speed-up':>9}"]
    for name, row in report.get("rows", report).items():
        if not isinstance(row, dict) or "search_ms" not in row:
            continue
        plan = row.get("plan_ms")
        speedup = row.get("speedup")
        lines.append(
            f"{name:24} {plan if plan is not None else float('nan'):9.1f} "
            f"{row['search_ms']:10.2f} "
            f"{speedup if speedup is not None else float('nan'):8.1f}x"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("source", help="the run's JSON file, or - for standard input")
    ap.add_argument("dest", type=Path, help="where to write it under docs/results/")
    ap.add_argument("--commit", default="", help="the commit the run started from")
    ap.add_argument("--command", default="", help="what was run")
    ap.add_argument(
        "--note",
        default="",
        help="what the figures alone do not say about the run (e.g. other work "
        "that shared the machine); the results pages print it with the run",
    )
    args = ap.parse_args(argv)
    text = sys.stdin.read() if args.source == "-" else Path(args.source).read_text()
    report = json.loads(text)
    if "scaling" in report and "rows" not in report:
        # `wsgrasp bench --json` prints its entries at the top level
        scaling = report.pop("scaling")
        libraries = report.pop("libraries", None)
        report = {"rows": report, "scaling": scaling}
        if libraries is not None:
            report["libraries"] = libraries
    out = publish(
        report,
        commit=args.commit or head_commit(),
        command=args.command or "",
        note=args.note,
    )
    args.dest.parent.mkdir(parents=True, exist_ok=True)
    args.dest.write_text(json.dumps(out, indent=1) + "\n")
    if "rows" in out and isinstance(out["rows"], dict):
        print(_bench_summary(out))
    print(f"wrote {args.dest} (commit {out['commit']}, {out['machine']})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
