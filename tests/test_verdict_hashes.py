"""The search decides what it decided when the hashes were stored: every
candidate's verdict, contacts and score and the plan's choice, on the bundled
scenes with each gripper's default spec and on the bench's dense sampling
(``tests/verdict_hashes.py``), with the compiled kernels and with numpy alone."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

import verdict_hashes  # noqa: E402

STORED = verdict_hashes.stored()
PLANS = [n for n in verdict_hashes.case_names() if n not in verdict_hashes.DENSE]
# the hashes hold for the environment they were stored in (verdict_hashes.py)
pytestmark = pytest.mark.skipif(STORED is None, reason=verdict_hashes.missing_reason())


@pytest.mark.parametrize("gripper", list(verdict_hashes.GRIPPERS))
def test_default_spec_plans_decide_as_stored(gripper):
    names = [n for n in PLANS if n.startswith(gripper + "/") and n in STORED]
    if not names:
        pytest.skip(
            f"the hashes stored for this environment have no {gripper} cases: "
            "store them from the code before a change with "
            f"`python tests/verdict_hashes.py --write` and its {gripper} cases"
        )
    got = verdict_hashes.compute(names)
    assert got == {n: STORED[n] for n in names}


@pytest.mark.parametrize("name", list(verdict_hashes.DENSE))
def test_dense_searches_decide_as_stored(name):
    assert verdict_hashes.compute([name]) == {name: STORED[name]}


@pytest.mark.slow
def test_numpy_alone_decides_as_stored():
    # a fresh process: the kernel choice is read when the search is imported
    env = {**os.environ, "WSGRASP_NUMBA": "0"}
    run = subprocess.run(
        [sys.executable, str(Path(verdict_hashes.__file__))],
        env=env,
        capture_output=True,
        text=True,
    )
    assert run.returncode == 0, run.stdout + run.stderr
