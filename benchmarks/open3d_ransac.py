"""Whether open3d's seeded ``segment_plane`` gives the same plane every time.

Each round runs a fresh process that seeds ``o3d.utility.random.seed`` before each
of ``--calls`` calls of ``segment_plane(0.005, 3, 1000)`` on two clouds (the
``box_upright`` example scene and a seeded noisy table with a box and clutter),
under each ``OMP_NUM_THREADS`` given, and prints how many distinct results
(plane coefficients and inlier indices, hashed) each cloud gave. One result per
cloud means reproducible; ``fit_plane_ransac`` in ``wsgrasp.perception.process``
exists while it is not.

    .venv/bin/python benchmarks/open3d_ransac.py [--rounds 10] [--calls 4]
        [--threads 2 8]
"""

from __future__ import annotations

import argparse
import collections
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = """
import hashlib, sys
import numpy as np, open3d as o3d
from wsgrasp.perception.io import load_scene
rng = np.random.default_rng(0)
table = np.c_[rng.uniform(-0.5, 0.5, (20000, 2)), rng.normal(0, 0.003, 20000)]
box = rng.uniform([-0.05, -0.05, 0], [0.05, 0.05, 0.2], (5000, 3))
clutter = rng.uniform(-0.5, 0.5, (3000, 3))
clouds = {
    "box_upright": load_scene(sys.argv[1]).points,
    "synthetic": np.vstack([table, box, clutter]),
}
for name, p in clouds.items():
    pc = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.asarray(p, float)))
    for _ in range(int(sys.argv[2])):
        o3d.utility.random.seed(7)
        model, inliers = pc.segment_plane(0.005, 3, 1000)
        h = np.asarray(model).tobytes() + np.asarray(inliers, np.int64).tobytes()
        print(name, hashlib.sha1(h).hexdigest()[:12], len(inliers))
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--rounds", type=int, default=10)
    ap.add_argument("--calls", type=int, default=4)
    ap.add_argument("--threads", nargs="+", default=["2", "8"])
    a = ap.parse_args()
    scene = str(ROOT / "examples/scenes/box_upright.npz")
    seen: dict[tuple[str, str], collections.Counter[str]] = collections.defaultdict(
        collections.Counter
    )
    for threads in a.threads:
        env = {**os.environ, "OMP_NUM_THREADS": threads}
        for _ in range(a.rounds):
            out = subprocess.run(
                [sys.executable, "-c", CHILD, scene, str(a.calls)],
                env=env,
                capture_output=True,
                text=True,
                check=True,
            ).stdout
            for line in out.splitlines():
                name, digest, n = line.split()
                seen[(threads, name)][f"{digest} ({n} inliers)"] += 1
    for (threads, name), results in sorted(seen.items()):
        calls = sum(results.values())
        print(f"OMP_NUM_THREADS={threads} {name}: {len(results)} distinct in {calls}")
        for result, count in results.most_common():
            print(f"    {count:4d} x {result}")


if __name__ == "__main__":
    main()
