"""The gripper table: every gripper description in a folder, and every built-in
and example gripper, from URDF to held grasp with its default spec.

For each URDF found under ``--grippers-dir`` (by default ``../shared/grippers``,
the vendor descriptions wsgrasp is developed against; any folder of URDFs with
their meshes works the same way), and each ``--also`` URDF of ``--also-dir``
(``make eval-grippers``: three that pybullet ships in ``pybullet_data``, which
are not among the development descriptions):

1. ``wsgrasp gripper new`` (Python: ``scaffold_plugin``) into a package under
   ``--out``, with no edit: scaffolds yes / no, and why not; with ``--tune``
   (``make eval-grippers``), then ``wsgrasp gripper tune`` on it, which may move
   its ``closed`` or its default spec's ``approach`` (the row says);
2. ``gripper check``: its errors and warnings;
3. a plan with the gripper's default spec on each bundled scene
   (``examples/scenes``) and on an upright 6 x 5 x 11 cm box and a 5 cm cube;
4. ``wsgrasp eval`` with the default spec on ``--objects`` (``random:000-299``,
   the development range, 1 trial each, by default): success rate, failure
   kinds, and success apart on objects that settled lower than
   :data:`LOW_OBJECT` (lying flat: a hand whose fingertips cannot reach down
   their sides touches them on top) and on the taller ones.

The built-in grippers and the example plugins run steps 2-4 with their own
YAMLs. Each gripper's trials run in a ``wsgrasp eval`` process of their own, so
a crash costs only that row. Writes ``grippers.json`` (every figure) and
``grippers.md`` (the table) under ``--out``, and the same ``grippers.json`` to
``--results`` (``docs/results/grippers.json``), which the documentation renders
(its Results: grippers page, with a chart), and a short table into the README:
the lift run's rows with the strict run's success beside them (from
``grippers-strict.json`` beside ``--results``, where there is one).
``--render FILE`` prints the table of a ``grippers.json``; ``--readme FILE``
writes the README's table from one (and the ``grippers-strict.json`` beside it);
``--no-readme`` leaves the README as it is (``make eval-grippers-strict``: the
strict protocol's run goes to ``docs/results/grippers-strict.json``, then the
README's table is written again from both).

    python benchmarks/eval_grippers.py                  # what `make eval-grippers` runs
    python benchmarks/eval_grippers.py --objects random:000-019 --no-results
"""

from __future__ import annotations

import argparse
import json
import platform
import re
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "examples" / "scenes"
BUILT_IN = {
    "franka_hand": "franka_hand",
    "allegro_right": "allegro_right",
    "barrett_bh8_like": str(
        ROOT / "examples/plugins/barrett_bh8_like/wsgrasp_barrett_bh8_like"
        "/barrett_bh8_like.yaml"
    ),
    "robotiq_2f85_like": str(
        ROOT / "examples/plugins/robotiq_2f85_like/wsgrasp_robotiq_2f85_like"
        "/robotiq_2f85_like.yaml"
    ),
}
#: objects that settled lower than this (m) are counted apart
LOW_OBJECT = 0.03
#: the synthetic shapes every default spec must grasp: size (m), scene seed
SHAPES = {"box 6x5x11": ((0.06, 0.05, 0.11), 2), "cube 5": ((0.05, 0.05, 0.05), 3)}


def package_name(urdf: Path) -> str:
    """A gripper name from a URDF's file name: letters, digits and '_'."""
    name = re.sub(r"[^A-Za-z0-9_]+", "_", urdf.stem).strip("_").lower()
    return name if name[:1].isalpha() else f"g_{name}"


def scenes() -> dict[str, Any]:
    """The bundled scenes and the two synthetic shapes, by label."""
    from wsgrasp.perception.synth import synth_scene

    out: dict[str, Any] = {p.stem: p for p in sorted(SCENES.glob("*.npz"))}
    for yaml in sorted(SCENES.glob("*/scene.yaml")):
        out[yaml.parent.name] = yaml
    for label, (size, seed) in SHAPES.items():
        out[label] = synth_scene("box", size=size, seed=seed).points
    return out


def scaffold(urdf: Path, out: Path) -> tuple[str | None, dict[str, Any]]:
    """Scaffold ``urdf`` into ``out`` as ``wsgrasp gripper new`` does (its
    check's refits included): the gripper YAML, or None, and the row."""
    from wsgrasp.errors import WsgraspError
    from wsgrasp.gripper.scaffold import scaffold_plugin

    name = package_name(urdf)
    t0 = time.perf_counter()
    try:
        yaml, sc = scaffold_plugin(name, urdf, out / name, force=True)
    except WsgraspError as exc:
        return None, {"scaffolds": False, "scaffold_error": str(exc)}
    row = {
        "scaffolds": sc.build_error is None,
        "scaffold_s": round(time.perf_counter() - t0, 1),
        "scaffold_warnings": list(sc.warnings),
    }
    if sc.build_error is not None:
        row["scaffold_error"] = sc.build_error
        return None, row
    return str(yaml), row


#: the objects ``--tune`` tries each hand's closings on (``gripper tune``'s
#: default; a part of the development range)
TUNE_OBJECTS = "random:000-119"


def tune(gripper: str, protocol: str, out: Path) -> dict[str, Any]:
    """``wsgrasp gripper tune`` on a scaffolded gripper, in a process of its
    own: the closing it chose (written into the package) and its figures."""
    json_out = out / f"tune-{package_name(Path(gripper))}.json"
    args = ["gripper", "tune", gripper, "--objects", TUNE_OBJECTS]
    report = _run_wsgrasp([*args, "--protocol", protocol], json_out)
    if isinstance(report, str):
        return {"tune_error": report}
    return {
        "tune": {
            "objects": report["objects"],
            "chosen": report["chosen"],
            "summary": report["summary"],
            "held": {v["name"]: v["successes"] for v in report["variants"]},
            "trials": report["variants"][0]["trials"],
        }
    }


def _cell_scaffolds(r: dict[str, Any], short: bool = False) -> str:
    """Whether ``gripper new`` scaffolded the row's URDF, and what ``gripper
    tune`` changed where the run tuned it."""
    if not r.get("scaffolds"):
        return "no" if short else "no: " + r.get("scaffold_error", "")
    t = r.get("tune")
    if t is None:
        return "yes" if "tune_error" not in r else "yes (tune failed)"
    if t["chosen"] == "as_is":
        return "yes (tune: as scaffolded)"
    what = {
        "limits": "closed at limits",
        "contacts": "2 cm past contacts",
        "limits_contacts": "closed at limits, 2 cm past contacts",
    }[t["chosen"]]
    return f"yes (tune: {what})"


def check(gripper: str) -> dict[str, Any]:
    """``gripper check``: counts and the problems, one line each."""
    from wsgrasp.errors import WsgraspError
    from wsgrasp.gripper.check import check_gripper

    try:
        report = check_gripper(gripper)
    except WsgraspError as exc:
        return {"check_error": str(exc), "errors": [str(exc)], "warnings": []}
    m = report.model
    return {
        "fingers": m.num_fingers,
        "finger_names": list(m.finger_names),
        "errors": [f"{p.message} [{p.field}]" for p in report.errors],
        "warnings": [f"{p.message} [{p.field}]" for p in report.warnings],
    }


def plans(gripper: str, scene_set: dict[str, Any]) -> dict[str, Any]:
    """A plan with the gripper's default spec on every scene."""
    import wsgrasp
    from wsgrasp.default_specs import default_spec
    from wsgrasp.errors import WsgraspError
    from wsgrasp.spec import load_spec

    data, source = default_spec(gripper)
    data["record"] = {"enabled": False}
    pipeline = wsgrasp.Pipeline(load_spec(data))
    out: dict[str, Any] = {}
    for label, scene in scene_set.items():
        try:
            r = pipeline.plan(scene)
            out[label] = "found" if r.found else f"no grasp: {r.hint}"
        except WsgraspError as exc:
            out[label] = f"error: {exc}"
    return {"spec": source, "plans": out}


def trials(
    gripper: str, objects: str, n: int, seed: int, protocol: str, out: Path
) -> dict[str, Any]:
    """``wsgrasp eval`` with the default spec, in a process of its own."""
    json_out = out / f"eval-{package_name(Path(gripper))}.json"
    args = ["eval", "-g", gripper, "--objects", objects, "-n", str(n)]
    args += ["--seed", str(seed), "--no-paper", "--protocol", protocol]
    report = _run_wsgrasp(args, json_out)
    if isinstance(report, str):
        return {"eval_error": report}
    res = report["results"][0]
    return {
        "trials": res["trials"],
        "successes": res["successes"],
        "success_rate": res["success_rate"],
        "failures": {k: v for k, v in res["failures"].items() if v},
        **by_height(report.get("trial_records", [])),
        "plan_ms_median": res["plan_ms_median"],
        # what the simulated gripper took from its URDF and YAML (gains, efforts)
        # and what was repaired: the report's entry for this one gripper
        "sim_notes": next(iter((report.get("sim_grippers") or {}).values()), {}),
        "eval_wall_s": report.get("wall_s"),
    }


def _run_wsgrasp(args: list[str], json_out: Path) -> dict[str, Any] | str:
    """``wsgrasp ARGS -q --json-out JSON_OUT`` in a process of its own: the
    report it wrote, or the last lines it printed where it wrote none."""
    cmd = [str(Path(sys.executable).with_name("wsgrasp")), *args]
    proc = subprocess.run(
        [*cmd, "-q", "--json-out", str(json_out)], capture_output=True, text=True
    )
    if proc.returncode != 0 or not json_out.exists():
        return " ".join((proc.stderr or proc.stdout).strip().splitlines()[-3:])
    return json.loads(json_out.read_text())  # type: ignore[no-any-return]


def by_height(records: list[dict[str, Any]]) -> dict[str, Any]:
    """Trials and successes of the plans' grasps on objects that settled lower
    than :data:`LOW_OBJECT` (``low``) and on the others (``tall``); nothing for
    records without the object's height."""
    plans = [
        r
        for r in records
        if r.get("pick", "plan") == "plan" and r.get("object_height") is not None
    ]
    if not plans:
        return {}
    out = {}
    for key, keep in (
        ("low", lambda h: h < LOW_OBJECT),
        ("tall", lambda h: h >= LOW_OBJECT),
    ):
        mine = [r for r in plans if keep(r["object_height"])]
        out[key] = {
            "trials": len(mine),
            "successes": sum(r["outcome"] == "success" for r in mine),
        }
    return {"by_height": out, "low_object_m": LOW_OBJECT}


def _cell_heights(row: dict[str, Any]) -> str:
    """Success on the low objects and on the taller ones, or '–'."""
    split = row.get("by_height")
    if not split:
        return "–"
    cells = []
    for key in ("low", "tall"):
        n, k = split[key]["trials"], split[key]["successes"]
        cells.append(f"{100 * k / n:.0f} % of {n}" if n else "–")
    return " / ".join(cells)


def commands(gripper: str, name: str, out: Path) -> dict[str, Any]:
    """``plan``, ``view``, ``batch`` and ``dataset`` with the gripper, each in a
    process of its own: the ones that ended in an internal error (a traceback,
    or the CLI's "internal error"), with its last line."""
    wsgrasp = str(Path(sys.executable).with_name("wsgrasp"))
    run = out / "commands" / name
    run.mkdir(parents=True, exist_ok=True)
    mcap = run / "plan.mcap"
    steps = {
        "plan": ["plan", str(SCENES / "box_upright.npz"), "-g", gripper],
        "view": ["view", str(mcap), "-o", str(run / "plan.png")],
        "batch": ["batch", str(SCENES / "mug.npz"), "-g", gripper, "-q"],
        "dataset": ["dataset", "random:000", "-g", gripper, "-k", "1", "-q"],
    }
    steps["plan"] += ["--record", str(mcap)]
    steps["batch"] += ["-o", str(run / "batch")]
    steps["dataset"] += ["-o", str(run / "dataset")]
    broken = {}
    for label, args in steps.items():
        proc = subprocess.run([wsgrasp, *args], capture_output=True, text=True)
        text = proc.stdout + proc.stderr
        if "internal error" in text or "Traceback" in text:
            broken[label] = text.strip().splitlines()[-1][:200]
    return {"commands_broken": broken}


def _cell_plans(row: dict[str, Any]) -> str:
    p = row.get("plans") or {}
    if not p:
        return "–"
    missed = [k for k, v in p.items() if v != "found"]
    return f"{len(p) - len(missed)}/{len(p)}" + (
        f" (none: {', '.join(missed)})" if missed else ""
    )


def _cell_success(row: dict[str, Any]) -> str:
    if "eval_error" in row:
        return "eval failed: " + row["eval_error"][:80]
    if "trials" not in row:
        return "–"
    fails = ", ".join(f"{k} {v}" for k, v in sorted(row["failures"].items()))
    return f"{100 * row['success_rate']:.1f} % of {row['trials']}" + (
        f" ({fails})" if fails else ""
    )


def _cell_commands(row: dict[str, Any]) -> str:
    if "commands_broken" not in row:
        return "–"
    broken = row["commands_broken"]
    return "; ".join(f"{k}: {v}" for k, v in broken.items()) or "no internal error"


def _cell_check(row: dict[str, Any]) -> str:
    """Errors in full; warnings counted, with the fields they name."""
    if "errors" not in row:
        return "–"
    e, w = row["errors"], row["warnings"]
    if not e and not w:
        return "no problems"
    fields = sorted({m.rsplit("[", 1)[-1].rstrip("]") for m in w if "[" in m})
    parts = [f"error: {x}" for x in e]
    if w:
        parts.append(f"{len(w)} warning(s) ({', '.join(fields)})")
    return "; ".join(parts)


def _mujoco(report: dict[str, Any]) -> str:
    """`MuJoCo` and the version the run recorded, where it recorded one."""
    version = (report.get("libraries") or {}).get("mujoco")
    return f"MuJoCo {version}" if version else "MuJoCo"


def _tune_objects(report: dict[str, Any]) -> str:
    """The object sets the rows' ``gripper tune`` runs tried, as written in
    their reports (rows merged from runs of several settings name each)."""
    sets = sorted({r["tune"].get("objects", "") for r in report["rows"] if "tune" in r})
    return " or ".join(f"`{s}`" for s in sets if s) or f"`{TUNE_OBJECTS}`"


def markdown(report: dict[str, Any]) -> str:
    """The table, with the run it came from."""
    lines = [
        f"From `make eval-grippers` at commit {report['commit']} on "
        f"{report['machine']} ({report['date']}); success: `wsgrasp eval` with "
        f"{_mujoco(report)}, protocol `{report['protocol']}`, "
        f"objects `{report['objects']}`, "
        f"{report['trials']} trial each, seed {report['seed']}, default spec"
        + (
            f"; `gripper tune` on {_tune_objects(report)} where the scaffolds "
            "column says."
            if any("tune" in r for r in report["rows"])
            else "."
        ),
        "",
        "| gripper | source | fingers | scaffolds | `gripper check` | plans found "
        "| plan, view, batch, dataset | success (failures) "
        f"| success, objects under {100 * LOW_OBJECT:.0f} cm high / taller "
        "| finger drive |",
        "|---|---|---:|---|---|---|---|---|---|---|",
    ]
    for r in report["rows"]:
        scaf = _ours(r) if r["source"] == "built-in" else _cell_scaffolds(r)
        lines.append(
            f"| {_name(r)} | {_source(r)} | {r.get('fingers', '–')} | {scaf} | "
            f"{_cell_check(r)} | {_cell_plans(r)} | {_cell_commands(r)} | "
            f"{_cell_success(r)} | {_cell_heights(r)} | {_cell_drive(r)} |"
        )
    return "\n".join(lines) + "\n"


def _name(r: dict[str, Any]) -> str:
    """A row's gripper, with the commit it ran at where that is not the
    table's (a row re-run into it: ``--merge``)."""
    rerun = r.get("rerun")
    return r["name"] + (f" (run at {rerun['commit']})" if rerun else "")


def _ours(r: dict[str, Any]) -> str:
    """How one of wsgrasp's own grippers (``source`` ``built-in`` in the rows)
    comes: registered by wsgrasp, or an example plugin's YAML under
    ``examples/plugins`` (its ``gripper`` a path, not its name)."""
    return "built in" if r.get("gripper", r["name"]) == r["name"] else "example"


def _source(r: dict[str, Any]) -> str:
    """Where a row's gripper comes from, as the full table names it."""
    if r["source"] != "built-in":
        return str(r["source"])
    return "examples/plugins" if _ours(r) == "example" else "built-in"


def _cell_drive(r: dict[str, Any]) -> str:
    """The finger actuators' gains the trials used and where each came from
    (the YAML's ``drive`` or the simulator's default)."""
    from wsgrasp.sim.report import finger_gains

    cells = [
        f"{kp:g} {unit} ({'YAML' if source == 'gripper' else 'default'})"
        for kp, unit, source in finger_gains(r.get("sim_notes") or {})
    ]
    return ", ".join(cells) or "–"


#: the README's gripper table lies between these lines
README_START = (
    "<!-- gripper table: benchmarks/eval_grippers.py writes it from "
    "docs/results/grippers.json -->"
)
README_END = "<!-- end of gripper table -->"


def readme_table(report: dict[str, Any], strict: dict[str, Any] | None = None) -> str:
    """The README's short gripper table: one row per gripper, with the run
    (``report``, the lift protocol's) and, where ``strict`` is given, the
    strict protocol's success beside it (``wsgrasp eval``'s default)."""
    tuned = any("tune" in r for r in report["rows"])
    held_strict = {  # the cell, with the commit of a row re-run into the table
        r["name"]: f"{100 * r['success_rate']:.1f} %"
        + (f" (at {r['rerun']['commit']})" if r.get("rerun") else "")
        for r in (strict or {}).get("rows", [])
        if r.get("success_rate") is not None
    }
    lines = [
        f"From `make eval-grippers` at commit {report['commit']}: `gripper new` with",
        "no edit"
        + (
            f" (then `gripper tune` on {_tune_objects(report)} where it says)"
            if tuned
            else ""
        )
        + f", `gripper check`, plans on the bundled scenes and {len(SHAPES)} "
        "synthetic shapes,",
        f"grasps held in {_mujoco(report)} (protocol `{report['protocol']}`, "
        f"`{report['objects']}`, {report['trials']} trial",
        "each, default spec)"
        + (
            f"; held under the protocol `{strict['protocol']}`, `wsgrasp eval`'s "
            f"default, from `make eval-grippers-strict` at commit {strict['commit']} "
            f"(`{strict['objects']}`, the same drops)."
            if strict is not None
            else "."
        ),
        "",
        "| gripper | fingers | from | scaffolds | `gripper check` | plans found "
        f"| held | held, objects under {100 * LOW_OBJECT:.0f} cm high / taller |"
        + (" held, strict |" if strict is not None else ""),
        "|---|---:|---|---|---|---|---:|---:|"
        + ("---:|" if strict is not None else ""),
    ]
    for r in report["rows"]:
        built_in = r["source"] == "built-in"
        scaf = _ours(r) if built_in else _cell_scaffolds(r, short=True)
        source = "wsgrasp" if built_in else r["source"].split("/")[0]
        held = f"{100 * r['success_rate']:.1f} %" if "success_rate" in r else "–"
        lines.append(
            f"| {_name(r)} | {r.get('fingers', '–')} | {source} | {scaf} | "
            f"{_cell_check(r)} | {_cell_plans(r).split(' (')[0]} | {held} | "
            f"{_cell_heights(r)} |"
            + (f" {held_strict.get(r['name'], '–')} |" if strict is not None else "")
        )
    return "\n".join(lines) + "\n"


def strict_beside(results: Path) -> dict[str, Any] | None:
    """The strict protocol's report beside the lift one at ``results``
    (``grippers-strict.json`` in the same folder), or None."""
    path = results.with_name("grippers-strict.json")
    return json.loads(path.read_text()) if path.is_file() else None


def write_readme(
    report: dict[str, Any], readme: Path, strict: dict[str, Any] | None = None
) -> None:
    """Replace the table between ``README_START`` and ``README_END`` in
    ``readme`` with :func:`readme_table`."""
    text = readme.read_text()
    start, end = text.find(README_START), text.find(README_END)
    if start < 0 or end < start:
        raise SystemExit(
            f"{readme} has no gripper table markers ({README_START!r} ... "
            f"{README_END!r}); put them where the table goes"
        )
    head = text[: start + len(README_START)]
    readme.write_text(head + "\n" + readme_table(report, strict) + text[end:])


def merged(old: dict[str, Any], new: dict[str, Any]) -> dict[str, Any]:
    """``old`` with its rows named in ``new`` replaced by ``new``'s, each of
    those carrying ``new``'s commit and date (``rerun``); the run's settings
    must match, or the table would mix protocols."""
    for key in ("objects", "trials", "seed", "protocol"):
        if old.get(key) != new.get(key):
            raise SystemExit(
                f"--merge: the report's {key} is {old.get(key)!r}, this run's "
                f"{new.get(key)!r}; run the same settings, or the whole table"
            )
    fresh = {r["name"]: r for r in new["rows"]}
    missing = set(fresh) - {r["name"] for r in old["rows"]}
    if missing:
        raise SystemExit(f"--merge: no row {sorted(missing)} in the report")
    rows = [
        {**fresh[r["name"]], "rerun": {"commit": new["commit"], "date": new["date"]}}
        if r["name"] in fresh
        else r
        for r in old["rows"]
    ]
    return {**old, "rows": rows}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--grippers-dir", type=Path, default=ROOT.parent / "shared/grippers"
    )
    ap.add_argument(
        "--also-dir",
        type=Path,
        help="a second folder of descriptions, of which only the --also files "
        "are taken (pybullet_data: URDFs outside the development set)",
    )
    ap.add_argument(
        "--also",
        action="append",
        default=[],
        help="a URDF in --also-dir, relative to it (repeatable)",
    )
    ap.add_argument("--objects", default="random:000-299")
    ap.add_argument("--trials", type=int, default=1)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--protocol",
        default="lift",
        help="wsgrasp eval's trial protocol (lift: lift and hold; strict: "
        "execution error, disturbances, slip in the grip)",
    )
    ap.add_argument("--out", type=Path, default=ROOT / "eval-results" / "grippers")
    ap.add_argument(
        "--results",
        type=Path,
        default=ROOT / "docs" / "results" / "grippers.json",
        help="also write grippers.json here, where the documentation renders it",
    )
    ap.add_argument("--no-results", action="store_true")
    ap.add_argument(
        "--no-readme",
        action="store_true",
        help="leave the README's table as it is (the lift run's rows, the strict "
        "run's success beside them)",
    )
    ap.add_argument("--no-eval", action="store_true", help="skip the trials")
    ap.add_argument(
        "--tune",
        action="store_true",
        help="after gripper new, run gripper tune on each scaffolded gripper "
        f"({TUNE_OBJECTS}, the run's protocol) and evaluate it as tuned",
    )
    ap.add_argument("--only", action="append", help="only these gripper names")
    ap.add_argument(
        "--merge",
        action="store_true",
        help="with --only: put the rows run into the --results report in place of "
        "the rows of the same name there, each marked with the commit it ran at "
        "(the report's objects, trials, seed and protocol must match)",
    )
    ap.add_argument(
        "--render", type=Path, help="only print the table of this grippers.json"
    )
    ap.add_argument(
        "--readme",
        type=Path,
        help="only write the README's table from this grippers.json (and the "
        "grippers-strict.json beside it)",
    )
    args = ap.parse_args(argv)
    if args.render is not None:
        print(markdown(json.loads(args.render.read_text())), end="")
        return 0
    if args.readme is not None:
        write_readme(
            json.loads(args.readme.read_text()),
            ROOT / "README.md",
            strict_beside(args.readme),
        )
        return 0

    from rich.console import Console

    console = Console(stderr=True)
    args.out.mkdir(parents=True, exist_ok=True)
    entries: list[tuple[str, str, Path | str]] = []
    if args.grippers_dir.is_dir():
        for urdf in sorted(args.grippers_dir.rglob("*.urdf")):
            rel = urdf.relative_to(args.grippers_dir)
            entries.append((package_name(urdf), str(rel), urdf))
    else:
        console.print(
            f"no folder {args.grippers_dir}: the vendor descriptions are left out "
            "(pass --grippers-dir)"
        )
    for rel in args.also:
        if args.also_dir is None or not (args.also_dir / rel).is_file():
            raise SystemExit(
                f"--also {rel}: no such file in --also-dir {args.also_dir}"
            )
        urdf = args.also_dir / rel
        entries.append((package_name(urdf), f"{args.also_dir.name}/{rel}", urdf))
    entries += [(n, "built-in", ref) for n, ref in BUILT_IN.items()]
    if args.only:
        entries = [e for e in entries if e[0] in args.only]
    from publish_result import head_commit  # beside this script

    commit = head_commit()
    scene_set = scenes()
    rows = []
    for name, source, ref in entries:
        console.print(f"[bold]{name}[/] ({source})")
        row: dict[str, Any] = {"name": name, "source": source}
        gripper: str | None = str(ref)
        if isinstance(ref, Path):
            gripper, scaf = scaffold(ref, args.out / "packages")
            row.update(scaf)
            if gripper is not None and args.tune and not args.no_eval:
                row.update(tune(gripper, args.protocol, args.out))
        if gripper is not None:
            row["gripper"] = gripper
            row.update(check(gripper))
            if "check_error" not in row:
                row.update(plans(gripper, scene_set))
                row.update(commands(gripper, name, args.out))
                if not args.no_eval:
                    row.update(
                        trials(
                            gripper,
                            args.objects,
                            args.trials,
                            args.seed,
                            args.protocol,
                            args.out,
                        )
                    )
        console.print(
            f"  check: {_cell_check(row)}\n  plans: {_cell_plans(row)}\n"
            f"  commands: {_cell_commands(row)}\n"
            f"  success: {_cell_success(row)}",
            highlight=False,
        )
        rows.append(row)
    from wsgrasp._version import library_versions

    report = {
        "version": 1,
        "commit": commit,
        "machine": f"{platform.machine()}, {__import__('os').cpu_count()} cores",
        "date": time.strftime("%Y-%m-%d"),
        "libraries": library_versions(),
        "objects": args.objects,
        "trials": args.trials,
        "seed": args.seed,
        "protocol": args.protocol,
        "rows": rows,
    }
    if args.merge:
        report = merged(json.loads(args.results.read_text()), report)
    text = json.dumps(report, indent=2) + "\n"
    (args.out / "grippers.json").write_text(text)
    (args.out / "grippers.md").write_text(markdown(report))
    console.print(f"wrote {args.out / 'grippers.json'} and grippers.md")
    if not args.no_results:
        args.results.parent.mkdir(parents=True, exist_ok=True)
        args.results.write_text(text)
        if args.no_readme:
            console.print(f"wrote {args.results}")
        else:
            write_readme(report, ROOT / "README.md", strict_beside(args.results))
            console.print(f"wrote {args.results} and the README's table")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
