"""Every built-in and example gripper, with its default spec, finds a grasp on an
upright 6 x 5 x 11 cm box and on a 5 cm cube (the shapes a hand held
perpendicular to the major axis alone cannot always reach)."""

from __future__ import annotations

from pathlib import Path

import pytest

import wsgrasp
from wsgrasp.perception.synth import synth_scene
from wsgrasp.spec import load_spec

ROOT = Path(__file__).resolve().parent.parent
ROBOTIQ = (
    ROOT
    / "examples/plugins/robotiq_2f85_like/wsgrasp_robotiq_2f85_like"
    / "robotiq_2f85_like.yaml"
)
CASES = {
    "franka_hand": ("franka.yaml", None),
    "allegro_right": ("allegro.yaml", None),
    "barrett_bh8_like": ("barrett.yaml", None),
    "robotiq_2f85_like": ("franka.yaml", ROBOTIQ),
}
SHAPES = {"box_6x5x11": ((0.06, 0.05, 0.11), 2), "cube_5": ((0.05, 0.05, 0.05), 3)}


@pytest.fixture(scope="module")
def scenes():
    return {
        k: synth_scene("box", size=s, seed=seed).points
        for k, (s, seed) in SHAPES.items()
    }


@pytest.mark.parametrize("shape", list(SHAPES))
@pytest.mark.parametrize("gripper", list(CASES))
def test_default_spec_grasps_box_and_cube(scenes, gripper, shape):
    spec_file, yaml = CASES[gripper]
    spec = load_spec(ROOT / "examples" / "specs" / spec_file)
    if yaml is not None:
        spec = load_spec({**spec.model_dump(), "gripper": str(yaml)})
    result = wsgrasp.Pipeline(spec).plan(scenes[shape])
    assert result.found, result.hint
    assert result.joints_grasp and result.T_world_pregrasp is not None
