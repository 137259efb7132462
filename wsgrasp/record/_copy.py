"""A copy of a recorded run with its Foxglove views built again from its exact
records: for a run whose process was killed before its views were written (they
are written after the plan), which Foxglove shows nothing of."""

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
    """Write ``run`` again to ``path``, through a recorder, with the Foxglove views
    of every stage it has: its records bit for bit, up to where it stops, and
    metadata ``copy_of`` saying where and when the original was recorded.

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
        created = str(run.metadata.get("wsgrasp", {}).get("created_utc", ""))
        copy_of = {"path": str(run.path), "created_utc": created}
        copy_of |= {"wsgrasp_version": str(run.wsgrasp_version)}
        copy_of |= {"truncated": str(run.truncated).lower()}
        recorder._w.add_metadata("copy_of", copy_of)  # noqa: SLF001 - our recorder
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
