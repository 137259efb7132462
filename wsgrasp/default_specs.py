"""The pipeline specs a gripper plans and is evaluated with when the user names
none: ``default`` (what ``wsgrasp plan --gripper NAME`` and ``wsgrasp eval`` run),
``paper`` (the paper's sampling and criterion alone) and ``followup`` (the
authors' follow-up sampling).

A gripper ships them beside its YAML as ``specs/<label>.yaml`` (the built-in
grippers, the example plugins and every package ``wsgrasp gripper new`` writes
do). A gripper that ships no ``default`` gets :data:`GENERIC_DEFAULT`, the
setting that measures best across grippers of every kind (a hand of three or
more fingers without the scorers in :data:`JAW_SCORERS`); one without
``paper`` or ``followup`` gets the Franka hand's with its gripper replaced.
Nothing here reads the repository's ``examples/``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from wsgrasp._names import gripper_ref, is_gripper_path

__all__ = [
    "FINGERTIPS_FIRST_SCORER",
    "GENERIC_DEFAULT",
    "JAW_SCORERS",
    "LABELS",
    "default_spec",
    "generic_spec_text",
    "spec_for",
]

#: the generic default's scorers that only a two-finger gripper keeps: a hand of
#: three or more fingers scores by the rest alone
#: (docs/explanation/defaults.md#the-generic-default)
JAW_SCORERS = frozenset({"antipodal", "closing_centre"})
#: the generic default's object frame for a hand of three or more fingers: the
#: sides no camera saw are not mirrored in, which two jaws held more objects with
#: from one camera and the Allegro hand fewer (docs/explanation/defaults.md)
HAND_OBJECT_FRAME = {"method": "farthest_split", "mirror_hidden": False}

#: the spec labels a gripper may ship, in ``specs/<label>.yaml`` beside its YAML
LABELS = ("default", "paper", "followup")

#: the default spec of a gripper that ships none (a YAML in the package)
GENERIC_DEFAULT = Path(__file__).parent / "data" / "default_spec.yaml"

_BUILT_IN: dict[str, dict[str, Any]] = {
    "paper": {
        "version": 1,
        "segmenter": {"name": "ransac_dbscan"},
        "sampling": {"points": 147, "orientations": 4, "angle_range_deg": 360},
        "scorers": [{"name": "centroid_distance", "weight": 1.0}],
    },
    "followup": {
        "version": 1,
        "segmenter": {"name": "ransac_dbscan"},
        "sampling": {"mode": "xyz", "grid": [5, 5, 5], "steps": [8, 8, 8]},
        "scorers": [{"name": "centroid_distance", "weight": 1.0}],
    },
}


def spec_for(label: str, gripper: str) -> tuple[dict[str, Any], str]:
    """The spec data for ``label`` and ``gripper`` and where it came from.

    The one the gripper ships (``specs/<label>.yaml`` beside its gripper YAML);
    else, for ``default``, :data:`GENERIC_DEFAULT`; else the Franka hand's; else
    a built-in copy of the paper's (or the follow-up's) setting. The data's
    ``gripper`` is ``gripper``.
    """
    from wsgrasp._loading import load_document

    if label not in LABELS:
        raise ValueError(f"spec label {label!r} is not one of {LABELS}")
    # the gripper's own folder, then the generic default or the Franka hand's
    folders = [_gripper_folder(gripper)]
    if label != "default":
        folders.append(_gripper_folder("franka_hand"))
    paths = [f / "specs" / f"{label}.yaml" for f in folders if f is not None]
    if label == "default":
        paths.append(GENERIC_DEFAULT)
    for path in paths:
        if path.is_file():
            data, _ = load_document(path)
            data = {**dict(data), "gripper": gripper}
            if path == GENERIC_DEFAULT and (_finger_count(gripper) or 2) >= 3:
                data["scorers"] = [
                    s for s in data["scorers"] if s["name"] not in JAW_SCORERS
                ]
                data["object_frame"] = dict(HAND_OBJECT_FRAME)
            return data, str(path)
    return {**_BUILT_IN[label], "gripper": gripper}, f"built-in {label}"


def default_spec(gripper: str) -> tuple[dict[str, Any], str]:
    """``spec_for("default", gripper)``: what ``plan --gripper`` runs."""
    return spec_for("default", gripper)


#: the scorer a hand that approaches fingertips first gets beside the generic
#: default's (docs/explanation/defaults.md#a-hand-that-approaches-fingertips-first)
FINGERTIPS_FIRST_SCORER = "  - {name: reach_down, weight: 1.0}"
#: ... and the direction its ``approach_direction`` prefers: level with the
#: table, where the generic default's prefers straight down onto it
FINGERTIPS_FIRST_DIRECTION = "level"


def generic_spec_text(
    gripper: str, *, fingertips_first: bool = False, fingers: int = 2
) -> str:
    """:data:`GENERIC_DEFAULT` as text, naming ``gripper`` (what ``gripper new``
    writes into a package as ``specs/default.yaml``).

    A hand of three or more ``fingers`` scores without :data:`JAW_SCORERS`:
    ``antipodal`` rewards contact normals that line up along one closing axis,
    which a jaw's two pads do and a thumb against several fingers cannot, and
    without it ``closing_centre`` chose no better than ``centroid_distance``
    alone (measured on the vendor hands: docs/explanation/defaults.md).

    A hand that approaches fingertips first (its open fingers pointing at the
    object, as ``gripper new`` may guess for a hand of four or more fingers)
    also scores by ``reach_down``: such a hand holds a low object only when its
    fingertips come down to the table beside it, rather than closing round the
    object's top edge. Its ``approach_direction`` prefers an approach level
    with the table (:data:`FINGERTIPS_FIRST_DIRECTION`): from above, such a
    hand points its fingers down at the table, and the oblique approaches
    that preference favours held fewer objects."""
    lines = GENERIC_DEFAULT.read_text().splitlines()
    while lines and lines[0].startswith("#"):  # its own header, replaced below
        lines.pop(0)
    out = [f"gripper: {gripper}" if ln.startswith("gripper:") else ln for ln in lines]
    notes = []  # the header's lines after the first
    if fingers >= 3:
        out = [ln for ln in out if _scorer_name(ln) not in JAW_SCORERS]
        frame = ", ".join(
            f"{k}: {str(v).lower()}" for k, v in HAND_OBJECT_FRAME.items()
        )
        out = [
            f"object_frame: {{{frame}}}" if ln.startswith("object_frame:") else ln
            for ln in out
        ]
        notes.append(
            f"# for a hand of {fingers} fingers: without "
            + " and ".join(sorted(JAW_SCORERS))
            + ", planning on the sides the cameras saw alone"
            + " (docs/explanation/defaults.md)."
        )
    if fingertips_first:
        out = [
            _level(ln) if _scorer_name(ln) == "approach_direction" else ln for ln in out
        ]
        notes.append(
            "# with reach_down, and approach_direction preferring a level approach, "
            "as for every hand that approaches fingertips first "
            "(docs/explanation/defaults.md)."
        )
    out[:0] = [
        f"# {gripper}'s default spec (`plan --gripper`, `eval`): wsgrasp's generic "
        "default as `gripper new` wrote it" + ("," if notes else "."),
        *notes,
    ]
    if fingertips_first:
        last = max(i for i, ln in enumerate(out) if ln.startswith("  - {name:"))
        out.insert(last + 1, FINGERTIPS_FIRST_SCORER)
    return "\n".join(out) + "\n"


def _level(line: str) -> str:
    """A spec line ``  - {name: approach_direction, ...}`` with its direction
    set to :data:`FINGERTIPS_FIRST_DIRECTION` (its weight kept)."""
    head = line.rstrip().removesuffix("}")
    return f"{head}, options: {{direction: {FINGERTIPS_FIRST_DIRECTION}}}}}"


def _scorer_name(line: str) -> str | None:
    """The scorer a spec line ``  - {name: NAME, ...}`` names, else None."""
    head = "  - {name: "
    if not line.startswith(head):
        return None
    return line[len(head) :].split(",")[0].split("}")[0].strip()


def _finger_count(gripper: str) -> int | None:
    """The number of fingers in a gripper's YAML (a path or a registered name),
    read without building the model; None where there is no YAML to read."""
    from wsgrasp._loading import load_document

    path = _gripper_yaml(gripper)
    if path is None:
        return None
    try:
        data, _ = load_document(path)
    except Exception:  # noqa: BLE001 - unreadable here: the model's build says why
        return None
    fingers = dict(data).get("fingers") if isinstance(data, dict) else None
    return len(fingers) if isinstance(fingers, list) else None


def _gripper_folder(gripper: str) -> Path | None:
    """The folder of a gripper's YAML (see :func:`_gripper_yaml`)."""
    path = _gripper_yaml(gripper)
    return None if path is None else path.parent


def _gripper_yaml(gripper: str) -> Path | None:
    """A gripper's YAML, for a YAML path or a registered name (None for a path
    that does not exist, a name no plugin registers, or a model registered
    without one)."""
    if is_gripper_path(gripper):
        path = Path(gripper_ref(gripper, Path.cwd()))
        return path if path.exists() else None
    from wsgrasp.errors import PluginError
    from wsgrasp.plugins import get_registry

    try:
        obj = get_registry().get("grippers", gripper).obj
    except PluginError:
        return None
    return Path(obj) if isinstance(obj, (str, Path)) else None
