"""Which pipeline specs an evaluation runs, per gripper.

By default two: ``default`` (the gripper's default spec) and ``paper`` (the
paper's sampling and criterion alone), and with ``followup`` a third (the
authors' follow-up sampling); :mod:`wsgrasp.default_specs` says where each comes
from. All run on the same scenes, so what each change does is measured, not
claimed. ``--spec FILE`` (or ``LABEL=FILE``) replaces them.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from wsgrasp._names import gripper_ref
from wsgrasp.default_specs import LABELS, spec_for
from wsgrasp.errors import InputError
from wsgrasp.sim.runner import SpecEntry

__all__ = ["LABELS", "spec_arg", "spec_entries"]


def spec_arg(item: str) -> tuple[str, Path]:
    """A ``--spec`` argument, ``FILE`` or ``LABEL=FILE``: its label (the file's
    stem when none is given) and its existing path."""
    label, _, file = item.rpartition("=")
    path = Path(file)
    if not path.exists():
        raise InputError(
            f"spec file {file!r} does not exist",
            hint="pass --spec FILE or --spec LABEL=FILE",
        )
    return label or path.stem, path


def spec_entries(
    grippers: list[str],
    specs: list[str] | None = None,
    *,
    paper: bool = True,
    followup: bool = False,
) -> list[SpecEntry]:
    """Spec entries for every gripper: the built-in ``default`` (and ``paper``
    unless ``paper`` is False, ``followup`` when asked), or the given
    ``LABEL=FILE`` / ``FILE`` specs."""
    from wsgrasp._loading import load_document
    from wsgrasp.spec import load_spec

    def sources_for(gripper: str) -> list[tuple[str, dict[str, Any], str]]:
        if not specs:
            labels = ["default"] + ["paper"] * paper + ["followup"] * followup
            return [(lb, *spec_for(lb, gripper)) for lb in labels]
        out = []
        for item in specs:
            label, path = spec_arg(item)
            data, _ = load_document(path)
            out.append((label, dict(data), str(path)))
        return out

    out = []
    for g in grippers:
        sources = sources_for(g)
        labels_seen = [s[0] for s in sources]
        if len(set(labels_seen)) != len(labels_seen):
            raise InputError(
                f"spec labels repeat: {labels_seen}",
                hint="name them: --spec mine=a.yaml --spec other=b.yaml",
            )
        for label, data, src in sources:
            d = {**data, "gripper": gripper_ref(g, Path.cwd())}
            d["record"] = {**(d.get("record") or {}), "enabled": False}
            load_spec(d)  # validate here, not in a worker
            out.append(SpecEntry(gripper=g, label=label, spec=d, source=src))
    return out
