"""``benchmarks/publish_result.py``: a run's result file with its provenance, and
the note a run can carry (other work on the machine, say), which the results
pages print beside the run (docs/hooks/docs_results.py)."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from types import ModuleType

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _import(folder: Path, name: str) -> ModuleType:
    sys.path.insert(0, str(folder))
    try:
        return __import__(name)
    finally:
        sys.path.remove(str(folder))


@pytest.fixture
def publish_result() -> ModuleType:
    return _import(ROOT / "benchmarks", "publish_result")


@pytest.fixture
def docs_results() -> ModuleType:
    return _import(ROOT / "docs" / "hooks", "docs_results")


REPORT = {"success_rate": 0.9, "trial_records": [{"outcome": "success"}]}


def test_provenance_first_and_the_note_only_where_given(
    publish_result: ModuleType,
) -> None:
    plain = publish_result.publish(REPORT, commit="abc1234", command="make eval")
    assert list(plain)[:5] == ["commit", "machine", "date", "command", "load_average"]
    assert "note" not in plain
    assert "trial_records" not in plain  # bulky per-trial parts stay out
    assert plain["success_rate"] == 0.9
    noted = publish_result.publish(
        REPORT, commit="abc1234", command="make eval", note="the tests ran beside it"
    )
    assert noted["note"] == "the tests ran beside it"


def test_the_command_line_writes_the_note(
    publish_result: ModuleType, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    src, dest = tmp_path / "run.json", tmp_path / "results" / "run.json"
    src.write_text(json.dumps(REPORT))
    argv = [str(src), str(dest), "--commit", "abc1234", "--note", "shared machine"]
    assert publish_result.main(argv) == 0
    out = json.loads(dest.read_text())
    assert (out["commit"], out["note"]) == ("abc1234", "shared machine")
    assert "wrote" in capsys.readouterr().out


def test_the_pages_print_the_note_with_the_run(docs_results: ModuleType) -> None:
    report = {
        "commit": "abc1234",
        "machine": "x86_64, 2 cores",
        "date": "2026-12-04 18:43 UTC",
        "load_average": [0.19, 1.19, 1.96],
    }
    line = docs_results._provenance(report, "`make eval-heldout`")
    assert line.endswith("load average 0.2 as it ended).")
    report["note"] = "The test suite shared the machine for half of the run."
    line = docs_results._provenance(report, "`make eval-heldout`")
    assert line.endswith(
        "as it ended). The test suite shared the machine for half of the run."
    )


def test_the_pages_name_the_libraries_a_run_recorded(docs_results: ModuleType) -> None:
    report = {
        "commit": "abc1234",
        "machine": "x86_64, 2 cores",
        "date": "2026-12-05",
        "libraries": {"python": "3.11.7", "mujoco": "4.0.1", "numpy": "2.4.6"},
    }
    line = docs_results._provenance(report, "`make eval`")
    assert line.endswith("(2026-12-05). With mujoco 4.0.1, numpy 2.4.6.")
    del report["libraries"]
    assert "With" not in docs_results._provenance(report, "`make eval`")


def test_a_bench_report_keeps_its_libraries_beside_its_rows(
    publish_result: ModuleType, tmp_path: Path
) -> None:
    src, dest = tmp_path / "bench.json", tmp_path / "results" / "bench.json"
    bench = {
        "franka_hand": {"plan_ms": 18.0, "search_ms": 2.0, "speedup": 27.0},
        "scaling": [],
        "libraries": {"numba": "0.68.1"},
    }
    src.write_text(json.dumps(bench))
    assert publish_result.main([str(src), str(dest), "--commit", "abc1234"]) == 0
    out = json.loads(dest.read_text())
    assert list(out["rows"]) == ["franka_hand"]
    assert out["libraries"] == {"numba": "0.68.1"}


def test_simulator_versions_table_counts_the_outcomes_that_differ(
    docs_results: ModuleType, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    folder = tmp_path / "simulator-versions"
    folder.mkdir()
    held = {"3.17.0": [1, 1, 0, 0], "4.0.1": [1, 0, 1, 1]}
    for version, successes in held.items():
        objects = [
            {"object": f"random_{i:03d}", "successes": s}
            for i, s in enumerate(successes)
        ]
        report = {
            "libraries": {"mujoco": version},
            "results": [{"gripper": "a/hand.yaml", "trials": 4, "objects": objects}],
        }
        (folder / f"hand-{version}.json").write_text(json.dumps(report))
    monkeypatch.setattr(docs_results, "RESULTS", tmp_path)
    text = docs_results.render_simulator_versions_runs()
    # the older release held random_001 alone, the newest random_002 and 003
    assert "| `hand` | 3.17.0 | 2 of 4 | 1 / 2 | `hand-3.17.0.json` |" in text
    assert "| `hand` | 4.0.1 | 3 of 4 |  | `hand-4.0.1.json` |" in text
