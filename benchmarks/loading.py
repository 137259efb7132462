"""What loading a camera's data costs: deprojecting a depth image
(``wsgrasp.perception.depth.depth_points``) at three resolutions beside reading
the same view as an NPZ cloud, and the check that the views of a scene agree
(``wsgrasp.perception.io.check_views_overlap``) on three views. Rendered scenes
(``scene synth``), alternating calls, medians (ms).

    .venv/bin/python benchmarks/loading.py [--repeat 15]
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from wsgrasp.perception.depth import Intrinsics, depth_points, read_depth_image
from wsgrasp.perception.io import check_views_overlap, load_cloud, write_scene_yaml
from wsgrasp.perception.synth import synth_scene
from wsgrasp.perception.types import Array


def _median_ms(fns: dict[str, Callable[[], Any]], repeat: int) -> dict[str, float]:
    times: dict[str, list[float]] = {k: [] for k in fns}
    for r in range(repeat + 1):  # the first round warms up
        for name, fn in fns.items():
            t = time.perf_counter()
            fn()
            if r:
                times[name].append((time.perf_counter() - t) * 1e3)
    return {k: statistics.median(v) for k, v in times.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=15)
    args = ap.parse_args()
    print(f"load average {os.getloadavg()[0]:.2f}")
    with tempfile.TemporaryDirectory() as tmp:
        for w, h in ((320, 240), (640, 480), (1280, 720)):
            synth = synth_scene("box", views=1, width=w, height=h)
            d = Path(tmp) / f"{w}x{h}"
            write_scene_yaml(d / "depth", synth.views, cameras=synth.cameras)
            write_scene_yaml(d / "cloud", synth.views)
            cam = synth.cameras[0]
            k = Intrinsics(fx=cam.fx, fy=cam.fy, cx=cam.cx, cy=cam.cy)
            png = d / "depth" / "view_0.png"
            ms = _median_ms(
                {
                    "png read + deproject": lambda: depth_points(
                        read_depth_image(png), k
                    ),
                    "npz cloud read": lambda: load_cloud(d / "cloud" / "view_0.npz"),
                },
                args.repeat,
            )
            cells = ", ".join(f"{name} {v:.1f}" for name, v in ms.items())
            print(f"{w} x {h} ({len(synth.views[0].points)} points): {cells}")
    synth = synth_scene("box")
    world: list[Array] = [
        v.points @ v.T_world_camera[:3, :3].T + v.T_world_camera[:3, 3]
        for v in synth.views
    ]
    ms = _median_ms(
        {"views agree": lambda: check_views_overlap(synth.views, world)},
        args.repeat,
    )
    n = sum(len(v.points) for v in synth.views)
    print(f"3 views ({n} points): views agree {ms['views agree']:.1f}")
    print(f"numpy {np.__version__}")


if __name__ == "__main__":
    main()
