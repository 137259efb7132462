"""Results pages' tables and charts, rendered from the JSON files that runs write
under docs/results/ (make bench, make eval*, make eval-grippers)."""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Any

from docs_tables import short, table

ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "docs" / "results"


def _load(path: Path) -> dict[str, Any] | None:
    return json.loads(path.read_text()) if path.is_file() else None


#: the libraries a results page names beside a run, where its file records them:
#: a simulated run's, and a timing's (the search and perception alone)
_SHOWN = ("cpu", "mujoco", "coacd", "numpy", "open3d", "numba")
_SHOWN_TIMING = ("cpu", "numpy", "scipy", "open3d", "numba")


def _provenance(
    report: dict[str, Any], what: str, libraries: tuple[str, ...] = _SHOWN
) -> str:
    commit = report.get("commit") or "not recorded"
    machine = report.get("machine") or "not recorded"
    date = report.get("date") or "not recorded"
    load = report.get("load_average")
    busy = f", load average {load[0]:.1f} as it ended" if load else ""
    note = f" {report['note'].rstrip('.')}." if report.get("note") else ""
    return (
        f"From {what} at commit `{commit}` on {machine} ({date}{busy})."
        f"{_libraries(report, libraries)}{note}"
    )


def _libraries(report: dict[str, Any], shown: tuple[str, ...]) -> str:
    """The sentence naming the versions a run recorded (``libraries``) of the
    libraries ``shown``, e.g. ``" With mujoco 4.0.1, numpy 2.4.6."``; empty for
    a file that records none."""
    libs = report.get("libraries") or {}
    named = [f"{k} {libs[k]}" for k in shown if libs.get(k)]
    return f" With {', '.join(named)}." if named else ""


def _eval_grippers_markdown(report: dict[str, Any]) -> str:
    import importlib.util

    path = ROOT / "benchmarks" / "eval_grippers.py"
    spec = importlib.util.spec_from_file_location("_eval_grippers", path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return str(mod.markdown(report))


def _grippers_table(name: str, target: str) -> str:
    """The gripper table of ``docs/results/<name>``, which ``make <target>``
    writes, or a line saying it is not there yet."""
    report = _load(RESULTS / name)
    if report is None:
        return (
            f"No `docs/results/{name}` yet: `make {target}` writes it "
            "(see [Evaluate a gripper](../how-to/evaluate-a-gripper.md)).\n"
        )
    return _eval_grippers_markdown(report)


def render_results_grippers() -> str:
    """Every gripper under the lift protocol (``make eval-grippers``)."""
    return _grippers_table("grippers.json", "eval-grippers")


def render_results_grippers_strict() -> str:
    """The same under the strict protocol (``make eval-grippers-strict``)."""
    return _grippers_table("grippers-strict.json", "eval-grippers-strict")


def render_defaults_success() -> str:
    """The built-in and example grippers' default specs, from grippers.json."""
    report = _load(RESULTS / "grippers.json")
    if report is None:
        return "No `docs/results/grippers.json` yet: `make eval-grippers` writes it.\n"
    rows = []
    for r in report["rows"]:
        if r.get("source") != "built-in" or "trials" not in r:
            continue
        fails = ", ".join(f"{k} {v}" for k, v in sorted(r["failures"].items()) if v)
        rows.append(
            [
                f"`{r['name']}`",
                r["trials"],
                f"{100 * r['success_rate']:.0f} %",
                fails or "–",
            ]
        )
    return (
        _provenance(report, "`make eval-grippers`")
        + f" Protocol `{report['protocol']}`, objects `{report['objects']}`, "
        f"{report['trials']} trial each, seed {report['seed']}.\n\n"
        + table(["gripper", "trials", "success", "failures"], rows)
    )


def render_chart_grippers() -> str:
    if not (RESULTS / "grippers.json").is_file():
        return ""
    return (
        "![success of every gripper with its default spec, from "
        "docs/results/grippers.json](grippers-success.svg)\n"
    )


def _svg(fig: Any) -> bytes:
    buf = io.StringIO()
    fig.savefig(buf, format="svg", metadata={"Date": None})
    return buf.getvalue().encode()


def chart_grippers() -> bytes | None:
    """Horizontal bars: each gripper's success, failures stacked by kind."""
    report = _load(RESULTS / "grippers.json")
    if report is None:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams["svg.hashsalt"] = "wsgrasp"
    rows = [r for r in report["rows"] if "trials" in r]
    kinds = sorted({k for r in rows for k, v in r["failures"].items() if v})
    names = [r["name"] for r in rows][::-1]
    fig, ax = plt.subplots(figsize=(8, 0.4 * len(rows) + 1.4))
    left = [0.0] * len(rows)
    succ = [100.0 * r["successes"] / r["trials"] for r in rows][::-1]
    ax.barh(names, succ, color="#2e7d32", label="success")
    left = succ
    colours = ["#c62828", "#ef6c00", "#f9a825", "#6a1b9a", "#1565c0", "#757575"]
    for i, kind in enumerate(kinds):
        vals = [100.0 * r["failures"].get(kind, 0) / r["trials"] for r in rows][::-1]
        ax.barh(names, vals, left=left, color=colours[i % len(colours)], label=kind)
        left = [a + b for a, b in zip(left, vals, strict=True)]
    for y, s in enumerate(succ):
        ax.text(1, y, f"{s:.0f} %", va="center", color="white", fontsize=8)
    ax.set_xlim(0, 100)
    ax.set_xlabel(
        f"% of trials ({report['objects']}, protocol {report['protocol']}, "
        f"commit {report['commit']})"
    )
    ax.legend(
        loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=4, fontsize=8, frameon=False
    )
    fig.tight_layout()
    data = _svg(fig)
    plt.close(fig)
    return data


def chart_eval(path: Path) -> bytes:
    """Bars: success of each gripper and spec of one eval summary, with chance's
    beside the choice where the run had a random baseline."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams["svg.hashsalt"] = "wsgrasp"
    r = json.loads(path.read_text())
    res = r.get("results", [])
    chance = {
        (b["gripper"], b.get("spec")): b["random_rate"]
        for b in r.get("baseline") or []
        if isinstance(b, dict) and "random_rate" in b
    }
    labels = [f"{short(x['gripper'])} · {x['spec']}" for x in res][::-1]
    rates = [100 * x["success_rate"] for x in res][::-1]
    fig, ax = plt.subplots(figsize=(8, 0.4 * len(res) + 1.4))
    ax.barh(labels, rates, color="#2e7d32", label="chosen grasp")
    if chance:
        ch = [100 * chance.get((x["gripper"], x["spec"]), 0) for x in res][::-1]
        ax.scatter(
            ch,
            labels,
            color="#c62828",
            marker="|",
            s=300,
            zorder=3,
            label="random feasible candidate",
        )
    for y, v in enumerate(rates):
        ax.text(1, y, f"{v:.0f} %", va="center", color="white", fontsize=8)
    ax.set_xlim(0, 100)
    protocol = r.get("params", {}).get("protocol", "?")
    ax.set_xlabel(
        f"% of trials ({r.get('objects')}, protocol {protocol}, "
        f"commit {r.get('commit', '?')})"
    )
    ax.legend(
        loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=2, fontsize=8, frameon=False
    )
    fig.tight_layout()
    data = _svg(fig)
    plt.close(fig)
    return data


def _ms(x: Any) -> str:
    if x is None or (isinstance(x, float) and x != x):
        return "–"
    x = float(x)
    if x >= 1000:
        return f"{x / 1000:.2f} s"
    if x >= 100:
        return f"{x:.0f} ms"
    if x >= 10:
        return f"{x:.1f} ms"
    return f"{x:.2f} ms"


def render_results_bench() -> str:
    report = _load(RESULTS / "bench.json")
    if report is None:
        return "No `docs/results/bench.json` yet: `make bench` writes it.\n"
    out = [_provenance(report, "`make bench`", _SHOWN_TIMING) + " Medians.\n"]
    rows, dense = [], []
    for name, r in report["rows"].items():
        if "plan_ms" in r:
            rows.append(
                [
                    f"`{name}`",
                    f"{int(r.get('candidates', 0)):,}",
                    _ms(r.get("plan_ms")),
                    _ms(r.get("preprocess_ms")),
                    _ms(r.get("segmentation_ms")),
                    _ms(r.get("object_frame_ms")),
                    _ms(r.get("search_ms")),
                    _ms(r.get("reference_search_ms")),
                    f"{r['speedup']:.0f}×" if r.get("speedup") else "–",
                    _ms(r.get("paper_plan_ms")),
                ]
            )
        else:
            dense.append((name, r))
    out.append(
        table(
            [
                "entry",
                "candidates",
                "whole plan",
                "preprocess",
                "segmentation",
                "object frame",
                "search",
                "loop-by-loop reference",
                "speed-up",
                "paper (Table II)",
            ],
            rows,
        )
    )
    if dense:
        out.append(
            "Dense entries (the search and the evaluation alone, alternating):\n"
        )
        out.append(
            table(
                [
                    "entry",
                    "candidates",
                    "search",
                    "evaluation",
                    "per candidate",
                    "peak (search)",
                    "compiled loops",
                ],
                [
                    [
                        f"`{n}`",
                        f"{int(r.get('candidates', 0)):,}",
                        _ms(r.get("search_ms")),
                        _ms(r.get("evaluate_ms")),
                        _us(r.get("us_per_candidate")),
                        _mb(r.get("peak_mb")),
                        "yes" if r.get("compiled") else "no",
                    ]
                    for n, r in dense
                ],
            )
        )
    scaling = report.get("scaling") or []
    if scaling:
        out.append("How the search grows with candidates and object points:\n")
        out.append(
            table(
                ["gripper", "samples × orientations", "object points", "search"],
                [
                    [
                        f"`{s['gripper']}`",
                        f"{s['samples']} × {s['orientations']}",
                        s["object_points"],
                        _ms(s["search_ms"]),
                    ]
                    for s in scaling
                ],
            )
        )
    return "\n".join(out)


def _us(v: Any) -> str:
    return "–" if v is None else f"{float(v):.2f} µs"


def _mb(v: Any) -> str:
    return "–" if v is None else f"{float(v):.0f} MB"


def eval_files() -> list[Path]:
    return sorted((RESULTS / "eval").glob("*.json"))


def render_results_eval() -> str:
    files = eval_files()
    if not files:
        return (
            "No run of `make eval`, `make eval-random`, `make eval-heldout`, "
            "`make eval-ycb` or `make eval-chance` is committed under "
            "`docs/results/eval/` yet; each of these targets writes its summary "
            "there (see [Evaluate a gripper](../how-to/evaluate-a-gripper.md)).\n"
        )
    out = []
    for path in files:
        r = json.loads(path.read_text())
        params = r.get("params", {})
        out.append(f"### `{path.stem}`\n")
        out.append(f"![success in {path.stem}](eval-{path.stem}.svg)\n")
        out.append(
            _provenance(r, f"`{r.get('command', 'wsgrasp eval')}`")
            + f" Protocol `{params.get('protocol', 'not recorded')}`, objects "
            f"`{r.get('objects')}`, {r.get('trials_per_object')} trial(s) each, "
            f"seed {r.get('seed')}.\n"
        )
        rows = []
        for res in r.get("results", []):
            fails = ", ".join(
                f"{k} {v}" for k, v in sorted(res.get("failures", {}).items()) if v
            )
            row = [
                short(res["gripper"]),
                res["spec"],
                res["trials"],
                f"{100 * res['success_rate']:.1f} %",
                _ms(res.get("plan_ms_median")),
                fails or "–",
            ]
            rows.append(row)
        out.append(
            table(
                ["gripper", "spec", "trials", "success", "median plan", "failures"],
                rows,
            )
        )
        out.append(_per_object(r.get("results", [])))
        base = r.get("baseline")
        if base:
            out.append(
                "Against chance (random feasible candidates of the same plan):\n"
            )
            brow = []
            for b in base if isinstance(base, list) else base.values():
                if not isinstance(b, dict) or "gripper" not in b:
                    continue
                brow.append(
                    [
                        short(b["gripper"]),
                        b.get("spec", ""),
                        f"{100 * b.get('chosen_rate', 0):.1f} %",
                        f"{100 * b.get('random_rate', 0):.1f} %",
                        _difference(b),
                    ]
                )
            if brow:
                out.append(
                    table(
                        [
                            "gripper",
                            "spec",
                            "chosen",
                            "random feasible",
                            "difference [95 %]",
                        ],
                        brow,
                    )
                )
        bands, heights = _by_height(r)
        if heights:
            out.append("By how high the object stood on the table:\n")
            out.append(table(["gripper", "spec", *bands], heights))
    return "\n".join(out)


def _by_height(r: dict[str, Any]) -> tuple[list[str], list[list[Any]]]:
    """The eval report ``r``'s split of success by the objects' height
    (``wsgrasp.sim.report.height_rows``, rates to one decimal, gripper paths
    shortened): the two bands' column names, and a row per gripper and spec."""
    from wsgrasp.sim.report import height_header, height_rows

    def pct(x: float | None) -> str:
        return "–" if x is None else f"{100 * x:.1f} %"

    below, rows = height_rows(r, pct)
    return height_header(below), [[short(g), spec, *cells] for g, spec, *cells in rows]


def _per_object(results: list[dict[str, Any]]) -> str:
    """Per gripper, a folded table of each object's success under each spec (and
    the paper's, where the object set has it); only for small object sets."""
    objects = {o["object"] for res in results for o in res.get("objects", [])}
    if not objects or len(objects) > 25:
        return ""
    out = []
    for gripper in dict.fromkeys(res["gripper"] for res in results):
        mine = [res for res in results if res["gripper"] == gripper]
        specs = [res["spec"] for res in mine]
        cells: dict[str, dict[str, str]] = {}
        paper: dict[str, str] = {}
        for res in mine:
            for o in res.get("objects", []):
                cells.setdefault(o["object"], {})[res["spec"]] = (
                    f"{100 * o['success_rate']:.0f} %"
                )
                if o.get("paper"):
                    pp = o["paper"]
                    paper[o["object"]] = (
                        f"{100 * pp['success_rate']:.0f} % ({pp['plan_s']:.2f} s)"
                    )
        header = ["object", *specs] + (
            ["paper (real robot, plan time)"] if paper else []
        )
        rows = [
            [f"`{name}`", *(c.get(sp, "–") for sp in specs)]
            + ([paper.get(name, "–")] if paper else [])
            for name, c in cells.items()
        ]
        folded = table(header, rows)
        body = "\n".join("    " + ln if ln else "" for ln in folded.splitlines())
        out.append(f'??? note "`{short(gripper)}`, per object"\n\n{body}\n')
    return "\n".join(out)


def _difference(row: dict[str, Any]) -> str:
    """A report row's paired difference in points, with its 95 % interval where
    the row has one."""
    lo, hi = row.get("ci95") or [None, None]
    interval = f" [{100 * lo:+.1f}, {100 * hi:+.1f}]" if lo is not None else ""
    return f"{100 * row.get('difference', 0):+.1f}{interval}"


def _chance_rows(path: Path, r: dict[str, Any], *, with_spec: bool) -> list[list[Any]]:
    """One row per plan-choice-against-chance comparison of the eval report
    ``r`` (its ``baseline``): file, gripper, (spec,) scenes × random candidates,
    chosen, random feasible, difference."""
    return [
        [
            f"`{path.name}`",
            f"`{short(b['gripper'])}`",
            *([f"`{b['spec']}`"] if with_spec else []),
            f"{b['scenes']} × {b['random_per_scene']}",
            f"{100 * b['chosen_rate']:.1f} %",
            f"{100 * b['random_rate']:.1f} %",
            _difference(b),
        ]
        for b in r.get("baseline", [])
    ]


def _runs_in(folder: str) -> str:
    """One row per gripper and run for every eval summary in
    ``docs/results/<folder>/``: its objects, setting, trials and success; then,
    for the runs that compared specs, each against the run's primary spec over
    the same scenes."""
    rows = []
    paired = []
    chance = []
    for path in sorted((RESULTS / folder).glob("*.json")):
        r = json.loads(path.read_text())
        chance += _chance_rows(path, r, with_spec=True)
        for c in r.get("specs_paired", []):
            paired.append(
                [
                    f"`{path.name}`",
                    f"`{short(c['gripper'])}`",
                    f"`{c['spec']}` against `{c['against']}`",
                    c["scenes"],
                    f"{100 * c['rate']:.1f} % vs {100 * c['against_rate']:.1f} %",
                    f"{c['gained']} / {c['lost']}",
                    _difference(c),
                ]
            )
        for res in r.get("results", []):
            rows.append(
                [
                    f"`{path.name}`",
                    f"`{r.get('objects')}`",
                    f"`{short(res['gripper'])}`",
                    f"`{res['spec']}`",
                    res["trials"],
                    f"{100 * res['success_rate']:.0f} %",
                ]
            )
    if not rows:
        return f"No runs under `docs/results/{folder}/`.\n"
    out = table(["file", "objects", "gripper", "setting", "trials", "success"], rows)
    if paired:
        header = ["file", "gripper", "specs", "scenes", "held", "gained / lost"]
        out += "\n" + table([*header, "difference, points (95 %)"], paired)
    if chance:
        header = ["file", "gripper", "spec", "scenes × random", "chosen", "random"]
        out += "\n" + table([*header, "difference, points (95 %)"], chance)
    return out


def render_angles_from_runs() -> str:
    """The runs that measured the major-axis angles set from the table."""
    return _runs_in("angles-from")


def render_across_narrowest_runs() -> str:
    """The runs on upright boxes a little narrower than a jaw opens
    (``docs/results/across-narrowest/``, ``benchmarks/upright_boxes.py``): the
    default spec beside the object frame's angles; then each box's trials held
    per setting."""
    return _runs_in("across-narrowest") + _object_table("across-narrowest")


def _object_table(folder: str) -> str:
    """Per run in ``docs/results/<folder>/``, a row per gripper and spec with
    the trials held of each object; empty without runs."""
    rows, names = [], []
    for path in sorted((RESULTS / folder).glob("*.json")):
        for res in json.loads(path.read_text()).get("results", []):
            held = {o["object"]: o for o in res.get("objects", [])}
            names = names or list(held)
            rows.append(
                [
                    f"`{path.name}`",
                    f"`{short(res['gripper'])}`",
                    f"`{res['spec']}`",
                    *(
                        f"{held[n]['successes']} of {held[n]['trials']}"
                        if n in held
                        else "–"
                        for n in names
                    ),
                ]
            )
    if not rows:
        return ""
    return "\n" + table(["file", "gripper", "setting", *map(str, names)], rows)


def render_noisy_depth_runs() -> str:
    """The runs under a noisier depth camera than the protocol's
    (``docs/results/noisy-depth/``, ``benchmarks/noisy_depth.py``): the default
    spec beside the segmenter's thresholds fixed (``noise_floor: 0``); then each
    one's success on the objects under 3 cm high and on the others."""
    return _runs_in("noisy-depth") + _height_table("noisy-depth")


def render_mirror_hidden_runs() -> str:
    """The runs seen by one camera with the sides it did not see mirrored in
    and without (``docs/results/mirror-hidden/``,
    ``benchmarks/one_camera_mirror.py``)."""
    return _runs_in("mirror-hidden")


def render_default_spec_runs() -> str:
    """The runs the generic default spec was chosen by: success per setting."""
    return _runs_in("default-spec")


def render_on_table_runs() -> str:
    """The runs that measured fingers sliding or sticking on the table."""
    return _runs_in("on-table")


def render_generic_scorers_runs() -> str:
    """The runs that measured the generic default's scorers on hands and jaws."""
    return _runs_in("generic-scorers")


def render_contact_fingers_runs() -> str:
    """The runs that measured hands needing their thumb and two fingers on the
    object against hands needing every finger."""
    return _runs_in("contact-fingers")


def render_approach_direction_runs() -> str:
    """The runs that measured approach_direction in the generic default."""
    return _runs_in("approach-direction")


def render_simulator_versions_runs() -> str:
    """The same trials run with several MuJoCo releases
    (``docs/results/simulator-versions/``): per gripper and release, the objects
    held, and per object against the newest release's run, the outcomes that
    differ."""
    runs: dict[str, list[tuple[str, str, dict[str, int], int]]] = {}
    for path in sorted((RESULTS / "simulator-versions").glob("*.json")):
        r = json.loads(path.read_text())
        version = (r.get("libraries") or {}).get("mujoco") or "not recorded"
        for res in r.get("results", []):
            held = {o["object"]: o["successes"] for o in res["objects"]}
            runs.setdefault(short(res["gripper"]), []).append(
                (version, path.name, held, res["trials"])
            )
    rows = []
    for gripper, got in runs.items():
        got.sort(key=lambda g: tuple(int(x) for x in g[0].split(".") if x.isdigit()))
        newest = got[-1]
        for version, name, held, trials in got:
            common = held.keys() & newest[2].keys()
            only = sum(held[o] > newest[2][o] for o in common)
            only_newest = sum(held[o] < newest[2][o] for o in common)
            rows.append(
                [
                    f"`{gripper}`",
                    version,
                    f"{sum(held.values())} of {trials}",
                    "" if version == newest[0] else f"{only} / {only_newest}",
                    f"`{name}`",
                ]
            )
    return table(
        [
            "gripper",
            "MuJoCo",
            "held",
            "held only with this release / only with the newest",
            "file",
        ],
        rows,
    )


def render_graze_depth_runs() -> str:
    """The runs that measured how deep a sliding fingertip's sweep may dip below
    the table (``docs/results/graze-depth/``): each depth against the first of
    its run, over the same objects; then each setting's success on the objects
    under 3 cm high and on the others (``by_height``)."""
    return _runs_in("graze-depth") + _height_table("graze-depth")


def render_allegro_closings_runs() -> str:
    """The Allegro hand's closing as shipped beside other postures that keep
    its fingertips low (``docs/results/allegro-closings/``), paired over the
    same drops; then each one's success by object height."""
    return _runs_in("allegro-closings") + _height_table("allegro-closings")


def render_closed_past_meet_runs() -> str:
    """The runs that measured a scaffolded hand closing on past where its pads
    meet (``docs/results/closed-past-meet/``): each hand's ``closed`` as
    ``gripper new`` guesses it and moved on along the closing line; then each
    one's success on the objects under 3 cm high and on the others."""
    return _runs_in("closed-past-meet") + _height_table("closed-past-meet")


def render_tune_runs() -> str:
    """The runs of ``wsgrasp gripper tune`` (``docs/results/tune/*.json``, its
    ``--json-out`` reports): per hand, what each closing held of the same drops
    and its paired difference from the hand as scaffolded, and the choice; then
    the hands as scaffolded and as tuned on other objects
    (``docs/results/tune-heldout/``), beside random feasible candidates."""
    rows = []
    for path in sorted((RESULTS / "tune").glob("*.json")):
        r = json.loads(path.read_text())
        for v in r["variants"]:
            lo, hi = (100 * x for x in v["ci95"])
            rows.append(
                [
                    f"`{path.name}`",
                    f"`{r['objects']}`",
                    f"`{v['name']}`"
                    + (" (chosen)" if v["name"] == r["chosen"] else ""),
                    f"{v['successes']} / {v['trials']}",
                    ""
                    if v["name"] == "as_is"
                    else f"{v['gained']} / {v['lost']}, "
                    f"{100 * v['difference']:+.0f} ({lo:+.0f} to {hi:+.0f})",
                ]
            )
    if not rows:
        return "No runs under `docs/results/tune/`.\n"
    header = ["file", "objects", "closing", "held", "gained / lost, points (95 %)"]
    return table(header, rows) + "\n" + _runs_in("tune-heldout")


def render_one_camera_runs() -> str:
    """The runs that planned from one camera (``docs/results/one-camera/``):
    looking down from nearly straight above, with the objects refused as
    hanging over the table, taken as standing, and with their sides filled in;
    and at 45 degrees; then each one's success on the objects under 3 cm high
    and on the others."""
    return _runs_in("one-camera") + _height_table("one-camera")


def render_flying_pixels_runs() -> str:
    """The runs that rendered flying pixels along every depth edge
    (``docs/results/flying-pixels/``): each gripper's default spec, which drops
    them, beside the same spec with the filter off; and the same on clean
    views; then each one's success on the objects under 3 cm high and on the
    others."""
    return _runs_in("flying-pixels") + _height_table("flying-pixels")


def render_thumb_drive_runs() -> str:
    """The runs that measured the Allegro hand's drive
    (``docs/results/thumb-drive/``): the hand as it is beside the same YAML
    with one gain for every joint (``allegro_right_one_gain``), the thumb's
    gain at other multiples, and the fingers' gain at other levels; then each
    gripper's success on the objects under 3 cm high and on the others, for
    the runs that split it."""
    return _runs_in("thumb-drive") + _height_table("thumb-drive")


def _height_table(folder: str) -> str:
    """Per run in ``docs/results/<folder>/`` that splits success by height
    (``by_height``), a row per gripper and spec; empty without such runs."""
    rows, bands = [], []
    for path in sorted((RESULTS / folder).glob("*.json")):
        bands, split = _by_height(json.loads(path.read_text()))
        rows += [
            [f"`{path.name}`", f"`{gripper}`", f"`{spec}`", low, tall]
            for gripper, spec, low, tall in split
        ]
    if not rows:
        return ""
    return "\n" + table(["file", "gripper", "setting", *bands], rows)


def render_drive_guess_runs() -> str:
    """The runs that measured the finger drive `gripper new` guesses for a hand
    (``docs/results/drive-guess/``): the gripper table with the simulator's
    default gain beside the current one, then each run of a hand's YAML beside
    the same YAML without its ``drive`` (``NAME-default-gain``), paired per
    object."""
    folder = RESULTS / "drive-guess"
    out = []
    old_path = folder / "grippers-default-gain.json"
    old, new = _load(old_path), _load(RESULTS / "grippers.json")
    if old is not None and new is not None:
        before = {r["name"]: r for r in old["rows"]}
        rows = []
        for r in new["rows"]:
            gains = (r.get("sim_notes") or {}).get("gains") or {}
            rev = gains.get("revolute") or {}
            b = before.get(r["name"])
            if rev.get("source") != "gripper" or r.get("source") == "built-in" or not b:
                continue
            rows.append(
                [
                    f"`{r['name']}`",
                    f"{rev['kp']:g}",
                    f"{b['successes']} of {b['trials']}",
                    f"{r['successes']} of {r['trials']}",
                ]
            )
        out.append(
            f"`grippers-default-gain.json`: {_provenance(old, '`make eval-grippers`')} "
            f"Beside it, `grippers.json`: {_provenance(new, '`make eval-grippers`')} "
            f"Both: protocol `{new['protocol']}`, objects `{new['objects']}`, "
            f"{new['trials']} trial each, seed {new['seed']}, the same drops.\n"
        )
        out.append(
            table(
                [
                    "hand",
                    "guessed kp_revolute (N·m/rad)",
                    "held, default gain (2 N·m/rad)",
                    "held, guessed drive",
                ],
                rows,
            )
        )
    rows, alone, chance = [], [], []
    for path in sorted(folder.glob("*.json")):
        if path == old_path:
            continue
        r = json.loads(path.read_text())
        chance += _chance_rows(path, r, with_spec=False)
        by = {short(res["gripper"]): res for res in r.get("results", [])}
        protocol = f"`{r.get('params', {}).get('protocol', 'not recorded')}`"
        out.append(f"`{path.name}`: {_provenance(r, '`wsgrasp eval`')}\n")
        if not any(name.endswith("-default-gain") for name in by):
            alone += [
                [
                    f"`{path.name}`",
                    f"`{r.get('objects')}`",
                    protocol,
                    f"`{name}`",
                    f"{res['successes']} of {res['trials']}",
                ]
                for name, res in by.items()
            ]
            continue
        for name, res in by.items():
            twin = by.get(f"{name}-default-gain")
            if twin is None:
                continue
            mine = {o["object"]: o["successes"] for o in res["objects"]}
            other = {o["object"]: o["successes"] for o in twin["objects"]}
            common = mine.keys() & other.keys()
            rows.append(
                [
                    f"`{path.name}`",
                    f"`{r.get('objects')}`",
                    protocol,
                    f"`{name}`",
                    f"{res['successes']} of {res['trials']}",
                    f"{twin['successes']} of {twin['trials']}",
                    f"{sum(mine[o] > other[o] for o in common)} / "
                    f"{sum(mine[o] < other[o] for o in common)}",
                ]
            )
    if rows:
        out.append(
            table(
                [
                    "file",
                    "objects",
                    "protocol",
                    "hand",
                    "held, guessed drive",
                    "held, default gain",
                    "objects gained / lost",
                ],
                rows,
            )
        )
    if alone:
        header = ["file", "objects", "protocol", "hand", "held, guessed drive"]
        out.append(table(header, alone))
    if chance:
        header = ["file", "hand", "scenes × random", "chosen", "random feasible"]
        out.append(table([*header, "difference, points (95 %)"], chance))
    return "\n".join(out) if out else "No runs under `docs/results/drive-guess/`.\n"


def render_reach_down_runs() -> str:
    """The runs that measured the reach_down scorer in the generic default."""
    return _runs_in("reach-down")


def render_thumb_turn_runs() -> str:
    """The runs that measured a thumb held opposed against one turning into
    opposition as it closes, then each hand's success by object height."""
    return _runs_in("thumb-turn") + _height_table("thumb-turn")


def render_other_descriptions_runs() -> str:
    """Grippers scaffolded from descriptions outside the development set, as
    other packages ship them, then each one's success by object height."""
    return _runs_in("other-descriptions") + _height_table("other-descriptions")


def render_coupled_jaws_runs() -> str:
    """Two-jaw grippers whose URDF drives the jaws apart, apart and moved
    together by ``gripper new``, then each one's success by object height."""
    return _runs_in("coupled-jaws") + _height_table("coupled-jaws")


def render_jaw_drive_runs() -> str:
    """The two-finger grippers with revolute jaws on the held-out objects, at
    the simulator's default gain and at the drive ``gripper new`` guesses."""
    return _runs_in("jaw-drive") + _height_table("jaw-drive")


def render_pose_margin_runs() -> str:
    """The runs that measured the pose_margin scorer beside a default spec."""
    return _runs_in("pose-margin")


def render_defaults_effect() -> str:
    """Each gripper's default spec beside the paper's and the follow-up's setting,
    from every eval summary that ran more than one spec per gripper."""
    out = []
    for path in eval_files():
        r = json.loads(path.read_text())
        by: dict[str, dict[str, float]] = {}
        for res in r.get("results", []):
            by.setdefault(short(res["gripper"]), {})[res["spec"]] = res["success_rate"]
        specs = sorted({sp for v in by.values() for sp in v}, key=_spec_order)
        if len(specs) < 2:
            continue
        protocol = r.get("params", {}).get("protocol", "not recorded")
        what = "`" + (r.get("command") or "wsgrasp eval") + "`"
        out.append(
            f"`{path.stem}`: {_provenance(r, what)} "
            f"Protocol `{protocol}`, objects `{r.get('objects')}`, "
            f"{r.get('trials_per_object')} trial(s) each.\n"
        )
        rows = [
            [g, *(f"{100 * v[sp]:.0f} %" if sp in v else "–" for sp in specs)]
            for g, v in by.items()
        ]
        out.append(table(["gripper", *specs], rows))
    if not out:
        return (
            "No evaluation run with several specs per gripper is committed under "
            "`docs/results/eval/` yet (`make eval` runs each gripper's default, "
            "paper and follow-up specs).\n"
        )
    return "\n".join(out)


def render_results_scorers() -> str:
    """Each score term's concordance with success and its pick rate, per
    gripper, from every run of ``benchmarks/scorer_concordance.py`` under
    docs/results (``scorers.json``, which ``make eval-scorers`` writes, and any
    other ``scorers*.json``)."""
    paths = sorted(RESULTS.glob("scorers*.json"))
    if not paths:
        return "No `docs/results/scorers.json` yet: `make eval-scorers` writes it.\n"
    out = []
    for path in paths:
        out.extend(_scorer_run(_load(path) or {}))
    return "\n".join(out)


def _scorer_run(report: dict[str, Any]) -> list[str]:
    """One run of ``benchmarks/scorer_concordance.py``: per gripper, the choice
    and chance, and each term's concordance and pick rate."""
    what = "`" + (report.get("command") or "make eval-scorers") + "`"
    out = [
        f"{_provenance(report, what)} Protocol `{report.get('protocol')}`, objects "
        f"`{report.get('objects')}`, the choice and {report.get('random_per_scene')} "
        "random feasible candidates labelled per scene.\n"
    ]
    for g, r in report.get("grippers", {}).items():
        out.append(
            f"**{short(g)}**: {r['scenes']} scenes; the choice held "
            f"{100 * r['chosen_success']:.0f} %, a random feasible candidate "
            f"{100 * r['random_success']:.0f} % ({r['random_labels']} labels); the "
            "default weights' pick among the random ones "
            f"{100 * r['default_pick_rate']:.0f} %.\n"
        )
        terms = sorted(r["terms"].items(), key=lambda kv: -kv[1]["concordance"])
        # runs before the held pairs' margin was measured have no such column
        margins = any("margin_pairs" in t for _, t in terms)
        header = ["term", "concordance", "its pick holds", "default weight"]
        if margins:
            header.append("held pairs: the firmer grip first (pairs)")
        rows = []
        for name, t in terms:
            row = [
                f"`{name}`",
                f"{t['concordance']:.2f}",
                f"{100 * t['pick_rate']:.0f} %",
                f"{t['default_weight']:g}",
            ]
            if margins:
                m = t.get("margin_concordance")
                row.append("—" if m is None else f"{m:.2f} ({t['margin_pairs']})")
            rows.append(row)
        out.append(table(header, rows))
    return out


def _spec_order(spec: str) -> tuple[int, str]:
    order = {"default": 0, "paper": 1, "followup": 2}
    return (order.get(spec, 3), spec)


#: the clutter benchmark's scene kinds, in the order the page shows them
_CLUTTER_ORDER = ("pile", "packed")
#: failure kinds of a clutter step (wsgrasp/sim/clutter.py), in the order shown
_CLUTTER_KINDS = ("no_grasp", "wrong_split", "neighbour_collision", "slip")


def clutter_files() -> list[Path]:
    """The published clutter runs, ``docs/results/clutter/*.json``: pile, packed,
    then any other by name."""
    paths = (RESULTS / "clutter").glob("*.json")

    def order(p: Path) -> tuple[int, str]:
        k = _CLUTTER_ORDER.index(p.stem) if p.stem in _CLUTTER_ORDER else 9
        return (k, p.stem)

    return sorted(paths, key=order)


def _share(rate: Any, count: Any, total: Any) -> str:
    """``62.5 % (5 of 8)``, or a dash where nothing was attempted."""
    if rate is None:
        return "–"
    return f"{100 * float(rate):.1f} % ({count} of {total})"


def render_results_clutter() -> str:
    """Every published clutter-removal run (``wsgrasp eval --scene pile|packed``,
    ``make eval-clutter``): where it ran, and per gripper the attempts, the
    rates, the plans' times and the failures by kind."""
    files = clutter_files()
    if not files:
        return (
            "No clutter run is published under `docs/results/clutter/` yet: "
            "`make eval-clutter` writes `pile.json` and `packed.json` there "
            "(see [Grasp in clutter](../how-to/clutter.md#measure-clutter-removal)).\n"
        )
    out = []
    for path in files:
        out.extend(_clutter_run(path.stem, json.loads(path.read_text())))
    return "\n".join(out)


def _clutter_run(name: str, r: dict[str, Any]) -> list[str]:
    """One clutter report: its provenance and protocol, then a row per gripper."""
    params = r.get("params") or {}
    what = "`" + (r.get("command") or "wsgrasp eval") + "`"
    steps = r.get("max_steps")
    limit = (
        f"at most {steps} attempts per scene"
        if steps
        else "at most twice as many attempts as objects per scene"
    )
    n = r.get("scenes")
    wall = r.get("wall_s")
    took = ""
    if wall is not None:
        w = float(wall)
        took = (
            f" The run took {w:.0f} s."
            if w < 120
            else f" The run took {w / 60:.0f} min."
        )
    out = [
        f"### `{name}`\n",
        f"{_provenance(r, what)} Scene `{r.get('scene', name)}`: "
        f"{r.get('objects_per_scene')} objects per scene drawn from "
        f"`{r.get('objects')}`, {n} scene{'' if n == 1 else 's'} per gripper "
        f"(the same objects and seeds for each), seed {r.get('seed')}, protocol "
        f"`{params.get('protocol', 'not recorded')}`, {limit}.{took}\n",
    ]
    rows = []
    runs = []
    for gripper, g in (r.get("grippers") or {}).items():
        runs.append((f"`{short(gripper)}`", g))
        if g.get("baseline"):
            runs.append((f"`{short(gripper)}`, random feasible", g["baseline"]))
    for label, g in runs:
        s = g.get("summary") or {}
        kinds = dict(s.get("failure_kinds") or {})
        order = [k for k in _CLUTTER_KINDS if k in kinds] + sorted(
            k for k in kinds if k not in _CLUTTER_KINDS
        )
        fails = ", ".join(f"{k} {kinds[k]}" for k in order if kinds[k])
        ends: dict[str, int] = {}
        fell = 0
        steps = []
        for scene in g.get("scenes") or []:
            ends[scene.get("end", "?")] = ends.get(scene.get("end", "?"), 0) + 1
            fell += len(scene.get("fell_off") or [])
            steps += scene.get("steps") or []
        # attempts whose gripper touched another object while it approached
        # and closed, successes included, and those that touched it before
        # the target (where the run recorded them)
        recorded = [st["touched"] for st in steps if "touched" in st]
        touched: str | int = sum(bool(t) for t in recorded) if recorded else "–"
        ahead = [st["touched_first"] for st in steps if "touched_first" in st]
        if ahead:
            touched = f"{touched} ({sum(bool(t) for t in ahead)})"
        p90 = s.get("first_plan_ms_p90")
        first = _ms(s.get("first_plan_ms_median")) + (
            f" / {_ms(p90)}" if p90 is not None else ""
        )
        attempts = s.get("attempts", 0)
        rows.append(
            [
                label,
                attempts,
                _share(s.get("grasp_success_rate"), s.get("successes"), attempts),
                _share(s.get("lift_rate"), s.get("target_lifted"), attempts),
                _share(s.get("declutter_rate"), s.get("removed"), s.get("objects")),
                _ms(s.get("pipeline_ms_median")),
                first,
                fails or "–",
                touched,
                s.get("two_lifted", "–"),
                fell,
                ", ".join(f"{k} {v}" for k, v in sorted(ends.items())) or "–",
            ]
        )
    out.append(
        table(
            [
                "gripper",
                "attempts",
                "grasp success",
                "target lifted",
                "declutter (removed of objects)",
                "plans per step, median",
                "first plan, median / p90",
                "failed attempts by kind",
                "touched a neighbour (before the target)",
                "two lifted at once",
                "knocked off the table",
                "scenes ended",
            ],
            rows,
        )
    )
    paired = [
        (gripper, g["baseline"]["paired"])
        for gripper, g in (r.get("grippers") or {}).items()
        if (g.get("baseline") or {}).get("paired")
    ]
    if paired:
        out.append(
            "\nThe choice less chance (a random feasible candidate of each step's "
            "plan), mean over the scenes both runs have the rate for, with its "
            "95 % interval (paired normal):\n"
        )
        rows = []
        for gripper, d in paired:
            row = [f"`{short(gripper)}`"]
            for key in ("grasp_success", "target_lifted", "declutter"):
                v = d.get(key) or {}
                if v.get("difference") is None:
                    row.append("–")
                    continue
                lo, hi = v["ci95"]
                row.append(
                    f"{100 * v['difference']:+.1f} [{100 * lo:+.1f}, {100 * hi:+.1f}]"
                    f" over {v['scenes']}"
                )
            rows.append(row)
        out.append(
            table(
                ["gripper", "grasp success", "target lifted", "declutter"],
                rows,
            )
        )
    out.extend(_touch_table(runs))
    return out


def _touch_table(runs: list[tuple[str, dict[str, Any]]]) -> list[str]:
    """Where a run recorded the neighbours touched before the target: per
    gripper (and chance), the executed attempts that held, split by what the
    gripper touched while it approached and closed."""
    rows = []
    for label, g in runs:
        steps = [
            st
            for scene in g.get("scenes") or []
            for st in scene.get("steps") or []
            if st.get("found") and "touched_first" in st
        ]
        if not steps:
            continue
        # (held, attempts) per what was touched: nothing, only after, before
        tally = {kind: [0, 0] for kind in ("none", "after", "before")}
        for st in steps:
            kind = (
                "before"
                if st["touched_first"]
                else "after"
                if st.get("touched")
                else "none"
            )
            tally[kind][0] += bool(st.get("success"))
            tally[kind][1] += 1
        rows.append(
            [label] + [_share(h / n if n else None, h, n) for h, n in tally.values()]
        )
    if not rows:
        return []
    return [
        "\nThe executed attempts that held, by what the gripper touched while it "
        "approached and closed: no other object; neighbours only after it had "
        "touched its target (fingers meeting them around the target); a "
        "neighbour before the target (one in its way: a failure there counts as "
        "`neighbour_collision`):\n",
        table(
            [
                "gripper",
                "touched no neighbour",
                "only after the target",
                "one before the target",
            ],
            rows,
        ),
    ]


def render_clutter_segments() -> str:
    """The published runs of ``benchmarks/clutter_segments.py``: per object
    range, scene kind and option set, how the ``clutter`` segmenter's instances
    compare with the objects the points came from."""
    paths = sorted((RESULTS / "clutter-segments").glob("*.json"))
    if not paths:
        return "No run of `benchmarks/clutter_segments.py` is published yet.\n"
    out = []
    for path in paths:
        r = json.loads(path.read_text())
        what = "`" + (r.get("command") or "benchmarks/clutter_segments.py") + "`"
        out.append(
            f"`{path.name}`: {_provenance(r, what)} {r.get('scenes')} scenes of "
            f"{r.get('objects_per_scene')} objects from `{r.get('objects')}` per "
            f"kind, seed {r.get('seed')}.\n"
        )
        rows = []
        for row in r.get("rows", []):
            options = row.get("options") or {}
            setting = ", ".join(f"`{k}: {v}`" for k, v in options.items())
            rows.append(
                [
                    f"`{row['scene']}`",
                    setting or "the defaults",
                    row["objects"],
                    row["instances"],
                    row["merged"],
                    row["target merged"],
                    row["split"],
                    row["refused"],
                ]
            )
        out.append(
            table(
                [
                    "scene",
                    "options",
                    "objects seen",
                    "instances",
                    "merged",
                    "merged, the highest",
                    "objects split",
                    "no table or object found",
                ],
                rows,
            )
        )
    return "\n".join(out)


def render_room_views() -> str:
    """The published runs of ``benchmarks/room_views.py``
    (``docs/results/rooms/``): per run (commit, depth noise, crop), how many of
    the views of a room around a desk planned on the object, elsewhere (a
    leg, the floor), found no grasp or stopped with an error; then, per
    camera distance to the desk, the views that planned on the object."""
    paths = sorted((RESULTS / "rooms").glob("*.json"))
    if not paths:
        return "No run of `benchmarks/room_views.py` is published yet.\n"
    outcomes = ("on the object", "elsewhere", "no grasp", "error")
    runs = [(path, json.loads(path.read_text())) for path in paths]
    dists = sorted({x["distance"] for _, r in runs for x in r["rows"]})
    rows, by_distance = [], []
    for path, r in runs:
        if r.get("noise_per_m2"):
            noise = f"{r['noise_per_m2'] * 1e3:g} mm × range² (m)"
        else:
            noise = f"{r['noise'] * 1e3:g} mm"
        crop = r.get("crop_past")
        rows.append(
            [
                f"`{path.name}`",
                f"`{r.get('commit') or 'not recorded'}`",
                f"`{r['gripper']}`",
                noise,
                "none" if crop is None else f"{crop:g} m past the desk",
                r["views"],
                *(r["outcomes"].get(o, 0) for o in outcomes),
            ]
        )
        cells = []
        for d in dists:
            at = [x for x in r["rows"] if x["distance"] == d]
            on = sum(x["outcome"] == "on the object" for x in at)
            cells.append(f"{on} of {len(at)}" if at else "–")
        by_distance.append([f"`{path.name}`", *cells])
    return (
        table(
            ["file", "commit", "gripper", "depth noise", "crop", "views", *outcomes],
            rows,
        )
        + "\nOn the object, by the camera's distance to the desk:\n\n"
        + table(["file", *(f"{d:g} m" for d in dists)], by_distance)
    )
