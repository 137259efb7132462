"""A copy of a recorded run with its Foxglove views built again from its exact
records.

The views and the summary are written after the plan (see
:class:`~wsgrasp.record.RunRecorder`); a process killed before that leaves a run
whose full-fidelity records are all there but which Foxglove shows nothing of.
:func:`copy_with_views` writes the run again, through a recorder, so that it has
its views, up to where it stops.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from wsgrasp.errors import RecordingError
from wsgrasp.record._run import PARTS
from wsgrasp.record._writer import RunRecorder

if TYPE_CHECKING:
    from wsgrasp.record._run import Run

__all__ = ["copy_with_views"]


class _RecordedError(Exception):
    """The error a run recorded, given back to a recorder as it was."""

    def __init__(self, record: dict[str, Any]) -> None:
        super().__init__(record.get("message") or "")
        self.type_name = str(record.get("type") or "Error")
        self.message = str(record.get("message") or "")
        self.hint = record.get("hint")


def copy_with_views(run: Run, path: str | Path, *, force: bool = False) -> Path:
    """Write ``run`` again to ``path``, with Foxglove views of every stage it has.

    The inputs, spec, gripper model, stages and result (or error) are the run's,
    bit for bit; metadata ``copy_of`` says where and when the original was
    recorded. A run that stops before its result is copied up to where it stops
    (and says what it lacks, as the original does).

    Raises
    ------
    RecordingError
        ``path`` is the run itself or exists (without ``force``), or the run holds
        no inputs or no gripper model to start from.
    """
    out = Path(path)
    if out.resolve() == Path(run.path).resolve():
        raise RecordingError(
            f"{out}: is the run being copied",
            hint="write the copy to another file",
        )
    if run.inputs is None or "gripper/model.npz" not in run.attachments:
        raise RecordingError(
            f"{run.path}: holds no inputs or no gripper model (the file was cut "
            "before them); there is nothing to draw",
        )
    recorder = RunRecorder(out, force=force)
    try:
        recorder.on_start(run.spec, run.gripper, run.scene)
        original = run.metadata.get("wsgrasp", {})
        recorder._w.add_metadata(  # noqa: SLF001 - this module's own recorder
            "copy_of",
            {
                "path": str(run.path),
                "created_utc": str(original.get("created_utc", "")),
                "wsgrasp_version": str(run.wsgrasp_version),
                "truncated": str(run.truncated).lower(),
            },
        )
        stages = [s for s in PARTS if s in run.stages]
        stages += [s for s in run.stages if s not in stages]
        for stage in stages:
            data = dict(run.stages[stage])
            if stage == "candidates" and run.candidates is not None:
                data["candidates"] = run.candidates  # as the planner reported them
            recorder.on_stage(stage, data)
        if run.result is not None:
            recorder.on_result(run.result)
        elif run.error is not None:
            recorder.on_error(_RecordedError(run.error))
    finally:
        recorder.close()
    return out
