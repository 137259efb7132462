"""One Markdown table of success rates from ``wsgrasp eval --json-out`` reports:
per object set, gripper and spec, the trials, success rate, median plan time and
the failures by kind. ``python benchmarks/eval_summary.py eval-results/*.json``
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from wsgrasp.sim.report import FAILURES


def summary_rows(report: dict, label: str) -> list[list[str]]:
    """One row per gripper × spec from the report's own ``results``."""
    rows = []
    for res in report["results"]:
        ms = res["plan_ms_median"]
        fails = ", ".join(
            f"{k.replace('_', ' ')} {n}"
            for k in FAILURES
            if (n := res["failures"].get(k, 0))
        )
        rows.append(
            [
                label,
                Path(res["gripper"]).stem,
                res["spec"],
                str(res["trials"]),
                f"{100 * res['success_rate']:.0f} %",
                "-" if ms is None else f"{ms / 1e3:.2f} s",
                fails or "none",
            ]
        )
    return rows


def main(paths: list[str]) -> None:
    print("| objects | gripper | spec | trials | success | plan (median) | failures |")
    print("|---|---|---|---:|---:|---:|---|")
    for p in paths:
        report = json.loads(Path(p).read_text())
        for row in summary_rows(report, Path(p).stem):
            print("| " + " | ".join(row) + " |")


if __name__ == "__main__":
    main(sys.argv[1:])
