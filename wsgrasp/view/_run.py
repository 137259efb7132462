"""A recorded run as a picture: scene, table, object, candidates coloured by why
they were rejected, and the chosen gripper with the spheres that hold the object,
from a few viewpoints (matplotlib)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from wsgrasp.record import Run

__all__ = ["RunLayers", "run_layers", "render_png", "REASON_COLOURS"]

Array = NDArray[np.float64]

#: colour of each candidate outcome (the same as the Foxglove channels)
#: feasible approach directions drawn at most
MAX_DIRECTIONS = 150
REASON_COLOURS: dict[str, str] = {
    "feasible": "#1abf33",
    "table_collision": "#8c5926",
    "object_collision": "#e52626",
    "obstacle_collision": "#9933bf",
    "finger_without_contact": "#8c99b2",
}
#: (elevation, azimuth) in degrees, and the panel titles
VIEWS = ((25.0, -60.0), (0.0, -90.0), (0.0, 0.0), (89.0, -90.0))
VIEW_NAMES = ("perspective", "front (from -y)", "side (from +x)", "top")
#: at most this many scene points are drawn
MAX_SCENE_POINTS = 6000


@dataclass
class RunLayers:
    """What is drawn of a run, world frame.

    Attributes
    ----------
    scene : (n, 3) float
        Downsampled scene (or the inputs), thinned for drawing.
    table, object : (m, 3) float
    obstacles : (k, 3) float
    samples : (ns, 3) float
        Bounding-box sample points.
    candidates : (C, 3) float
        Candidate positions (gripper-workspace centroids).
    reasons : (C,) int
        Code into ``reason_names`` of each candidate.
    gripper : (ng, 3) float
        The gripper cloud at the chosen pose (empty if none).
    spheres, radii : (S, 3), (S,) float
        Workspace spheres at the chosen pose.
    holding : (S,) bool
        Spheres holding object points.
    contacts : (q, 3) float
    T_world_object, T_world_ee : (4, 4) float or None
    approach : (2, 3) float
        Pre-grasp and grasp origins of the chosen pose (empty if none).
    directions : (k, 2, 3) float
        Short strokes along the approach of the feasible candidates.
    """

    scene: Array
    table: Array
    object: Array
    obstacles: Array
    samples: Array
    candidates: Array
    reasons: NDArray[np.int64]
    reason_names: tuple[str, ...]
    gripper: Array
    spheres: Array
    radii: Array
    holding: NDArray[np.bool_]
    contacts: Array
    T_world_object: Array | None
    T_world_ee: Array | None
    title: str
    notes: list[str] = field(default_factory=list)
    approach: Array = field(default_factory=lambda: np.zeros((0, 3)))
    directions: Array = field(default_factory=lambda: np.zeros((0, 2, 3)))


def _pts(x: Any) -> Array:
    if x is None:
        return np.zeros((0, 3))
    if isinstance(x, list):
        parts = [np.asarray(p, dtype=np.float64).reshape(-1, 3) for p in x]
        return np.concatenate(parts) if parts else np.zeros((0, 3))
    return np.asarray(x, dtype=np.float64).reshape(-1, 3)


def _thin(points: Array, n: int) -> Array:
    if len(points) <= n:
        return points
    idx = np.linspace(0, len(points) - 1, n).astype(np.int64)
    return points[idx]


def run_layers(run: Run) -> RunLayers:
    """Collect the drawable layers of a run (also of a truncated one)."""
    from wsgrasp.errors import RecordingError
    from wsgrasp.planning.result import REASONS

    notes: list[str] = []
    pre = run.stages.get("preprocess", {})
    seg = run.stages.get("segmentation", {})
    frame = run.stages.get("object_frame", {})
    if "points" in pre:
        scene = _pts(pre["points"])
    elif run.inputs is not None:
        scene = _pts(run.inputs["points"])
    else:
        scene = np.zeros((0, 3))
    cs = run.candidates
    if cs is not None and len(cs):
        cands = np.asarray(cs.T_world_gwc)[:, :3, 3]  # (C, 3)
        reasons = np.asarray(cs.reason, dtype=np.int64)
    else:
        cands, reasons = np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
    res = run.result
    gripper_pts = np.zeros((0, 3))
    spheres, radii = np.zeros((0, 3)), np.zeros(0)
    holding = np.zeros(0, dtype=bool)
    contacts = np.zeros((0, 3))
    T_ee = None
    if res is not None and res.found and res.T_world_ee is not None:
        T_ee = np.asarray(res.T_world_ee, dtype=np.float64)
        try:
            g = run.gripper
        except RecordingError:
            notes.append("no gripper model in the file")
        else:
            R, t = T_ee[:3, :3], T_ee[:3, 3]
            gripper_pts = np.asarray(g.cloud) @ R.T + t  # (ng, 3)
            spheres = np.asarray(g.sphere_centers) @ R.T + t  # (S, 3)
            radii = np.asarray(g.sphere_radii, dtype=np.float64)
            holding = np.zeros(len(spheres), dtype=bool)
            for c in res.contacts:
                holding[np.asarray(c.spheres, dtype=np.int64)] = True
        contacts = _pts([c.points for c in res.contacts])
    if run.truncated:
        notes.append("truncated: missing " + (", ".join(run.missing) or "the index"))
    if run.error is not None:
        notes.append(f"failed: {run.error.get('type')}: {run.error.get('message')}")
    status = (
        "grasp found"
        if res is not None and res.found
        else ("no grasp found" if res is not None else run.status)
    )
    T_obj = frame.get("T_world_object")
    approach = np.zeros((0, 3))
    if res is not None and T_ee is not None and res.T_world_pregrasp is not None:
        approach = np.stack([np.asarray(res.T_world_pregrasp)[:3, 3], T_ee[:3, 3]])
    directions = np.zeros((0, 2, 3))
    obj = _pts(seg.get("object_points"))
    if cs is not None and len(cs) and len(obj):
        ok = np.flatnonzero(np.asarray(cs.reason) == 0)
        ok = ok[:: max(1, len(ok) // MAX_DIRECTIONS)]
        T = np.asarray(cs.T_world_gwc)[ok]  # (k, 4, 4)
        stroke = 0.25 * float(np.ptp(obj, axis=0).max())
        directions = np.stack([T[:, :3, 3] - stroke * T[:, :3, 2], T[:, :3, 3]], 1)
    mode = None if res is None else res.info.get("sampling_mode")
    if res is not None and mode:
        notes.append(
            f"sampling {mode}: {res.info.get('orientations')} orientations, "
            f"{len(cands)} candidates"
        )
    return RunLayers(
        scene=_thin(scene, MAX_SCENE_POINTS),
        table=_thin(_pts(seg.get("table_points")), MAX_SCENE_POINTS // 2),
        object=obj,
        obstacles=_pts(seg.get("obstacles")),
        samples=_pts(frame.get("samples_world")),
        candidates=cands,
        reasons=reasons,
        reason_names=tuple(REASONS),
        gripper=gripper_pts,
        spheres=spheres,
        radii=radii,
        holding=holding,
        contacts=contacts,
        T_world_object=None if T_obj is None else np.asarray(T_obj, dtype=np.float64),
        T_world_ee=T_ee,
        title=f"{run.path.name}: {status}",
        notes=notes,
        approach=approach,
        directions=directions,
    )


def _focus(layers: RunLayers) -> tuple[Array, float]:
    """Centre and half-size of the drawn box: around the object and the gripper."""
    parts = [p for p in (layers.object, layers.gripper, layers.samples) if len(p)]
    if not parts:
        parts = [layers.scene] if len(layers.scene) else [np.zeros((1, 3))]
    pts = np.concatenate(parts)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    return (lo + hi) / 2.0, max(float((hi - lo).max()) / 2.0 * 1.3, 0.05)


def _sphere_wire(c: Array, r: float, n: int = 10) -> tuple[Array, Array, Array]:
    u = np.linspace(0, 2 * np.pi, n)
    v = np.linspace(0, np.pi, n // 2 + 1)
    x = c[0] + r * np.outer(np.cos(u), np.sin(v))
    y = c[1] + r * np.outer(np.sin(u), np.sin(v))
    z = c[2] + r * np.outer(np.ones_like(u), np.cos(v))
    return x, y, z


def render_png(run: Run, path: str | Path, *, dpi: int = 100) -> Path:
    """Draw a run from four viewpoints into a PNG.

    Parameters
    ----------
    run
        From :func:`wsgrasp.record.open_run`.
    path
        Output ``.png``.
    dpi
        Resolution.

    Returns
    -------
    Path
        The file written.
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    L = run_layers(run)
    centre, half = _focus(L)
    fig = plt.figure(figsize=(14, 11))
    for i, ((elev, azim), name) in enumerate(zip(VIEWS, VIEW_NAMES, strict=True)):
        ax: Any = fig.add_subplot(2, 2, i + 1, projection="3d")
        # only what lies near the object is drawn: the scene can be much larger
        near = np.all(np.abs(L.scene - centre) < half, axis=1)
        ax.scatter(*L.scene[near].T, s=1, c="0.75", depthshade=False, alpha=0.5)
        if len(L.table):
            near_t = np.all(np.abs(L.table - centre) < half, axis=1)
            ax.scatter(*L.table[near_t].T, s=1, c="#a08060", depthshade=False)
        if len(L.obstacles):
            ax.scatter(*L.obstacles.T, s=2, c="#e08020", depthshade=False)
        if len(L.object):
            ax.scatter(*L.object.T, s=3, c="#1f66e5", depthshade=False)
        if len(L.candidates):
            for code, reason in enumerate(L.reason_names):
                sel = L.reasons == code
                if sel.any():
                    ax.scatter(
                        *L.candidates[sel].T,
                        s=10 if reason == "feasible" else 5,
                        c=REASON_COLOURS.get(reason, "0.3"),
                        depthshade=False,
                        alpha=0.9 if reason == "feasible" else 0.5,
                    )
        if len(L.gripper):
            ax.scatter(*L.gripper.T, s=2, c="0.25", depthshade=False, alpha=0.6)
            for c, r in zip(L.spheres[L.holding], L.radii[L.holding], strict=True):
                ax.plot_wireframe(*_sphere_wire(c, float(r)), color="#10c030", lw=0.5)
            idle = ~L.holding
            ax.scatter(*L.spheres[idle].T, s=4, c="#4d99ff", depthshade=False)
            T = L.T_world_ee
            if T is not None:
                for k, col in enumerate(("r", "g", "b")):
                    end = T[:3, 3] + T[:3, k] * half * 0.4
                    ax.plot(*np.stack([T[:3, 3], end]).T, color=col, lw=2)
        if len(L.contacts):
            ax.scatter(*L.contacts.T, s=8, c="#10c030", depthshade=False)
        if len(L.directions):
            # one line with a break (NaN) after each stroke: (k, 3, 3) -> (3k, 3)
            gap = np.full((len(L.directions), 1, 3), np.nan)
            strokes = np.concatenate([L.directions, gap], axis=1).reshape(-1, 3)
            ax.plot(*strokes.T, color=REASON_COLOURS["feasible"], lw=0.4)
        if len(L.approach):
            ax.plot(*L.approach.T, color="#d02090", lw=2, ls="--")
        for k in range(3):
            getattr(ax, f"set_{'xyz'[k]}lim")(centre[k] - half, centre[k] + half)
        ax.set_box_aspect((1, 1, 1))
        ax.view_init(elev=elev, azim=azim)
        ax.set_title(name)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_zlabel("z (m)")
    handles = [
        Line2D([], [], ls="", marker="o", color="#1f66e5", label="object"),
        Line2D([], [], ls="", marker="o", color="#a08060", label="table"),
        *(
            Line2D(
                [],
                [],
                ls="",
                marker="o",
                color=REASON_COLOURS.get(r, "0.3"),
                label=f"{r.replace('_', ' ')} ({int((L.reasons == c).sum())})",
            )
            for c, r in enumerate(L.reason_names)
            if (L.reasons == c).any()
        ),
        Line2D([], [], ls="", marker="o", color="0.25", label="gripper (chosen)"),
        Line2D([], [], ls="-", color="#10c030", label="spheres holding the object"),
        *(
            [Line2D([], [], ls="--", color="#d02090", label="approach from pre-grasp")]
            if len(L.approach)
            else []
        ),
        *(
            [
                Line2D(
                    [],
                    [],
                    ls="-",
                    lw=0.6,
                    color=REASON_COLOURS["feasible"],
                    label="feasible approach directions",
                )
            ]
            if len(L.directions)
            else []
        ),
    ]
    fig.legend(handles=handles, loc="lower center", ncol=4, frameon=False)
    title = L.title + ("" if not L.notes else "\n" + "; ".join(L.notes))
    fig.suptitle(title)
    fig.tight_layout(rect=(0, 0.05, 1, 0.97))
    out = Path(path)
    fig.savefig(out, dpi=dpi)
    plt.close(fig)
    return out
