"""MkDocs hook: the reference and results pages' tables, generated at build time.

A page asks for a table with a marker on a line of its own::

    <!-- render: spec -->

and the hook replaces it with Markdown generated from the code (the pydantic
models, the registered plugins, the CLI's own help, a run recorded on a bundled
scene) or from the result files under ``docs/results/`` that runs write. An
unknown marker, or a renderer that fails, stops the build: a reference page
cannot drift from the code it documents. Charts (SVG) are drawn from the same
result files with matplotlib and added to the site as generated files.

Everything here runs offline and gives the same output for the same inputs.
"""

from __future__ import annotations

import inspect
import io
import json
import re
import tempfile
import typing
from collections.abc import Callable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "docs" / "results"
MARKER = re.compile(r"^<!-- render: ([a-z0-9-]+) -->$", re.M)

# --------------------------------------------------------------------------------
# small helpers
# --------------------------------------------------------------------------------


def _cell(text: Any) -> str:
    """A value made safe for one Markdown table cell."""
    s = str(text).replace("\n", " ").replace("|", "\\|")
    return s


def _code(value: Any) -> str:
    if value is None:
        return "–"
    return "`" + json.dumps(value, default=str) + "`"


def _type_name(annotation: Any) -> str:
    """A short, readable name of a field's type."""
    s = str(annotation) if not isinstance(annotation, type) else annotation.__name__
    s = re.sub(r"typing\.|pydantic\.types\.|annotated_types\.", "", s)
    s = re.sub(r"Annotated\[(\w+), [^\]]*\]", r"\1", s)
    s = re.sub(r"<class '([\w.]+)'>", lambda m: m.group(1).rsplit(".", 1)[-1], s)
    s = re.sub(r"wsgrasp\.spec\.", "", s)
    s = s.replace("NoneType", "None")
    return s


def _table(header: list[str], rows: list[list[Any]]) -> str:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(_cell(c) for c in row) + " |" for row in rows]
    return "\n".join(out) + "\n"


def _doc_summary(obj: Any) -> str:
    doc = inspect.getdoc(obj) or ""
    return " ".join(doc.split("\n\n")[0].split())


# --------------------------------------------------------------------------------
# spec and gripper YAML fields, from the pydantic models
# --------------------------------------------------------------------------------


def _models_in(annotation: Any) -> list[type]:
    from pydantic import BaseModel

    found: list[type] = []
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        found.append(annotation)
    for arg in typing.get_args(annotation):
        found += _models_in(arg)
    return found


def _model_tables(root: type, key: str) -> str:
    """One table per model reachable from ``root``, fields in declaration order."""
    from pydantic_core import PydanticUndefined

    out: list[str] = []
    seen: set[type] = set()
    todo: list[tuple[str, type]] = [(key, root)]
    while todo:
        path, model = todo.pop(0)
        if model in seen:
            continue
        seen.add(model)
        rows = []
        for name, f in model.model_fields.items():
            if f.default is PydanticUndefined and f.default_factory is None:
                default = "required"
            elif f.default_factory is not None:
                value = f.default_factory()  # type: ignore[call-arg]
                default = _code(_plain(value))
            else:
                default = _code(_plain(f.default))
            nested = _models_in(f.annotation)
            if nested and isinstance(f.default, nested[0]):
                default = "its fields' defaults"
            desc = f.description or ""
            if nested and not desc:
                desc = _doc_summary(nested[0])
            limits = _limits(f)
            rows.append(
                [
                    f"`{name}`",
                    f"`{_type_name(f.annotation)}`",
                    default,
                    desc + (f" ({limits})" if limits else ""),
                ]
            )
            for sub in nested:
                todo.append((f"{path}.{name}" if path else name, sub))
        title = f"`{path}`" if path else model.__name__
        out.append(f"### {title}\n\n{_doc_summary(model)}\n")
        out.append(_table(["field", "type", "default", "meaning"], rows))
    return "\n".join(out)


def _plain(value: Any) -> Any:
    from pydantic import BaseModel

    if isinstance(value, BaseModel):
        return value.model_dump(mode="json")
    if isinstance(value, list):
        return [_plain(v) for v in value]
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    return value


def _limits(field: Any) -> str:
    parts = []
    for m in field.metadata:
        for attr, sym in (("gt", ">"), ("ge", "≥"), ("lt", "<"), ("le", "≤")):
            v = getattr(m, attr, None)
            if v is not None:
                parts.append(f"{sym} {v}")
        if getattr(m, "min_length", None) is not None:
            parts.append(f"at least {m.min_length} item(s)")
    return ", ".join(parts)


def render_spec() -> str:
    from wsgrasp.spec import PipelineSpec

    return _model_tables(PipelineSpec, "")


def render_gripper_yaml() -> str:
    from wsgrasp.spec import GripperDescription

    return _model_tables(GripperDescription, "")


# --------------------------------------------------------------------------------
# plugins, from the registry (the wsgrasp distribution's own)
# --------------------------------------------------------------------------------


def _builtin(kind: str) -> list[Any]:
    from wsgrasp.plugins import get_registry

    reg = get_registry()
    items = [reg.items[kind][n] for n in reg.names(kind)]
    return [r for r in items if r.plugin.distribution == "wsgrasp"]


def render_plugins() -> str:
    out = []
    grippers = _builtin("grippers")
    out.append("### Grippers\n")
    rows = []
    for r in grippers:
        from wsgrasp.spec import load_gripper_description

        desc, _ = load_gripper_description(r.obj)
        rows.append(
            [
                f"`{r.name}`",
                len(desc.fingers),
                ", ".join(f.name for f in desc.fingers),
                desc.spheres_per_finger,
                desc.ellipsoids.count,
                desc.cloud_points,
            ]
        )
    out.append(
        _table(
            [
                "name",
                "fingers",
                "finger names",
                "spheres per finger (nsp)",
                "superellipsoids (ne)",
                "cloud points (ng)",
            ],
            rows,
        )
    )
    for kind, title in (("segmenters", "Segmenters"), ("scorers", "Scorers")):
        out.append(f"### {title}\n")
        for r in _builtin(kind):
            out.append(f"#### `{r.name}`\n\n{_doc_summary(r.obj)}\n")
            model = getattr(r.obj, "Options", None)
            fields = {} if model is None else model.model_fields
            if not fields:
                out.append("No options.\n")
                continue
            rows = []
            for key, f in fields.items():
                default = "required" if f.is_required() else _code(_plain(f.default))
                rows.append(
                    [
                        f"`{key}`",
                        f"`{_type_name(f.annotation)}`",
                        default,
                        f.description or "",
                    ]
                )
            out.append(_table(["option", "type", "default", "meaning"], rows))
    return "\n".join(out)


# --------------------------------------------------------------------------------
# the CLI, from its own --help
# --------------------------------------------------------------------------------


def _commands() -> list[tuple[list[str], Any]]:
    """Every visible command and group, by its path of names from the root."""
    import typer

    from wsgrasp.cli import app

    out: list[tuple[list[str], Any]] = []

    def walk(path: list[str], cmd: Any) -> None:
        out.append((path, cmd))
        if hasattr(cmd, "list_commands"):
            ctx = cmd.context_class(cmd)
            for name in cmd.list_commands(ctx):
                sub = cmd.get_command(ctx, name)
                if sub is not None and not sub.hidden:
                    walk([*path, name], sub)

    walk([], typer.main.get_command(app))
    return out


def render_cli() -> str:
    from typer.testing import CliRunner

    from wsgrasp.cli import app

    runner = CliRunner()
    env = {"COLUMNS": "88", "NO_COLOR": "1", "TERM": "dumb"}
    out = []
    for path, _cmd in _commands():
        res = runner.invoke(app, [*path, "--help"], env=env)
        if res.exit_code != 0:
            raise RuntimeError(f"wsgrasp {' '.join(path)} --help: {res.output}")
        title = " ".join(["wsgrasp", *path])
        level = "##" if len(path) <= 1 else "###"
        out.append(f"{level} `{title}`\n\n```text\n{res.output.rstrip()}\n```\n")
    return "\n".join(out)


# --------------------------------------------------------------------------------
# the recording's channels, from a run recorded on a bundled scene
# --------------------------------------------------------------------------------

_recorded: dict[str, Any] = {}


def _record_run() -> dict[str, Any]:
    """Channels, schemas, message counts and attachments of one recorded plan."""
    if _recorded:
        return _recorded
    from mcap.reader import make_reader

    from wsgrasp import Pipeline
    from wsgrasp.record import RunRecorder

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "run.mcap"
        pipe = Pipeline.from_file(ROOT / "examples" / "specs" / "franka.yaml")
        with RunRecorder(path, force=True) as rec:
            pipe.plan(ROOT / "examples" / "scenes" / "mug.npz", observers=[rec])
        with path.open("rb") as f:
            reader = make_reader(f)
            summary = reader.get_summary()
            assert summary is not None
            counts = summary.statistics.channel_message_counts
            channels = []
            for cid, ch in sorted(summary.channels.items()):
                schema = summary.schemas[ch.schema_id]
                channels.append(
                    (
                        ch.topic,
                        schema.name,
                        schema.encoding,
                        ch.message_encoding,
                        counts.get(cid, 0),
                    )
                )
            attachments = [a.name for a in summary.attachment_indexes]
            metadata = [m.name for m in summary.metadata_indexes]
            header = reader.get_header()
    _recorded.update(
        channels=channels,
        attachments=attachments,
        metadata=metadata,
        profile=header.profile,
    )
    return _recorded


def render_channels() -> str:
    run = _record_run()
    rows = []
    order = {"/wsgrasp": 0}
    chans = sorted(run["channels"], key=lambda c: (order.get(c[0][:8], 1), c[0]))
    for topic, schema, enc, msg_enc, n in chans:
        rows.append([f"`{topic}`", f"`{schema}`", f"{enc} / {msg_enc}", n])
    out = [
        f"MCAP profile `{run['profile']}`. Channels of a plan recorded on "
        "`examples/scenes/mug.npz` with `examples/specs/franka.yaml`:\n",
        _table(["topic", "schema", "schema / message encoding", "messages"], rows),
        "Attachments: "
        + ", ".join(f"`{a}`" for a in sorted(set(run["attachments"])))
        + ".\n",
        "Metadata records: "
        + ", ".join(f"`{m}`" for m in sorted(set(run["metadata"])))
        + ".\n",
    ]
    return "\n".join(out)


def render_record_proto() -> str:
    from google.protobuf import descriptor_pb2, text_format

    from wsgrasp.record._codec import DESCRIPTOR_SET

    fds = descriptor_pb2.FileDescriptorSet.FromString(DESCRIPTOR_SET)
    text = "\n".join(text_format.MessageToString(f) for f in fds.file)
    return f"```text\n{text.rstrip()}\n```\n"


def render_record_topics() -> str:
    from wsgrasp.record._codec import FORMAT_VERSION, SCHEMA_NAME, TOPICS

    rows = [[f"`{k}`", f"`{v}`"] for k, v in TOPICS.items()]
    return (
        f"Schema `{SCHEMA_NAME}`, recording format version {FORMAT_VERSION}.\n\n"
        + _table(["record", "topic"], rows)
    )


# --------------------------------------------------------------------------------
# results, from the files runs write under docs/results/
# --------------------------------------------------------------------------------


def _load(path: Path) -> dict[str, Any] | None:
    return json.loads(path.read_text()) if path.is_file() else None


def _provenance(report: dict[str, Any], what: str) -> str:
    commit = report.get("commit") or "not recorded"
    machine = report.get("machine") or "not recorded"
    date = report.get("date") or "not recorded"
    load = report.get("load_average")
    busy = f", load average {load[0]:.1f} as it ended" if load else ""
    return f"From {what} at commit `{commit}` on {machine} ({date}{busy})."


def _eval_grippers_markdown(report: dict[str, Any]) -> str:
    import importlib.util

    path = ROOT / "benchmarks" / "eval_grippers.py"
    spec = importlib.util.spec_from_file_location("_eval_grippers", path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return str(mod.markdown(report))


def render_results_grippers() -> str:
    report = _load(RESULTS / "grippers.json")
    if report is None:
        return (
            "No `docs/results/grippers.json` yet: `make eval-grippers` writes it "
            "(see [Evaluate a gripper](../how-to/evaluate-a-gripper.md)).\n"
        )
    return _eval_grippers_markdown(report)


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
        + _table(["gripper", "trials", "success", "failures"], rows)
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
    labels = [f"{_short(x['gripper'])} · {x['spec']}" for x in res][::-1]
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
    out = [_provenance(report, "`make bench`") + " Medians.\n"]
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
        _table(
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
            _table(
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
            _table(
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


def _short(gripper: str) -> str:
    """A gripper named by a YAML path, by its file's stem."""
    return gripper.rsplit("/", 1)[-1].removesuffix(".yaml")


def _eval_files() -> list[Path]:
    return sorted((RESULTS / "eval").glob("*.json"))


def render_results_eval() -> str:
    files = _eval_files()
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
                f"`{_short(res['gripper'])}`",
                f"`{res['spec']}`",
                res["trials"],
                f"{100 * res['success_rate']:.1f} %",
                _ms(res.get("plan_ms_median")),
                fails or "–",
            ]
            rows.append(row)
        out.append(
            _table(
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
                lo, hi = b.get("ci95") or [None, None]
                brow.append(
                    [
                        f"`{_short(b['gripper'])}`",
                        f"`{b.get('spec', '')}`",
                        f"{100 * b.get('chosen_rate', 0):.1f} %",
                        f"{100 * b.get('random_rate', 0):.1f} %",
                        f"{100 * b.get('difference', 0):+.1f}"
                        + (
                            f" [{100 * lo:+.1f}, {100 * hi:+.1f}]"
                            if lo is not None
                            else ""
                        ),
                    ]
                )
            if brow:
                out.append(
                    _table(
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
    return "\n".join(out)


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
        table = _table(header, rows)
        body = "\n".join("    " + ln if ln else "" for ln in table.splitlines())
        out.append(f'??? note "`{_short(gripper)}`, per object"\n\n{body}\n')
    return "\n".join(out)


def render_default_spec_runs() -> str:
    """The runs the generic default spec was chosen by: success per setting."""
    rows = []
    for path in sorted((RESULTS / "default-spec").glob("*.json")):
        r = json.loads(path.read_text())
        for res in r.get("results", []):
            rows.append(
                [
                    f"`{path.name}`",
                    f"`{r.get('objects')}`",
                    f"`{_short(res['gripper'])}`",
                    f"`{res['spec']}`",
                    res["trials"],
                    f"{100 * res['success_rate']:.0f} %",
                ]
            )
    if not rows:
        return "No runs under `docs/results/default-spec/`.\n"
    return _table(["file", "objects", "gripper", "setting", "trials", "success"], rows)


RENDERERS: dict[str, Callable[[], str]] = {
    "spec": render_spec,
    "gripper-yaml": render_gripper_yaml,
    "plugins": render_plugins,
    "cli": render_cli,
    "channels": render_channels,
    "record-topics": render_record_topics,
    "record-proto": render_record_proto,
    "results-grippers": render_results_grippers,
    "chart-grippers": render_chart_grippers,
    "defaults-success": render_defaults_success,
    "results-bench": render_results_bench,
    "results-eval": render_results_eval,
    "default-spec-runs": render_default_spec_runs,
}

#: generated files: site path -> function giving its bytes (None: not made)
GENERATED: dict[str, Callable[[], bytes | None]] = {
    "results/grippers-success.svg": chart_grippers,
}


def render(markdown: str) -> str:
    """Replace every marker in ``markdown``; an unknown one raises."""

    def one(m: re.Match[str]) -> str:
        name = m.group(1)
        if name not in RENDERERS:
            raise KeyError(
                f"unknown render marker {name!r}; known: {sorted(RENDERERS)}"
            )
        return RENDERERS[name]().rstrip() + "\n"

    return MARKER.sub(one, markdown)


# --------------------------------------------------------------------------------
# MkDocs events
# --------------------------------------------------------------------------------


def on_files(files: Any, config: Any) -> Any:
    from mkdocs.structure.files import File

    for uri, make in GENERATED.items():
        data = make()
        if data is not None:
            files.append(File.generated(config, uri, content=data))
    for path in _eval_files():
        uri = f"results/eval-{path.stem}.svg"
        files.append(File.generated(config, uri, content=chart_eval(path)))
    return files


def on_page_markdown(markdown: str, page: Any, config: Any, files: Any) -> str:
    return render(markdown)
