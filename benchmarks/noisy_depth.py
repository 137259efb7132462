"""Grasp trials under a noisier depth camera than ``wsgrasp eval``'s (1 mm): the
default spec beside the same spec with the segmenter's ``noise_floor`` at 0 (its
thresholds fixed whatever the noise), the same drops for both.

    python benchmarks/noisy_depth.py --noise 0.008 --out eval-results/noisy-depth.json
    python benchmarks/publish_result.py eval-results/noisy-depth.json \\
        docs/results/noisy-depth/franka_hand-8mm.json \\
        --command "python benchmarks/noisy_depth.py --noise 0.008"
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from _paired import run_paired

from wsgrasp.default_specs import default_spec


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gripper", default="franka_hand")
    ap.add_argument("--noise", type=float, default=0.008, help="depth noise (m)")
    ap.add_argument("--objects", default="random:000-119")
    ap.add_argument("--trials", type=int, default=1)
    ap.add_argument("-j", "--workers", type=int, default=0)
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    data, _ = default_spec(args.gripper)
    segmenter = data.get("segmenter", {"name": "ransac_dbscan"})
    options = {**segmenter.get("options", {}), "noise_floor": 0.0}
    fixed = {**data, "segmenter": {**segmenter, "options": options}}
    return run_paired(
        args.gripper,
        {"default": data, "fixed-floor": fixed},
        ["--objects", args.objects, "--trials", str(args.trials)]
        + ["--sim", f"depth_noise={args.noise}"],
        args.out,
        args.workers,
    )


if __name__ == "__main__":
    sys.exit(main())
