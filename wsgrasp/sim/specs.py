"""Which pipeline specs an evaluation runs, per gripper.

By default two: ``default`` (wsgrasp's defaults for the gripper) and ``paper``
(the paper's sampling and criterion alone), and with ``followup`` a third (the
authors' follow-up sampling). A gripper ships them beside its gripper YAML, as
``specs/default.yaml``, ``specs/paper.yaml`` and ``specs/followup.yaml`` (the
built-in grippers and the Barrett example do; ``examples/specs`` holds the same
settings for users to copy); a gripper without them gets the Franka hand's with
its ``gripper`` replaced. Nothing here reads the repository's ``examples/``. All
run on the same scenes, so what each change does is measured, not claimed.
``--spec FILE`` (or ``LABEL=FILE``) replaces them.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from wsgrasp._names import gripper_ref, is_gripper_path
from wsgrasp.errors import InputError
from wsgrasp.sim.runner import SpecEntry

__all__ = ["LABELS", "spec_arg", "spec_entries"]

#: the spec labels a gripper may ship, in ``specs/<label>.yaml`` beside its YAML
LABELS = ("default", "paper", "followup")

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
    """The spec data for ``label``: the one the gripper ships
    (``specs/<label>.yaml`` beside its gripper YAML), else the Franka hand's,
    else a built-in copy."""
    from wsgrasp._loading import load_document

    for ref in (gripper, "franka_hand"):
        folder = _gripper_folder(ref)
        path = None if folder is None else folder / "specs" / f"{label}.yaml"
        if path is not None and path.is_file():
            data, _ = load_document(path)
            return dict(data), str(path)
    base = {
        "version": 1,
        "segmenter": {"name": "ransac_dbscan"},
        "sampling": {"points": 147, "orientations": 4, "angle_range_deg": 360},
    }
    return {**base, **_FALLBACK[label]}, f"built-in {label}"


def _gripper_folder(gripper: str) -> Path | None:
    """The folder of a gripper's YAML, for a YAML path or a registered name
    (None for a name no plugin registers, or a model registered without one)."""
    if is_gripper_path(gripper):
        path = Path(gripper_ref(gripper, Path.cwd()))
        return path.parent if path.exists() else None
    from wsgrasp.errors import PluginError
    from wsgrasp.plugins import get_registry

    try:
        obj = get_registry().get("grippers", gripper).obj
    except PluginError:
        return None
    return Path(obj).parent if isinstance(obj, (str, Path)) else None


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
            return [(lb, *_template(lb, gripper)) for lb in labels]
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
