"""``wsgrasp gripper tune``: how a hand closes, chosen by grasp trials.

Two settings decide how hard a position-controlled hand presses an object: the
posture its fingers close to (the gripper YAML's ``closed``) and how its grasp
targets are set (the default spec's ``approach``: ``close_to: closed``, every
finger driven to ``closed``; or ``close_to: contacts``, each finger driven
``squeeze`` past its contact). ``gripper new`` stops ``closed`` where the pads
meet, which keeps long fingers from curling past a small object; for a hand
whose pads pass each other apart (the Robotiq 3F's stay 24 mm from their
centroid), that posture presses nothing narrower than their gap, and such a
hand holds far more closing to its joints' limits. Which setting holds best
depends on the hand's kinematics and on how its fingers touch the table, which
no rule read from the URDF has told apart (``docs/how-to/add-a-gripper.md``,
Tune the closing, gives the runs), so :func:`tune_closing` measures it: the
same drops are grasped with each of :data:`VARIANTS` and the one that holds
the most is kept, when the paired difference from the hand as it is has a
95 % interval above zero (:func:`compare_drops`); else the hand stays as
it is. :func:`write_tuned` writes the choice into the YAML and the spec, with
the figures in a comment.
"""

from __future__ import annotations

import math
import re
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from wsgrasp.errors import InputError

__all__ = [
    "CONTACTS_APPROACH",
    "VARIANTS",
    "TuneResult",
    "VariantResult",
    "closed_at_limits",
    "compare_drops",
    "tune_closing",
    "write_tuned",
]

#: the closings tried, in order of preference on a tie: the hand as it is, its
#: ``closed`` at the joints' limits on the closing side, each finger driven past
#: its contact (:data:`CONTACTS_APPROACH`), and both
VARIANTS = ("as_is", "limits", "contacts", "limits_contacts")
#: ``approach`` of the variants that drive each finger past its contact: 2 cm,
#: the squeeze at which the BarrettHand's description held most of
#: ``random:000-119`` (strict; 6 cm pushed low objects out of its fingers)
CONTACTS_APPROACH = {"close_to": "contacts", "squeeze": 0.02}


@dataclass
class VariantResult:
    """One closing's trials, paired with the hand as it is over the same drops."""

    name: str
    closed: dict[str, float]
    approach: dict[str, Any]
    trials: int
    successes: int
    gained: int = 0
    lost: int = 0
    difference: float = 0.0
    ci95: tuple[float, float] = (0.0, 0.0)

    @property
    def rate(self) -> float:
        return self.successes / self.trials if self.trials else 0.0

    def to_json(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "closed": self.closed,
            "approach": self.approach,
            "trials": self.trials,
            "successes": self.successes,
            "success_rate": round(self.rate, 4),
            "gained": self.gained,
            "lost": self.lost,
            "difference": round(self.difference, 4),
            "ci95": [round(v, 4) for v in self.ci95],
        }


@dataclass
class TuneResult:
    """What :func:`tune_closing` measured and chose."""

    gripper: str
    objects: str
    protocol: str
    seed: int
    trials_per_object: int
    variants: list[VariantResult]
    chosen: str
    wall_s: float
    skipped: list[str] = field(default_factory=list)

    def variant(self, name: str) -> VariantResult:
        return next(v for v in self.variants if v.name == name)

    def summary(self) -> str:
        """One sentence for the YAML's and the spec's comments."""
        base = self.variant("as_is")
        where = (
            f"{self.protocol} protocol, {self.objects}, {self.trials_per_object} "
            f"trial(s) each, seed {self.seed}"
        )
        if self.chosen == "as_is":
            return (
                f"`wsgrasp gripper tune` ({where}): the hand as it is held "
                f"{base.successes} of {base.trials}, and no other closing held "
                "more with a paired 95 % interval above zero, so it stays"
            )
        v = self.variant(self.chosen)
        lo, hi = (100 * x for x in v.ci95)
        return (
            f"`wsgrasp gripper tune` ({where}): {_describe(v.name)} held "
            f"{v.successes} of {v.trials} against {base.successes} as it was "
            f"(paired difference {100 * v.difference:+.0f} points, 95 % interval "
            f"{lo:+.0f} to {hi:+.0f})"
        )

    def to_json(self) -> dict[str, Any]:
        return {
            "gripper": self.gripper,
            "objects": self.objects,
            "protocol": self.protocol,
            "seed": self.seed,
            "trials_per_object": self.trials_per_object,
            "chosen": self.chosen,
            "summary": self.summary(),
            "wall_s": round(self.wall_s, 1),
            "skipped": self.skipped,
            "variants": [v.to_json() for v in self.variants],
        }


def _describe(name: str) -> str:
    return {
        "as_is": "the hand as it was",
        "limits": "closed at the joints' limits",
        "contacts": "each finger driven 2 cm past its contact",
        "limits_contacts": "closed at the joints' limits with each finger driven "
        "2 cm past its contact",
    }[name]


def closed_at_limits(model: Any) -> dict[str, float]:
    """``model``'s ``closed`` posture with every finger joint that moves from
    the pre-grasp posture at its limit on the closing side (the limits the
    model keeps: the URDF's, narrowed where ``gripper new`` stopped a finger at
    the palm); joints that do not move stay."""
    closed = {k: float(v) for k, v in model.closed.items()}
    for joints, lim in zip(model.finger_joints, model.finger_limits, strict=True):
        for j, (lo, hi) in zip(joints, np.asarray(lim, dtype=np.float64), strict=True):
            pre = float(model.pregrasp.get(j, lo))
            end = closed.get(j, pre)
            if end > pre:
                closed[j] = float(hi)
            elif end < pre:
                closed[j] = float(lo)
    return closed


def compare_drops(
    a: list[bool], b: list[bool]
) -> tuple[int, int, float, tuple[float, float]]:
    """Over the same drops, ``a`` against ``b``: drops gained, lost, the mean
    difference of successes and its 95 % interval as the eval report gives it
    (:func:`wsgrasp.sim.report.paired_difference`); one drop alone bounds
    nothing (an interval without ends)."""
    from wsgrasp.sim.report import paired_difference

    d = [float(x) - float(y) for x, y in zip(a, b, strict=True)]
    if not d:
        return 0, 0, 0.0, (0.0, 0.0)
    mean, low, high = paired_difference(d)
    if len(d) == 1:
        low, high = -math.inf, math.inf
    return sum(x > 0 for x in d), sum(x < 0 for x in d), mean, (low, high)


def tune_closing(
    gripper: str,
    *,
    objects: list[str],
    trials: int = 1,
    seed: int = 0,
    params: Any = None,
    workers: int = 0,
    progress: bool = True,
    say: Callable[[str], None] | None = None,
) -> TuneResult:
    """Grasp the same drops with each closing of :data:`VARIANTS` and choose.

    ``gripper`` is a gripper YAML; its default spec (``specs/default.yaml``
    beside it, else the generic default) is the hand as it is. Variants that
    change nothing (a hand already closing to its limits, a spec already
    closing to contacts) are skipped and named in ``skipped``.
    """
    from wsgrasp.default_specs import default_spec
    from wsgrasp.gripper import load_gripper
    from wsgrasp.sim.objects import resolve_objects
    from wsgrasp.sim.params import SimParams
    from wsgrasp.sim.runner import EvalConfig, SpecEntry, run_eval
    from wsgrasp.spec import Approach

    tell = say or (lambda _msg: None)
    path = Path(gripper).expanduser().resolve()
    if not path.is_file():
        raise InputError(
            f"gripper tune: {gripper} is not a gripper YAML file (it rewrites one)",
            hint="pass the path of the gripper's YAML, e.g. "
            "my_gripper/wsgrasp_my_gripper/my_gripper.yaml as gripper new wrote it",
        )
    data = yaml.safe_load(path.read_text())
    model = load_gripper(str(path))
    spec, _ = default_spec(str(path))
    # every field, the spec's own or its default
    approach = Approach.model_validate(spec.get("approach") or {}).model_dump()
    # the YAML's own joints, in its order
    as_is_closed = {k: float(v) for k, v in (data.get("closed") or {}).items()}
    at_limits = closed_at_limits(model)
    limits = {k: at_limits.get(k, v) for k, v in as_is_closed.items()}
    contacts_approach = {**approach, **CONTACTS_APPROACH}
    plan = {
        "as_is": (as_is_closed, approach),
        "limits": (limits, approach),
        "contacts": (as_is_closed, contacts_approach),
        "limits_contacts": (limits, contacts_approach),
    }
    skipped = []
    if _same_closed(limits, as_is_closed):
        skipped += ["limits", "limits_contacts"]
    if (
        approach.get("close_to", "contacts") == "contacts"
        and approach.get("squeeze") == CONTACTS_APPROACH["squeeze"]
    ):
        skipped += ["contacts", "limits_contacts"]
    names = [n for n in VARIANTS if n not in skipped]
    resolved = resolve_objects(objects, workers=workers, progress=False)
    params = params or SimParams.for_protocol("strict")
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="wsgrasp-tune-") as tmp:
        entries = []
        for name in names:
            closed, appr = plan[name]
            variant = {**data, "name": f"{data['name']}_{name}", "closed": closed}
            urdf = Path(str(data["urdf"])).expanduser()
            variant["urdf"] = str(urdf if urdf.is_absolute() else path.parent / urdf)
            vpath = Path(tmp) / f"{data['name']}_{name}.yaml"
            vpath.write_text(yaml.safe_dump(variant, sort_keys=False))
            d = {**spec, "gripper": str(vpath), "approach": appr}
            d["record"] = {**(d.get("record") or {}), "enabled": False}
            entries.append(SpecEntry(gripper=str(vpath), label=name, spec=d))
        tell(
            f"{len(names)} closings × {len(resolved.objects)} objects × {trials} "
            f"trial(s) under the {params.protocol} protocol"
        )
        config = EvalConfig(
            objects=resolved.objects,
            specs=entries,
            trials=trials,
            seed=seed,
            params=params,
            workers=workers,
        )
        records, _ = run_eval(config, progress=progress)
    outcomes: dict[str, dict[tuple[str, int], bool]] = {n: {} for n in names}
    for r in records:
        outcomes[r["spec"]][(r["object"], int(r["trial"]))] = r["outcome"] == "success"
    drops = sorted(outcomes["as_is"])
    base = [outcomes["as_is"][k] for k in drops]
    results = []
    for name in names:
        got = [outcomes[name].get(k, False) for k in drops]
        gained, lost, diff, ci = compare_drops(got, base)
        closed, appr = plan[name]
        results.append(
            VariantResult(
                name, closed, appr, len(got), int(sum(got)), gained, lost, diff, ci
            )
        )
    best = max(results, key=lambda v: (v.successes, -names.index(v.name)))
    chosen = best.name if best.name != "as_is" and best.ci95[0] > 0.0 else "as_is"
    return TuneResult(
        gripper=str(path),
        objects=", ".join(objects),
        protocol=params.protocol,
        seed=seed,
        trials_per_object=trials,
        variants=results,
        chosen=chosen,
        wall_s=time.perf_counter() - t0,
        skipped=sorted(set(skipped)),
    )


def _same_closed(a: dict[str, float], b: dict[str, float]) -> bool:
    return all(abs(a[k] - b.get(k, a[k])) <= 1e-9 for k in a)


def write_tuned(result: TuneResult) -> list[Path]:
    """Write the chosen closing into the gripper YAML (``closed``, with the
    figures in a comment above it) and its ``specs/default.yaml``
    (``approach``); the files written. Nothing where the hand stays as it is."""
    if result.chosen == "as_is":
        return []
    path = Path(result.gripper)
    v = result.variant(result.chosen)
    base = result.variant("as_is")
    written = []
    note = _comment(result.summary())
    if not _same_closed(v.closed, base.closed):
        text = path.read_text()
        path.write_text(_replace_closed(text, v.closed, note, path))
        written.append(path)
    if v.approach != base.approach:
        spec = path.parent / "specs" / "default.yaml"
        written.append(_write_approach(spec, str(path), v.approach, note))
    return written


def _comment(sentence: str, width: int = 88) -> str:
    """``sentence`` as ``#`` comment lines of at most ``width`` characters."""
    import textwrap

    return "\n".join("# " + line for line in textwrap.wrap(sentence, width - 2)) + "\n"


_CLOSED = re.compile(r"^closed:[ \t]*(#.*)?$", re.MULTILINE)


def _replace_closed(text: str, closed: dict[str, float], note: str, path: Path) -> str:
    """``text`` (a gripper YAML) with its block ``closed:`` mapping replaced by
    ``closed`` and ``note`` put above it."""
    m = _CLOSED.search(text)
    if m is None:
        raise InputError(
            f"{path}: no block mapping 'closed:' to rewrite (a flow mapping "
            "'closed: {...}' or none)",
            hint="write closed: as one joint per line, or run gripper tune with "
            "--dry-run and copy the printed posture",
        )
    lines = text[m.end() :].split("\n")
    # the mapping's entries: the indented lines after it (blank lines inside)
    n = 1  # lines[0] is the rest of the 'closed:' line
    while n < len(lines) and (lines[n].startswith((" ", "\t")) or not lines[n]):
        n += 1
    while n > 1 and not lines[n - 1].strip():
        n -= 1
    body = "".join(f"\n  {j}: {float(v)!r}" for j, v in closed.items())
    before = _strip_note(text[: m.start()])
    return before + note + "closed:" + body + "\n" + "\n".join(lines[n:])


def _strip_note(before: str) -> str:
    """``before`` (the text above a key) without the comment an earlier
    ``gripper tune`` put right above the key."""
    lines = before.split("\n")  # the last is "" (the key's line starts after)
    k = len(lines) - 1
    while k > 0 and lines[k - 1].startswith("#"):
        k -= 1
        if lines[k].startswith("# `wsgrasp gripper tune`"):
            return "\n".join(lines[:k]) + "\n"
    return before


_APPROACH = re.compile(r"^approach:.*$", re.MULTILINE)


def _write_approach(
    spec: Path, gripper: str, approach: dict[str, Any], note: str
) -> Path:
    """Set ``approach`` in the spec file ``spec`` (written from the gripper's
    default spec where it does not exist), with ``note`` above it."""
    from wsgrasp.default_specs import default_spec

    line = "approach: {" + ", ".join(f"{k}: {v}" for k, v in approach.items()) + "}"
    if spec.is_file():
        text = spec.read_text()
        if _APPROACH.search(text) is None:
            text = text.rstrip("\n") + "\n" + note + line + "\n"
        else:
            m = _APPROACH.search(text)
            assert m is not None
            text = _strip_note(text[: m.start()]) + note + line + text[m.end() :]
    else:
        data, source = default_spec(gripper)
        data = {**data, "gripper": Path(gripper).stem, "approach": dict(approach)}
        spec.parent.mkdir(parents=True, exist_ok=True)
        text = f"# the default spec of {Path(gripper).stem}, from {source}\n" + note
        text += yaml.safe_dump(data, sort_keys=False)
    spec.write_text(text)
    return spec
