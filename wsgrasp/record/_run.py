"""A recorded run as :func:`~wsgrasp.record.open_run` reads it: :class:`Run`."""

from __future__ import annotations

import json
from dataclasses import dataclass, field, fields
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from wsgrasp.errors import RecordingError

if TYPE_CHECKING:
    from wsgrasp.gripper.model import GripperModel
    from wsgrasp.perception.types import Scene
    from wsgrasp.planning.result import CandidateSet, PlanResult
    from wsgrasp.spec import PipelineSpec

__all__ = ["PARTS", "RawMessage", "Run"]

#: What a complete run holds, in the order it is written.
PARTS = (
    "metadata",
    "spec",
    "inputs",
    "gripper model",
    "preprocess",
    "segmentation",
    "object_frame",
    "candidates",
    "result",
)


#: spec fields added after runs were recorded without them, each with the value
#: that plans as those runs were planned (a recorded spec holds every field, so
#: a missing one was not there yet); new specs get the field's default
_RECORDED_BEFORE: dict[tuple[str, str], Any] = {
    ("sampling", "angles_from"): "object",
    ("sampling", "across_narrowest"): False,
}


def _as_planned(data: dict[str, Any]) -> dict[str, Any]:
    """A recorded spec's data with the fields it predates set as it planned."""
    out = dict(data)
    for (section, key), value in _RECORDED_BEFORE.items():
        part = out.get(section)
        if isinstance(part, dict) and key not in part:
            out[section] = {**part, key: value}
    return out


@dataclass
class RawMessage:
    """One message as stored, with its channel's schema."""

    topic: str
    schema_name: str
    schema_encoding: str
    schema_data: bytes
    message_encoding: str
    log_time: int
    data: bytes


@dataclass
class Run:
    """A recorded run, as read by :func:`open_run`: ``metadata`` (by record name:
    ``wsgrasp``, ``spec``, ``plugins``, ``run_end``, each str to str),
    ``attachments``, the decoded records (arrays exact), ``truncated`` (no footer),
    ``truncated_at`` (the offset of the first incomplete record), ``missing``
    (parts of :data:`PARTS` the file lacks) and every message in file order."""

    path: Path
    format_version: int
    wsgrasp_version: str
    metadata: dict[str, dict[str, str]]
    attachments: dict[str, bytes]
    inputs: dict[str, Any] | None
    stages: dict[str, dict[str, Any]]
    result_data: dict[str, Any] | None
    error: dict[str, Any] | None
    truncated: bool
    truncated_at: int | None
    missing: list[str]
    messages: list[RawMessage] = field(repr=False, default_factory=list)

    @property
    def status(self) -> str:
        """``"ok"`` (a result), ``"error"`` (the plan raised) or ``"truncated"``."""
        if self.result_data is not None:
            return "ok"
        if self.error is not None:
            return "error"
        return "truncated"

    @cached_property
    def spec_data(self) -> dict[str, Any] | None:
        """The resolved spec as plain data."""
        raw = self.metadata.get("spec", {}).get("json")
        return None if raw is None else json.loads(raw)

    @cached_property
    def spec(self) -> PipelineSpec:
        """The recorded spec, validated (plugins not looked up); a
        ``RecordingError`` when the file holds none or it does not validate."""
        from wsgrasp.errors import SpecError
        from wsgrasp.spec import load_spec

        if self.spec_data is None:
            raise RecordingError(
                f"{self.path}: holds no spec (the file was cut before it)",
                hint="replay needs a run recorded at least up to its inputs",
            )
        try:
            return load_spec(_as_planned(self.spec_data), check_plugins=False)
        except SpecError as exc:
            raise RecordingError(
                f"{self.path}: the recorded spec does not validate with this "
                f"wsgrasp: {exc.message}",
                hint=f"use wsgrasp {self.wsgrasp_version}, which recorded it",
            ) from None

    @property
    def plugins(self) -> list[dict[str, Any]]:
        """Every plugin loaded when the run was recorded (distribution, version)."""
        out = []
        for k, raw in sorted(self.metadata.get("plugins", {}).items()):
            try:
                out.append(json.loads(raw))
            except ValueError:
                out.append({"name": k, "error": raw})
        return out

    @cached_property
    def gripper(self) -> GripperModel:
        """The gripper model from the attachment (no plugin needed); a
        ``RecordingError`` when the file holds none."""
        from wsgrasp.errors import GripperError
        from wsgrasp.gripper.model import GripperModel

        data = self.attachments.get("gripper/model.npz")
        if data is None:
            raise RecordingError(
                f"{self.path}: holds no gripper model"
                + (" (the file is truncated)" if self.truncated else ""),
                hint="replay needs a run recorded at least up to its inputs",
            )
        try:
            return GripperModel.from_bytes(data)
        except GripperError as exc:
            raise RecordingError(
                f"{self.path}: the recorded gripper model is unreadable: {exc.message}"
            ) from None

    @cached_property
    def scene(self) -> Scene:
        """The planner's input, bit for bit; a ``RecordingError`` when the file
        holds none."""
        from wsgrasp.perception.types import Scene, View

        d = self.inputs
        if d is None:
            raise RecordingError(
                f"{self.path}: holds no inputs (the file was cut before them)",
                hint="nothing of this run can be replayed",
            )
        views = [View(v["points"], v["T_world_camera"], v["name"]) for v in d["views"]]
        return Scene(
            views=views,
            points=d["points"],
            dropped_nonfinite=int(d.get("dropped_nonfinite", 0)),
            dropped_no_depth=int(d.get("dropped_no_depth", 0)),
        )

    @cached_property
    def candidates(self) -> CandidateSet | None:
        """Every candidate evaluated, or None if the file stops before them."""
        for d in (self.result_data, self.stages.get("candidates")):
            if d is not None and isinstance(d.get("candidates"), dict):
                return _candidate_set(d["candidates"])
        return None

    @cached_property
    def result(self) -> PlanResult | None:
        """The plan's result, or None if the plan failed or the file stops early."""
        from wsgrasp.planning.result import Alternative, Contact, PlanResult

        if self.result_data is None:
            return None
        d = dict(self.result_data)
        cs = self.candidates
        d["candidates"] = cs if cs is not None else _candidate_set({})
        d["contacts"] = [Contact(**_known(Contact, c)) for c in d.get("contacts", [])]
        d["alternatives"] = [
            Alternative(**_known(Alternative, a)) for a in d.get("alternatives", [])
        ]
        try:
            return PlanResult(**_known(PlanResult, d))
        except TypeError as exc:
            raise RecordingError(
                f"{self.path}: the recorded result does not fit this wsgrasp: {exc}",
                hint=f"use wsgrasp {self.wsgrasp_version}, which recorded it",
            ) from None

    @property
    def timing_ms(self) -> dict[str, float]:
        """The plan's stage timings, the recorder's time in the plan
        (``recorder``) and, after it, building the Foxglove views (``views``)."""
        timing = (self.result_data or {}).get("timing_ms", {})
        out = {k: float(v) for k, v in timing.items()}
        end = self.metadata.get("run_end", {})
        for key, name in (("recorder_ms", "recorder"), ("views_ms", "views")):
            if end.get(key) is not None:
                out[name] = float(end[key])
        return out

    def topics(self) -> dict[str, tuple[str, int]]:
        """Topic → (schema name, message count)."""
        out: dict[str, tuple[str, int]] = {}
        for m in self.messages:
            name, n = out.get(m.topic, (m.schema_name, 0))
            out[m.topic] = (name, n + 1)
        return out


def _known(cls: Any, d: dict[str, Any]) -> dict[str, Any]:
    names = {f.name for f in fields(cls)}
    return {k: v for k, v in d.items() if k in names}


def _candidate_set(d: dict[str, Any]) -> CandidateSet:
    """The recorded candidates ``d`` (``{}``: none)."""
    from wsgrasp.planning.result import CandidateSet

    if not d:
        z, e, i = np.zeros((0, 4, 4)), np.zeros(0), np.zeros(0, dtype=np.int64)
        return CandidateSet(z, z, i, e, i, np.zeros((0, 0), np.int64), e)
    d = _known(CandidateSet, d)
    d["terms"] = dict(d.get("terms") or {})
    return CandidateSet(**d)
