"""Plans on one camera's view of a room around a desk: where the grasp lands.

A box and a can on a desk (1.2 x 0.8 m, 72 cm legs), a floor and a wall, seen
by one camera 1-3 m away (six placements) as its image gives them (points in the
camera's frame, no pose), 640 x 480 at 69 degrees and 1280 x 720 at 87. Depth
noise is either constant (``--noise``, m) or grows with the square of the range
(``--noise-per-m2``: a stereo camera's, about 2.5 mm at 1 m). Each plan is
judged by where its tool point lands: within 8 cm of the object's centre (on
the object), elsewhere (a leg, the floor), no grasp, or an error.

    python benchmarks/room_views.py --json-out eval-results/rooms.json
    python benchmarks/publish_result.py eval-results/rooms.json \\
        docs/results/rooms/franka_hand-2mm.json \\
        --command "python benchmarks/room_views.py"
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from wsgrasp.api import Pipeline
from wsgrasp.default_specs import default_spec
from wsgrasp.errors import WsgraspError
from wsgrasp.geometry import transform_from
from wsgrasp.perception.io import scene_from_arrays
from wsgrasp.perception.synth import Camera, look_at, make_object, render_scene
from wsgrasp.spec import PipelineSpec

#: the objects on the desk
OBJECTS = (("box", (0.05, 0.07, 0.14)), ("cylinder", (0.035, 0.11)))
#: the camera's placements: distance (m), elevation and azimuth (degrees)
PLACEMENTS = (
    (1.0, 45, 0),
    (1.5, 40, 20),
    (2.0, 35, -30),
    (2.5, 30, 10),
    (1.2, 60, 45),
    (3.0, 25, 0),
)
#: the cameras: width, height, horizontal field of view (degrees)
CAMERAS = {"640": (640, 480, 69.0), "1280": (1280, 720, 87.0)}
#: a tool point this close (m) to the object's centre is on the object
ON_OBJECT_M = 0.08


def room(
    kind: str | None,
    size: tuple[float, ...],
    eye: np.ndarray,
    camera: tuple[int, int, float],
    noise: float,
    noise_per_m2: float,
    seed: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The camera's points (its frame), its pose and the object's centre (an
    empty desk without ``kind``: the desk's top's middle)."""
    import trimesh

    rng = np.random.default_rng(seed)
    box = trimesh.creation.box
    parts = []
    centre = np.zeros(3)
    if kind is not None:
        mesh = make_object(kind, size)
        T = transform_from(None, [0.05, -0.1, -mesh.bounds[0][2]])
        parts.append((mesh, T))
        centre = T[:3, 3] + mesh.bounds.mean(axis=0)
    parts += [
        (box(extents=(0.8, 1.2, 0.03)), transform_from(None, [0, 0, -0.015])),
        (box(extents=(8, 8, 0.02)), transform_from(None, [0, 0, -0.76])),
        (box(extents=(0.02, 8, 2.5)), transform_from(None, [-1.6, 0, 0.45])),
    ]
    for sx in (-1, 1):
        for sy in (-1, 1):
            leg = transform_from(None, [sx * 0.35, sy * 0.55, -0.39])
            parts.append((box(extents=(0.05, 0.05, 0.72)), leg))
    w, h, fov = camera
    cam = Camera.from_fov(look_at(eye, [0, 0, 0.05]), w, h, fov)
    (view,) = render_scene(parts, None, [cam], 0.0 if noise_per_m2 else noise, rng, 0.3)
    points = view.points
    if noise_per_m2:  # along each ray, growing with the square of the range
        z = np.abs(points[..., 2:3])
        points = points * (1.0 + rng.normal(0.0, 1.0, z.shape) * noise_per_m2 * z)
    return points, view.T_world_camera, centre


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gripper", default="franka_hand")
    ap.add_argument("--resolution", action="append", choices=sorted(CAMERAS))
    ap.add_argument("--noise", type=float, default=0.002, help="depth noise (m)")
    ap.add_argument("--noise-per-m2", type=float, default=0.0)
    ap.add_argument(
        "--crop-past",
        type=float,
        default=None,
        help="crop the scene this far (m) past the camera's distance to the desk",
    )
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json-out", type=Path, required=True)
    args = ap.parse_args()
    data, _ = default_spec(args.gripper)
    rows: list[dict[str, Any]] = []
    for res in args.resolution or sorted(CAMERAS):
        for kind, size in OBJECTS:
            for distance, elevation, azimuth in PLACEMENTS:
                el, az = np.radians(elevation), np.radians(azimuth)
                eye = distance * np.array(
                    [np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)]
                )
                points, T_world_camera, centre = room(
                    kind,
                    size,
                    eye,
                    CAMERAS[res],
                    args.noise,
                    args.noise_per_m2,
                    args.seed,
                )
                spec = PipelineSpec.model_validate(data)
                if args.crop_past is not None:
                    spec.preprocess.crop_radius = distance + args.crop_past
                row: dict[str, Any] = {
                    "object": kind,
                    "resolution": res,
                    "distance": distance,
                    "elevation": elevation,
                    "azimuth": azimuth,
                }
                t = time.perf_counter()
                try:
                    result = Pipeline(spec).plan(scene_from_arrays(points))
                except WsgraspError as exc:
                    row.update(outcome="error", error=str(exc).splitlines()[0][:200])
                else:
                    if not result.found:
                        row.update(outcome="no grasp")
                    else:
                        tcp = (T_world_camera @ result.T_world_tcp)[:3, 3]
                        off = float(np.linalg.norm(tcp - centre))
                        row.update(
                            outcome="on the object"
                            if off <= ON_OBJECT_M
                            else "elsewhere",
                            offset_m=off,
                        )
                    row["warnings"] = len(result.warnings)
                row["plan_s"] = time.perf_counter() - t
                rows.append(row)
                print(
                    f"{kind} {res} {distance} m {elevation}° {azimuth}°: "
                    f"{row['outcome']} ({row['plan_s']:.2f} s)",
                    flush=True,
                )
    outcomes = ("on the object", "elsewhere", "no grasp", "error")
    report = {
        "gripper": args.gripper,
        "noise": args.noise,
        "noise_per_m2": args.noise_per_m2,
        "crop_past": args.crop_past,
        "seed": args.seed,
        "views": len(rows),
        "outcomes": {o: sum(r["outcome"] == o for r in rows) for o in outcomes},
        "plan_s_median": statistics.median(r["plan_s"] for r in rows),
        "rows": rows,
    }
    args.json_out.parent.mkdir(parents=True, exist_ok=True)
    args.json_out.write_text(json.dumps(report, indent=1) + "\n")
    print(json.dumps(report["outcomes"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
