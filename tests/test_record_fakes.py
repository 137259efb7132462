"""Shared helpers of the record/replay/view tests: a small Franka-like gripper model
(conftest.make_jaw_gripper, no URDF), synthetic scenes, and recorded runs.

It holds no tests itself; the other ``test_record*`` modules import it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from conftest import make_jaw_gripper

from wsgrasp.gripper.model import GripperModel
from wsgrasp.perception.types import Scene, View
from wsgrasp.spec import PipelineSpec, load_spec


def fake_gripper(name: str = "fake_franka") -> GripperModel:
    """A Franka-like gripper: 5 body SEs, 2 fingers of 10 spheres, ~500 points."""
    return make_jaw_gripper(name=name)


def box_scene(seed: int = 0, views: int = 2) -> Scene:
    """A 4 x 6 x 12 cm box on a 40 cm table, seen by ``views`` cameras."""
    rng = np.random.default_rng(seed)
    table = np.column_stack(
        [rng.uniform(-0.2, 0.2, 3000), rng.uniform(-0.2, 0.2, 3000), np.zeros(3000)]
    )
    box = rng.uniform(-0.5, 0.5, size=(1500, 3))
    axis = rng.integers(0, 3, size=1500)
    box[np.arange(1500), axis] = np.sign(box[np.arange(1500), axis]) * 0.5
    box = box * [0.04, 0.06, 0.12] + [0.0, 0.0, 0.06]
    world = np.concatenate([table, box]) + rng.normal(0, 0.0005, size=(4500, 3))
    parts = np.array_split(world, views)
    vlist = []
    for i, p in enumerate(parts):
        T = np.eye(4)
        c, s = np.cos(0.3 * i), np.sin(0.3 * i)
        T[:3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
        T[:3, 3] = [0.1 * i, -0.05 * i, 0.5]
        p_cam = (p - T[:3, 3]) @ T[:3, :3]  # (n, 3) world → camera
        vlist.append(View(points=p_cam, T_world_camera=T, name=f"cam{i}"))
    merged = np.concatenate(
        [v.points @ v.T_world_camera[:3, :3].T + v.T_world_camera[:3, 3] for v in vlist]
    )
    return Scene(views=vlist, points=merged, dropped_nonfinite=0)


def fake_spec(**overrides: Any) -> PipelineSpec:
    data: dict[str, Any] = {
        "gripper": "fake_franka",
        "segmenter": {"name": "ransac_dbscan"},
        "sampling": {"points": 147, "orientations": 4, "angle_range_deg": 360},
        "scorers": [{"name": "centroid_distance", "weight": 1.0}],
    }
    data.update(overrides)
    return load_spec(data, check_plugins=False)


def plan_recorded(
    path: Path,
    *,
    spec: PipelineSpec | None = None,
    gripper: GripperModel | None = None,
    scene: Scene | None = None,
) -> Any:
    """Plan with the real pipeline and the fake gripper, recording to ``path``;
    the file is finished when this returns (the writer thread writes its views
    and summary after the plan: a test that reads the bytes would otherwise race
    it)."""
    from wsgrasp.api import Pipeline
    from wsgrasp.record import RunRecorder

    spec = spec or fake_spec()
    gripper = gripper or fake_gripper()
    scene = scene or box_scene()
    rec = RunRecorder(path)
    result = Pipeline(spec, gripper=gripper).plan(scene, observers=[rec])
    rec.close()
    return result
