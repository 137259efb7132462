"""Commands about the installation itself: plugins, schemas, spec checking."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.table import Table

from wsgrasp.cli._common import console, print_json

spec_app = typer.Typer(help="Pipeline spec files.", no_args_is_help=True)


def register(app: typer.Typer) -> None:
    app.command("plugins")(plugins)
    app.command("schema")(schema)
    app.add_typer(spec_app, name="spec")


def plugins(
    as_json: bool = typer.Option(False, "--json", help="Print JSON."),
) -> None:
    """List every plugin: distribution, version, what it registers, and failures."""
    from wsgrasp.plugins import get_registry

    reg = get_registry()
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
    table = Table(title="wsgrasp plugins")
    for col in (
        "plugin",
        "distribution",
        "version",
        "grippers",
        "segmenters",
        "scorers",
    ):
        table.add_column(col)
    for p in summary:
        table.add_row(
            p["name"],
            p["distribution"],
            p["version"],
            *(
                ", ".join(p["provides"].get(k, []))
                for k in ("grippers", "segmenters", "scorers")
            ),
        )
    console.print(table)
    for f in failed:
        console.print(
            f"[red]failed:[/] {f['name']} ({f['distribution']} {f['version']}): "
            f"{f['error']}"
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
    """Validate a pipeline spec, including its plugins' options."""
    from wsgrasp.spec import load_spec

    spec = load_spec(file)
    console.print(
        f"[green]ok[/] {file}: gripper {spec.gripper}, segmenter "
        f"{spec.segmenter.name}, scorers "
        + ", ".join(f"{s.name}×{s.weight:g}" for s in spec.scorers)
    )
