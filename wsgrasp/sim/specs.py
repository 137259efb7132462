"""Which pipeline specs an evaluation runs, per gripper.

By default two: ``default`` (wsgrasp's scorers, the template
``examples/specs/franka.yaml``) and ``paper`` (the paper's criterion alone,
``examples/specs/franka_paper.yaml``), each with its ``gripper`` set to the gripper
evaluated, so that the effect of the added scorers is measured on the same scenes.
``--spec FILE`` (or ``LABEL=FILE``) replaces them.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from wsgrasp.errors import InputError
from wsgrasp.sim.runner import SpecEntry

__all__ = ["BUILTIN_SPECS", "spec_entries"]

#: label → template file in examples/specs (with an in-code fallback)
BUILTIN_SPECS = {"default": "franka.yaml", "paper": "franka_paper.yaml"}

_FALLBACK: dict[str, dict[str, Any]] = {
    "default": {
        "scorers": [
            {"name": "centroid_distance", "weight": 1.0},
            {"name": "antipodal", "weight": 1.0},
            {"name": "contact_balance", "weight": 0.5},
            {"name": "table_clearance", "weight": 0.5},
        ]
    },
    "paper": {"scorers": [{"name": "centroid_distance", "weight": 1.0}]},
}


def _template(label: str) -> tuple[dict[str, Any], str]:
    from wsgrasp._loading import load_document
    from wsgrasp.bench import project_root

    path = project_root() / "examples" / "specs" / BUILTIN_SPECS[label]
    if path.exists():
        data, _ = load_document(path)
        return dict(data), str(path)
    base = {
        "version": 1,
        "segmenter": {"name": "ransac_dbscan"},
        "sampling": {"points": 147, "orientations": 4, "angle_range_deg": 360},
    }
    return {**base, **_FALLBACK[label]}, f"built-in {label}"


def _gripper_ref(gripper: str) -> str:
    p = Path(gripper)
    if p.suffix in (".yaml", ".yml", ".json", ".toml"):
        return str(p.resolve())
    return gripper


def spec_entries(
    grippers: list[str], specs: list[str] | None = None, *, paper: bool = True
) -> list[SpecEntry]:
    """Spec entries for every gripper: the built-in ``default`` (and ``paper``
    unless ``paper`` is False), or the given ``LABEL=FILE`` / ``FILE`` specs."""
    from wsgrasp._loading import load_document
    from wsgrasp.spec import load_spec

    sources: list[tuple[str, dict[str, Any], str]] = []
    if specs:
        for item in specs:
            label, _, file = item.rpartition("=")
            path = Path(file)
            if not path.exists():
                raise InputError(
                    f"spec file {file!r} does not exist",
                    hint="pass --spec FILE or --spec LABEL=FILE",
                )
            data, _ = load_document(path)
            sources.append((label or path.stem, dict(data), str(path)))
    else:
        labels = ["default", "paper"] if paper else ["default"]
        sources = [(lb, *_template(lb)) for lb in labels]
    labels_seen = [s[0] for s in sources]
    if len(set(labels_seen)) != len(labels_seen):
        raise InputError(
            f"spec labels repeat: {labels_seen}",
            hint="name them: --spec mine=a.yaml --spec other=b.yaml",
        )
    out = []
    for g in grippers:
        for label, data, src in sources:
            d = {**data, "gripper": _gripper_ref(g)}
            d["record"] = {**(d.get("record") or {}), "enabled": False}
            load_spec(d)  # validate here, not in a worker
            out.append(SpecEntry(gripper=g, label=label, spec=d, source=src))
    return out
