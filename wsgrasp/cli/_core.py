"""Commands about the installation itself: plugins, schemas, spec checking."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer
from rich import box
from rich.markup import escape
from rich.table import Table

from wsgrasp.cli._common import console, err_console, print_json

spec_app = typer.Typer(
    help="Pipeline spec files.", no_args_is_help=True, rich_markup_mode=None
)


def register(app: typer.Typer) -> None:
    app.command("plugins")(plugins)
    app.command("schema")(schema)
    app.add_typer(spec_app, name="spec")


def plugins(
    as_json: bool = typer.Option(False, "--json", help="Print JSON."),
    options: bool = typer.Option(
        False, "--options", help="Also list each segmenter's and scorer's options."
    ),
) -> None:
    """List every plugin: distribution, version, what it registers, and failures."""
    from wsgrasp.plugins import get_registry

    reg = get_registry()
    if options:
        _print_options(reg, as_json)
        return
    summary = reg.plugin_summary()
    failed = [
        {
            "name": f.plugin.name,
            "distribution": f.plugin.distribution,
            "version": f.plugin.version,
            "error": f.error,
        }
        for f in reg.failed
    ]
    if as_json:
        print_json({"plugins": summary, "failed": failed})
        return
    # one row per kind a plugin registers, each distribution named once (in
    # the caption): the built-ins are three plugins of one distribution
    table = Table(title="wsgrasp plugins", box=box.SIMPLE_HEAD, pad_edge=False)
    table.add_column("kind", no_wrap=True)
    table.add_column("names")
    table.add_column("plugin", no_wrap=True)
    for p in summary:
        for kind in ("grippers", "segmenters", "scorers"):
            names = p["provides"].get(kind, [])
            if names:
                table.add_row(kind, ", ".join(names), p["name"])
    dists = dict.fromkeys(f"{p['distribution']} {p['version']}" for p in summary)
    table.caption = "from " + ", ".join(dists) if dists else "no plugins"
    console.print(table)
    for f in failed:
        console.print(
            f"[red]failed:[/] {f['name']} ({f['distribution']} {f['version']}): "
            f"{f['error']}"
        )


def _print_options(reg: Any, as_json: bool) -> None:
    """The options of every segmenter and scorer: name, type, default, meaning."""
    rows: dict[str, dict[str, list[dict[str, Any]]]] = {}
    for kind in ("segmenters", "scorers"):
        for name in reg.names(kind):
            model = getattr(reg.get(kind, name).obj, "Options", None)
            fields = [] if model is None else model.model_fields.items()
            rows.setdefault(kind, {})[name] = [
                {
                    "option": key,
                    "type": getattr(f.annotation, "__name__", str(f.annotation)),
                    "default": None if f.is_required() else f.get_default(),
                    "description": f.description or "",
                }
                for key, f in fields
            ]
    if as_json:
        print_json(rows)
        return
    for kind, plugins in rows.items():
        for name, fields in plugins.items():
            console.print(f"[bold]{kind[:-1]} {name}[/]", highlight=False)
            if not fields:
                console.print("  (no options)")
            for f in fields:
                console.print(
                    f"  {f['option']}: {f['type']} = {f['default']!r}"
                    + (f"  {f['description']}" if f["description"] else ""),
                    highlight=False,
                    markup=False,
                )


def schema(
    out: Path = typer.Option(Path("schemas"), "--out", "-o", help="Directory."),
) -> None:
    """Write the JSON Schemas of pipeline specs and gripper descriptions."""
    from wsgrasp.spec import write_schemas

    for p in write_schemas(out):
        console.print(f"wrote {p}")


@spec_app.command("check")
def spec_check(
    file: Path = typer.Argument(..., help="Spec file (YAML/TOML/JSON)."),
) -> None:
    """Validate a pipeline spec, including its plugins' options, and list every
    problem in it at once. Exits 2 when there are problems, as ``plan`` does
    on the same file."""
    from wsgrasp.cli._spec_check import spec_problems
    from wsgrasp.spec import load_spec

    problems = spec_problems(file)
    if problems:
        for text in problems:
            err_console.print(
                f"[bold red]error:[/] {escape(text)}", highlight=False, soft_wrap=True
            )
        n = len(problems)
        err_console.print(
            f"{file}: {n} problem{'s' if n > 1 else ''}; the keys and their types "
            "are in schemas/pipeline.schema.json, a plugin's options in "
            "`wsgrasp plugins --options`",
            highlight=False,
            soft_wrap=True,
        )
        raise typer.Exit(2)
    spec = load_spec(file)
    console.print(
        f"[green]ok[/] {file}: gripper {spec.gripper}, segmenter "
        f"{spec.segmenter.name}, scorers "
        + ", ".join(f"{s.name}×{s.weight:g}" for s in spec.scorers),
        highlight=False,
    )
