"""Scenes a careless user hands the planner, for ``test_bad_input.py`` and
``test_fuzz.py``: a table with nothing on it but its own edges, and objects far
larger than a gripper encloses."""

from __future__ import annotations

import numpy as np


def table_slab(
    rng: np.random.Generator,
    *,
    size: tuple[float, float] = (0.8, 0.8),
    thickness: float = 0.02,
    step: float = 0.004,
    noise: float = 0.0005,
    sides: tuple[bool, bool, bool, bool] = (True, True, True, True),
    fold: float = 0.0,
) -> np.ndarray:
    """A table top ``size`` (m) with its top at z = 0, seen from above: the top
    face on a grid of ``step`` and the side faces ``thickness`` deep (those of
    ``sides``: -x, +x, -y, +y), and with ``fold`` > 0 a cloth hanging that far
    down over the +x edge. Points ``(n, 3)``, world frame, z up."""
    hx, hy = size[0] / 2.0, size[1] / 2.0
    u = np.arange(-hx, hx + 1e-9, step)
    v = np.arange(-hy, hy + 1e-9, step)
    X, Y = np.meshgrid(u, v)  # (len(v), len(u)) each
    parts = [np.column_stack([X.ravel(), Y.ravel(), np.zeros(X.size)])]
    z = np.arange(-thickness, 0.0, step)
    for k, on in enumerate(sides):
        if not on:
            continue
        along = v if k < 2 else u
        A, Z = np.meshgrid(along, z)
        edge = np.full(A.size, (hx if k < 2 else hy) * (1 if k % 2 else -1))
        if k < 2:
            parts.append(np.column_stack([edge, A.ravel(), Z.ravel()]))
        else:
            parts.append(np.column_stack([A.ravel(), edge, Z.ravel()]))
    if fold > 0.0:
        A, Z = np.meshgrid(v, np.arange(-fold, 0.0, step))
        # the cloth hangs a little outside the edge, in a gentle wave
        x = hx + 0.01 + 0.005 * np.sin(A.ravel() * 25.0)
        parts.append(np.column_stack([x, A.ravel(), Z.ravel()]))
    p = np.concatenate(parts)
    return p + rng.normal(0.0, noise, p.shape)


def noisy_box(
    rng: np.random.Generator,
    size: tuple[float, float, float],
    *,
    table: float,
    step: float = 0.005,
    noise: float = 0.003,
    yaw: float = 0.0,
) -> np.ndarray:
    """A box ``size`` (m) standing on a square table ``table`` (m) wide, seen
    from above: the table around its footprint, its top and its four sides on a
    grid of ``step``, depth noise ``noise`` (m) on every point, turned ``yaw``
    about z. Points ``(n, 3)``, world frame, z up."""
    sx, sy, sz = size
    h = table / 2.0
    t = np.arange(-h, h + 1e-9, step * 2.0)
    X, Y = np.meshgrid(t, t)
    floor = np.column_stack([X.ravel(), Y.ravel(), np.zeros(X.size)])
    c, s = np.cos(yaw), np.sin(yaw)
    local = floor[:, :2] @ np.array([[c, -s], [s, c]])  # world xy → box xy
    floor = floor[(np.abs(local) > [sx / 2 + step, sy / 2 + step]).any(axis=1)]
    faces = []
    u = np.arange(-sx / 2, sx / 2 + 1e-9, step)
    v = np.arange(-sy / 2, sy / 2 + 1e-9, step)
    w = np.arange(step, sz + 1e-9, step)
    A, B = np.meshgrid(u, v)
    faces.append(np.column_stack([A.ravel(), B.ravel(), np.full(A.size, sz)]))
    for sign in (-1.0, 1.0):
        A, Z = np.meshgrid(v, w)
        faces.append(
            np.column_stack([np.full(A.size, sign * sx / 2), A.ravel(), Z.ravel()])
        )
        A, Z = np.meshgrid(u, w)
        faces.append(
            np.column_stack([A.ravel(), np.full(A.size, sign * sy / 2), Z.ravel()])
        )
    box = np.concatenate(faces)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    p = np.concatenate([floor, box @ R.T])
    return p + rng.normal(0.0, noise, p.shape)
