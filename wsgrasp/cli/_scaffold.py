"""``wsgrasp gripper``: scaffold a gripper plugin from a URDF, check a gripper
(``_grippers`` adds ``list`` and ``show`` to the group)."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.markup import escape

from wsgrasp.cli._common import console, err_console, print_json

gripper_app = typer.Typer(
    help="Gripper models: list and draw them, scaffold a plugin from a URDF, "
    "check a model.",
    no_args_is_help=True,
    rich_markup_mode=None,
)


def register(app: typer.Typer) -> None:
    """Add this module's commands to ``app``."""
    app.add_typer(gripper_app, name="gripper")


@gripper_app.command("new")
def new(
    name: str = typer.Argument(..., help="Gripper (and distribution) name."),
    urdf: Path = typer.Option(
        ..., "--urdf", help="The gripper's URDF, or a xacro file (.urdf.xacro)."
    ),
    out: Path = typer.Option(..., "--out", "-o", help="Folder for the plugin package."),
    base_link: str | None = typer.Option(
        None, "--base-link", help="Link the arm holds (default: the URDF's root)."
    ),
    mesh_dir: list[Path] = typer.Option(
        [], "--mesh-dir", help="Extra folder to look for meshes in (repeatable)."
    ),
    mesh_units: str | None = typer.Option(
        None, "--mesh-units", help="Units of the mesh files: m, cm or mm."
    ),
    package_path: list[Path] = typer.Option(
        [],
        "--package-path",
        help="Folder holding ROS packages, for package:// URIs, like "
        "ROS_PACKAGE_PATH (repeatable).",
    ),
    xacro_arg: list[str] = typer.Option(
        [],
        "--xacro-arg",
        help="NAME:=VALUE for a xacro file's <xacro:arg> (repeatable).",
    ),
    force: bool = typer.Option(False, "--force", help="Write into a non-empty --out."),
    independent_jaws: bool = typer.Option(
        False,
        "--independent-jaws",
        help="Leave two mirrored jaws that the URDF drives apart as they are "
        "(by default they are made to move together, as one drive moves a "
        "parallel gripper's jaws).",
    ),
    close_past: float = typer.Option(
        0.0,
        "--close-past",
        help="Where the fingers close only to where their pads meet, close on "
        "until the pads have travelled this much more (m, e.g. 0.06): for a hand "
        "whose pads pass each other without meeting, to compare in `wsgrasp eval` "
        "(`wsgrasp gripper tune` tries the joints' limits for you).",
    ),
) -> None:
    """Write a pip-installable plugin package for a gripper, guessed from its URDF
    (or a xacro file, expanded first: the `xacro` extra)."""
    from wsgrasp.gripper._scaffold_urdf import xacro_args
    from wsgrasp.gripper.scaffold import scaffold_plugin

    with err_console.status(f"scaffolding {name} from {urdf.name}"):
        yaml_path, scaffold = scaffold_plugin(
            name,
            urdf,
            out,
            base_link=base_link,
            mesh_dirs=list(mesh_dir),
            mesh_units=mesh_units,
            force=force,
            package_paths=list(package_path),
            xacro_args=xacro_args(list(xacro_arg)),
            couple_jaws=not independent_jaws,
            close_past=close_past,
        )
    d = scaffold.data
    fingers = ", ".join(
        f"{f['name']} [{', '.join(map(str, f['joints']))}]" for f in d["fingers"]
    )
    kp = (d.get("drive") or {}).get("kp_revolute")
    drive = f"; finger drive in simulation {kp:g} N·m/rad" if kp is not None else ""
    console.print(
        f"[green]wrote[/] {escape(str(out))}/ : plugin package {escape(repr(name))} "
        + escape(
            f"({len(d['fingers'])} fingers: {fingers}; base {d['base_link']}, "
            f"approach {d['approach_axis']}, closing {d['closing_axis']}{drive})"
        ),
        highlight=False,
    )
    for w in scaffold.warnings:
        console.print(w, style="yellow", highlight=False, markup=False)
    if scaffold.build_error is not None:
        err_console.print(
            f"[bold red]error:[/] the guessed model does not build: "
            f"{escape(scaffold.build_error)} (the package is written; fix "
            f"{yaml_path} and run `wsgrasp gripper check {yaml_path}`)",
            highlight=False,
            soft_wrap=True,
        )
        raise typer.Exit(2)
    console.print(
        f"next: read the guesses in {yaml_path}, then\n"
        f"  wsgrasp gripper check {yaml_path} -o {name}.png\n"
        f"  wsgrasp gripper tune {yaml_path}    # how it closes, by grasp trials\n"
        f"  pip install -e {out}    # then `gripper: {name}` in a spec",
        highlight=False,
    )


@gripper_app.command("check")
def check(
    name: str = typer.Argument(..., help="Registered gripper name or gripper YAML."),
    output: Path | None = typer.Option(
        None, "--out", "-o", "--output", help="Also draw the model into this PNG."
    ),
    as_json: bool = typer.Option(False, "--json", help="Print JSON."),
    rebuild: bool = typer.Option(False, "--rebuild", help="Ignore cached models."),
    cache_dir: Path | None = typer.Option(
        None, "--cache-dir", help="Model cache (default: $WSGRASP_CACHE_DIR)."
    ),
) -> None:
    """Build a gripper model and report what to trust and what to fix.

    Exits with status 1 when the report has errors.
    """
    from wsgrasp.gripper.check import check_gripper

    with err_console.status(f"checking gripper {name}") as status:

        def progress(label: str) -> None:
            if label:
                status.update(label)

        report = check_gripper(
            name, rebuild=rebuild, cache_dir=cache_dir, progress=progress
        )
    if output is not None:
        from wsgrasp.view import render_gripper

        render_gripper(report.model, output)
    if as_json:
        data = report.to_dict()
        data["picture"] = str(output) if output is not None else None
        print_json(data)
    else:
        for line in report.format().splitlines():
            style = (
                "red"
                if line.startswith("error")
                else "yellow"
                if line.startswith("warning")
                else None
            )
            console.print(
                line, style=style, highlight=False, soft_wrap=True, markup=False
            )
        if output is not None:
            console.print(f"[green]wrote[/] {output}", highlight=False)
    if report.errors:
        raise typer.Exit(1)
