"""What a fresh process pays to import open3d, as ``import open3d`` and as
wsgrasp imports it (``wsgrasp._open3d.load_open3d``: without the plotly viewer
that imports plotly and dash), and a whole ``wsgrasp plan`` process.

Each round runs every command once in a fresh process, in turn, and prints the
medians and their ratio: the reason ``wsgrasp/_open3d.py`` exists holds while
the second import is clearly cheaper than the first.

    .venv/bin/python benchmarks/open3d_import.py [--rounds 9]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

TIMED = """
import sys, time
import wsgrasp._open3d  # wsgrasp itself, before the clock starts
assert "open3d" not in sys.modules
t = time.perf_counter()
{body}
print(time.perf_counter() - t, "dash" in sys.modules)
"""

CASES = {
    "import open3d": "import open3d",
    "load_open3d()": "wsgrasp._open3d.load_open3d()",
}


def _seconds(body: str) -> tuple[float, bool]:
    out = subprocess.run(
        [sys.executable, "-c", TIMED.format(body=body)],
        capture_output=True,
        text=True,
        check=True,
        cwd=ROOT,
    ).stdout.split()
    return float(out[0]), out[1] == "True"


def _plan_seconds() -> float:
    wsgrasp = Path(sys.executable).with_name("wsgrasp")
    scene = ROOT / "examples" / "scenes" / "box_upright.npz"
    t = time.perf_counter()
    subprocess.run(
        [str(wsgrasp), "plan", str(scene), "-g", "franka_hand", "--no-record"],
        capture_output=True,
        check=True,
        cwd=ROOT,
    )
    return time.perf_counter() - t


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=9)
    args = ap.parse_args()
    times: dict[str, list[float]] = {k: [] for k in CASES}
    dash: dict[str, bool] = {}
    plans: list[float] = []
    for _ in range(args.rounds):
        for name, body in CASES.items():
            s, d = _seconds(body)
            times[name].append(s)
            dash[name] = d
        plans.append(_plan_seconds())
    for name, values in times.items():
        print(
            f"{name:>15}: median {statistics.median(values):.3f} s over "
            f"{len(values)} processes (dash imported: {dash[name]})"
        )
    a, b = (statistics.median(v) for v in times.values())
    print(f"{'ratio':>15}: {b / a:.2f}")
    print(f"{'wsgrasp plan':>15}: median {statistics.median(plans):.2f} s (a process)")


if __name__ == "__main__":
    main()
