"""Which pipeline specs an evaluation runs, per gripper.

By default two: ``default`` (wsgrasp's defaults: the gripper's example spec
``examples/specs/<x>.yaml``, e.g. ``allegro.yaml``) and ``paper`` (the paper's
sampling and criterion alone, ``<x>_paper.yaml``), and with ``followup`` a third
(the authors' follow-up sampling, ``<x>_followup.yaml``); a gripper without
example specs gets the Franka ones with its ``gripper`` replaced. All run on the
same scenes, so what each change does is measured, not claimed.
``--spec FILE`` (or ``LABEL=FILE``) replaces them.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from wsgrasp._names import gripper_ref
from wsgrasp.errors import InputError
from wsgrasp.sim.runner import SpecEntry

__all__ = ["BUILTIN_SPECS", "spec_entries"]

#: label → template file in examples/specs (with an in-code fallback)
BUILTIN_SPECS = {
    "default": "franka.yaml",
    "paper": "franka_paper.yaml",
    "followup": "franka_followup.yaml",
}
#: label → the suffix of its file name (``<x><suffix>.yaml``)
_SUFFIX = {"default": "", "paper": "_paper", "followup": "_followup"}

_FALLBACK: dict[str, dict[str, Any]] = {
    "default": {
        "scorers": [
            {"name": "centroid_distance", "weight": 1.0},
            {"name": "antipodal", "weight": 1.0},
        ]
    },
    "paper": {"scorers": [{"name": "centroid_distance", "weight": 1.0}]},
    "followup": {
        "sampling": {"mode": "xyz", "grid": [5, 5, 5], "steps": [8, 8, 8]},
        "scorers": [{"name": "centroid_distance", "weight": 1.0}],
    },
}


def _template(label: str, gripper: str) -> tuple[dict[str, Any], str]:
    """The spec data for ``label``: the gripper's own example spec if there is
    one (``examples/specs/<x>.yaml`` or ``<x>_paper.yaml`` naming this gripper),
    else the Franka one with its gripper replaced, else a built-in copy."""
    from wsgrasp._loading import load_document
    from wsgrasp.bench import project_root

    folder = project_root() / "examples" / "specs"
    names = {gripper, _gripper_name(gripper)}
    if folder.is_dir():
        for path in sorted(folder.glob("*.yaml")):
            suffix = next(
                (x for x in _SUFFIX.values() if x and path.stem.endswith(x)), ""
            )
            if suffix != _SUFFIX[label]:
                continue
            data, _ = load_document(path)
            ref = str(data.get("gripper", ""))
            if ref in names or _gripper_name(str(path.parent / ref)) in names:
                return dict(data), str(path)
        path = folder / BUILTIN_SPECS[label]
        if path.exists():
            data, _ = load_document(path)
            return dict(data), str(path)
    base = {
        "version": 1,
        "segmenter": {"name": "ransac_dbscan"},
        "sampling": {"points": 147, "orientations": 4, "angle_range_deg": 360},
    }
    return {**base, **_FALLBACK[label]}, f"built-in {label}"


def _gripper_name(gripper: str) -> str:
    """The registered name of a gripper given by name or by its YAML's path."""
    path = Path(gripper_ref(gripper, Path.cwd()))  # absolute only for a file
    if path.is_absolute() and path.exists():
        from wsgrasp.spec import load_gripper_description

        return load_gripper_description(path)[0].name
    return gripper


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
            return [(lb, *_template(lb, gripper)) for lb in labels]
        out = []
        for item in specs:
            label, _, file = item.rpartition("=")
            path = Path(file)
            if not path.exists():
                raise InputError(
                    f"spec file {file!r} does not exist",
                    hint="pass --spec FILE or --spec LABEL=FILE",
                )
            data, _ = load_document(path)
            out.append((label or path.stem, dict(data), str(path)))
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
