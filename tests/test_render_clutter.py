"""The clutter results page's renderer (docs/hooks/docs_results.py): the rates,
times and failure kinds of a published ``wsgrasp eval --scene pile|packed``
report, and the sentence when none is published."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

HOOKS = Path(__file__).resolve().parents[1] / "docs" / "hooks"


@pytest.fixture
def docs_results(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> ModuleType:
    """The renderers' module, reading its results from ``tmp_path``."""
    sys.path.insert(0, str(HOOKS))
    try:
        import docs_results as mod  # type: ignore[import-not-found]
    finally:
        sys.path.remove(str(HOOKS))
    monkeypatch.setattr(mod, "RESULTS", tmp_path)
    return mod


def _report(scene: str) -> dict[str, Any]:
    """A published clutter report: 2 scenes of 5 objects for franka_hand, 8
    attempts, 5 held, 6 took their target off the table, 7 objects removed."""
    summary = {
        "scenes": 2,
        "objects": 10,
        "attempts": 8,
        "successes": 5,
        "removed": 7,
        "target_lifted": 6,
        "grasp_success_rate": 5 / 8,
        "lift_rate": 6 / 8,
        "declutter_rate": 7 / 10,
        "failure_kinds": {"slip": 1, "no_grasp": 1, "wrong_split": 1},
        "two_lifted": 1,
        "plan_ms_median": 140.0,
        "plan_ms_max": 900.0,
        "pipeline_ms_median": 120.0,
        "first_plan_ms_median": 95.0,
        "first_plan_ms_p90": 1500.0,
    }
    scenes = [
        {
            "scene": scene,
            "end": "clear",
            "fell_off": [],
            # the first attempt's gripper touched a neighbour, the second not
            "steps": [{"touched": ["b"]}, {"touched": []}],
        },
        {"scene": scene, "end": "two_failures", "fell_off": ["a"], "steps": []},
    ]
    return {
        "commit": "abc1234",
        "machine": "Test CPU, x86_64, 2 cores",
        "date": "2030-01-01 00:00 UTC",
        "command": "make eval-clutter",
        "load_average": [1.0, 1.0, 1.0],
        "kind": "clutter",
        "scene": scene,
        "objects": "random:300-999",
        "objects_per_scene": 5,
        "scenes": 2,
        "max_steps": None,
        "seed": 1,
        "params": {"protocol": "strict"},
        "grippers": {"franka_hand": {"spec": {}, "summary": summary, "scenes": scenes}},
        "wall_s": 600.0,
    }


def _rendered(docs_results: ModuleType, root: Path, report: dict[str, Any]) -> str:
    """The clutter page with ``report`` published alone, as the pile run."""
    (root / "clutter").mkdir()
    (root / "clutter" / "pile.json").write_text(json.dumps(report))
    return docs_results.render_results_clutter()  # type: ignore[no-any-return]


def _cells(md: str) -> list[str]:
    """The cells of the page's first ``franka_hand`` row."""
    row = next(ln for ln in md.splitlines() if ln.startswith("| `franka_hand`"))
    return [c.strip() for c in row.strip("|").split("|")]


def _rendered_steps(
    docs_results: ModuleType, root: Path, steps: list[dict[str, Any]]
) -> str:
    """The clutter page with the pile run's first scene made of ``steps``."""
    report = _report("pile")
    report["grippers"]["franka_hand"]["scenes"][0]["steps"] = steps
    return _rendered(docs_results, root, report)


def _publish(root: Path, scene: str) -> None:
    folder = root / "clutter"
    folder.mkdir(exist_ok=True)
    (folder / f"{scene}.json").write_text(json.dumps(_report(scene)))


def test_each_published_scene_kind_is_a_table_of_its_rates(
    docs_results: ModuleType, tmp_path: Path
) -> None:
    _publish(tmp_path, "packed")
    _publish(tmp_path, "pile")
    md = docs_results.render_results_clutter()
    assert md.index("### `pile`") < md.index("### `packed`")
    assert "From `make eval-clutter` at commit `abc1234` on Test CPU" in md
    assert "5 objects per scene drawn from `random:300-999`, 2 scenes" in md
    assert "protocol `strict`" in md
    assert "at most twice as many attempts as objects per scene" in md
    row = next(ln for ln in md.splitlines() if ln.startswith("| `franka_hand`"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells == [
        "`franka_hand`",
        "8",
        "62.5 % (5 of 8)",
        "75.0 % (6 of 8)",
        "70.0 % (7 of 10)",
        "120 ms",
        "95.0 ms / 1.50 s",
        "no_grasp 1, wrong_split 1, slip 1",
        "1",
        "1",
        "1",
        "clear 1, two_failures 1",
    ]


def test_a_run_that_did_not_record_touches_shows_none(
    docs_results: ModuleType, tmp_path: Path
) -> None:
    report = _report("pile")
    for scene in report["grippers"]["franka_hand"]["scenes"]:
        scene["steps"] = [{} for _ in scene["steps"]]
    md = _rendered(docs_results, tmp_path, report)
    assert _cells(md)[8] == "–"


def test_a_run_that_recorded_neighbours_in_the_way_counts_them_apart(
    docs_results: ModuleType, tmp_path: Path
) -> None:
    # the first attempt met its neighbour around the target, the second not at all
    steps = [
        {"touched": ["b"], "touched_first": []},
        {"touched": [], "touched_first": []},
        {"touched": ["c", "d"], "touched_first": ["d"]},
    ]
    md = _rendered_steps(docs_results, tmp_path, steps)
    assert _cells(md)[8] == "2 (1)"


def test_the_attempts_that_held_are_split_by_what_the_gripper_touched(
    docs_results: ModuleType, tmp_path: Path
) -> None:
    step = {"found": True, "touched": [], "touched_first": []}
    steps = [
        {**step, "success": True},
        {**step, "success": False},
        {**step, "success": True, "touched": ["b"]},  # met around the target
        {**step, "success": False, "touched": ["b"], "touched_first": ["b"]},
        {"found": False, "success": False, "touched": [], "touched_first": []},
    ]
    md = _rendered_steps(docs_results, tmp_path, steps)
    assert "by what the gripper touched" in md
    row = [ln for ln in md.splitlines() if ln.startswith("| `franka_hand`")][-1]
    assert [c.strip() for c in row.strip("|").split("|")] == [
        "`franka_hand`",
        "50.0 % (1 of 2)",
        "100.0 % (1 of 1)",
        "0.0 % (0 of 1)",
    ]


def test_a_run_from_before_the_split_has_no_table_of_touches(
    docs_results: ModuleType, tmp_path: Path
) -> None:
    _publish(tmp_path, "pile")  # its steps record touched alone
    assert "by what the gripper touched" not in docs_results.render_results_clutter()


def test_no_published_run_says_which_target_writes_it(
    docs_results: ModuleType,
) -> None:
    md = docs_results.render_results_clutter()
    assert "No clutter run is published" in md
    assert "`make eval-clutter`" in md
    assert "|" not in md
