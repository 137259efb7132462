"""benchmarks/scorer_concordance.py's analysis, on a dataset table made by hand."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"


def _row(obj, cand, success, terms, *, random_pick=True, chosen=False):
    return {
        "object": obj,
        "trial": 0,
        "candidate": cand,
        "random_pick": random_pick,
        "chosen": chosen,
        "label": "success" if success else "slipped_in_grip",
        "success": success,
        "score_terms": list(terms.items()),
    }


def _dataset(folder: Path, rows, *, friction_use: bool = False) -> Path:
    """A dataset folder holding ``rows`` as its ``candidates`` table (with the
    ``friction_use`` column when asked)."""
    (folder / "candidates").mkdir(parents=True)
    columns = [
        ("object", pa.string()),
        ("trial", pa.int32()),
        ("candidate", pa.int32()),
        ("random_pick", pa.bool_()),
        ("chosen", pa.bool_()),
        ("label", pa.string()),
        ("success", pa.bool_()),
        *([("friction_use", pa.float64())] if friction_use else []),
        ("score_terms", pa.map_(pa.string(), pa.float64())),
    ]
    table = pa.Table.from_pylist(rows, schema=pa.schema(columns))
    pq.write_table(table, folder / "candidates" / "part.parquet")
    return folder


def test_concordance_and_pick_rates(tmp_path: Path):
    sys.path.insert(0, str(BENCH))
    try:
        from scorer_concordance import analyse
    finally:
        sys.path.remove(str(BENCH))
    rows = [
        # scene a: term "good" ranks the one that held first, "bad" last
        _row("a", 0, True, {"good": 0.9, "bad": 0.1}),
        _row("a", 1, False, {"good": 0.2, "bad": 0.8}),
        _row("a", 2, False, {"good": 0.2, "bad": 0.5}, random_pick=False, chosen=True),
        # scene b: both hold; no pair, but it counts in the pick rates
        _row("b", 0, True, {"good": 0.5, "bad": 0.5}),
        _row("b", 1, True, {"good": 0.4, "bad": 0.5}, chosen=True),
    ]
    folder = _dataset(tmp_path / "ds", rows)
    (folder / "scorer_weights.json").write_text(json.dumps({"bad": 1.0, "good": 0.0}))
    r = analyse(folder)
    assert r["scenes"] == 2 and r["random_labels"] == 4
    assert r["random_success"] == pytest.approx(0.75)
    assert r["chosen_labels"] == 2 and r["chosen_success"] == pytest.approx(0.5)
    good, bad = r["terms"]["good"], r["terms"]["bad"]
    assert good["concordance"] == 1.0 and bad["concordance"] == 0.0
    assert good["pairs"] == bad["pairs"] == 1
    # the pick in a: good picks the one that held, bad the one that did not;
    # in b both hold (bad ties, averaged)
    assert good["pick_rate"] == pytest.approx(1.0)
    assert bad["pick_rate"] == pytest.approx(0.5)
    assert r["default_pick_rate"] == pytest.approx(0.5)
    assert bad["default_weight"] == 1.0 and good["default_weight"] == 0.0


def test_margin_concordance_ranks_held_grasps_by_friction_use(tmp_path: Path):
    """Among the held random picks of a scene, a term that ranks higher the
    grip that used less of its friction scores 1, the reverse 0, a constant
    0.5; a pick that dropped, the choice, or a dataset without the column
    adds no pair."""
    sys.path.insert(0, str(BENCH))
    try:
        from scorer_concordance import analyse
    finally:
        sys.path.remove(str(BENCH))
    terms = [
        {"firm": 0.9, "loose": 0.1, "flat": 0.5},
        {"firm": 0.5, "loose": 0.5, "flat": 0.5},
        {"firm": 0.1, "loose": 0.9, "flat": 0.5},
    ]
    rows = [
        {**_row("a", i, True, t), "friction_use": use}
        for i, (t, use) in enumerate(zip(terms, (0.2, 0.5, 0.8), strict=True))
    ]
    rows.append({**_row("a", 3, False, terms[2]), "friction_use": None})
    rows.append(
        {
            **_row("a", 4, True, terms[2], random_pick=False, chosen=True),
            "friction_use": 0.1,
        }
    )
    folder = _dataset(tmp_path / "ds", rows, friction_use=True)
    r = analyse(folder)["terms"]
    assert {n: r[n]["margin_pairs"] for n in r} == {"firm": 3, "loose": 3, "flat": 3}
    assert r["firm"]["margin_concordance"] == 1.0
    assert r["loose"]["margin_concordance"] == 0.0
    assert r["flat"]["margin_concordance"] == 0.5
