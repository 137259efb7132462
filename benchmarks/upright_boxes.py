"""Upright boxes of square section a little narrower than a jaw opens: grasp
trials with the default spec beside the same spec with
``sampling.across_narrowest: false`` (the object frame's angles), the same drops
for both.

Writes the box meshes (``--sizes``, cm across, 10 cm tall) to a temporary
folder, then runs ``wsgrasp eval`` on them under the strict protocol; the report
is ``wsgrasp eval``'s, with both specs.

    python benchmarks/upright_boxes.py --out eval-results/upright-boxes.json
    python benchmarks/publish_result.py eval-results/upright-boxes.json \\
        docs/results/across-narrowest/franka_hand-strict.json \\
        --command "python benchmarks/upright_boxes.py"
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import trimesh
from _paired import run_paired

from wsgrasp.default_specs import default_spec


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gripper", default="franka_hand")
    ap.add_argument("--sizes", default="6.8,7.2,7.4,7.6", help="cm across")
    ap.add_argument("--height", type=float, default=10.0, help="cm")
    ap.add_argument("--trials", type=int, default=10)
    ap.add_argument("--mass", type=float, default=0.2, help="kg, every box")
    ap.add_argument("-j", "--workers", type=int, default=0)
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "boxes"
        folder.mkdir()
        for cm in (float(s) for s in args.sizes.split(",")):
            box = trimesh.creation.box((cm / 100, cm / 100, args.height / 100))
            box.export(folder / f"box_{round(cm * 10)}mm.obj")
        data, _ = default_spec(args.gripper)
        frame = {**data, "sampling": {**data["sampling"], "across_narrowest": False}}
        code = run_paired(
            args.gripper,
            {"default": data, "frame-angles": frame},
            ["--objects", str(folder), "--trials", str(args.trials)]
            + ["--mass", str(args.mass)],
            args.out,
            args.workers,
        )
    if code == 0:  # the boxes' folder is gone: name them instead
        report = json.loads(args.out.read_text())
        report["objects"] = (
            f"upright boxes {args.sizes.replace(',', ', ')} cm across, "
            f"{args.height:g} cm tall"
        )
        args.out.write_text(json.dumps(report, indent=1) + "\n")
    return code


if __name__ == "__main__":
    sys.exit(main())
