"""Palm first or fingertips first: how ``gripper new`` picks a hand's approach.

A hand of four or more fingers can meet an object two ways: palm first, the
fingers curling round it in front of the palm, or fingertips first, the fingers
pointing at it and closing on it with their tips against the thumb's. Which one
grasps more depends on the hand: a hand whose open thumb stands far out in front
of its palm cannot bring its pads down to an object lying flat palm first (the
thumb meets the table first), while a hand with short, thick fingers reaches
such an object palm first and hardly at all fingertips first. No single
geometric rule read from the URDF told these apart on the hands wsgrasp is
developed against, so :func:`choose_approach` plans both on a few low objects
(:data:`LOW_OBJECTS`, rendered as the views of a camera would see them) and keeps
the approach that leaves more feasible grasps. Upright objects are left out: a
hand finds grasps on them either way, and their counts did not follow what held
(the Shadow hand's palm-first guess leaves more feasible grasps on upright
boxes and cylinders, yet holds fewer of the taller random objects in MuJoCo).
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Any

from wsgrasp.errors import WsgraspError
from wsgrasp.gripper._guess import Scaffold

__all__ = ["LOW_OBJECTS", "choose_approach", "choose_thumb"]

#: the objects both approaches are planned on: (primitive, size in m), each in
#: two renderings (seeds 0 and 1): a book, a small box and a disc lying flat
LOW_OBJECTS: tuple[tuple[str, tuple[float, ...]], ...] = (
    ("box", (0.08, 0.05, 0.02)),
    ("box", (0.04, 0.04, 0.015)),
    ("cylinder", (0.03, 0.02)),
)
SEEDS = (0, 1)


def low_object_scenes() -> list[Any]:
    """The clouds of :data:`LOW_OBJECTS`, each rendered with every seed of
    :data:`SEEDS`."""
    from wsgrasp.perception.synth import synth_scene

    return [
        synth_scene(kind, size=size, seed=seed).points
        for kind, size in LOW_OBJECTS
        for seed in SEEDS
    ]


def _generic_pipeline(yaml_path: Path) -> Any:
    """A pipeline of wsgrasp's generic default spec for the gripper YAML at
    ``yaml_path``, recording nothing."""
    from wsgrasp._loading import load_document
    from wsgrasp.api import Pipeline
    from wsgrasp.default_specs import GENERIC_DEFAULT
    from wsgrasp.spec import PipelineSpec

    data, _ = load_document(GENERIC_DEFAULT)
    spec = {**dict(data), "gripper": str(yaml_path), "record": {"enabled": False}}
    return Pipeline(PipelineSpec.model_validate(spec))


def feasible_on_low_objects(yaml_path: Path, scenes: list[Any]) -> int:
    """Feasible candidates summed over ``scenes`` (:func:`low_object_scenes`) for
    the gripper YAML at ``yaml_path``, planned with wsgrasp's generic default
    spec."""
    pipeline = _generic_pipeline(yaml_path)
    return sum(int(pipeline.plan(s).candidates.feasible.sum()) for s in scenes)


def _trial(
    option: Scaffold,
    label: str,
    base_dir: Path,
    scenes: list[Any],
    count: Callable[[Path, list[Any]], int],
    *,
    into: Scaffold,
    field: str,
    what: str,
) -> int | None:
    """``count`` for the guess ``option``, written for the trial as a hidden
    YAML in ``base_dir`` (beside the URDF it names) and removed after; None
    where that guess cannot plan, which ``into``'s note on ``field`` then says
    (``what`` was not tried)."""
    from wsgrasp.gripper.scaffold import render_yaml

    path = Path(base_dir) / f".{option.data['name']}-{label}.yaml"
    path.write_text(render_yaml(option))
    try:
        return count(path, scenes)
    except WsgraspError as exc:  # a guess that does not build: keep the first
        into.notes[field] += (
            f"; {what} was not tried: the {label} guess cannot plan "
            f"({str(exc).splitlines()[0]})"
        )
        return None
    finally:
        path.unlink(missing_ok=True)


def grasps_on_low_objects(yaml_path: Path, scenes: list[Any]) -> int:
    """How many of ``scenes`` (:func:`low_object_scenes`) the gripper YAML at
    ``yaml_path`` finds a grasp on, planned with wsgrasp's generic default spec
    (a grasp its fingers close on: ``found``)."""
    pipeline = _generic_pipeline(yaml_path)
    return sum(bool(pipeline.plan(s).found) for s in scenes)


def choose_thumb(scaffold: Scaffold, base_dir: Path) -> None:
    """Keep a hand's thumb held opposed (the guess) or let it turn into
    opposition as it closes (``scaffold.thumb_turning``).

    Held opposed, the open thumb stands in front of the palm; where it stands
    far enough out, it meets the table before the fingers reach an object lying
    flat, and the hand finds no grasp there (the vendor Allegro URDF's thumb:
    no grasp on any of the renderings of :data:`LOW_OBJECTS`; turning in as it
    closes, a grasp on every one, and 36 of ``random:000-059`` held against 7
    under the strict protocol). Where the held thumb leaves grasps on half of
    them or more, it is kept: the Shadow hand's, which finds grasps on 4 of
    the 6 renderings held and on all 6 turning, held 25 of ``random:000-119``
    held and 8 turning (``docs/results/thumb-turn/``). The choice and the counts
    are noted on ``pregrasp``. The trial YAMLs are written into ``base_dir`` and
    removed."""
    alternative = scaffold.thumb_turning
    if alternative is None:
        return
    scenes = low_object_scenes()
    turned = ", ".join(
        f"{m} from {a:g} to {b:g}" for m, (a, b) in alternative["turned"].items()
    )
    trial = partial(
        _trial,
        base_dir=base_dir,
        scenes=scenes,
        count=grasps_on_low_objects,
        into=scaffold,
        field="pregrasp",
        what=f"turning the thumb ({turned})",
    )
    held = trial(scaffold, "thumb-held")
    if held is None:
        return
    if 2 * held >= len(scenes):
        scaffold.notes["pregrasp"] += (
            f"; held so, it finds a grasp on {held} of {len(scenes)} "
            "renderings of objects lying flat, so it is not turned as it closes"
        )
        return
    turning = trial(replace(scaffold, data=alternative["data"]), "thumb-turning")
    if turning is None:
        return
    what = (
        f"; held so, the open thumb finds a grasp on {held} of {len(scenes)} "
        f"renderings of objects lying flat (it stands in front of the palm), "
        f"turning into opposition as it closes on {turning}"
    )
    if turning > held:
        scaffold.data = alternative["data"]
        scaffold.notes = alternative["notes"]
        scaffold.notes["pregrasp"] += what + f": it turns ({turned})"
    else:
        scaffold.notes["pregrasp"] += what + ": it stays held"


def choose_approach(scaffold: Scaffold, base_dir: Path) -> None:
    """Keep the palm-first guess in ``scaffold`` or switch it to fingertips
    first (``scaffold.fingertips_first``), whichever leaves more feasible grasps
    on :data:`LOW_OBJECTS`; a tie keeps palm first. Notes the counts. The two
    trial YAMLs are written into ``base_dir`` (beside the URDF they name) and
    removed."""
    alternative = scaffold.fingertips_first
    if alternative is None:
        return
    fingers = copy.deepcopy(scaffold)
    fingers.data.update(
        approach_axis=alternative["approach_axis"],
        closing_axis=alternative["closing_axis"],
    )
    fingers.notes.update(alternative["notes"])
    scenes = low_object_scenes()  # rendered once, planned on by both
    counts: list[int] = []
    for label, option in (("palm", scaffold), ("fingertips", fingers)):
        n = _trial(
            option,
            f"{label}-first",
            base_dir,
            scenes,
            feasible_on_low_objects,
            into=scaffold,
            field="approach_axis",
            what="fingertips first",
        )
        if n is None:  # a guess that does not build: palm first stays
            return
        counts.append(n)
    palm, tips = counts
    what = (
        f"; planned on {len(LOW_OBJECTS) * len(SEEDS)} renderings of "
        f"{len(LOW_OBJECTS)} objects lying flat, it leaves {tips} feasible grasps "
        f"fingertips first and {palm} palm first"
    )
    chosen: dict[str, Any] = fingers.data if tips > palm else scaffold.data
    notes = fingers.notes if tips > palm else scaffold.notes
    scaffold.data = chosen
    scaffold.notes = {**notes, "approach_axis": notes["approach_axis"] + what}
