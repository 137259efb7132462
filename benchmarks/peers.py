"""wsgrasp's whole plan beside GPG's grasp candidate generation, on the same scenes.

GPG is the candidate sampler of GPD (ten Pas et al., "Grasp Pose Detection in
Point Clouds", IJRR 2017), here through the ``grasp-pose-generator`` binding on
PyPI (``make bench-peers`` builds it against Debian's libpcl-dev). The two do
different amounts of work, and the table says which:

- ``wsgrasp``: ``Pipeline(franka.yaml).plan(scene)``, the whole plan from the
  merged scene cloud (table and object): downsampling, table and object
  segmentation, object frame, samples, the workspace-sphere search over every
  candidate (object, finger and table tests), scoring, and the one grasp it
  chooses with its finger targets;
- ``gpg scene``: ``generate_grasps(cloud, samples)`` on the same scene cloud:
  its own preprocessing (statistical outlier removal, 3 mm voxels, normals from a
  3 cm neighbourhood), local frames at ``samples`` random points, 8 hand
  orientations each, and its collision test of the hand's box model against the
  points within reach. It returns every collision-free candidate that encloses
  a point; it neither scores nor chooses one (GPD's classifier would);
- ``gpg object``: the same on the object's points only (the scene points more
  than 5 mm above wsgrasp's table plane, found outside the timing): GPG given a
  segmentation for free, without the table to collide with. ``under table``
  counts the candidates whose hand box reaches more than 5 mm below that plane.

Each round plans every scene with each method in turn (the order rotating), so
that load on a shared machine hits all alike; figures are medians over the rounds,
after one warm-up call of each method. The binding runs GPG on every core
(``std::thread::hardware_concurrency``), seeds its sampler with the clock (its
counts vary from round to round) and keeps about 5 MB per call of a 60,000-point
cloud (it never frees its cloud); wsgrasp runs in this process as ``wsgrasp plan``
does.

GPG's binding fixes its single viewpoint at the cloud's origin (normals are turned
towards it, and a hand approaches against them), so it gets each cloud in the
frame of the scene's first camera: the pose the scene YAML gives, or, for the
bundled merged clouds, the one ``wsgrasp scene synth`` rendered them from
(re-rendered here with the arguments of examples/scenes/README.md and checked to
give the same points).

    .venv/bin/python benchmarks/peers.py [--rounds 3] [--samples 147 1000]
        [--random 3] [--json]
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SPEC = ROOT / "examples" / "specs" / "franka.yaml"  # = franka_hand's default spec
SCENES = ROOT / "examples" / "scenes"

#: GPG's hand model for the Franka hand, read off wsgrasp's own model of it
#: (plugins/grippers/.../franka_hand.urdf, authored from Franka Emika's published
#: dimensions), so that both plan for the same hand: 80 mm maximum opening
#: (2 x 40 mm finger travel), fingers 18 mm thick along the closing axis, 20 mm
#: across it and 54 mm long. GPG's ``hand_outer_diameter`` is the opening plus
#: both fingers (its FingerHand puts the finger centres ``outer - finger_width``
#: apart); ``init_bite`` is GPD's default (how far the fingertips first reach past
#: the nearest point).
FRANKA_GPG = {
    "finger_width": 0.018,
    "hand_outer_diameter": 0.116,  # 0.08 + 2 x 0.018
    "hand_depth": 0.054,
    "hand_height": 0.020,
    "init_bite": 0.01,
}
#: hand orientations GPG tries per sample (fixed by the binding)
GPG_ORIENTATIONS = 8
#: metres: GPG's voxel grid (CandidatesGenerator::preprocessPointCloud); it takes
#: every point of it as a sample when it has fewer than asked for
GPG_VOXEL = 0.003
#: metres above wsgrasp's table plane: the object's points for ``gpg object``;
#: and below it: a GPG candidate's hand box in the table
TABLE_MARGIN = 0.005

#: the ``wsgrasp scene synth`` arguments of the bundled merged clouds
#: (examples/scenes/README.md), to recover the camera each was rendered from
BUNDLED = {
    "box_upright": {"kind": "box", "table_size": 0.46, "seed": 0},
    "mug": {
        "kind": "cylinder",
        "size": (0.04, 0.10),
        "table_size": 0.4,
        "width": 256,
        "height": 192,
        "seed": 1,
    },
    "bottle_lying": {
        "kind": "cylinder",
        "size": (0.035, 0.22),
        "pose": "lying",
        "table_size": 0.4,
        "width": 256,
        "height": 192,
        "seed": 2,
    },
    "box_camera_frame": {
        "kind": "box",
        "size": (0.05, 0.07, 0.12),
        "pose": "random",
        "table_size": 0.4,
        "width": 256,
        "height": 192,
        "seed": 3,
        "camera_frame": True,
    },
}


@dataclass
class Case:
    """A scene, as wsgrasp plans it and as GPG gets it.

    Attributes
    ----------
    label : str
    scene : wsgrasp.perception.types.Scene
    T_world_camera : (4, 4) float
        GPG's viewpoint (its cloud's origin) in the scene's frame.
    """

    label: str
    scene: Any
    T_world_camera: np.ndarray


def _camera_of(path: Path, scene: Any) -> np.ndarray | None:
    """The first camera's pose of a loaded scene file: from its YAML, or by
    rendering a bundled merged cloud again (None for a cloud of unknown origin)."""
    if len(scene.viewpoints()):
        return np.asarray(scene.views[0].T_world_camera, dtype=np.float64)
    args = BUNDLED.get(path.stem)
    if args is None:
        return None
    from wsgrasp.perception.synth import synth_scene

    again = synth_scene(**args)
    if again.points.shape != scene.points.shape or not np.allclose(
        again.points, scene.points, atol=1e-6
    ):
        return None
    return np.asarray(again.views[0].T_world_camera, dtype=np.float64)


def bundled_cases() -> list[Case]:
    """The example scenes (``examples/scenes``), loaded as ``wsgrasp bench`` does."""
    from wsgrasp.api import as_scene

    cases = []
    paths = [*sorted(SCENES.glob("*.npz")), *sorted(SCENES.glob("*/scene.yaml"))]
    for path in paths:
        scene = as_scene(path)
        T = _camera_of(path, scene)
        label = path.parent.name if path.name == "scene.yaml" else path.stem
        if T is None:
            print(f"skipped {label}: its camera pose is unknown", file=sys.stderr)
            continue
        cases.append(Case(label, scene, T))
    return cases


def random_cases(count: int, tmp: Path) -> list[Case]:
    """pybullet_data's random objects 000 to ``count - 1`` (the ``eval-random``
    set), each rendered on a table like the bundled scenes, in a random pose."""
    if count <= 0:
        return []
    from wsgrasp.api import as_scene
    from wsgrasp.errors import WsgraspError
    from wsgrasp.perception.synth import synth_scene
    from wsgrasp.sim.random_objects import random_objects

    try:
        sources, _ = random_objects(f"0-{count - 1}")  # the too small ones skipped
    except WsgraspError as exc:
        print(f"no random objects: {exc}", file=sys.stderr)
        return []
    cases = []
    for number, src in enumerate(sources):
        mesh_path = tmp / f"{src.name}.stl"
        src.scaled().export(mesh_path)
        synth = synth_scene(
            str(mesh_path),
            pose="random",
            table_size=0.4,
            width=256,
            height=192,
            seed=100 + number,
        )
        # the merged cloud alone, as the bundled .npz scenes are planned
        scene = as_scene(synth.points)
        cases.append(Case(src.name, scene, synth.views[0].T_world_camera))
    return cases


@contextlib.contextmanager
def _quiet_stdout() -> Iterator[None]:
    """File descriptor 1 to /dev/null: GPG prints its progress with std::cout and
    printf (flushed before the descriptor comes back, or it would print later)."""
    import ctypes

    libc = ctypes.CDLL(None)
    sys.stdout.flush()
    saved = os.dup(1)
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, 1)
    try:
        yield
    finally:
        libc.fflush(None)
        os.dup2(saved, 1)
        os.close(saved)
        os.close(null)


class Gpg:
    """GPG's ``generate_grasps`` with the Franka hand, for clouds in camera frames."""

    def __init__(self, tmp: Path) -> None:
        try:
            import grasp_pose_generator
        except ImportError:
            sys.exit(
                "grasp_pose_generator is not installed: run `make bench-peers` "
                "(it installs libpcl-dev and builds the binding into .venv)"
            )
        self._generate = grasp_pose_generator.generate_grasps
        # the binding reads the hand from a key = value file on every call
        self.config = tmp / "franka_hand.cfg"
        self.config.write_text("".join(f"{k} = {v}\n" for k, v in FRANKA_GPG.items()))

    def __call__(self, cloud_camera: np.ndarray, samples: int) -> list[Any]:
        """Candidates for ``cloud_camera`` ``(n, 3) float32``, viewpoint at 0."""
        with _quiet_stdout():
            return list(self._generate(cloud_camera, samples, False, str(self.config)))


def hand_corners(grasps: list[Any]) -> np.ndarray:
    """The corners of each candidate's hand box in GPG's model (fingers from its
    bottom to its top, ``hand_outer_diameter`` wide along the binormal,
    ``hand_height`` along the axis): ``(n, 8, 3)``, in the cloud's frame."""
    if not grasps:
        return np.empty((0, 8, 3))
    # per candidate: (n, 3) each
    bottom, top, binormal, axis = (
        np.array([getattr(g, f"get_grasp_{k}")() for g in grasps], dtype=np.float64)
        for k in ("bottom", "top", "binormal", "axis")
    )
    ends = np.stack([bottom, top], axis=1)  # (n, 2, 3)
    across = binormal[:, None] * np.array([-1.0, 1.0])[:, None]  # (n, 2, 3)
    across *= FRANKA_GPG["hand_outer_diameter"] / 2.0
    up = axis[:, None] * np.array([-1.0, 1.0])[:, None]  # (n, 2, 3)
    up *= FRANKA_GPG["hand_height"] / 2.0
    corners = ends[:, :, None, None] + across[:, None, :, None] + up[:, None, None, :]
    return corners.reshape(-1, 8, 3)  # (n, 2, 2, 2, 3) -> (n, 8, 3)


def gpg_counts(grasps: list[Any], case: Case, table: Any) -> dict[str, int]:
    """GPG's candidates against wsgrasp's table plane (scene frame): those whose
    hand box reaches more than ``TABLE_MARGIN`` below the table's top (into the
    table, or grasping its edge), and those on the object and clear of it."""
    from wsgrasp.geometry import transform_points

    corners = transform_points(case.T_world_camera, hand_corners(grasps))
    depth = table.signed_distance(corners.reshape(-1, 3)).reshape(-1, 8)  # (n, 8)
    under = (depth < -TABLE_MARGIN).any(axis=1)  # (n,)
    surface = np.array([g.get_grasp_surface() for g in grasps]).reshape(-1, 3)
    height = table.signed_distance(transform_points(case.T_world_camera, surface))
    on_object = (height > TABLE_MARGIN) & ~under
    return {
        "kept": len(grasps),
        "on_object": int(on_object.sum()),
        "under_table": int(under.sum()),
    }


def _ms(fn: Callable[[], Any]) -> tuple[float, Any]:
    t = time.perf_counter()
    out = fn()
    return (time.perf_counter() - t) * 1e3, out


def gpg_inputs(case: Case, table: Any) -> dict[str, np.ndarray]:
    """GPG's clouds ``(n, 3) float32`` in the first camera's frame: the whole
    scene, and its points more than ``TABLE_MARGIN`` above the table."""
    from wsgrasp.geometry import invert_transforms, transform_points

    T_camera_world = invert_transforms(case.T_world_camera)
    points = case.scene.points
    above = table.signed_distance(points) > TABLE_MARGIN
    return {
        kind: transform_points(T_camera_world, pts).astype(np.float32)
        for kind, pts in (("scene", points), ("object", points[above]))
    }


def measure(
    cases: list[Case], samples: list[int], rounds: int, gpg: Gpg
) -> tuple[list[dict[str, Any]], dict[str, str]]:
    """One row per scene and method: medians over ``rounds`` (after one warm-up
    pass on the first scene); and the scenes wsgrasp refuses (left out for both),
    with its reason."""
    from wsgrasp import Pipeline, load_spec
    from wsgrasp.errors import WsgraspError

    pipe = Pipeline(load_spec(SPEC))
    methods: list[tuple[str, str, int]] = [("wsgrasp", "", 0)] + [
        (f"gpg {kind} {n}", kind, n) for kind in ("scene", "object") for n in samples
    ]
    tables, inputs, voxels, refused = {}, {}, {}, {}
    for c in cases:
        try:
            prep = pipe.prepare(c.scene)  # wsgrasp's table plane, outside the timing
        except WsgraspError as exc:
            refused[c.label] = exc.message
            continue
        tables[c.label] = prep.table_plane
        inputs[c.label] = gpg_inputs(c, prep.table_plane)
        voxels[c.label] = {
            kind: len(np.unique(np.floor(cloud / GPG_VOXEL), axis=0))
            for kind, cloud in inputs[c.label].items()
        }
    cases = [c for c in cases if c.label not in refused]

    def run(c: Case, kind: str, n: int) -> tuple[float, dict[str, int]]:
        if not kind:
            dt, result = _ms(lambda: pipe.plan(c.scene))
            kept = int(result.candidates.feasible.sum())
            return dt, {
                "tried": len(result.candidates),
                "kept": kept,
                "on_object": kept,
                "chosen": int(result.found),
            }
        cloud = inputs[c.label][kind]
        dt, grasps = _ms(lambda: gpg(cloud, n))
        tried = {"tried": min(n, voxels[c.label][kind]) * GPG_ORIENTATIONS}
        return dt, {**tried, **gpg_counts(grasps, c, tables[c.label])}

    for _, kind, n in methods:
        run(cases[0], kind, n)  # warm-up
    ms: dict[tuple[str, str], list[float]] = {}
    counts: dict[tuple[str, str], dict[str, list[int]]] = {}
    for i in range(rounds):
        for j, c in enumerate(cases):
            k = (i + j) % len(methods)
            for name, kind, n in methods[k:] + methods[:k]:  # each first in turn
                dt, got = run(c, kind, n)
                ms.setdefault((c.label, name), []).append(dt)
                for field, v in got.items():
                    counts.setdefault((c.label, name), {}).setdefault(field, [])
                    counts[c.label, name][field].append(v)
    rows = []
    for c in cases:
        base = statistics.median(ms[c.label, "wsgrasp"])
        for name, kind, n in methods:
            times = ms[c.label, name]
            row: dict[str, Any] = {
                "scene": c.label,
                "method": name,
                "scene_points": len(c.scene.points),
                "input_points": len(inputs[c.label][kind] if kind else c.scene.points),
                "ms": round(statistics.median(times), 1),
                "min_ms": round(min(times), 1),
                "vs_wsgrasp": round(statistics.median(times) / base, 2),
                "rounds": len(times),
            }
            if kind:
                row["samples"] = n
            for field, v in counts[c.label, name].items():
                row[field] = statistics.median(v)
            rows.append(row)
    return rows, refused


def print_table(
    rows: list[dict[str, Any]], refused: dict[str, str], rounds: int
) -> None:
    """The rows as a rich table (120 columns wide when not on a terminal)."""
    from rich import box
    from rich.console import Console
    from rich.table import Table

    t = Table(
        title=f"wsgrasp's plan and GPG's candidates, medians of {rounds} rounds",
        box=box.SIMPLE_HEAD,
        caption=(
            "tried: wsgrasp's candidate poses, GPG's samples (at most its "
            f"{GPG_VOXEL * 1e3:g} mm voxels) x {GPG_ORIENTATIONS} hand orientations. "
            "kept: wsgrasp's feasible "
            "candidates, GPG's collision-free ones; on object: of those, on the "
            "object and clear of the table; under table: GPG's hand box more "
            f"than {TABLE_MARGIN * 1e3:g} mm under the table's top. wsgrasp chooses "
            f"one grasp, GPG none. GPG ran on {os.cpu_count()} cores."
        ),
    )
    right = ("points", "ms", "x wsgrasp", "tried", "kept", "on object")
    for col in ("scene", "method", *right, "under table", "chosen"):
        t.add_column(col, justify="left" if col in ("scene", "method") else "right")
    last = None
    for r in rows:
        if last is not None and r["scene"] != last:
            t.add_section()
        last = r["scene"]
        t.add_row(
            r["scene"],
            r["method"],
            f"{r['input_points']:,}",
            f"{r['ms']:,.1f}",
            f"{r['vs_wsgrasp']:.2f}",
            f"{r['tried']:,g}",
            f"{r['kept']:g}",
            f"{r['on_object']:g}",
            f"{r['under_table']:g}" if "under_table" in r else "",
            f"{r['chosen']:g}" if "chosen" in r else "",
        )
    console = Console() if sys.stdout.isatty() else Console(width=120)
    console.print(t)
    for label, why in refused.items():
        console.print(f"left out {label}: wsgrasp refuses it ({why})", highlight=False)


def _commit() -> str:
    """The checkout's commit, ``+`` when its tracked files have changes."""
    import subprocess

    def git(*args: str) -> str:
        run = subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True)
        return run.stdout.strip()

    return git("rev-parse", "--short", "HEAD") + (
        "+" if git("status", "-uno", "-s") else ""
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument(
        "--samples",
        type=int,
        nargs="+",
        default=[147, 1000],
        help="GPG's sample counts (147: wsgrasp's default sample count)",
    )
    ap.add_argument(
        "--random", type=int, default=3, help="random objects to add (0: none)"
    )
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        gpg = Gpg(Path(tmp))
        cases = bundled_cases() + random_cases(a.random, Path(tmp))
        rows, refused = measure(cases, a.samples, a.rounds, gpg)
    if a.json:
        info = {
            "wsgrasp_commit": _commit(),
            "gpg_hand": FRANKA_GPG,
            "cores": os.cpu_count(),
            "rounds": a.rounds,
        }
        out = {"info": info, "rows": rows, "refused": refused}
        print(json.dumps(out, indent=2))
        return
    print_table(rows, refused, a.rounds)


if __name__ == "__main__":
    main()
