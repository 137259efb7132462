"""Reference pages' tables, generated from the code: the spec and gripper YAML
fields (pydantic models), the built-in plugins and their options (the registry),
the command line (its own --help) and the recording's channels (a run recorded on
a bundled scene)."""

from __future__ import annotations

import tempfile
import typing
from pathlib import Path
from typing import Any

from docs_tables import code, doc_summary, plain, table, type_name

ROOT = Path(__file__).resolve().parents[2]


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
                default = code(plain(value))
            else:
                default = code(plain(f.default))
            nested = _models_in(f.annotation)
            if nested and isinstance(f.default, nested[0]):
                default = "its fields' defaults"
            desc = f.description or ""
            if nested and not desc:
                desc = doc_summary(nested[0])
            limits = _limits(f)
            rows.append(
                [
                    f"`{name}`",
                    f"`{type_name(f.annotation)}`",
                    default,
                    desc + (f" ({limits})" if limits else ""),
                ]
            )
            for sub in nested:
                todo.append((f"{path}.{name}" if path else name, sub))
        title = f"`{path}`" if path else model.__name__
        out.append(f"### {title}\n\n{doc_summary(model)}\n")
        out.append(table(["field", "type", "default", "meaning"], rows))
    return "\n".join(out)


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
        table(
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
            out.append(f"#### `{r.name}`\n\n{doc_summary(r.obj)}\n")
            model = getattr(r.obj, "Options", None)
            fields = {} if model is None else model.model_fields
            if not fields:
                out.append("No options.\n")
                continue
            rows = []
            for key, f in fields.items():
                default = "required" if f.is_required() else code(plain(f.default))
                rows.append(
                    [
                        f"`{key}`",
                        f"`{type_name(f.annotation)}`",
                        default,
                        f.description or "",
                    ]
                )
            out.append(table(["option", "type", "default", "meaning"], rows))
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
        table(["topic", "schema", "schema / message encoding", "messages"], rows),
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
        + table(["record", "topic"], rows)
    )
