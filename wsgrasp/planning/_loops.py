"""The body and finger tests as plain loops, which numba compiles
(:mod:`wsgrasp.planning._compiled` loads them): ``_count_loop``, per candidate
and object point, the depth grid's verdict at the nearest node
(``_grids.FingerDepth``) and, for a finger it leaves unsure, the spheres listed
at that node, with the arithmetic of ``FingerDepth.holding_coordinates``;
``_body_loop``, per candidate, whether some object point lies inside a body
superellipsoid, with the arithmetic of ``coordinates_in_superellipsoids``;
``_reach_loop``, per candidate, whether a finger's closing sweep reaches an
object point in time, with the arithmetic of ``sweeps._reached_first``.
Plain Python functions, so tests hold their logic to the reference with or
without numba."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from wsgrasp.geometry._superellipsoid import _power as superellipsoid_power

Array = NDArray[np.float64]


def _count_loop(
    Q: Array,
    ol: NDArray[np.int64],
    u: Array,
    d_origin: Array,
    d_inv_cell: float,
    d_last: Array,
    d_strides: Array,
    d_codes: NDArray[np.integer],
    packed: NDArray[np.int64],
    held_f: NDArray[np.uint8],
    n_plain: int,
    start: NDArray[np.int32],
    listed: NDArray[np.int32],
    owner: NDArray[np.int32],
    centers: Array,
    radii2: Array,
    counts: NDArray[np.int64],
    perm: NDArray[np.int64],
    held: NDArray[np.bool_],
    dest: NDArray[np.int64],
    q_lo: Array,
    q_hi: Array,
    box_lo: Array,
    box_hi: Array,
) -> None:  # pragma: no cover - run compiled, or by the tests on tiny inputs
    """``counts[i, f]``: the points of candidate ``i`` (``Q[ol[i], :, j] -
    u[i]``) strictly inside a sphere of finger ``f`` (any number of fingers,
    fewer than 2**16 points). Where ``held`` has rows, also the holdings
    themselves: ``held[dest[i], perm[j], f]`` for point ``j`` (``perm``: each
    column's index in the caller's point order).

    The depth grid's list code at each point's nearest node decides first
    (``FingerDepth.compact_lists``; the tables per list code, ``(L, ...)``):
    ``packed[code, w]`` holds finger ``f``'s held bit at bit ``16 (f % 4)``
    of word ``w = f // 4``, so one sum per word counts four fingers;
    ``held_f`` (L, nf) the fingers it proves to hold the point; a code from
    ``n_plain`` on leaves some open (``compact_lists`` numbers the nodes unsure
    for some finger from there: a compare instead of a third table, the
    Allegro hand's dense count 234 -> 226 ms).
    For those, the entries ``start[code]``
    to ``start[code + 1]`` (a sphere ``listed`` of finger ``owner`` each)
    decide, with the arithmetic of ``FingerDepth.holding_coordinates``:
    their bits go to the same words (a finger is never both held and unsure
    at a node, so a lane still counts below 2**16).

    Per candidate, three loops: the nearest nodes of its points (from the
    points in node units, once per row of ``Q``, less the translation in node
    units: about 1e-14 of a node from ``(Q - u - origin) / cell``, far inside
    the grid's margin); their codes, noting the unsure points without a
    branch; then the unsure points' entries, one loop over them whatever
    fingers they are for. The code names the entries, so an unsure point
    reads no per-node table (a lookup in 10 MB of node starts took 40 % of
    the Allegro's dense count loop, a branch per finger another 20 %).

    First, a candidate whose object box (its row's extremes ``q_lo``,
    ``q_hi`` (q, 3), less ``u``) lies below ``box_lo[f]`` or above
    ``box_hi[f]`` along some axis, for every finger ``f`` (the fingers'
    sphere boxes, widened by the caller's margin), holds nothing: its counts
    stay 0 and its holdings are written false, with no point looked up."""
    m = ol.shape[0]
    n = Q.shape[2]
    nf = counts.shape[1]
    words = packed.shape[1]
    Qn = np.empty((3, n))  # the row's points in node units, offset half a node
    node = np.empty(n, dtype=np.int64)
    unsure = np.empty(n, dtype=np.int64)
    ucode = np.empty(n, dtype=np.int64)  # their codes, kept: 13 % less time
    first = np.ascontiguousarray(packed[:, 0])  # (L,) fingers 0-3
    more = np.zeros(words, dtype=np.int64)  # the words past the first
    got = np.zeros(words, dtype=np.int64)  # one unsure point's held bits
    prev = -1
    keep = held.shape[0] > 0
    for i in range(m):
        r = ol[i]
        if r != prev:
            for k in range(3):
                for j in range(n):
                    Qn[k, j] = (Q[r, k, j] - d_origin[k]) * d_inv_cell + 0.5
            prev = r
        ux, uy, uz = u[i, 0], u[i, 1], u[i, 2]
        near = False  # some finger's box meets the candidate's object box
        for f in range(nf):
            apart = False
            for k in range(3):
                uk = ux if k == 0 else (uy if k == 1 else uz)
                if q_lo[r, k] - uk > box_hi[f, k] or q_hi[r, k] - uk < box_lo[f, k]:
                    apart = True
            if not apart:
                near = True
        if not near:
            if keep:
                for j in range(n):
                    for f in range(nf):
                        held[dest[i], perm[j], f] = False
            continue
        vx, vy, vz = ux * d_inv_cell, uy * d_inv_cell, uz * d_inv_cell
        for j in range(n):  # clipped onto the border, far from every sphere
            nx = min(max(np.floor(Qn[0, j] - vx), 0.0), d_last[0])
            ny = min(max(np.floor(Qn[1, j] - vy), 0.0), d_last[1])
            nz = min(max(np.floor(Qn[2, j] - vz), 0.0), d_last[2])
            node[j] = int(nx * d_strides[0] + ny * d_strides[1] + nz * d_strides[2])
        total = np.int64(0)  # the first word: fingers 0-3
        for w in range(1, words):
            more[w] = 0
        nu = 0
        row = dest[i] if keep else 0
        # up to four fingers (one word): loops without the one over words,
        # which LLVM keeps tight, and the point's column read once (a store
        # to ``held`` may alias ``perm``, which would be read again)
        if words == 1 and not keep:
            for j in range(n):
                code = d_codes[node[j]]
                total += first[code]
                unsure[nu] = j
                ucode[nu] = code
                nu += int(code >= n_plain)  # some finger unsure: keep it
        elif words == 1:
            for j in range(n):
                code = d_codes[node[j]]
                lanes = first[code]  # finger f's held bit at bit 16 f
                total += lanes
                unsure[nu] = j
                ucode[nu] = code
                nu += int(code >= n_plain)
                pj = perm[j]
                for f in range(nf):
                    held[row, pj, f] = (lanes >> (16 * f)) & 1
        else:
            for j in range(n):
                code = d_codes[node[j]]
                total += first[code]
                for w in range(1, words):
                    more[w] += packed[code, w]
                unsure[nu] = j
                ucode[nu] = code
                nu += int(code >= n_plain)
                if keep:
                    pj = perm[j]
                    for f in range(nf):
                        held[row, pj, f] = held_f[code, f] != 0
        for t in range(nu):
            j = unsure[t]
            code = ucode[t]
            x = Q[r, 0, j] - ux
            y = Q[r, 1, j] - uy
            z = Q[r, 2, j] - uz
            pj = perm[j]
            acc = np.int64(0)  # fingers 0-3 in a register: 5 % less time
            for e in range(start[code], start[code + 1]):
                s = listed[e]
                dx = x - centers[s, 0]
                dy = y - centers[s, 1]
                dz = z - centers[s, 2]
                inside = dx * dx + dy * dy + dz * dz < radii2[s]
                f = owner[e]
                if f < 4:
                    acc |= np.int64(inside) << (16 * f)
                else:
                    got[f >> 2] |= np.int64(inside) << (16 * (f & 3))
                if keep and inside:
                    held[row, pj, f] = True
            total += acc
            for w in range(1, words):
                more[w] += got[w]
                got[w] = 0
        for f in range(nf):
            word = total if f < 4 else more[f // 4]
            counts[i, f] = (word >> (16 * (f % 4))) & 0xFFFF


#: ``x ** exponent`` as ``wsgrasp.geometry``'s superellipsoid test computes it
#: (repeated squaring for 2, 4 and 10): the same function, on scalars here
#: (compiled and inlined into the body loop by ``_compiled.load``)
_power = superellipsoid_power


#: probes per near body: its centre and two points along its longest axis
_PROBES = 3
#: without the hint grid, the probes are this many points spread over the cloud
#: (every ``n // _SPREAD``-th), tried against every near body: of the Franka
#: hand's 373 Table I candidates that hit a body, they find 326 (24 points: 279),
#: and the loop takes 0.20 ms instead of 0.30 ms
_SPREAD = 64


def _body_loop(
    Q: Array,
    ol: NDArray[np.int64],
    u: Array,
    centers: Array,
    semi_axes: Array,
    exponent: float,
    R: Array,
    h_origin: Array,
    h_inv_cell: float,
    h_last: Array,
    h_strides: Array,
    h_point: NDArray[np.int32],
    hit: NDArray[np.bool_],
) -> None:  # pragma: no cover - run compiled, or by the tests on tiny inputs
    """``hit[i]``: some point of candidate ``i`` (``Q[ol[i], :, j] - u[i]``)
    strictly inside some superellipsoid, with the arithmetic of
    ``coordinates_in_superellipsoids``; stops at the first such point.

    A superellipsoid whose box the candidate's object box (its row's extremes
    less ``u``) lies apart from is skipped: every point's ``|x - c| < a`` test
    along that axis fails (the rounding of ``Q - u`` and of ``- c`` keeps the
    order of the coordinates). Of the Allegro's dense candidates, those clear of
    every body are tested against the few bodies near the object only.

    Before the scan, per body near the candidate, the point ``h_point`` names
    at the voxel of the body's centre (world frame: ``R[ol[i]] (c + u[i])``;
    ``_grids.NearestPoint``, empty for none) is tried: most candidates in
    collision hold it in a body. Without the grid, every ``n // _SPREAD``-th
    point is tried instead. Only the order of the tests changes, not their
    answer."""
    m = ol.shape[0]
    n = Q.shape[2]
    ne = centers.shape[0]
    lo = np.empty(3)  # the row's object box, gripper axes, untranslated
    hi = np.empty(3)
    near = np.empty(ne, dtype=np.int64)  # the bodies the candidate's box meets
    long_axis = np.empty(ne, dtype=np.int64)
    for e in range(ne):
        long_axis[e] = np.argmax(semi_axes[e])
    prev = -1
    # where the scan starts: the point that put the last candidate in a body
    # (the candidates come by orientation, a sample's neighbours next to it,
    # so the same point is often inside again: the Allegro's dense hits take
    # half the time, 0.52 -> 0.24 ms per 900-candidate chunk)
    first = 0
    last_body = -1
    for i in range(m):
        r = ol[i]
        if r != prev:
            for k in range(3):
                lo[k] = hi[k] = Q[r, k, 0] if n else 0.0
                for j in range(n):
                    lo[k] = min(lo[k], Q[r, k, j])
                    hi[k] = max(hi[k], Q[r, k, j])
            prev = r
        ux, uy, uz = u[i, 0], u[i, 1], u[i, 2]
        nn = 0
        for e in range(ne):
            apart = False
            for k in range(3):
                uk = ux if k == 0 else (uy if k == 1 else uz)
                if (lo[k] - uk) - centers[e, k] >= semi_axes[e, k]:
                    apart = True
                if centers[e, k] - (hi[k] - uk) >= semi_axes[e, k]:
                    apart = True
            if not apart:
                near[nn] = e
                nn += 1
        found = False
        if nn == 0 or n == 0:
            hit[i] = False
            continue
        for t in range(1, nn):  # the body of the last hit first
            if near[t] == last_body:
                near[t] = near[0]
                near[0] = last_body
        # the probes first, each against every near body: the point that put
        # the last candidate in a body, then per near body the hints at its
        # centre and half-way to its long ends (without hints, points spread
        # over the cloud). Then per near body, the first and last of the points
        # in its box (one branch-free pass); where some are, the points from
        # the first to the last against that body (the Allegro hand's dense
        # body tests: 86 -> 63 ms)
        hinted = h_point.shape[0] > 0
        probes = 1 + (_PROBES * nn if hinted else _SPREAD)
        spread = max(1, n // _SPREAD)
        step = 0
        tb = 0  # the near body of the second phase
        jb = 0  # its next point
        while True:
            if step < probes:
                t0, t1 = 0, nn
                if step == 0:
                    j = first
                elif not hinted:  # every spread-th point (the numpy path's subset)
                    j = min((step - 1) * spread, n - 1)
                else:
                    e = near[(step - 1) // _PROBES]
                    cx = centers[e, 0] + ux
                    cy = centers[e, 1] + uy
                    cz = centers[e, 2] + uz
                    k = (step - 1) % _PROBES  # 0: the centre; 1, 2: long ends
                    if k:
                        kl = long_axis[e]
                        off = (0.5 if k == 1 else -0.5) * semi_axes[e, kl]
                        if kl == 0:
                            cx += off
                        elif kl == 1:
                            cy += off
                        else:
                            cz += off
                    g = 0.0
                    for k in range(3):  # the probe's voxel, world frame
                        w = R[r, k, 0] * cx + R[r, k, 1] * cy + R[r, k, 2] * cz
                        v = np.floor((w - h_origin[k]) * h_inv_cell)
                        g += min(max(v, 0.0), h_last[k]) * h_strides[k]
                    j = h_point[int(g)]
                step += 1
            else:
                if tb >= nn:
                    break
                e = near[tb]
                if jb == 0:  # a new body: the span of the points in its box
                    j_lo = n
                    j_hi = -1
                    for jj in range(n):
                        bx = abs((Q[r, 0, jj] - ux) - centers[e, 0]) < semi_axes[e, 0]
                        by = abs((Q[r, 1, jj] - uy) - centers[e, 1]) < semi_axes[e, 1]
                        bz = abs((Q[r, 2, jj] - uz) - centers[e, 2]) < semi_axes[e, 2]
                        inb = bx & by & bz
                        j_lo = min(j_lo, jj if inb else n)
                        j_hi = max(j_hi, jj if inb else -1)
                    if j_hi < 0:
                        tb += 1
                        continue
                    jb = j_lo
                if jb > j_hi:
                    tb += 1
                    jb = 0
                    continue
                j = jb
                jb += 1
                t0, t1 = tb, tb + 1
            x = Q[r, 0, j] - ux
            y = Q[r, 1, j] - uy
            z = Q[r, 2, j] - uz
            for t in range(t0, t1):
                e = near[t]
                dx = abs(x - centers[e, 0])
                if not dx < semi_axes[e, 0]:
                    continue
                dy = abs(y - centers[e, 1])
                if not dy < semi_axes[e, 1]:
                    continue
                dz = abs(z - centers[e, 2])
                if not dz < semi_axes[e, 2]:
                    continue
                c = dz / semi_axes[e, 2]
                value = (
                    _power(dx / semi_axes[e, 0], exponent)
                    + _power(dy / semi_axes[e, 1], exponent)
                    + c * c
                )
                if value < 1.0:
                    found = True
                    last_body = e
                    break
            if found:
                first = j
                break
        hit[i] = found


def _reach_loop(
    p_rot: NDArray[np.float32],
    rotation: NDArray[np.int64],
    offset: NDArray[np.float32],
    grid: NDArray[np.uint8],
    limit: NDArray[np.int64],
    reached: NDArray[np.bool_],
) -> None:  # pragma: no cover - run compiled, or by the tests on tiny inputs
    """``reached[i]``: some object point of candidate ``i``
    (``p_rot[rotation[i]] - offset[i]``, reach-grid voxels) lies in a voxel of
    ``grid`` whose step is below ``limit[i]``, with the float32 arithmetic of
    ``sweeps._reached_first`` (rounded to the nearest voxel, clipped onto the
    border); stops at the first such point."""
    nx, ny, nz = grid.shape
    for i in range(rotation.shape[0]):
        P = p_rot[rotation[i]]
        ox, oy, oz = offset[i, 0], offset[i, 1], offset[i, 2]
        found = False
        for j in range(P.shape[0]):
            a = min(max(int(np.rint(P[j, 0] - ox)), 0), nx - 1)
            b = min(max(int(np.rint(P[j, 1] - oy)), 0), ny - 1)
            c = min(max(int(np.rint(P[j, 2] - oz)), 0), nz - 1)
            if grid[a, b, c] < limit[i]:
                found = True
                break
        reached[i] = found
