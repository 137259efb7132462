"""The default specs a gripper ships beside its YAML (``specs/<label>.yaml``):
found without the repository's ``examples/``, equal to the examples users copy."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from wsgrasp.default_specs import GENERIC_DEFAULT, LABELS, spec_for
from wsgrasp.sim.specs import spec_entries

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = {
    "franka": ROOT / "plugins/grippers/wsgrasp_grippers/franka_hand",
    "allegro": ROOT / "plugins/grippers/wsgrasp_grippers/allegro_right",
    "barrett": ROOT / "examples/plugins/barrett_bh8_like/wsgrasp_barrett_bh8_like",
}


def _settings(path: Path) -> dict:
    data = yaml.safe_load(path.read_text())
    data.pop("gripper")
    return data


@pytest.mark.parametrize("gripper", sorted(SHIPPED))
@pytest.mark.parametrize("label", LABELS)
def test_shipped_specs_equal_the_examples(gripper, label):
    suffix = "" if label == "default" else f"_{label}"
    example = ROOT / "examples" / "specs" / f"{gripper}{suffix}.yaml"
    shipped = SHIPPED[gripper] / "specs" / f"{label}.yaml"
    assert _settings(shipped) == _settings(example)


def test_defaults_are_found_without_the_repository(monkeypatch, tmp_path):
    import wsgrasp.bench

    # a checkout without examples/: the shipped specs are still found
    monkeypatch.setattr(wsgrasp.bench, "project_root", lambda: tmp_path)
    monkeypatch.chdir(tmp_path)
    for label in LABELS:
        data, source = spec_for(label, "allegro_right")
        assert Path(source).parent.parent.name == "allegro_right", source
        assert data["gripper"] == "allegro_right"


def test_a_gripper_yaml_path_gets_the_specs_beside_it():
    barrett = SHIPPED["barrett"] / "barrett_bh8_like.yaml"
    entries = spec_entries([str(barrett)], followup=True)
    assert [e.label for e in entries] == list(LABELS)
    assert all(Path(e.source).parent.name == "specs" for e in entries)


def test_a_gripper_without_specs_gets_the_generic_default(tmp_path):
    import shutil

    folder = tmp_path / "jaw"
    shutil.copytree(SHIPPED["franka"], folder, ignore=shutil.ignore_patterns("specs"))
    yaml_path = str(folder / "franka_hand.yaml")
    data, source = spec_for("default", yaml_path)
    assert source == str(GENERIC_DEFAULT)
    assert data["gripper"] == yaml_path
    assert data["sampling"]["mode"] == "approach_sphere"
    # the paper's and the follow-up's settings are the Franka hand's
    for label in ("paper", "followup"):
        data, source = spec_for(label, yaml_path)
        assert "franka_hand" in source and source.endswith(f"{label}.yaml")


def test_the_generic_default_validates_for_every_kind_of_gripper():
    from wsgrasp.spec import load_spec

    barrett = SHIPPED["barrett"] / "barrett_bh8_like.yaml"
    for gripper in ("franka_hand", "allegro_right", str(barrett)):
        data = yaml.safe_load(GENERIC_DEFAULT.read_text())
        spec = load_spec({**data, "gripper": gripper})
        assert spec.sampling.mode == "approach_sphere"


def _level_if(scorers, tips):
    """``scorers`` as a fingertips-first hand's default has them: its
    approach_direction preferring a level approach, every other one as it is."""
    if not tips:
        return scorers
    level = {"options": {"direction": "level"}}
    return [{**s, **level} if s["name"] == "approach_direction" else s for s in scorers]


@pytest.mark.parametrize("tips", [False, True])
def test_the_written_default_is_the_generic_one_with_reach_down_fingertips_first(tips):
    """What `gripper new` writes: the generic default naming the gripper; for a
    hand that approaches fingertips first, with reach_down added after the
    generic scorers, approach_direction preferring a level approach, and a
    comment that says why."""
    from wsgrasp.default_specs import generic_spec_text
    from wsgrasp.spec import load_spec

    text = generic_spec_text("allegro_right", fingertips_first=tips)
    data = yaml.safe_load(text)
    generic = yaml.safe_load(GENERIC_DEFAULT.read_text())
    assert data["gripper"] == "allegro_right"
    extra = [{"name": "reach_down", "weight": 1.0}] if tips else []
    assert data["scorers"] == _level_if(generic["scorers"], tips) + extra
    assert {k: v for k, v in data.items() if k not in ("gripper", "scorers")} == {
        k: v for k, v in generic.items() if k not in ("gripper", "scorers")
    }
    assert ("approaches fingertips first" in text) == tips
    spec = load_spec(data)
    last = "reach_down" if tips else "closing_centre"
    assert [s.name for s in spec.scorers][-1] == last


@pytest.mark.parametrize("tips", [False, True])
@pytest.mark.parametrize("fingers", [3, 5])
def test_a_hand_gets_the_generic_default_without_the_jaw_scorers(tips, fingers):
    """For a hand of three or more fingers, `gripper new` writes the generic
    default without ``antipodal`` and ``closing_centre`` (reach_down still
    added fingertips first), and says so in the header."""
    from wsgrasp.default_specs import JAW_SCORERS, generic_spec_text
    from wsgrasp.spec import load_spec

    text = generic_spec_text("hand", fingertips_first=tips, fingers=fingers)
    data = yaml.safe_load(text)
    generic = yaml.safe_load(GENERIC_DEFAULT.read_text())
    kept = [s for s in generic["scorers"] if s["name"] not in JAW_SCORERS]
    assert kept and len(kept) < len(generic["scorers"])
    extra = [{"name": "reach_down", "weight": 1.0}] if tips else []
    assert data["scorers"] == _level_if(kept, tips) + extra
    head = [ln for ln in text.splitlines() if ln.startswith("#")]
    assert f"a hand of {fingers} fingers" in head[1]
    assert generic["object_frame"]["mirror_hidden"] is True
    assert data["object_frame"] == {"method": "farthest_split", "mirror_hidden": False}
    assert ("approaches fingertips first" in text) == tips
    assert load_spec({**data, "gripper": "allegro_right"}).scorers


def test_a_hand_without_a_spec_plans_with_the_hand_default(tmp_path):
    """A gripper YAML with no specs folder: a hand (the Allegro's four fingers)
    gets the generic default without the jaw scorers, a jaw (the Franka hand)
    gets it whole."""
    import shutil

    from wsgrasp.default_specs import JAW_SCORERS

    generic = yaml.safe_load(GENERIC_DEFAULT.read_text())
    for key, yaml_name, jaw in (
        ("allegro", "allegro_right.yaml", False),
        ("franka", "franka_hand.yaml", True),
    ):
        folder = tmp_path / key
        shutil.copytree(SHIPPED[key], folder, ignore=shutil.ignore_patterns("specs"))
        data, source = spec_for("default", str(folder / yaml_name))
        assert source == str(GENERIC_DEFAULT)
        want = [s for s in generic["scorers"] if jaw or s["name"] not in JAW_SCORERS]
        assert data["scorers"] == want
        # a jaw's pad on the face no camera saw finds the sides mirrored in
        assert data["object_frame"]["mirror_hidden"] is jaw


def test_plan_without_a_spec_uses_the_generic_default(tmp_path):
    import shutil

    from wsgrasp.cli._plan import plan_spec

    folder = tmp_path / "jaw"
    shutil.copytree(SHIPPED["franka"], folder, ignore=shutil.ignore_patterns("specs"))
    spec = plan_spec(None, str(folder / "franka_hand.yaml"))
    assert spec.sampling.mode == "approach_sphere"
    assert Path(spec.gripper) == folder / "franka_hand.yaml"
