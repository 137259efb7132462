"""Recording runs to MCAP, reading them back, replaying them.

- :class:`RunRecorder` is a plan observer that writes one ``.mcap`` file per run;
  :func:`default_run_path` is where ``plan`` puts it; :func:`wait_for_recorders`
  waits until the writer thread has finished every file handed to it.
- :func:`open_run` reads a run back (also a truncated one) as a :class:`Run`;
  :func:`copy_with_views` writes it again with its Foxglove views.
- :func:`replay_run` re-plans a run's inputs and compares the results.
- :func:`summarize_run` is what ``wsgrasp inspect --json`` prints.
- :func:`open_sequence` reads a recorded clutter run: a folder of runs, one per
  plan, and the ``clutter.json`` that orders them into steps.
"""

from __future__ import annotations

from wsgrasp.record._codec import FORMAT_VERSION
from wsgrasp.record._copy import copy_with_views
from wsgrasp.record._reader import open_run
from wsgrasp.record._replay import ReplayReport, compare_results, replay_run
from wsgrasp.record._run import PARTS, RawMessage, Run
from wsgrasp.record._sequence import SequenceStep, open_sequence
from wsgrasp.record._summary import summarize_run
from wsgrasp.record._writer import (
    RunRecorder,
    check_record_path,
    default_run_path,
    wait_for_recorders,
)

__all__ = [
    "FORMAT_VERSION",
    "PARTS",
    "RawMessage",
    "ReplayReport",
    "Run",
    "RunRecorder",
    "SequenceStep",
    "check_record_path",
    "compare_results",
    "copy_with_views",
    "default_run_path",
    "open_run",
    "open_sequence",
    "replay_run",
    "summarize_run",
    "wait_for_recorders",
]
