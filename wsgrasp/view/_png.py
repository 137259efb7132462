"""A recorded run as a PNG from four viewpoints (matplotlib): see
:mod:`wsgrasp.view._run` for what is drawn."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp.view._run import (
    COLOURS,
    DEPTH_AXIS,
    REASON_COLOURS,
    VIEW_NAMES,
    VIEWS,
    RunLayers,
    _focus,
    _sphere_wire,
    run_layers,
)

if TYPE_CHECKING:
    from wsgrasp.record import Run

__all__ = ["render_png"]

Array = NDArray[np.float64]
#: direction the light comes from (world), for shading the gripper's faces
LIGHT = np.array([0.4, -0.6, 0.7]) / np.linalg.norm([0.4, -0.6, 0.7])
#: frame axis colours, x y z
AXIS_COLOURS = ("#e41a1c", "#4daf4a", "#377eb8")


def pyplot() -> Any:
    """matplotlib's ``pyplot`` drawing off screen (the Agg backend, unless one
    was chosen already): pictures are written on machines without a display."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def _shaded(vertices: Array, faces: NDArray[np.int64], colour: str) -> Array:
    """``(F, 4)`` RGBA of each face: ``colour`` lit by :data:`LIGHT`."""
    from matplotlib.colors import to_rgba

    tri = vertices[faces]  # (F, 3 corners, 3)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])  # (F, 3)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    lit = 0.45 + 0.55 * np.abs(n @ LIGHT)  # (F,) two-sided
    rgba = np.tile(to_rgba(colour), (len(faces), 1))
    rgba[:, :3] *= lit[:, None]
    return rgba


def _mesh(
    ax: Any, vertices: Array, faces: NDArray[np.int64], colour: str, alpha: float
) -> None:
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    rgba = _shaded(vertices, faces, colour)
    rgba[:, 3] = alpha
    ax.add_collection3d(
        Poly3DCollection(vertices[faces], facecolors=rgba, edgecolors="none")
    )


def _triad(ax: Any, T: Array, size: float, label: str) -> None:
    """A frame's axes (x red, y green, z blue), each tip lettered, the origin
    named."""
    o = T[:3, 3]
    for k in range(3):
        end = o + T[:3, k] * size
        ax.plot(*np.stack([o, end]).T, color=AXIS_COLOURS[k], lw=2)
        ax.text(*end, "xyz"[k], color=AXIS_COLOURS[k], fontsize=8, weight="bold")
    ax.text(*(o - 0.25 * size * T[:3, 2]), label, fontsize=8, color="0.1")


#: more holding spheres than this are drawn as their centres, not wireframes
MAX_WIREFRAMES = 24


def _panel(ax: Any, L: RunLayers, centre: Array, half: float, k: int) -> None:
    # drawn in this order, not matplotlib's depth guess per collection: the
    # object's points stay visible in front of the gripper's faces
    ax.computed_zorder = False
    near = np.all(np.abs(L.scene - centre) < half, axis=1)
    if not len(L.table) and not len(L.object) and near.any():
        ax.scatter(*L.scene[near].T, s=1, c=COLOURS["scene"], depthshade=False)
    if len(L.table):
        near_t = np.all(np.abs(L.table - centre) < half, axis=1)
        ax.scatter(*L.table[near_t].T, s=1, c=COLOURS["table"], depthshade=False)
    faces = L.shape_faces
    if len(L.shape_pregrasp):
        _mesh(ax, L.shape_pregrasp, faces, COLOURS["gripper_pregrasp"], 0.35)
    if len(L.shape_grasp):
        _mesh(ax, L.shape_grasp, faces, COLOURS["gripper_grasp"], 0.9)
    for reason, verts in L.rejected:
        _mesh(ax, verts, faces, REASON_COLOURS[reason], 0.3)
        top = verts[np.argmax(verts[:, 2])]
        ax.text(
            *top, reason.replace("_", " "), fontsize=7, color=REASON_COLOURS[reason]
        )
    if len(L.obstacles):
        ax.scatter(*L.obstacles.T, s=3, c=COLOURS["obstacles"], depthshade=False)
    if len(L.object):
        ax.scatter(*L.object.T, s=4, c=COLOURS["object"], depthshade=False)
    for code, reason in enumerate(L.reason_names):
        sel = L.reasons == code
        if sel.any():
            ax.scatter(
                *L.candidates[sel].T,
                s=9 if reason == "feasible" else 4,
                c=REASON_COLOURS.get(reason, "0.3"),
                depthshade=False,
                alpha=0.9 if reason == "feasible" else 0.45,
                marker="^" if reason == "feasible" else "o",
            )
    if len(L.directions):
        # one line with a break (NaN) after each stroke: (k, 3, 3) -> (3k, 3)
        gap = np.full((len(L.directions), 1, 3), np.nan)
        strokes = np.concatenate([L.directions, gap], axis=1).reshape(-1, 3)
        ax.plot(*strokes.T, color=COLOURS["directions"], lw=0.4, alpha=0.6)
    if 0 < L.holding.sum() <= MAX_WIREFRAMES:
        for c, r in zip(L.spheres[L.holding], L.radii[L.holding], strict=True):
            ax.plot_wireframe(
                *_sphere_wire(c, float(r)), color=COLOURS["holding"], lw=0.6
            )
    elif L.holding.any():
        ax.scatter(*L.spheres[L.holding].T, s=6, c=COLOURS["holding"], depthshade=False)
    if len(L.contacts):
        ax.scatter(
            *L.contacts.T,
            s=18,
            c=COLOURS["contacts"],
            edgecolors="k",
            linewidths=0.4,
            depthshade=False,
        )
    if len(L.approach):
        a, b = L.approach
        ax.quiver(
            *a, *(b - a), color=COLOURS["approach"], lw=2, arrow_length_ratio=0.25
        )
    if L.T_world_object is not None:
        _triad(ax, L.T_world_object, half * 0.35, "object")
    if L.T_world_ee is not None:
        _triad(ax, L.T_world_ee, half * 0.3, "gripper")
    for i, name in enumerate("xyz"):
        getattr(ax, f"set_{name}lim")(centre[i] - half, centre[i] + half)
        getattr(ax, f"set_{name}label")(f"{name} (m)", fontsize=8)
    ax.tick_params(labelsize=7)
    depth = DEPTH_AXIS[k]
    if depth is not None:  # seen end-on: its ticks would pile up on one spot
        ax.set_proj_type("ortho")
        getattr(ax, f"set_{depth}ticks")([])
        getattr(ax, f"set_{depth}label")("")
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(elev=VIEWS[k][0], azim=VIEWS[k][1])
    ax.set_title(VIEW_NAMES[k], fontsize=10)


def _legend(L: RunLayers) -> list[Any]:
    """One entry for each thing drawn, in its colour; nothing else."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    def dot(colour: str, label: str, marker: str = "o", **kw: Any) -> Line2D:
        return Line2D([], [], ls="", marker=marker, color=colour, label=label, **kw)

    h: list[Any] = []
    if not len(L.table) and not len(L.object) and len(L.scene):
        h.append(dot(COLOURS["scene"], "scene points"))
    if len(L.object):
        h.append(dot(COLOURS["object"], "object"))
    if len(L.table):
        h.append(dot(COLOURS["table"], "table"))
    if len(L.obstacles):
        h.append(dot(COLOURS["obstacles"], "obstacles"))
    for code, reason in enumerate(L.reason_names):
        n = int((L.reasons == code).sum())
        if n:
            label = f"candidate: {reason.replace('_', ' ')} ({n})"
            marker = "^" if reason == "feasible" else "o"
            h.append(dot(REASON_COLOURS.get(reason, "0.3"), label, marker))
    if len(L.directions):
        h.append(
            Line2D(
                [],
                [],
                color=COLOURS["directions"],
                lw=0.8,
                label="feasible approach directions",
            )
        )
    how = "" if L.shape_source != "superellipsoids" else " (body superellipsoids)"
    if len(L.shape_pregrasp):
        h.append(
            Patch(
                color=COLOURS["gripper_pregrasp"],
                alpha=0.5,
                label=f"gripper at pre-grasp, open{how}",
            )
        )
    if len(L.shape_grasp):
        h.append(
            Patch(
                color=COLOURS["gripper_grasp"], label=f"gripper at grasp, closed{how}"
            )
        )
    if len(L.approach):
        h.append(
            Line2D(
                [],
                [],
                color=COLOURS["approach"],
                lw=2,
                marker=">",
                label="approach: pre-grasp → grasp",
            )
        )
    if L.holding.sum() > MAX_WIREFRAMES:
        n = int(L.holding.sum())
        h.append(
            dot(
                COLOURS["holding"],
                f"centres of the workspace spheres holding the object ({n})",
            )
        )
    elif L.holding.any():
        h.append(
            Line2D(
                [],
                [],
                color=COLOURS["holding"],
                lw=1,
                label=f"workspace spheres holding the object ({int(L.holding.sum())})",
            )
        )
    if len(L.contacts):
        h.append(dot(COLOURS["contacts"], "contact points", markeredgecolor="k"))
    seen = set()
    for reason, _ in L.rejected:
        if reason not in seen:
            seen.add(reason)
            h.append(
                Patch(
                    color=REASON_COLOURS[reason],
                    alpha=0.5,
                    label=f"rejected pose: {reason.replace('_', ' ')}",
                )
            )
    if L.T_world_object is not None or L.T_world_ee is not None:
        for k, name in enumerate("xyz"):
            h.append(
                Line2D([], [], color=AXIS_COLOURS[k], lw=2, label=f"frame axis {name}")
            )
    return h


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
    plt = pyplot()
    L = run_layers(run)
    centre, half = _focus(L)
    fig = plt.figure(figsize=(14, 11.5))
    for k in range(len(VIEWS)):
        _panel(fig.add_subplot(2, 2, k + 1, projection="3d"), L, centre, half, k)
    handles = _legend(L)
    fig.legend(handles=handles, loc="lower center", ncol=3, frameon=False, fontsize=9)
    title = L.title + ("" if not L.notes else "\n" + "; ".join(L.notes))
    fig.suptitle(title, fontsize=11)
    rows = -(-len(handles) // 3)  # legend rows, ceil
    fig.tight_layout(rect=(0, 0.025 * rows + 0.01, 1, 0.96))
    out = Path(path)
    fig.savefig(out, dpi=dpi)
    plt.close(fig)
    return out
