"""Every problem of a pipeline spec file at once, for ``wsgrasp spec check``.

Loading a spec (``wsgrasp.spec.load_spec``) stops at its first problem, as a run
should; a check lists them all: every field pydantic refuses, and the plugin
names and options of each section that is well-formed enough to look them up.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from wsgrasp.errors import SpecError

__all__ = ["spec_problems"]


def spec_problems(path: str | Path) -> list[str]:
    """The problems of the spec file at ``path``, one message each (file, line,
    key, what was expected and found); empty when it is valid.

    Raises
    ------
    SpecError
        The file is missing, unreadable or does not parse (nothing to check).
    """
    from wsgrasp._loading import load_document, validation_messages
    from wsgrasp._names import is_gripper_path
    from wsgrasp.plugins import get_registry
    from wsgrasp.spec import (
        PipelineSpec,
        PluginRef,
        ScorerRef,
        _check_name,
        _check_plugin,
        check_gripper_files,
    )

    data, lines = load_document(path)
    problems: list[str] = []
    try:
        PipelineSpec.model_validate(data)
    except ValidationError as exc:
        problems += validation_messages(exc, lines, "pipeline spec")
    reg = get_registry()
    # the plugin sections that parse on their own are checked against their
    # plugins even when another part of the file is wrong
    refs: list[tuple[str, Any, tuple[str | int, ...]]] = []
    seg = data.get("segmenter", {"name": "ransac_dbscan"})
    refs.append(("segmenters", _ref(PluginRef, seg), ("segmenter",)))
    scorers = data.get("scorers", [{"name": "centroid_distance"}])
    if isinstance(scorers, list):
        for i, item in enumerate(scorers):
            refs.append(("scorers", _ref(ScorerRef, item), ("scorers", i)))
    for kind, ref, loc in refs:
        if ref is None:
            continue
        try:
            entry = _check_name(reg, kind, ref.name, (*loc, "name"), lines)
        except SpecError as exc:
            problems.append(exc.message)
            continue
        options_model = getattr(entry.obj, "Options", None)
        if options_model is not None:
            try:
                options_model.model_validate(ref.options)
            except ValidationError as exc:
                what = f"options of {kind[:-1]} {ref.name!r}"
                problems += validation_messages(exc, lines, what, (*loc, "options"))
                continue
        try:  # what the options model lets through: NaN and inf
            _check_plugin(reg, kind, ref, loc, lines)
        except SpecError as exc:
            problems.append(exc.message)
    gripper = data.get("gripper")
    if isinstance(gripper, str):
        try:
            if is_gripper_path(gripper):
                check_gripper_files(gripper, lines)
            else:
                _check_name(reg, "grippers", gripper, ("gripper",), lines)
        except SpecError as exc:
            problems.append(exc.message)
    unique = list(dict.fromkeys(problems))  # a problem found twice is listed once
    return sorted(unique, key=_line)  # in file order (stable within a line)


def _line(message: str) -> int:
    """The line a message names after its file (``path:LINE: ...``), else 0."""
    m = re.match(r"[^\n]*?:(\d+): ", message)
    return int(m.group(1)) if m else 0


def _ref(model: Any, value: Any) -> Any:
    """``value`` as a plugin reference, or None where it is not one (pydantic's
    messages about it are already in the list)."""
    try:
        return model.model_validate(value)
    except ValidationError:
        return None
