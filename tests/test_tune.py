"""``wsgrasp gripper tune``: the closings it tries, its choice and what it writes."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from vendor_factory import hand_urdf

from wsgrasp.errors import InputError
from wsgrasp.gripper import load_gripper
from wsgrasp.gripper.scaffold import scaffold_plugin
from wsgrasp.sim.tune import (
    CONTACTS_APPROACH,
    TuneResult,
    VariantResult,
    _replace_closed,
    closed_at_limits,
    compare_drops,
    write_tuned,
)
from wsgrasp.spec import GripperDescription


@pytest.fixture(scope="module")
def hand(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A three-finger hand of boxes as ``gripper new`` scaffolds it."""
    root = tmp_path_factory.mktemp("tune")
    (root / "hand.urdf").write_text(hand_urdf())
    yaml_path, _ = scaffold_plugin(
        "hand", root / "hand.urdf", root / "pkg", check=False
    )
    return yaml_path


def test_closed_at_limits_moves_every_closing_joint_to_its_limit(hand: Path):
    """Each finger joint that moves from the pre-grasp posture ends at its limit
    on the closing side; one that does not move stays where ``closed`` has it."""
    g = load_gripper(str(hand))
    at = closed_at_limits(g)
    moved = 0
    for joints, lim in zip(g.finger_joints, g.finger_limits, strict=True):
        for j, (lo, hi) in zip(joints, np.asarray(lim), strict=True):
            pre, end = g.pregrasp.get(j, lo), g.closed.get(j, g.pregrasp.get(j, lo))
            if end > pre:
                assert at[j] == pytest.approx(hi), j
            elif end < pre:
                assert at[j] == pytest.approx(lo), j
            else:
                assert at[j] == end, j
            moved += end != pre
    assert moved >= 3
    # the lone finger closes towards its lower limits, the others their upper
    assert {np.sign(at[j] - g.pregrasp[j]) for j in at if at[j] != g.closed[j]} >= {
        -1.0,
        1.0,
    }


def test_compare_drops_counts_and_interval():
    """Drops gained and lost, and the eval report's paired interval (mean ±
    1.96 s / √n); one drop bounds nothing."""
    a = [True, True, False, True, True, False]
    b = [True, False, False, False, True, True]
    gained, lost, mean, (lo, hi) = compare_drops(a, b)
    assert (gained, lost) == (2, 1)
    d = np.array(a, float) - np.array(b, float)
    assert mean == pytest.approx(d.mean())
    half = 1.96 * d.std(ddof=1) / np.sqrt(len(d))
    assert (lo, hi) == pytest.approx((d.mean() - half, d.mean() + half))
    assert compare_drops([], []) == (0, 0, 0.0, (0.0, 0.0))
    assert compare_drops([True], [False]) == (1, 0, 1.0, (-np.inf, np.inf))


def _result(hand: Path, chosen: str, ci_low: float = 0.2) -> TuneResult:
    """A tune result for ``hand`` as :func:`tune_closing` returns one."""
    g = load_gripper(str(hand))
    data = yaml.safe_load(hand.read_text())
    as_is = {k: float(v) for k, v in data["closed"].items()}
    limits = {k: closed_at_limits(g).get(k, v) for k, v in as_is.items()}
    approach = {"squeeze": 0.06, "close_to": "closed"}
    contacts = {**approach, **CONTACTS_APPROACH}
    return TuneResult(
        gripper=str(hand),
        objects="random:000-059",
        protocol="strict",
        seed=0,
        trials_per_object=1,
        variants=[
            VariantResult("as_is", as_is, approach, 60, 20),
            VariantResult("limits", limits, approach, 60, 30, 12, 2, 0.17, (0.05, 0.3)),
            VariantResult(
                "limits_contacts", limits, contacts, 60, 40, 22, 2, 0.33, (ci_low, 0.45)
            ),
        ],
        chosen=chosen,
        wall_s=1.0,
    )


def test_write_tuned_rewrites_closed_and_the_spec(tmp_path: Path, hand: Path):
    """The chosen closing goes into the YAML's ``closed`` block (the other
    lines, comments included, as they were) and the package's default spec's
    ``approach``, each under a comment with the figures; tuning again replaces
    that comment rather than adding another."""
    import shutil

    pkg = tmp_path / "pkg"
    shutil.copytree(hand.parents[1], pkg)
    yaml_path = pkg / hand.parent.name / hand.name
    before = yaml_path.read_text()
    result = _result(hand, "limits_contacts")
    result.gripper = str(yaml_path)
    written = write_tuned(result)
    spec = yaml_path.parent / "specs" / "default.yaml"
    assert written == [yaml_path, spec]
    text = yaml_path.read_text()
    data = yaml.safe_load(text)
    GripperDescription.model_validate(data)
    assert data["closed"] == pytest.approx(result.variant("limits").closed)
    assert text.count("# `wsgrasp gripper tune`") == 1
    assert "held 40 of 60 against 20 as it was" in " ".join(
        line.lstrip("# ") for line in text.splitlines()
    )
    # every other line as it was
    kept = [ln for ln in before.splitlines() if ln.strip() and ln not in text]
    assert all(ln.startswith("  ") for ln in kept), kept
    assert yaml.safe_load(spec.read_text())["approach"] == {
        "squeeze": 0.02,
        "close_to": "contacts",
    }
    write_tuned(result)
    assert yaml_path.read_text() == text
    assert spec.read_text().count("# `wsgrasp gripper tune`") == 1
    # a YAML with no spec beside it gets one, from the generic default
    spec.unlink()
    write_tuned(result)
    again = yaml.safe_load(spec.read_text())
    assert again["approach"] == {"squeeze": 0.02, "close_to": "contacts"}
    assert again["scorers"]


def test_write_tuned_keeps_a_hand_that_no_closing_beats(tmp_path: Path, hand: Path):
    result = _result(hand, "as_is", ci_low=-0.01)
    assert write_tuned(result) == []
    assert "stays" in result.summary()


def test_a_flow_mapping_closed_is_named():
    with pytest.raises(InputError, match="block mapping 'closed:'"):
        _replace_closed("name: x\nclosed: {a: 1.0}\n", {"a": 2.0}, "", Path("x.yaml"))


def test_tune_runs_every_closing_on_the_same_drops(
    tmp_path: Path, hand: Path, capsys: pytest.CaptureFixture
):
    """``gripper tune --dry-run --json``: every closing grasps the same drop,
    the report pairs each with the hand as it is, and nothing is written."""
    pytest.importorskip("mujoco")
    from wsgrasp.cli import main

    before = hand.read_text()
    argv = ["gripper", "tune", str(hand), "--objects", "realsense_box", "-n", "1"]
    assert main([*argv, "-j", "1", "--dry-run", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    names = [v["name"] for v in report["variants"]]
    assert names == ["as_is", "limits", "contacts", "limits_contacts"]
    assert all(v["trials"] == 1 for v in report["variants"])
    assert report["chosen"] in names and report["written"] == []
    assert report["protocol"] == "strict"
    # every approach field, the spec's own or its default
    first = report["variants"][0]["approach"]
    assert first == {"distance": 0.1, "squeeze": 0.06, "close_to": "closed"}
    assert report["variants"][2]["approach"]["squeeze"] == 0.02
    assert hand.read_text() == before


def test_tune_of_a_name_or_a_missing_file_is_named(capsys: pytest.CaptureFixture):
    pytest.importorskip("mujoco")
    from wsgrasp.cli import main

    assert main(["gripper", "tune", "allegro_right", "--dry-run"]) != 0
    err = capsys.readouterr().err
    assert "not a gripper YAML file" in err and "Traceback" not in err
