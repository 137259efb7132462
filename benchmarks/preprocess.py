"""Voxel downsampling on the bundled scenes: open3d's ``voxel_down_sample`` (the
cloud converted to open3d and back) against ``wsgrasp.perception.process.downsample``,
which gives the same points in another order. Alternating calls, medians (ms).

    .venv/bin/python benchmarks/preprocess.py [--repeat 25] [--voxel 0.005]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path

import numpy as np
import open3d as o3d

from wsgrasp.perception.io import load_scene
from wsgrasp.perception.process import downsample

ROOT = Path(__file__).resolve().parents[1]
SCENES = ["box_upright.npz", "box_camera_frame.npz", "mug.npz", "bottle_lying.npz"]


def open3d_downsample(points: np.ndarray, voxel: float) -> np.ndarray:
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    return np.asarray(cloud.voxel_down_sample(voxel).points)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=25)
    ap.add_argument("--voxel", type=float, default=0.005)
    args = ap.parse_args()
    print(f"load average {os.getloadavg()[0]:.2f}")
    for name in SCENES:
        points = load_scene([ROOT / "examples" / "scenes" / name]).points
        times: dict[str, list[float]] = {"open3d": [], "wsgrasp": []}
        for _ in range(args.repeat + 1):  # the first round warms up
            for label, fn in (("open3d", open3d_downsample), ("wsgrasp", downsample)):
                t = time.perf_counter()
                fn(points, args.voxel)
                times[label].append((time.perf_counter() - t) * 1e3)
        a, b = (statistics.median(times[k][1:]) for k in ("open3d", "wsgrasp"))
        print(
            f"{name:22s} {len(points):7d} points: open3d {a:5.2f} ms, "
            f"wsgrasp {b:5.2f} ms ({a / b:.1f}x)"
        )


if __name__ == "__main__":
    main()
