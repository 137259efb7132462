"""Grasp trials seen by one camera: a gripper's default spec with the sides no
camera saw mirrored in (``object_frame.mirror_hidden: true``) beside the same
spec planning on what the camera saw alone, the same drops for both.

    python benchmarks/one_camera_mirror.py --gripper franka_hand \\
        --objects random:000-119 --out eval-results/mirror.json
    python benchmarks/publish_result.py eval-results/mirror.json \\
        docs/results/mirror-hidden/franka_hand-random-000-119.json \\
        --command "python benchmarks/one_camera_mirror.py --objects random:000-119"
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
    ap.add_argument("--objects", default="random:000-119")
    ap.add_argument("--trials", type=int, default=1)
    ap.add_argument("--elevation", type=float, default=45.0, help="camera (deg)")
    ap.add_argument("-j", "--workers", type=int, default=0)
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    data, _ = default_spec(args.gripper)
    frame = data.get("object_frame", {})
    specs = {
        label: {**data, "object_frame": {**frame, "mirror_hidden": on}}
        for label, on in (("mirrored", True), ("as-seen", False))
    }
    return run_paired(
        args.gripper,
        specs,
        ["--objects", args.objects, "--trials", str(args.trials)]
        + ["--sim", "views=1", "--sim", f"camera_elevation_deg={args.elevation}"],
        args.out,
        args.workers,
    )


if __name__ == "__main__":
    sys.exit(main())
