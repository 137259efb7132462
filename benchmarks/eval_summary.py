"""One Markdown table of success rates from ``wsgrasp eval --json-out`` reports:
per object set, gripper and spec, the trials, success rate, median plan time and
the failures by kind. ``python benchmarks/eval_summary.py eval-results/*.json``
"""

from __future__ import annotations

import json
import statistics
import sys
from collections import defaultdict
from pathlib import Path

from wsgrasp.sim.report import FAILURES


def summary_rows(report: dict, label: str) -> list[list[str]]:
    groups: dict[tuple[str, str], list[dict]] = defaultdict(list)
    for r in report["trial_records"]:
        groups[(Path(r["gripper"]).stem, r["spec"])].append(r)
    rows = []
    for (gripper, spec), recs in groups.items():
        ok = sum(r["outcome"] == "success" for r in recs)
        plans = [r["plan_ms"] for r in recs if r.get("plan_ms") is not None]
        et = f"{statistics.median(plans) / 1e3:.2f} s" if plans else "-"
        fails = ", ".join(
            f"{k.replace('_', ' ')} {n}"
            for k in FAILURES
            if (n := sum(r["outcome"] == k for r in recs))
        )
        rows.append(
            [
                label,
                gripper,
                spec,
                str(len(recs)),
                f"{100 * ok / len(recs):.0f} %",
                et,
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
