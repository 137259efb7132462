"""``wsgrasp scene``: synthetic scenes and a look at what perception makes of a
scene."""

from __future__ import annotations

from pathlib import Path

import typer

from wsgrasp.cli._common import (
    DEPTH_SCALE_HELP,
    INTRINSICS_HELP,
    console,
    intrinsics_of,
    number,
    print_json,
)

scene_app = typer.Typer(
    help="Scenes: render synthetic ones, inspect segmentation.",
    no_args_is_help=True,
    rich_markup_mode=None,
)


def register(app: typer.Typer) -> None:
    """Add this module's commands to ``app``."""
    app.add_typer(scene_app, name="scene")


def _floats(text: str | None, what: str) -> list[float] | None:
    from wsgrasp.errors import InputError

    if not text:
        return None
    try:
        return [float(v) for v in text.replace(" ", "").split(",") if v]
    except ValueError:
        raise InputError(
            f"{what} {text!r} is not a comma-separated list of numbers",
            hint=f"e.g. {what} 0.06,0.08,0.16",
        ) from None


def _lens(text: str | None, depth_images: bool) -> tuple[str, list[float]] | None:
    """``--lens MODEL:C1,C2,...`` checked: the model and its coefficients."""
    from pydantic import ValidationError

    from wsgrasp.errors import InputError
    from wsgrasp.perception.depth import DISTORTION_MODELS, Intrinsics

    if text is None:
        return None
    if not depth_images:
        raise InputError(
            "--lens bends the depth images, and needs --depth-images",
            hint="add --depth-images --views-out DIR",
        )
    model, _, rest = text.partition(":")
    try:
        coefficients = [float(c) for c in rest.split(",") if c.strip()]
        Intrinsics(
            fx=1.0,
            fy=1.0,
            cx=0.0,
            cy=0.0,
            distortion_model=model,
            distortion=coefficients,
        )
    except (ValueError, ValidationError):
        raise InputError(
            f"--lens {text!r} is not a distortion model and its coefficients",
            hint="give MODEL:C1,C2,... with MODEL one of "
            + ", ".join(
                f"{m} ({' or '.join(map(str, n))} coefficients)"
                for m, n in DISTORTION_MODELS.items()
            )
            + ", e.g. --lens plumb_bob:-0.28,0.09,0.0012,-0.0008,-0.012",
        ) from None
    return model, coefficients


@scene_app.command("synth")
def synth(
    out: Path = typer.Option(
        ..., "--out", "-o", help="Merged cloud (.npz, .ply, .pcd, .xyz)."
    ),
    obj: str = typer.Option(
        "box",
        "--object",
        help="box, cylinder, cone, ring, sphere, or a mesh file (metres).",
    ),
    size: str | None = typer.Option(
        None,
        "--size",
        help="Comma-separated sizes (m): box x,y,z; cylinder/cone r,h; "
        "ring r_in,r_out,h; sphere r.",
    ),
    pose: str = typer.Option("upright", "--pose", help="upright, lying or random."),
    views: int = typer.Option(3, "--views", min=1, max=64, help="Number of cameras."),
    noise: float = typer.Option(
        0.001, "--noise", callback=number(0.0, 0.1), help="Depth noise std (m)."
    ),
    flying: float = typer.Option(
        0.0,
        "--flying",
        callback=number(0.0, 1.0),
        help="Share (0-1) of the pixels along depth edges that come back as "
        "flying pixels, hanging between an object's outline and the surface "
        "behind it.",
    ),
    seed: int = typer.Option(0, "--seed", help="Random seed."),
    table_size: float = typer.Option(
        0.6,
        "--table-size",
        callback=number(0.0, 10.0, above=True),
        help="Table side (m).",
    ),
    width: int = typer.Option(
        320, "--width", min=8, max=8192, help="Image width (px)."
    ),
    height: int = typer.Option(
        240, "--height", min=8, max=8192, help="Image height (px)."
    ),
    distance: float = typer.Option(
        0.55,
        "--distance",
        callback=number(0.0, 20.0, above=True),
        help="Camera distance (m).",
    ),
    elevation: float = typer.Option(
        45.0,
        "--elevation",
        callback=number(0.0, 90.0, above=True),
        help="Camera elevation above the table (deg).",
    ),
    views_out: Path | None = typer.Option(
        None,
        "--views-out",
        help="Also write each view in its camera frame and a scene.yaml here.",
    ),
    depth_images: bool = typer.Option(
        False,
        "--depth-images",
        help="With --views-out, write the views as depth images (16-bit PNG, "
        "millimetres) with their intrinsics instead of clouds.",
    ),
    lens: str | None = typer.Option(
        None,
        "--lens",
        metavar="MODEL:C1,C2,...",
        help="With --depth-images, write each view as the raw image of a camera "
        "whose lens bends it (MODEL plumb_bob, rational_polynomial or "
        "equidistant; coefficients in OpenCV's order), listed with that "
        "distortion, e.g. plumb_bob:-0.28,0.09,0.0012,-0.0008,-0.012.",
    ),
    camera_frame: bool = typer.Option(
        False,
        "--camera-frame",
        help="Express everything in the first camera's frame (table tilted).",
    ),
    as_json: bool = typer.Option(False, "--json", help="Print a JSON summary."),
) -> None:
    """Render an object on a table from virtual depth cameras."""
    from wsgrasp.errors import InputError
    from wsgrasp.perception.io import save_cloud, write_scene_yaml
    from wsgrasp.perception.synth import synth_scene

    if pose not in ("upright", "lying", "random"):
        raise InputError(
            f"--pose {pose!r} is unknown, expected upright, lying or random",
            hint="pass --pose upright",
        )
    scene = synth_scene(
        obj,
        size=_floats(size, "--size"),
        pose=pose,  # type: ignore[arg-type]
        views=views,
        noise=noise,
        flying=flying,
        seed=seed,
        table_size=table_size,
        width=width,
        height=height,
        distance=distance,
        elevation_deg=elevation,
        camera_frame=camera_frame,
    )
    save_cloud(out, scene.points)
    if depth_images and views_out is None:
        raise InputError(
            "--depth-images writes the views, and needs --views-out",
            hint="add --views-out DIR",
        )
    distortion = _lens(lens, depth_images)
    yaml_path = (
        write_scene_yaml(
            views_out,
            scene.views,
            cameras=scene.cameras if depth_images else None,
            lens=distortion,
        )
        if views_out
        else None
    )
    counts = [int(v.points.shape[0]) for v in scene.views]
    summary = {
        "out": str(out),
        "points": int(scene.points.shape[0]),
        "views": counts,
        "frame": "camera 0" if camera_frame else "world (z up)",
        "T_world_object": scene.T_world_mesh,
        "table_normal": scene.table.normal,
        "table_offset": scene.table.offset,
        "scene_yaml": str(yaml_path) if yaml_path else None,
    }
    if as_json:
        print_json(summary)
        return
    console.print(
        f"wrote {out}: {summary['points']} points from {len(scene.views)} views "
        f"({', '.join(map(str, counts))}), frame {summary['frame']}"
    )
    if yaml_path:
        console.print(f"wrote {yaml_path} and {len(scene.views)} view files")


@scene_app.command("info")
def info(
    clouds: list[Path] = typer.Argument(
        ..., help="Cloud files, a depth image with --intrinsics, or one scene YAML."
    ),
    spec: Path | None = typer.Option(
        None, "--spec", "-s", help="Pipeline spec (segmenter, preprocess, target)."
    ),
    registered: bool = typer.Option(
        False, "--registered", help="Several clouds already share one frame."
    ),
    icp: bool = typer.Option(False, "--icp", help="Refine view poses with ICP."),
    intrinsics: str | None = typer.Option(
        None, "--intrinsics", metavar="FX,FY,CX,CY|FILE", help=INTRINSICS_HELP
    ),
    depth_scale: float | None = typer.Option(
        None, "--depth-scale", callback=number(0.0, above=True), help=DEPTH_SCALE_HELP
    ),
    as_json: bool = typer.Option(False, "--json", help="Print JSON."),
) -> None:
    """Load a scene and show the table plane, objects and object frame found."""
    import time

    from wsgrasp.perception.frame import object_frame
    from wsgrasp.perception.io import load_scene
    from wsgrasp.perception.process import preprocess, select_target, thin
    from wsgrasp.perception.sides import mirror_hidden
    from wsgrasp.plugins import get_registry
    from wsgrasp.spec import PipelineSpec, load_spec

    ps = (
        load_spec(spec)
        if spec
        else PipelineSpec.model_validate({"gripper": "franka_hand"})
    )
    from wsgrasp._open3d import load_open3d

    load_open3d()  # imported before timing starts

    entry = get_registry().get("segmenters", ps.segmenter.name)
    options = entry.obj.Options.model_validate(ps.segmenter.options)
    timing: dict[str, float] = {}
    t = time.perf_counter()

    def lap(stage: str) -> None:
        nonlocal t
        now = time.perf_counter()
        timing[stage] = round((now - t) * 1e3, 2)
        t = now

    scene = load_scene(
        clouds,
        icp=icp or ps.preprocess.icp,
        registered=registered,
        intrinsics=intrinsics_of(intrinsics),
        depth_scale=depth_scale,
    )
    lap("load")
    points, flying = preprocess(scene, ps.preprocess)
    lap("downsample")
    seg = entry.obj().segment(points, options, seed=ps.seed)
    lap("segment")
    obj_points, obstacles = select_target(seg, ps.target)
    seen = len(obj_points)
    if ps.object_frame.mirror_hidden:  # as a plan with this spec does
        obj_points = mirror_hidden(obj_points, seg.table.normal, scene.viewpoints())
    mirrored = len(obj_points) - seen
    obj_points = thin(obj_points, ps.preprocess.max_object_points, ps.seed)
    frame = object_frame(obj_points, ps.object_frame.method)
    lap("object_frame")
    # with the views' poses the world is the robot's or the room's, whose z is
    # usually up: the table's tilt from it shows a wrong pose
    tilt_deg = scene.table_tilt(seg.table.normal)
    summary = {
        "points": int(scene.points.shape[0]),
        "dropped_nonfinite": scene.dropped_nonfinite,
        "dropped_no_depth": scene.dropped_no_depth,
        "posed": tilt_deg is not None,
        "flying_pixels": len(flying),
        "downsampled": int(points.shape[0]),
        "table_normal": seg.table.normal,
        "table_offset": seg.table.offset,
        "table_points": int(seg.table_points.shape[0]),
        "depth_noise": seg.info.get("depth_noise"),
        "clusters": [int(c.shape[0]) for c in seg.clusters],
        "object_points": int(obj_points.shape[0]),
        "mirrored_points": mirrored,
        "obstacles": len(obstacles),
        "T_world_object": frame.T_world_object,
        "extents": frame.extents,
        "timing_ms": timing,
    }
    if as_json:
        print_json(summary)
        return
    n = seg.table.normal
    tilt = "" if tilt_deg is None else f", {tilt_deg:.1f}° from the world's z axis"
    console.print(
        f"{summary['points']} points ({scene.dropped_nonfinite} non-finite and "
        f"{scene.dropped_no_depth} without depth (0, 0, 0) dropped, "
        f"{len(flying)} flying pixels), {summary['downsampled']} after voxel "
        f"{ps.preprocess.voxel_size:g} m"
    )
    noise = summary["depth_noise"]
    scatter = "" if noise is None else f", depth noise {1e3 * float(noise):.1f} mm"
    console.print(
        f"table: normal ({n[0]:.3f}, {n[1]:.3f}, {n[2]:.3f}), offset "
        f"{seg.table.offset:.4f} m{tilt}, {summary['table_points']} points{scatter}"
    )
    hidden = (
        f" (of {seen} seen and {mirrored} mirrored in for the sides no camera saw)"
        if mirrored
        else ""
    )
    console.print(
        f"objects: {len(seg.clusters)} ({', '.join(map(str, summary['clusters']))} "
        f"points); target {obj_points.shape[0]} points{hidden}, "
        f"{len(obstacles)} obstacles"
    )
    e = frame.extents
    console.print(
        f"object frame ({frame.method}): centroid "
        f"{tuple(round(float(v), 4) for v in frame.centroid)}, extents "
        f"{e[0]:.3f} x {e[1]:.3f} x {e[2]:.3f} m"
    )
    console.print(
        "timing (ms): " + ", ".join(f"{k} {v:.1f}" for k, v in timing.items())
    )
