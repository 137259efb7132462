"""``wsgrasp plan``, ``wsgrasp demo`` and ``wsgrasp bench``."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import typer
from rich.table import Table

from wsgrasp.cli._common import (
    DEPTH_SCALE_HELP,
    INTRINSICS_HELP,
    console,
    err_console,
    intrinsics_of,
    number,
    print_json,
)
from wsgrasp.errors import InputError


def register(app: typer.Typer) -> None:
    app.command("plan")(plan)
    app.command("demo")(demo)
    app.command("bench")(bench)


def _pose_text(T: np.ndarray) -> str:
    from wsgrasp.planning.result import translation_quaternion

    pose = translation_quaternion(T)
    xyz, q = pose["translation"], pose["quaternion_xyzw"]
    return (
        f"xyz [{xyz[0]:+.4f}, {xyz[1]:+.4f}, {xyz[2]:+.4f}] m, "
        f"q_xyzw [{q[0]:+.4f}, {q[1]:+.4f}, {q[2]:+.4f}, {q[3]:+.4f}]"
    )


def print_result(result: Any, title: str = "plan") -> None:
    """A rich summary of a ``PlanResult``."""
    table = Table(title=title, show_header=False)
    table.add_column("", style="bold")
    table.add_column("")
    table.add_row("gripper", result.gripper)
    if result.found:
        table.add_row("found", "[green]yes[/]")
        table.add_row("T_world_ee", _pose_text(result.T_world_ee))
        table.add_row("T_world_tcp", _pose_text(result.T_world_tcp))
        if result.T_world_pregrasp is not None:
            table.add_row("T_world_pregrasp", _pose_text(result.T_world_pregrasp))
        if result.joints_grasp:
            table.add_row(
                "joints",
                ", ".join(
                    f"{j} {result.joints_pregrasp[j]:+.3f} -> {v:+.3f}"
                    for j, v in result.joints_grasp.items()
                )
                + "  (pregrasp -> grasp)",
            )
        table.add_row(
            "score",
            f"{result.score:.4f} = "
            + " + ".join(f"{k} {v:.3f}" for k, v in result.score_terms.items()),
        )
        table.add_row(
            "contacts",
            ", ".join(
                f"{c.finger}: {len(c.points)} pts / {len(c.spheres)} spheres"
                for c in result.contacts
            ),
        )
    else:
        table.add_row("found", "[red]no[/]")
        table.add_row("why", result.hint)
    n = len(result.candidates)
    mode = result.info.get("sampling_mode")
    table.add_row(
        "candidates",
        (f"{mode}: {result.info.get('orientations')} orientations; " if mode else "")
        + f"{n} evaluated, {int(result.candidates.feasible.sum())} feasible; rejected: "
        + ", ".join(f"{k} {v}" for k, v in result.rejections.items() if v),
    )
    fallback = result.info.get("fallback")
    if fallback is not None:
        table.add_row(
            "fallback",
            "the spec's sampling found no grasp ("
            + (
                ", ".join(
                    str(v) if k == "too_large" else f"{k} {v}"
                    for k, v in fallback["first_search"].items()
                )
                or "no candidate"
            )
            + "); these are sampling.fallback's",
        )
    table.add_row(
        "timing",
        ", ".join(f"{k} {v:.1f} ms" for k, v in result.timing_ms.items()),
    )
    for warning in result.warnings:
        table.add_row("[yellow]warning[/]", warning)
    console.print(table)


def _observers(
    spec: Any,
    gripper_name: str,
    record: Path | None,
    no_record: bool,
    force: bool,
    inputs: list[Path],
) -> tuple[list[Any], Path | None]:
    if no_record or (record is None and not spec.record.enabled):
        return [], None
    from wsgrasp.record import RunRecorder, default_run_path
    from wsgrasp.record._writer import check_record_path

    path = record if record is not None else default_run_path(spec, gripper_name)
    check_record_path(path, force=force, inputs=inputs)
    return [RunRecorder(path, force=force)], path


def plan(
    clouds: list[Path] = typer.Argument(
        ...,
        help="Cloud files (PLY, PCD, XYZ, NPY/NPZ), a depth image with "
        "--intrinsics, a scene YAML, or a ROS 2 bag.",
    ),
    spec_file: Path | None = typer.Option(
        None,
        "--spec",
        "-s",
        help="Pipeline spec file; without it, the default spec of --gripper.",
    ),
    gripper: str | None = typer.Option(
        None,
        "--gripper",
        "-g",
        help="Registered gripper name or gripper YAML, in place of the spec's.",
    ),
    record: Path | None = typer.Option(
        None, "--record", help="Write the run's MCAP recording here."
    ),
    no_record: bool = typer.Option(False, "--no-record", help="Do not record."),
    force: bool = typer.Option(
        False, "--force", help="Overwrite an existing recording at --record."
    ),
    registered: bool = typer.Option(
        False, "--registered", help="Several clouds already share one frame."
    ),
    intrinsics: str | None = typer.Option(
        None, "--intrinsics", metavar="FX,FY,CX,CY|FILE", help=INTRINSICS_HELP
    ),
    depth_scale: float | None = typer.Option(
        None, "--depth-scale", callback=number(0.0, above=True), help=DEPTH_SCALE_HELP
    ),
    topic: str | None = typer.Option(
        None,
        "--topic",
        help="PointCloud2 or depth Image topic, when the input is a ROS 2 bag.",
    ),
    frame: str | None = typer.Option(
        None, "--frame", help="World frame of the bag's /tf tree."
    ),
    at: float | None = typer.Option(
        None,
        "--at",
        callback=number(),
        help="Bag time (s) to plan at; the latest cloud by default.",
    ),
    choose: int | None = typer.Option(
        None,
        "--choose",
        min=0,
        help=(
            "Take this feasible candidate (an index, as in the alternatives of a "
            "plan on the same scene) as the grasp instead of the best-scored one."
        ),
    ),
    as_json: bool = typer.Option(False, "--json", help="Print the result as JSON."),
) -> None:
    """Plan a grasp on a scene, with a spec file, a gripper's default spec
    (--gripper without --spec), or a spec file with its gripper replaced (both).
    Each recording is linked from latest.mcap beside it."""
    from wsgrasp.api import Pipeline
    from wsgrasp.perception.io import load_scene

    spec = plan_spec(spec_file, gripper)
    if record is not None and no_record:
        raise InputError(
            "--record and --no-record were both given", hint="choose one of them"
        )
    bag = len(clouds) == 1 and clouds[0].suffix.lower() == ".mcap"
    if bag:
        from wsgrasp.perception.bag import read_bag_scene

        if topic is None:
            raise InputError(
                f"{clouds[0]} is an MCAP file: planning on a ROS 2 bag needs --topic",
                hint="pass --topic /camera/points (a PointCloud2 topic) or "
                "--topic /camera/depth/image_rect_raw (a depth Image topic)",
            )
        if intrinsics is not None or depth_scale is not None:
            raise InputError(
                "--intrinsics and --depth-scale are for depth image files; a bag's "
                "depth images take theirs from the camera_info beside them",
                hint="drop --intrinsics and --depth-scale",
            )
        scene = read_bag_scene(clouds[0], topic, frame=frame, at=at)
    else:
        scene = load_scene(
            clouds,
            icp=spec.preprocess.icp,
            registered=registered,
            intrinsics=intrinsics_of(intrinsics),
            depth_scale=depth_scale,
        )
    pipeline = Pipeline(spec)
    observers, path = _observers(
        spec, pipeline.gripper.name, record, no_record, force, list(clouds)
    )
    result = pipeline.plan(scene, observers=observers, choose=choose)
    if as_json:
        data = result.to_json()
        data["recording"] = None if path is None else str(path)
        print_json(data)
    else:
        print_result(result)
    for o in observers:  # the writer thread finishes the file meanwhile
        o.close()
    if path is not None:
        link = link_latest(path)
        if not as_json:
            console.print(
                f"recorded to {path}" + (f" (linked from {link})" if link else ""),
                highlight=False,
            )


def plan_spec(spec_file: Path | None, gripper: str | None) -> Any:
    """The spec ``plan`` runs: the file, with its gripper replaced by ``gripper``
    when given; with no file, the gripper's default spec (the one it ships as
    ``specs/default.yaml`` beside its YAML, else wsgrasp's generic default; the
    one ``wsgrasp eval`` uses, see :mod:`wsgrasp.default_specs`)."""
    from wsgrasp._loading import load_document
    from wsgrasp.spec import load_spec

    if spec_file is None and gripper is None:
        raise typer.BadParameter(
            "give a spec file (--spec FILE) or a gripper (--gripper NAME), or both",
            param_hint="--spec / --gripper",
        )
    if gripper is None:
        return load_spec(spec_file)  # type: ignore[arg-type]
    from wsgrasp._names import gripper_ref
    from wsgrasp.default_specs import default_spec

    if spec_file is None:
        data, _ = default_spec(gripper)
        source = None
    else:
        # every problem of the file, with its lines, but its gripper's (a name
        # not installed here, files not found): that gripper is replaced
        spec = load_spec(spec_file, check_gripper=False)
        data, _ = load_document(spec_file)
        source = spec.source
    replaced = load_spec({**data, "gripper": gripper_ref(gripper, Path.cwd())})
    replaced._source = source
    return replaced


#: name of the link to the newest recording, in the folder of each recording
LATEST = "latest.mcap"


def link_latest(path: Path) -> Path | None:
    """Point ``latest.mcap`` beside ``path`` at it (a relative symbolic link,
    replaced atomically); None where a real file of that name is there (it is
    a recording of its own, never replaced) or links cannot be made."""
    import os

    link = path.parent / LATEST
    if path.name == LATEST or (link.exists() and not link.is_symlink()):
        return None
    tmp = path.parent / f".{LATEST}.{os.getpid()}"
    try:
        tmp.unlink(missing_ok=True)
        tmp.symlink_to(path.name)
        os.replace(tmp, link)
    except OSError:
        tmp.unlink(missing_ok=True)
        return None
    return link


def demo(
    out: Path = typer.Option(Path("demo"), "--out", "-o", help="Output directory."),
) -> None:
    """Build both grippers, plan with each on a bundled scene, write pictures and
    recordings."""
    from wsgrasp.api import Pipeline
    from wsgrasp.bench import project_root
    from wsgrasp.perception.io import load_scene
    from wsgrasp.spec import load_spec

    root = project_root()
    out.mkdir(parents=True, exist_ok=True)
    scene_path = root / "examples" / "scenes" / "box_upright.npz"
    scene = load_scene([scene_path])
    from wsgrasp.record import RunRecorder
    from wsgrasp.view import render_gripper, render_run

    for name, spec_name in (("franka_hand", "franka"), ("allegro_right", "allegro")):
        spec = load_spec(root / "examples" / "specs" / f"{spec_name}.yaml")
        with console.status(f"building the {name} model (cached after the first run)"):
            pipeline = Pipeline(spec)
        gripper_png = out / f"{name}_model.png"
        render_gripper(pipeline.gripper, gripper_png)
        run_path = out / f"{name}.mcap"
        recorder = RunRecorder(run_path, force=True)
        result = pipeline.plan(scene, observers=[recorder])
        print_result(result, title=f"{name} on {scene_path.name}")
        recorder.close()
        picture = render_run(run_path, out / f"{name}_grasp.png")
        page = render_run(run_path, out / f"{name}_grasp.html")
        console.print(
            f"wrote {gripper_png}, {run_path}, {picture} and {page}", highlight=False
        )


def bench(
    as_json: bool = typer.Option(False, "--json", help="Print JSON."),
    repeat: int = typer.Option(
        15, min=1, help="Runs per median (the search alone: seven times as many)."
    ),
    scaling: bool = typer.Option(True, help="Also measure the scaling table."),
) -> None:
    """Time the whole plan, the search and the loop-by-loop reference (medians)."""
    from wsgrasp.bench import run_bench

    with console.status("benchmarking") as status:
        res = run_bench(
            repeat=repeat, scaling=scaling, progress=lambda m: status.update(m)
        )
    if as_json:
        from wsgrasp._version import library_versions

        print_json(
            {**res.rows, "scaling": res.scaling, "libraries": library_versions()}
        )
        return
    t = Table(title="wsgrasp bench (medians, ms)")
    cols = [
        "plan_ms",
        "preprocess_ms",
        "segmentation_ms",
        "object_frame_ms",
        "search_ms",
        "reference_search_ms",
        "speedup",
        "paper_plan_ms",
    ]
    t.add_column("gripper")
    for c in cols:
        t.add_column(c.replace("_ms", ""), justify="right")
    for g, row in res.rows.items():
        t.add_row(g, *(f"{row.get(c, float('nan')):.1f}" for c in cols))
    console.print(t)
    if res.scaling:
        s = Table(title="search scaling (medians, ms)")
        for c in ("gripper", "samples", "orientations", "candidates", "object points"):
            s.add_column(c, justify="right")
        s.add_column("search ms", justify="right")
        for r in res.scaling:
            s.add_row(
                r["gripper"],
                str(r["samples"]),
                str(r["orientations"]),
                str(r["samples"] * r["orientations"]),
                str(r["object_points"]),
                f"{r['search_ms']:.1f}",
            )
        console.print(s)
    err_console.print("timings are medians on this machine; see `wsgrasp bench --json`")
