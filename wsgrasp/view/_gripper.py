"""A gripper model as a picture, like Fig. 1 of the paper: the gripper cloud, the
body superellipsoids as wireframes and each finger's workspace spheres in its own
colour, from several viewpoints."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from wsgrasp.geometry import superellipsoid_surface
from wsgrasp.gripper.model import GripperModel

#: finger colours in the paper's order (red, green, blue, grey), then more; none
#: purple (the superellipsoids) nor near black (the cloud)
FINGER_COLOURS = (
    "tab:red",
    "tab:green",
    "tab:blue",
    "tab:gray",
    "tab:orange",
    "tab:brown",
    "tab:pink",
    "tab:olive",
    "tab:cyan",
)
#: (elevation, azimuth) in degrees of the default viewpoints
VIEWS = ((20.0, -60.0), (0.0, 0.0), (0.0, -90.0), (90.0, -90.0))
VIEW_NAMES = ("perspective", "from +x", "from -y", "from +z")
#: points drawn on each sphere's surface (a Fibonacci lattice)
SPHERE_POINTS = 40


def finger_colour(f: int) -> tuple[float, float, float, float]:
    """Finger ``f``'s colour, RGBA: :data:`FINGER_COLOURS`, then hues a golden
    ratio of a turn apart (no two fingers alike, whatever their number)."""
    from matplotlib import colormaps
    from matplotlib.colors import to_rgba

    if f < len(FINGER_COLOURS):
        return to_rgba(FINGER_COLOURS[f])
    hue = (f - len(FINGER_COLOURS)) * 0.6180339887 % 1.0
    return tuple(colormaps["hsv"](hue))  # type: ignore[return-value]


def _sphere_directions(n: int) -> np.ndarray:
    """``(n, 3)`` unit vectors spread evenly over the sphere."""
    i = np.arange(n) + 0.5
    phi = np.arccos(1.0 - 2.0 * i / n)
    theta = np.pi * (1.0 + 5**0.5) * i
    return np.stack(
        [np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)],
        axis=1,
    )


def render_gripper(
    model: GripperModel,
    path: str | Path,
    *,
    views: tuple[tuple[float, float], ...] = VIEWS,
    dpi: int = 110,
) -> Path:
    """Draw ``model`` from several viewpoints into a PNG.

    Parameters
    ----------
    model
        The gripper model.
    path
        Output file (PNG).
    views
        ``(elevation, azimuth)`` pairs in degrees, one panel each.
    dpi
        Resolution.

    Returns
    -------
    Path
        The file written.
    """
    from wsgrasp.view._png import pyplot

    plt = pyplot()
    dirs = _sphere_directions(SPHERE_POINTS)  # (P, 3)
    # sphere surface points: (S, 1, 3) + (S, 1, 1) * (1, P, 3) -> (S, P, 3)
    shells = (
        model.sphere_centers[:, None, :]
        + model.sphere_radii[:, None, None] * dirs[None, :, :]
    )
    surfaces = [
        superellipsoid_surface(c, a, model.se_exponent, n_around=20, n_height=10)
        for c, a in zip(model.se_centers, model.se_semi_axes, strict=True)
    ]
    everything = np.concatenate([model.cloud, shells.reshape(-1, 3)])
    lo, hi = everything.min(axis=0), everything.max(axis=0)
    mid, half = 0.5 * (lo + hi), 0.5 * float(np.max(hi - lo)) * 1.05

    n = len(views)
    cols = 2 if n > 1 else 1
    rows = int(np.ceil(n / cols))
    fig = plt.figure(figsize=(5.2 * cols, 5.0 * rows))
    for k, (elev, azim) in enumerate(views):
        ax: Any = fig.add_subplot(rows, cols, k + 1, projection="3d")
        c = model.cloud
        ax.scatter(c[:, 0], c[:, 1], c[:, 2], s=3, c="0.15", alpha=0.8, linewidths=0)
        for X, Y, Z in surfaces:
            ax.plot_wireframe(X, Y, Z, color="tab:purple", linewidth=0.4, alpha=0.5)
        for f, name in enumerate(model.finger_names):
            pts = shells[model.sphere_finger == f].reshape(-1, 3)
            ax.scatter(
                pts[:, 0],
                pts[:, 1],
                pts[:, 2],
                s=1.5,
                c=[finger_colour(f)],
                alpha=0.5,
                linewidths=0,
                label=name if k == 0 else None,
            )
        gwc = model.T_gripper_gwc
        for axis_i, colour in enumerate(("r", "g", "b")):
            tip = gwc[:3, 3] + 0.03 * gwc[:3, axis_i]
            ax.plot(*zip(gwc[:3, 3], tip, strict=True), color=colour, linewidth=1.5)
        ax.set_xlim(mid[0] - half, mid[0] + half)
        ax.set_ylim(mid[1] - half, mid[1] + half)
        ax.set_zlim(mid[2] - half, mid[2] + half)
        ax.set_box_aspect((1, 1, 1))
        ax.view_init(elev=elev, azim=azim)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_zlabel("z (m)")
        ax.tick_params(labelsize=6)
        title = VIEW_NAMES[k] if views is VIEWS else f"elev {elev:g}, azim {azim:g}"
        ax.set_title(title, fontsize=9)
        if k == 0:
            ax.legend(loc="upper left", fontsize=7, markerscale=4)
    counts = ", ".join(str(c) for c in model.spheres_per_finger)
    fig.suptitle(
        f"{model.name}: cloud {len(model.cloud)} points, {len(model.se_centers)} "
        f"superellipsoids (l={model.se_exponent:g}), spheres per finger {counts}",
        fontsize=10,
    )
    fig.tight_layout()
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=dpi)
    plt.close(fig)
    return out
