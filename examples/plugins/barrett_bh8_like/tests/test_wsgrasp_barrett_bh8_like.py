"""The gripper of this package.

It builds, `wsgrasp gripper check` finds no error in it, and it plans a grasp.
"""

from __future__ import annotations

from pathlib import Path

from wsgrasp import Pipeline
from wsgrasp.gripper.check import check_gripper
from wsgrasp.perception.io import scene_from_arrays
from wsgrasp.perception.synth import synth_scene
from wsgrasp.spec import load_spec

HERE = Path(__file__).resolve().parents[1]
YAML = HERE / "wsgrasp_barrett_bh8_like" / "barrett_bh8_like.yaml"


def test_check_finds_no_errors():
    report = check_gripper(str(YAML))
    assert not report.errors, report.format()


def test_plans_a_grasp_on_a_cylinder():
    pipe = Pipeline(load_spec({"gripper": str(YAML), "record": {"enabled": False}}))
    radius = min(0.035, max(0.012, 0.2 * pipe.gripper.max_opening))
    scene = synth_scene("cylinder", size=(radius, 0.12), seed=0, width=160, height=120)
    result = pipe.plan(scene_from_arrays(scene.points))
    assert result.found, result.hint
