"""The evaluation report: Table II of the paper, for wsgrasp, as data, rich and
Markdown.

Plan time (ET in the paper) is the planner's own time per plan (``timing_ms
["total"]``: preprocessing, segmentation, object frame, search), median over the
trials; rendering and physics are not included, as in the paper.

With a random baseline (``eval --baseline random``) the report's ``baseline``
has, per gripper and spec, the plan's choice beside chance on the same scenes:
the success rate of the choice, that of the random feasible candidates executed
beside it (each scene's share of them held, averaged over the scenes) and the
paired difference with a 95 % interval (:func:`paired_difference`). With several
specs per gripper, ``specs_paired`` sets each against the primary spec over the
scenes both ran (:func:`spec_pairs`).

Each gripper × spec, and each baseline row, also splits its scenes by how high
the object stood on the table once it settled (``by_height``: objects lower
than :data:`LOW_OBJECT` and the others): a hand that holds tall objects and
drops flat ones shows it there, where the overall rate averages the two.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Callable, Sequence
from typing import Any

from wsgrasp._names import gripper_label
from wsgrasp._version import library_versions
from wsgrasp.sim.trial import OUTCOMES

__all__ = [
    "LOW_OBJECT",
    "PAPER_TABLE2",
    "baseline_rows",
    "build_report",
    "finger_gains",
    "paired_difference",
    "spec_pairs",
    "report_markdown",
    "report_table",
]

#: Sorour et al. (2019), Table II: object → gripper → (plan time s, success rate)
PAPER_TABLE2: dict[str, dict[str, tuple[float, float]]] = {
    "storage_bin": {"allegro_right": (1.77, 0.8), "franka_hand": (0.39, 1.0)},
    "mug": {"allegro_right": (1.07, 0.9), "franka_hand": (0.23, 0.8)},
    "thermos": {"allegro_right": (1.61, 0.4), "franka_hand": (0.33, 0.0)},
    "realsense_box": {"allegro_right": (1.39, 1.0), "franka_hand": (0.41, 0.9)},
    "cookies_package": {"allegro_right": (1.24, 0.8), "franka_hand": (0.62, 0.4)},
    "plant_pot": {"allegro_right": (1.43, 1.0), "franka_hand": (0.36, 0.8)},
    "plastic_cup": {"allegro_right": (0.31, 0.4), "franka_hand": (0.31, 0.0)},
    "tooth_paste": {"allegro_right": (1.64, 0.6), "franka_hand": (0.24, 1.0)},
    "toilet_paper_roll": {"allegro_right": (1.09, 1.0), "franka_hand": (0.26, 1.0)},
    "doll": {"allegro_right": (1.18, 0.4), "franka_hand": (0.37, 0.4)},
    "dish_brush": {"allegro_right": (0.99, 0.2), "franka_hand": (0.29, 0.8)},
    "banana": {"allegro_right": (1.53, 0.2), "franka_hand": (0.27, 1.0)},
    "sprayer": {"allegro_right": (0.58, 0.8), "franka_hand": (0.25, 0.4)},
}
PAPER_AVERAGE = {"allegro_right": (1.22, 0.65), "franka_hand": (0.34, 0.65)}
FAILURES = OUTCOMES[1:]
#: objects standing lower than this (m) on the table are the ``by_height``
#: split's low ones (half of the random set stands 2.0-2.5 cm high, the rest
#: 4-8 cm: a fingertip about as wide as the object is high grips its edge)
LOW_OBJECT = 0.03


def _height_band(r: dict[str, Any]) -> str | None:
    """``"low"`` or ``"tall"`` (:data:`LOW_OBJECT`), or None for a trial whose
    object never settled (no height recorded)."""
    h = r.get("object_height")
    if h is None:
        return None
    return "low" if float(h) < LOW_OBJECT else "tall"


def _by_height(records: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Trials, successes and success rate of the low and the tall objects."""
    out: dict[str, Any] = {"low_below_m": LOW_OBJECT}
    for band in ("low", "tall"):
        recs = [r for r in records if _height_band(r) == band]
        ok = sum(r["outcome"] == "success" for r in recs)
        out[band] = {
            "trials": len(recs),
            "successes": ok,
            "success_rate": ok / len(recs) if recs else None,
        }
    return out


def _median(values: Sequence[float | None]) -> float | None:
    vals = [v for v in values if v is not None]
    return float(statistics.median(vals)) if vals else None


def _summary(records: Sequence[dict[str, Any]]) -> dict[str, Any]:
    n = len(records)
    ok = sum(r["outcome"] == "success" for r in records)
    return {
        "trials": n,
        "successes": ok,
        "success_rate": ok / n if n else 0.0,
        "plan_ms_median": _median([r.get("plan_ms") for r in records]),
        "failures": {k: sum(r["outcome"] == k for r in records) for k in FAILURES},
        # how near the held grasps' grips were to sliding at the end of the
        # hold: where nearly every grasp holds, a spec that holds as many may
        # still hold them more firmly
        "held_friction_use_median": _median(
            [
                (r.get("metrics") or {}).get("friction_use_held")
                for r in records
                if r["outcome"] == "success"
            ]
        ),
    }


def build_report(
    records: Sequence[dict[str, Any]],
    *,
    primary: str = "default",
    meta: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """The report as plain data (what ``wsgrasp eval --json`` prints).

    Top-level ``success_rate``, ``trials`` and ``plan_ms_median`` are over the
    ``primary`` spec's trials (every gripper); ``results`` has one entry per
    gripper × spec with per-object rows.
    """
    chosen = [r for r in records if r.get("pick", "plan") == "plan"]
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for r in chosen:
        groups.setdefault((r["gripper"], r["spec"]), []).append(r)
    results = []
    for (gripper, spec), recs in groups.items():
        objects: dict[str, list[dict[str, Any]]] = {}
        for r in recs:
            objects.setdefault(r["object"], []).append(r)
        rows = []
        for name, orecs in objects.items():
            row = {"object": name, **_summary(orecs)}
            paper = PAPER_TABLE2.get(name, {}).get(gripper)
            if paper is not None:
                row["paper"] = {"plan_s": paper[0], "success_rate": paper[1]}
            rows.append(row)
        results.append(
            {
                "gripper": gripper,
                "spec": spec,
                **_summary(recs),
                "by_height": _by_height(recs),
                "objects": rows,
            }
        )
    main = [r for r in chosen if r["spec"] == primary] or list(chosen)
    out = {
        "version": 1,
        "libraries": library_versions(),
        **(meta or {}),
        "primary_spec": primary,
        **_summary(main),
        "results": results,
        "trial_records": list(records),
    }
    baseline = baseline_rows(records)
    if baseline:
        out["baseline"] = baseline
    paired = spec_pairs(records, primary)
    if paired:
        out["specs_paired"] = paired
    return out


#: the interval the baseline's difference is given with
INTERVAL = (
    "paired normal 95 %: mean of the per-scene differences ± 1.96 × their "
    "standard deviation / √scenes"
)


def paired_difference(differences: Sequence[float]) -> tuple[float, float, float]:
    """Mean of per-scene differences and its 95 % interval (paired normal: mean
    ± 1.96 s / √n, s the sample standard deviation); ``(mean, low, high)``."""
    n = len(differences)
    if n == 0:
        return 0.0, 0.0, 0.0
    mean = sum(differences) / n
    sd = statistics.stdev(differences) if n > 1 else 0.0
    half = 1.96 * sd / math.sqrt(n)
    return mean, mean - half, mean + half


def baseline_rows(records: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per gripper and spec with random candidates: the choice against chance.

    A scene is one (object, trial). Its choice scores 1 when it held; its random
    score is the share of its random candidates that held (0 when it had none:
    no feasible candidate). ``difference`` is the mean over scenes of the two's
    difference, with ``ci95`` as :func:`paired_difference` gives it.
    """
    randoms: dict[tuple[str, str, str, int], list[bool]] = {}
    for r in records:
        if r.get("pick") == "random":
            key = (r["gripper"], r["spec"], r["object"], r["trial"])
            randoms.setdefault(key, []).append(r["outcome"] == "success")
    if not randoms:
        return []
    rows = []
    chosen = [r for r in records if r.get("pick", "plan") == "plan"]
    pairs = dict.fromkeys((r["gripper"], r["spec"]) for r in chosen)
    for gripper, spec in pairs:
        scenes = [r for r in chosen if (r["gripper"], r["spec"]) == (gripper, spec)]
        held = [float(r["outcome"] == "success") for r in scenes]
        draws = [
            randoms.get((gripper, spec, r["object"], r["trial"]), []) for r in scenes
        ]
        chance = [sum(d) / len(d) if d else 0.0 for d in draws]
        diff, low, high = paired_difference(
            [a - b for a, b in zip(held, chance, strict=True)]
        )
        n = len(scenes)
        bands: dict[str, Any] = {"low_below_m": LOW_OBJECT}
        for band in ("low", "tall"):
            at = [i for i, r in enumerate(scenes) if _height_band(r) == band]
            m = len(at)
            bands[band] = {
                "scenes": m,
                "chosen_rate": sum(held[i] for i in at) / m if m else None,
                "random_rate": sum(chance[i] for i in at) / m if m else None,
            }
        rows.append(
            {
                "gripper": gripper,
                "spec": spec,
                "scenes": n,
                "random_per_scene": max((len(d) for d in draws), default=0),
                "random_trials": sum(len(d) for d in draws),
                "chosen_rate": sum(held) / n if n else 0.0,
                "random_rate": sum(chance) / n if n else 0.0,
                "difference": diff,
                "ci95": [low, high],
                "interval": INTERVAL,
                "by_height": bands,
            }
        )
    return rows


def spec_pairs(records: Sequence[dict[str, Any]], primary: str) -> list[dict[str, Any]]:
    """Per gripper, each other spec against ``primary`` over the scenes both
    ran (the same objects, trials and drops): a scene is one (object, trial),
    scoring 1 where the choice held. ``gained`` counts the scenes the other
    spec held and ``primary`` did not, ``lost`` the reverse; ``difference``
    (other less primary) and ``ci95`` as :func:`paired_difference` gives them."""
    held: dict[tuple[str, str], dict[tuple[str, int], bool]] = {}
    for r in records:
        if r.get("pick", "plan") == "plan":
            key = (r["gripper"], r["spec"])
            held.setdefault(key, {})[(r["object"], r["trial"])] = (
                r["outcome"] == "success"
            )
    rows = []
    for (gripper, spec), other in held.items():
        base = held.get((gripper, primary))
        if spec == primary or base is None:
            continue
        scenes = [k for k in base if k in other]
        diff, low, high = paired_difference(
            [float(other[k]) - float(base[k]) for k in scenes]
        )
        n = len(scenes)
        rows.append(
            {
                "gripper": gripper,
                "spec": spec,
                "against": primary,
                "scenes": n,
                "rate": sum(other[k] for k in scenes) / n if n else 0.0,
                "against_rate": sum(base[k] for k in scenes) / n if n else 0.0,
                "gained": sum(other[k] and not base[k] for k in scenes),
                "lost": sum(base[k] and not other[k] for k in scenes),
                "difference": diff,
                "ci95": [low, high],
                "interval": INTERVAL,
            }
        )
    return rows


def _pairs_table(report: dict[str, Any]) -> tuple[list[str], list[list[str]]]:
    """Each spec against the primary one, paired over the same scenes."""
    header = ["gripper", "spec", "against", "scenes", "held", "gained", "lost"]
    header.append("difference")
    rows = [
        [
            _shown(report, p["gripper"]),
            p["spec"],
            p["against"],
            str(p["scenes"]),
            f"{_pct(p['rate'])} vs {_pct(p['against_rate'])}",
            str(p["gained"]),
            str(p["lost"]),
            _difference(p),
        ]
        for p in report["specs_paired"]
    ]
    return header, rows


def _difference(row: dict[str, Any]) -> str:
    """A paired difference and its interval, in points."""
    low, high = row["ci95"]
    return f"{100 * row['difference']:+.1f} pts [{100 * low:+.1f}, {100 * high:+.1f}]"


# --------------------------------------------------------------------------------
def _pct(x: float | None) -> str:
    return "–" if x is None else f"{100 * x:.0f} %"


def _sec(ms: float | None) -> str:
    return "–" if ms is None else f"{ms / 1e3:.2f} s"


def _shown(report: dict[str, Any], gripper: str) -> str:
    """``gripper`` as the report's tables show it: a gripper file by its stem
    (:func:`~wsgrasp._names.gripper_label`), unless another gripper of the
    report has the same one (two packages' ``hand.yaml``): then by its path."""
    label = gripper_label(gripper)
    others = {r["gripper"] for r in report.get("results", [])} - {gripper}
    return gripper if label in {gripper_label(o) for o in others} else label


def _columns(report: dict[str, Any]) -> list[dict[str, Any]]:
    order = {"franka_hand": 0, "allegro_right": 1}
    return sorted(
        report["results"],
        key=lambda r: (
            order.get(r["gripper"], 9),
            r["gripper"],
            r["spec"] != "default",
        ),
    )


def _table_rows(
    report: dict[str, Any], gripper: str
) -> tuple[list[str], list[list[str]]]:
    """One gripper's Table II: a row per object, ET and SR per spec, then the
    paper's figures where it has them."""
    cols = [c for c in _columns(report) if c["gripper"] == gripper]
    header = ["object"]
    for c in cols:
        header += [f"{c['spec']} ET", f"{c['spec']} SR"]
    paper = gripper in PAPER_AVERAGE
    if paper:
        header += ["IROS'19 ET", "IROS'19 SR"]
    names = list(dict.fromkeys(o["object"] for c in cols for o in c["objects"]))
    rows = []
    for name in names:
        row = [name]
        for c in cols:
            o = next((o for o in c["objects"] if o["object"] == name), None)
            row += (
                [_sec(o["plan_ms_median"]), _pct(o["success_rate"])]
                if o
                else ["–", "–"]
            )
        if paper:
            p = PAPER_TABLE2.get(name, {}).get(gripper)
            row += [f"{p[0]:.2f} s", _pct(p[1])] if p else ["–", "–"]
        rows.append(row)
    total = ["all"]
    for c in cols:
        total += [_sec(c["plan_ms_median"]), _pct(c["success_rate"])]
    if paper:
        p = PAPER_AVERAGE[gripper]
        total += [f"{p[0]:.2f} s", _pct(p[1])]
    rows.append(total)
    return header, rows


def _grippers(report: dict[str, Any]) -> list[str]:
    return list(dict.fromkeys(c["gripper"] for c in _columns(report)))


def _failure_rows(report: dict[str, Any]) -> tuple[list[str], list[list[str]]]:
    header = ["gripper", "spec", "trials", "success", *FAILURES, "held: friction use"]
    rows = [
        [
            _shown(report, c["gripper"]),
            c["spec"],
            str(c["trials"]),
            str(c["successes"]),
            *[str(c["failures"].get(k, 0)) for k in FAILURES],
            "–"
            if c.get("held_friction_use_median") is None
            else f"{c['held_friction_use_median']:.2f}",
        ]
        for c in _columns(report)
    ]
    return header, rows


def _baseline_table(report: dict[str, Any]) -> tuple[list[str], list[list[str]]]:
    """Chosen, random feasible and their paired difference, a row per gripper
    and spec."""
    header = ["gripper", "spec", "scenes", "chosen", "random feasible", "difference"]
    rows = [
        [
            _shown(report, b["gripper"]),
            b["spec"],
            f"{b['scenes']} × {b['random_per_scene']} random",
            _pct(b["chosen_rate"]),
            _pct(b["random_rate"]),
            _difference(b),
        ]
        for b in report["baseline"]
    ]
    return header, rows


def height_rows(
    report: dict[str, Any], pct: Callable[[float | None], str] = _pct
) -> tuple[float, list[list[str]]]:
    """Success on the low objects and on the tall ones (``by_height``), a row
    ``[gripper, spec, low, tall]`` per gripper and spec of an eval report, with
    chance beside each where the run had a random baseline, and the height (m)
    the split is at; no rows for a report without the split. ``pct`` formats a
    rate (the documentation's tables give one decimal)."""
    base = {(b["gripper"], b.get("spec")): b for b in report.get("baseline") or []}
    rows = []
    below = LOW_OBJECT
    for res in report.get("results", []):
        split = res.get("by_height")
        if not split:
            continue
        below = split["low_below_m"]
        chance = (base.get((res["gripper"], res["spec"])) or {}).get("by_height", {})
        cells = []
        for band in ("low", "tall"):
            b = split[band]
            cell = f"{pct(b['success_rate'])} of {b['trials']}"
            if chance.get(band, {}).get("random_rate") is not None:
                cell += f" (random {pct(chance[band]['random_rate'])})"
            cells.append(cell)
        rows.append([_shown(report, res["gripper"]), res["spec"], *cells])
    return below, rows


def height_header(below: float) -> list[str]:
    """The two columns of :func:`height_rows`' bands."""
    return [f"objects under {100 * below:g} cm high", "the others"]


def _height_table(report: dict[str, Any]) -> tuple[list[str], list[list[str]]]:
    below, rows = height_rows(report)
    return ["gripper", "spec", *height_header(below)], rows


#: the report's comparisons, each as (key, title, table builder, columns on the left)
_COMPARISONS = (
    (
        "baseline",
        "The plan's choice against random feasible candidates of the same plan",
        _baseline_table,
        2,
    ),
    (
        "specs_paired",
        "Each spec against the primary one, over the same scenes",
        _pairs_table,
        3,
    ),
    (
        "results",
        "Success by how high the object stood on the table",
        _height_table,
        2,
    ),
)


def _repair_counts(report: dict[str, Any]) -> list[str]:
    """Per simulated gripper, one line counting what was not taken from its
    URDF (``sim_grippers`` of the report's metadata)."""
    from collections import Counter

    lines = []
    for gripper, notes in (report.get("sim_grippers") or {}).items():
        kinds = Counter(r["kind"] for r in notes.get("repairs", []))
        if kinds:
            lines.append(
                f"{gripper}: URDF values replaced in simulation: "
                + ", ".join(f"{kind} {n}" for kind, n in sorted(kinds.items()))
                + " (the report's sim_grippers says which and why)"
            )
    return lines


#: where a simulated gripper's finger gains came from, as the report says it
_GAIN_SOURCES = {"gripper": "the gripper YAML's drive", "params": "the simulator's"}


def finger_gains(notes: dict[str, Any]) -> list[tuple[float, str, str]]:
    """``(gain, unit, source)`` of the finger actuators of each joint kind a
    simulated gripper has, from its entry in a report's ``sim_grippers``
    (:meth:`~wsgrasp.sim.gripper.SimGripper.notes_json`): revolute in N·m/rad,
    prismatic in N/m; ``source`` ``gripper`` (its YAML's ``drive``) or
    ``params`` (the simulator's)."""
    units = {e["unit"] for e in (notes.get("efforts") or {}).values()}
    gains = notes.get("gains") or {}
    return [
        (float(gains[kind]["kp"]), gain_unit, str(gains[kind]["source"]))
        for kind, unit, gain_unit in (
            ("revolute", "N·m", "N·m/rad"),
            ("prismatic", "N", "N/m"),
        )
        if unit in units and kind in gains
    ]


def _repair_markdown(report: dict[str, Any]) -> list[str]:
    """The simulated grippers' force limits, finger gains and repairs as
    Markdown."""
    grippers = report.get("sim_grippers") or {}
    if not grippers:
        return []
    lines = ["", "**Simulated grippers: what was not taken from the URDF as it is**"]
    for gripper, notes in grippers.items():
        efforts = ", ".join(
            f"{j} {e['effort']:g} {e['unit']} ({e['source']})"
            for j, e in notes.get("efforts", {}).items()
        )
        lines += ["", f"{gripper}: finger force limits {efforts or '–'}"]
        gains = ", ".join(
            f"{kp:g} {unit} ({_GAIN_SOURCES.get(source, source)})"
            for kp, unit, source in finger_gains(notes)
        )
        own = ", ".join(
            f"{j} {g['kp']:g}" for j, g in (notes.get("joint_gains") or {}).items()
        )
        if own:
            gains += f"; of their own, from the gripper YAML's drive.joints: {own}"
        if gains:
            lines += ["", f"{gripper}: finger position gains {gains}"]
        repairs = notes.get("repairs", [])
        if repairs:
            lines += [
                "",
                "| item | kind | problem | used instead |",
                "|---|---|---|---|",
            ]
            lines += [
                f"| {r['item']} | {r['kind']} | {r['problem']} | {r['action']} |"
                for r in repairs
            ]
    return lines


def _protocol_line(params: dict[str, Any]) -> str:
    """The protocol and its main parameters in one line."""
    mass = params.get("object_mass")
    line = (
        f"{params.get('protocol', 'lift')} (friction {params['friction']:g}, "
        + (
            f"mass {mass:g} kg"
            if mass is not None
            else f"masses: the set's, else {params.get('density', 0):g} kg/m³"
        )
        + f", hold {params['hold_time']:g} s"
    )
    if params.get("disturbance_weights"):
        line += (
            f", 6 disturbances of {params['disturbance_weights']:g} × weight for "
            f"{params['disturbance_time']:g} s"
        )
    if params.get("execution_offset") or params.get("execution_angle_deg"):
        line += (
            f", execution error {1e3 * params['execution_offset']:g} mm and "
            f"{params['execution_angle_deg']:g}°"
        )
    if params.get("slip_distance") or params.get("slip_angle_deg"):
        line += (
            f", slip limit {1e3 * params['slip_distance']:g} mm / "
            f"{params['slip_angle_deg']:g}°"
        )
    return line + ")"


def report_table(report: dict[str, Any]) -> list[Any]:
    """Rich renderables: the per-object table, the failure classes and a line
    per simulated gripper counting what was repaired in its URDF."""
    from rich.table import Table

    out: list[Any] = []
    for gripper in _grippers(report):
        header, rows = _table_rows(report, gripper)
        t = Table(
            title=f"{_shown(report, gripper)}: median plan time (ET) and success "
            "rate (SR)"
        )
        for i, h in enumerate(header):
            t.add_column(h, justify="left" if i == 0 else "right")
        for i, row in enumerate(rows):
            t.add_row(*row, end_section=i == len(rows) - 2)
        out.append(t)
    for key, title, build, left in _COMPARISONS:
        if report.get(key):
            header, crows = build(report)
            if not crows:  # a report written before the table's data was
                continue
            c = Table(title=title)
            for i, h in enumerate(header):
                c.add_column(h, justify="left" if i < left else "right")
            for row in crows:
                c.add_row(*row)
            out.append(c)
    fh, frows = _failure_rows(report)
    f = Table(title="Outcomes")
    for i, h in enumerate(fh):
        f.add_column(h, justify="left" if i < 2 else "right")
    for row in frows:
        f.add_row(*row)
    return [*out, f, *_repair_counts(report)]


def report_markdown(report: dict[str, Any]) -> str:
    """The report as Markdown: the Table II analogue, the outcome counts and the
    simulated grippers' force limits and URDF repairs."""
    lines: list[str] = []
    for gripper in _grippers(report):
        header, rows = _table_rows(report, gripper)
        lines += [
            f"**{_shown(report, gripper)}**",
            "",
            "| " + " | ".join(header) + " |",
            "|" + "|".join(["---"] + ["---:"] * (len(header) - 1)) + "|",
        ]
        for i, row in enumerate(rows):
            cells = [f"**{c}**" for c in row] if i == len(rows) - 1 else row
            lines.append("| " + " | ".join(cells) + " |")
        lines.append("")
    for key, title, build, left in _COMPARISONS:
        if report.get(key):
            header, crows = build(report)
            if not crows:  # a report written before the table's data was
                continue
            lines += [
                f"**{title}**",
                "",
                "| " + " | ".join(header) + " |",
                "|" + "|".join(["---"] * left + ["---:"] * (len(header) - left)) + "|",
            ]
            lines += ["| " + " | ".join(r) + " |" for r in crows]
            lines += ["", f"Interval: {INTERVAL}.", ""] if key != "results" else [""]
    fh, frows = _failure_rows(report)
    lines += [
        "| " + " | ".join(fh) + " |",
        "|" + "|".join(["---", "---"] + ["---:"] * (len(fh) - 2)) + "|",
    ]
    lines += ["| " + " | ".join(r) + " |" for r in frows]
    meta = [
        f"{k}: {report[k]}"
        for k in ("objects", "trials_per_object", "seed", "wall_s", "workers")
        if k in report
    ]
    if "params" in report:
        meta.append(f"protocol: {_protocol_line(report['params'])}")
    if meta:
        lines += ["", "; ".join(meta)]
    lines += _repair_markdown(report)
    return "\n".join(lines) + "\n"
