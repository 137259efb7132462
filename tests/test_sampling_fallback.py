"""``sampling.fallback``: where the spec's sampling finds no grasp, the search
runs once more with another, and says so; where it finds one, nothing changes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from pydantic import ValidationError

from wsgrasp.api import Pipeline, as_scene
from wsgrasp.record import RunRecorder, open_run, replay_run
from wsgrasp.spec import Sampling, load_spec

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
#: one approach straight down at the middle of an upright 6 x 8 x 16 cm box:
#: across the box's 9.8 cm the Franka hand's 8 cm opening spans nothing
NARROW = {
    "mode": "approach_sphere",
    "directions": 1,
    "orientations": 1,
    "grid": [1, 1, 1],
}
TABLE_I = {"points": 147, "orientations": 4}


def _pipeline(sampling: dict) -> Pipeline:
    spec = load_spec(EXAMPLES / "specs" / "franka.yaml")
    spec.sampling = Sampling.model_validate(sampling)
    spec.record.enabled = False
    return Pipeline(spec)


@pytest.fixture(scope="module")
def scene():
    return as_scene(EXAMPLES / "scenes" / "box_upright.npz")


def test_a_fallback_has_no_fallback_of_its_own():
    with pytest.raises(ValidationError, match="no fallback of its own"):
        Sampling.model_validate({"fallback": {"fallback": {}}})


def test_no_grasp_searches_the_fallback_and_says_why_the_first_found_none(scene):
    alone = _pipeline(NARROW).plan(scene)
    assert not alone.found and "too large" in alone.hint
    result = _pipeline({**NARROW, "fallback": TABLE_I}).plan(scene)
    assert result.found
    first = result.info["fallback"]["first_search"]
    assert "too large for franka_hand" in first["too_large"]
    # the candidates are the fallback's, as a plan with its sampling gives them
    direct = _pipeline(TABLE_I).plan(scene)
    assert len(result.candidates) == len(direct.candidates) == 588
    np.testing.assert_array_equal(result.candidates.reason, direct.candidates.reason)
    assert result.best_index == direct.best_index
    np.testing.assert_array_equal(result.T_world_ee, direct.T_world_ee)
    assert "fallback" in result.timing_ms
    # what `plan --json` prints says so too
    assert result.to_json()["fallback"] == result.info["fallback"]
    assert "fallback" not in direct.to_json()


def test_a_grasp_found_leaves_the_fallback_unsearched(scene):
    plain = _pipeline(TABLE_I).plan(scene)
    result = _pipeline({**TABLE_I, "fallback": NARROW}).plan(scene)
    assert plain.found and "fallback" not in result.info
    assert "fallback" not in result.timing_ms
    np.testing.assert_array_equal(result.candidates.reason, plain.candidates.reason)
    np.testing.assert_array_equal(result.T_world_ee, plain.T_world_ee)


def test_a_run_that_fell_back_records_it_and_replays_bit_for_bit(scene, tmp_path):
    pipe = _pipeline({**NARROW, "fallback": TABLE_I})
    path = tmp_path / "run.mcap"
    rec = RunRecorder(path)
    result = pipe.plan(scene, observers=[rec])
    rec.close()
    run = open_run(path)
    stage = run.stages["fallback"]
    assert "too_large" in stage["first_search"]
    assert np.asarray(stage["R_world_gwc"]).shape == (4, 3, 3)
    assert len(np.asarray(stage["samples_world"])) == 147
    report = replay_run(path)
    assert report.identical and report.differences == []
    assert result.found
