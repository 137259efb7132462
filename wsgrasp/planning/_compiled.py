"""The body and finger tests as compiled loops (numba), behind
``wsgrasp.planning.body`` and ``wsgrasp.planning.fingers``: the loops themselves
are plain functions in ``_loops`` (``_count_loop`` counts the points each
finger holds and, when asked, writes the holdings; ``_body_loop`` finds a point
inside a body), run here compiled, or as they are by the tests. One thread: on a
machine shared with other work, numba's thread pools cost more than they gave
(measured on 2 cores under load: the dense entries 20-40 % slower with 2 threads
than with 1).

numba is imported, and the loops loaded from its on-disk cache, only when a
search first asks for them (:func:`load`; when, ``wsgrasp.planning.kernels``
decides)."""

from __future__ import annotations

import importlib.util
import os
import threading
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from wsgrasp.geometry._superellipsoid import _power as superellipsoid_power
from wsgrasp.planning import _loops
from wsgrasp.planning._grids import FingerDepth, NearestPoint
from wsgrasp.planning._loops import _body_loop, _count_loop, _reach_loop
from wsgrasp.planning.poses import MARGIN

__all__ = [
    "count_by_fingers",
    "body_hits",
    "available",
    "load",
    "loaded",
    "reach_loop",
]

Array = NDArray[np.float64]

#: whether numba can be imported (found, and not turned off by WSGRASP_NUMBA=0);
#: it is imported by :func:`load`
_AVAILABLE = (
    os.environ.get("WSGRASP_NUMBA", "1") != "0"
    and importlib.util.find_spec("numba") is not None
)


#: the compiled loops, once :func:`load` has compiled or loaded them
_compiled_count: Callable[..., None] | None = None
_compiled_body: Callable[..., None] | None = None
_compiled_reach: Callable[..., None] | None = None
_LOADING = threading.Lock()  # one thread loads them, the others wait for it


def count_by_fingers(
    depth: FingerDepth,
    Q: Array,
    ol: NDArray[np.int64],
    u: Array,
    loop: Callable[..., None] | None = None,
    perm: NDArray[np.int64] | None = None,
    out: NDArray[np.bool_] | None = None,
    dest: NDArray[np.int64] | None = None,
) -> NDArray[np.int64]:
    """Points each finger's spheres hold, per candidate, and where ``out`` is
    given the holdings themselves.

    Parameters
    ----------
    depth : FingerDepth
    Q : (q, 3, n) float
        Object points per orientation, gripper axes, untranslated; fewer than
        2**16.
    ol : (m,) int
        Each candidate's row of ``Q`` (nondecreasing is fastest).
    u : (m, 3) float
        Each candidate's translation (its points are ``Q[ol] - u``).
    loop : callable, optional
        The loop to run: the compiled one by default, ``_count_loop`` itself in
        tests.
    perm : (n,) int, optional
        Each column's index in ``out``'s point order (by default the same).
    out : (k, n, nf) bool, optional
        Where the holdings go: candidate ``i`` to row ``dest[i]`` (by default
        row ``i``).
    dest : (m,) int, optional

    Returns
    -------
    counts : (m, nf) int
    """
    run = loop or _compiled_count or load()[0]
    _, _, centers, radii = depth.sphere_lists
    codes, of, start, listed, owner = depth.compact_lists
    n = Q.shape[2]
    if n >= 2**16:
        raise ValueError(f"count_by_fingers counts below 2**16 points, got {n}")
    counts = np.zeros((len(ol), depth.num_fingers), dtype=np.int64)
    if out is None:
        out = np.zeros((0, n, depth.num_fingers), dtype=bool)
    if dest is None:
        dest = np.arange(len(ol), dtype=np.int64)
    run(
        np.ascontiguousarray(Q, dtype=np.float64),
        np.ascontiguousarray(ol, dtype=np.int64),
        np.ascontiguousarray(u, dtype=np.float64),
        np.asarray(depth.origin, dtype=np.float64),
        float(1.0 / depth.cell),
        np.asarray(depth.shape - 1, dtype=np.float64),
        np.asarray(depth.strides, dtype=np.float64),
        codes,
        depth.packed_held[of],  # (L, ...) the tables per list code
        depth.held_fingers[of].view(np.uint8),
        len(depth.states),  # the list codes from here on are unsure ones
        start,
        listed,
        owner,
        np.ascontiguousarray(centers, dtype=np.float64),
        np.square(np.asarray(radii, dtype=np.float64)),  # r * r, the same bits
        counts,
        np.ascontiguousarray(np.arange(n) if perm is None else perm, dtype=np.int64),
        out,
        np.ascontiguousarray(dest, dtype=np.int64),
        Q.min(axis=2) if n else np.zeros((len(Q), 3)),  # each row's object box
        Q.max(axis=2) if n else np.zeros((len(Q), 3)),
        # the fingers' boxes as ``poses.clear_of_boxes`` widens them
        np.asarray(depth.box_lo, dtype=np.float64) - MARGIN,
        np.asarray(depth.box_hi, dtype=np.float64) + MARGIN,
    )
    return counts


def body_hits(
    Q: Array,
    ol: NDArray[np.int64],
    u: Array,
    centers: Array,
    semi_axes: Array,
    exponent: float,
    R: Array | None = None,
    hints: NearestPoint | None = None,
    loop: Callable[..., None] | None = None,
) -> NDArray[np.bool_]:
    """Whether some object point lies inside some body superellipsoid, per
    candidate (``Q``, ``ol``, ``u`` as in :func:`count_by_fingers`): (m,) bool.

    With ``hints`` (the object points' :class:`~wsgrasp.planning._grids.
    NearestPoint` grid) and ``R`` (q, 3, 3), the rotations whose axes ``Q`` is
    in, the point near each body's centre is tried first; the answers are the
    same."""
    run = loop or _compiled_body or load()[1]
    hit = np.zeros(len(ol), dtype=bool)
    if hints is None or R is None:
        R = np.zeros((Q.shape[0], 3, 3))
        grid = (np.zeros(3), 1.0, np.zeros(3), np.zeros(3), np.zeros(0, np.int32))
    else:
        grid = hints.arrays()
    run(
        np.ascontiguousarray(Q, dtype=np.float64),
        np.ascontiguousarray(ol, dtype=np.int64),
        np.ascontiguousarray(u, dtype=np.float64),
        np.ascontiguousarray(centers, dtype=np.float64),
        np.ascontiguousarray(semi_axes, dtype=np.float64),
        float(exponent),
        np.ascontiguousarray(R, dtype=np.float64),
        *grid,
        hit,
    )
    return hit


def available() -> bool:
    """Whether the compiled loops can be used (numba importable and not turned
    off by ``WSGRASP_NUMBA=0``); they are loaded by :func:`load`."""
    return _AVAILABLE


def loaded() -> bool:
    """Whether the compiled loops are loaded in this process."""
    return _compiled_count is not None and _compiled_body is not None


def load() -> tuple[Callable[..., None], Callable[..., None]]:
    """Import numba and compile the loops, or load them from numba's cache
    beside this file: the count loop and the body loop. Once per process; raises
    RuntimeError naming the fix when numba cannot be used."""
    global _compiled_count, _compiled_body
    with _LOADING:
        if _compiled_count is not None and _compiled_body is not None:
            return _compiled_count, _compiled_body
        if not _AVAILABLE:
            raise RuntimeError(
                "numba cannot be imported (or WSGRASP_NUMBA=0 turns it off): "
                "pip install numba, or unset WSGRASP_NUMBA"
            )
        import numba

        # the body loop reads _power as a global when numba compiles it
        _loops._power = numba.njit(inline="always")(superellipsoid_power)
        _compiled_count = numba.njit(cache=True, nogil=True)(_count_loop)
        _compiled_body = numba.njit(cache=True, nogil=True)(_body_loop)
        return _compiled_count, _compiled_body


def reach_loop() -> Callable[..., None] | None:
    """The closing sweeps' reach test compiled (``_loops._reach_loop``), in a
    process that has loaded the loops (:func:`load`; compiled or read from
    numba's cache on the first call), else None: numpy's (``sweeps``) runs."""
    global _compiled_reach
    if not loaded():
        return None
    with _LOADING:
        if _compiled_reach is None:
            import numba

            _compiled_reach = numba.njit(cache=True, nogil=True)(_reach_loop)
        return _compiled_reach
