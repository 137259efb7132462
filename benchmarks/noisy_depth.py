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
import subprocess
import sys
import tempfile
from pathlib import Path

import yaml

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
    with tempfile.TemporaryDirectory() as tmp:
        specs = {}
        for label, spec in (("default", data), ("fixed-floor", fixed)):
            specs[label] = Path(tmp) / f"{label}.yaml"
            specs[label].write_text(yaml.safe_dump(spec))
        args.out.parent.mkdir(parents=True, exist_ok=True)
        cmd = [
            str(Path(sys.executable).with_name("wsgrasp")), "eval",
            "-g", args.gripper, "--no-paper",
            *(a for label, p in specs.items() for a in ("-s", f"{label}={p}")),
            "--objects", args.objects, "--trials", str(args.trials),
            "--sim", f"depth_noise={args.noise}", "--seed", "0",
            "-j", str(args.workers), "--json-out", str(args.out),
        ]  # fmt: skip
        return subprocess.run(cmd).returncode


if __name__ == "__main__":
    sys.exit(main())
