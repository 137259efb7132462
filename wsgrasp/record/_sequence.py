"""A recorded clutter run: a folder of one MCAP file per plan and the
``clutter.json`` that lists the steps in order with their outcomes
(:func:`wsgrasp.sim.clutter.run_clutter_scene` writes both)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from wsgrasp.errors import RecordingError

__all__ = ["SEQUENCE_INDEX", "SequenceStep", "open_sequence"]

#: the file that makes a folder a recorded clutter run
SEQUENCE_INDEX = "clutter.json"


@dataclass
class SequenceStep:
    """One step of a clutter run: what the benchmark wrote for it (``step``,
    ``target``, ``outcome``, ``kind``, ``lifted``, ...) and its plans' files, in
    the order they were made."""

    info: dict[str, Any]
    records: list[Path]

    def line(self) -> str:
        """The step in one line: its number, what was planned and what came of
        it."""
        i = self.info
        target = i.get("target") or "no target"
        what = i.get("outcome", "?") + (f" ({i['kind']})" if i.get("kind") else "")
        lifted = ", ".join(i.get("lifted") or []) or "nothing"
        took = (
            ""
            if i.get("candidate") is None
            else f" (random feasible candidate {i['candidate']})"
        )
        return (
            f"step {i.get('step')}: {i.get('objects_left')} objects left, "
            f"{i.get('segments')} instances seen, {i.get('tries')} plan(s), "
            f"target {target}{took}: {what}; lifted {lifted}{_touches(i)}"
        )


def _touches(info: dict[str, Any]) -> str:
    """The neighbours a step's gripper touched, in a clause: each with the
    links that touched it, and whether before the target."""
    by = info.get("touched_by") or {}
    first = set(info.get("touched_first") or [])
    parts = [
        name
        + (f" by {', '.join(by[name])}" if by.get(name) else "")
        + (" before the target" if name in first else "")
        for name in info.get("touched") or []
    ]
    return f"; touched {'; '.join(parts)}" if parts else ""


def open_sequence(folder: str | Path) -> tuple[dict[str, Any], list[SequenceStep]]:
    """The run's summary (``clutter.json`` without its steps) and its steps.

    Raises
    ------
    RecordingError
        ``folder`` has no ``clutter.json``, it is not a clutter run's, or a
        step's recording is missing.
    """
    root = Path(folder)
    index = root / SEQUENCE_INDEX
    if not index.is_file():
        raise RecordingError(
            f"{root}: no {SEQUENCE_INDEX}, so it is no recorded clutter run",
            hint="pass a run's .mcap file, or the folder `wsgrasp eval --scene pile "
            "--record-dir DIR` wrote for one scene (DIR/<gripper>/pile-000)",
        )
    try:
        data = json.loads(index.read_text())
        steps = data["steps"]
        assert isinstance(steps, list)
    except (ValueError, KeyError, AssertionError) as exc:
        raise RecordingError(
            f"{index}: not a clutter run's index ({type(exc).__name__}: {exc})",
            hint="record the scene again with `wsgrasp eval --scene ... "
            "--record-dir DIR`",
        ) from None
    out = []
    for s in steps:
        paths = [root / r for r in s.get("records") or []]
        missing = [p.name for p in paths if not p.is_file()]
        if missing:
            raise RecordingError(
                f"{root}: step {s.get('step')}'s recording {missing[0]} is missing",
                hint="record the scene again, or copy the whole folder",
            )
        out.append(SequenceStep(info=s, records=paths))
    return {k: v for k, v in data.items() if k != "steps"}, out
