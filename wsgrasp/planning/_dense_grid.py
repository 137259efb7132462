"""Grids that prove verdicts of the dense search before any point is tested.

Two conservative tests, both exact where they decide and silent where they cannot:

``ObjectDistance``
    The distance from each voxel centre of a grid to the nearest object point
    (exact, from a KD-tree, for the voxels that ``scipy.ndimage``'s Euclidean
    distance transform of the occupancy puts near the object), queried at ball
    centres: the nearest point lies at most the query's distance to its voxel's
    centre farther, so a ball inscribed in a body superellipsoid that provably
    holds an object point proves the body hits the object. Distances are
    rotation-invariant, so one grid in the world frame serves every orientation.
``FingerDepth``
    Per finger, ``D(y) = max_k (r_k - |y - c_k|)`` at the nodes of a grid in the
    gripper frame (the depth of ``y`` inside the finger's union of spheres, exact
    outside it, a lower bound inside). ``D`` is 1-Lipschitz, so a point within
    ``t`` of a node is held where ``D > t`` (strictly inside the sphere that
    gives ``D``) and not held where ``D < -t`` (outside every sphere). At the
    nodes it leaves unsure, a short list of the finger's spheres that can hold a
    point nearest the node decides (``FingerDepth.sphere_lists``).

Both keep ``MARGIN`` (m) on the safe side of every bound, far above rounding in
the coordinates and in the float32 grids, so a verdict decided here is the one the
exact test gives.
"""

from __future__ import annotations

import weakref

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from scipy.spatial import cKDTree

from wsgrasp.planning.spheres import FingerSpheres

__all__ = [
    "ObjectDistance",
    "NearestPoint",
    "FingerDepth",
    "inscribed_balls",
    "finger_depth",
]

Array = NDArray[np.float64]

#: bounds decide a verdict only this far (m) from it
MARGIN = 1e-6
_SQRT3 = float(np.sqrt(3.0))


def inscribed_balls(
    centers: Array, semi_axes: Array, exponent: float, fill: float = 0.8
) -> tuple[Array, Array, NDArray[np.int64]]:
    """Balls inside each superellipsoid, strung along its longest axis.

    A ball of radius ``rho`` at offset ``t`` along axis ``k`` from the centre lies
    in the box ``|x_i| <= rho`` (``i != k``), ``|x_k| <= |t| + rho``, on which eq.
    (1) is largest at the far corner (it grows with each ``|x_i|``); the balls kept
    have that corner's value below ``1 - 1e-6``.

    Parameters
    ----------
    centers, semi_axes : (e, 3) float
    exponent : float
    fill : float
        Ball radius as a fraction of the smallest semi-axis (less where the
        other axes' terms would leave too little room).

    Returns
    -------
    ball_centers : (b, 3) float
        Gripper frame.
    radii : (b,) float
    body : (b,) int
        The superellipsoid each ball lies in.
    """
    out_c, out_r, out_e = [], [], []
    powers = np.array([exponent, exponent, 2.0])
    for e, (c, a) in enumerate(zip(centers, semi_axes, strict=True)):
        rho = fill * float(a.min())
        k = int(np.argmax(a))
        rest = [i for i in range(3) if i != k]
        used = sum((rho / a[i]) ** powers[i] for i in rest)
        # smaller where even a centred ball's box corner is outside (low
        # exponents: an ellipsoid's inscribed cube is smaller than its axes)
        while used + (rho / a[k]) ** powers[k] > 0.9:
            rho *= 0.8
            used = sum((rho / a[i]) ** powers[i] for i in rest)
        room = 1.0 - 1e-6 - used
        if room <= 0:
            continue
        t = a[k] * room ** (1.0 / powers[k]) - rho  # farthest offset along k
        if t < 0:
            continue
        n = int(np.ceil(2.0 * t / rho)) + 1  # a radius apart
        offsets = np.linspace(-t, t, n) if n > 1 else np.zeros(1)
        ball = np.tile(c, (len(offsets), 1))
        ball[:, k] += offsets
        out_c.append(ball)
        out_r.append(np.full(len(offsets), rho))
        out_e.append(np.full(len(offsets), e, dtype=np.int64))
    if not out_c:
        return np.zeros((0, 3)), np.zeros(0), np.zeros(0, dtype=np.int64)
    return np.concatenate(out_c), np.concatenate(out_r), np.concatenate(out_e)


class ObjectDistance:
    """Upper bounds on the distance from a query point to the nearest object point.

    Parameters
    ----------
    points : (n, 3) float
    radii : (b,) float
        The radii of the balls :meth:`hits` tests, in the order it tests them;
        queries farther than the largest outside the points' box are never
        proven.
    cell : float
        Voxel size (m).
    """

    def __init__(self, points: Array, radii: Array, cell: float = 0.004) -> None:
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        self.radii = np.asarray(radii, dtype=np.float64)
        reach = float(self.radii.max()) if len(self.radii) else 0.0
        self.cell = h = float(cell)
        self.empty = len(p) == 0 or reach <= 0
        if self.empty:
            return
        self.origin = p.min(axis=0) - reach - h
        shape = np.ceil((p.max(axis=0) + reach + h - self.origin) / h).astype(np.int64)
        self.shape = np.maximum(shape, 1)
        occupied = np.zeros(tuple(self.shape), dtype=bool)
        ijk = np.floor((p - self.origin) / h).astype(np.int64)
        occupied[ijk[:, 0], ijk[:, 1], ijk[:, 2]] = True
        # distance from each voxel centre to the nearest occupied voxel's centre;
        # the nearest point is within h√3/2 of that, so only voxels closer than
        # reach + h√3/2 can prove anything, and get their exact distance to the
        # nearest point (a KD-tree query); the others never prove
        dist = np.asarray(ndimage.distance_transform_edt(~occupied, sampling=h))
        near = np.flatnonzero(dist.ravel() < reach + 0.5 * h * _SQRT3)
        ijk_near = np.stack(np.unravel_index(near, tuple(self.shape)), axis=1)
        centres = self.origin + (ijk_near + 0.5) * h  # (v, 3)
        d, _ = cKDTree(p).query(centres, distance_upper_bound=reach + h)
        self.upper = np.full(int(np.prod(self.shape)), np.inf, dtype=np.float32)
        # float32 moves a distance by far less than MARGIN
        self.upper[near] = np.asarray(d, dtype=np.float32)
        # the border voxels prove nothing (a query beyond the grid is read there)
        border = np.ones(tuple(self.shape), dtype=bool)
        border[1:-1, 1:-1, 1:-1] = False
        self.upper[border.ravel()] = np.inf
        self.strides = np.array([shape[1] * shape[2], shape[2], 1], dtype=np.int64)

    def within(self, x: Array, radius: float) -> NDArray[np.bool_]:
        """Whether some object point provably lies strictly within ``radius`` of
        each query ``x`` (k, 3): (k,) bool; False where not proven."""
        return self.within_coordinates(x[:, 0], x[:, 1], x[:, 2], radius)

    def within_coordinates(
        self, x: Array, y: Array, z: Array, radius: float
    ) -> NDArray[np.bool_]:
        """:meth:`within` for queries given as three coordinate arrays (k,)."""
        if self.empty:
            return np.zeros(len(x), dtype=bool)
        inv = 1.0 / self.cell
        flat = np.zeros(len(x))  # flat voxel index, exact in floats below 2**53
        d2 = np.zeros(len(x))  # squared distance to the voxel's centre, in cells
        for k, c in enumerate((x, y, z)):
            t = (c - self.origin[k]) * inv
            g = np.floor(t)
            f = t - g - 0.5
            d2 += f * f
            # beyond the grid: read at its border, whose voxels prove nothing
            np.clip(g, 0.0, float(self.shape[k] - 1), out=g)
            g *= float(self.strides[k])
            flat += g
        # the nearest point lies at most the query's distance to its voxel's
        # centre farther from the query than from the centre
        to_centre = np.sqrt(d2) * self.cell
        upper = np.take(self.upper, flat.astype(np.int64))
        return upper + to_centre < radius - MARGIN  # type: ignore[no-any-return]

    def hits(
        self,
        A: Array,
        Bb: Array,
        s: NDArray[np.int64],
        o: NDArray[np.int64],
        body: NDArray[np.int64],
        min_yield: float = 0.02,
    ) -> NDArray[np.bool_]:
        """Candidates ``(s, o)`` (k,) with some ball ``b`` around ``A[s] + Bb[o,
        b]`` provably holding an object point.

        The balls in turn, each on the candidates not yet proven; once a ball
        proves fewer than ``min_yield`` of those it was given, the other balls
        of its ``body`` are skipped (they only cost time; what they would have
        proven, the exact tests decide).

        Parameters
        ----------
        A : (ns, 3) float
        Bb : (O, b, 3) float
            Ball centres less the sample's part, world frame.
        s, o : (k,) int
        body : (b,) int
        """
        hit = np.zeros(len(s), dtype=bool)
        rest = np.arange(len(s))
        spent: set[int] = set()
        for b, radius in enumerate(self.radii):
            if rest.size == 0:
                break
            if int(body[b]) in spent:
                continue
            sr, orr = s[rest], o[rest]
            # the ball centres A[s] + Bb[o, b], (r,) per coordinate
            x, y, z = (
                np.take(A[:, k], sr) + np.take(Bb[:, b, k], orr) for k in range(3)
            )
            got = self.within_coordinates(x, y, z, float(radius))
            if np.count_nonzero(got) < min_yield * len(rest):
                spent.add(int(body[b]))
            hit[rest[got]] = True
            rest = rest[~got]
        return hit


class NearestPoint:
    """Per voxel of a world-frame grid around the object, an object point near
    its centre: the one ``scipy.ndimage``'s distance transform finds in the
    nearest occupied voxel. A hint, not a bound: the compiled body test tries
    the point near each body's centre first (most colliding candidates hold it
    in the body), and every verdict still comes from the exact test.

    Parameters
    ----------
    points : (n, 3) float
    cell : float
        Voxel size (m); a query outside the grid reads its border voxel.
    """

    def __init__(self, points: Array, cell: float = 0.004) -> None:
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        self.cell = h = float(cell)
        if len(p) == 0:
            self.origin = np.zeros(3)
            self.shape = np.ones(3, dtype=np.int64)
            self.point = np.zeros(0, dtype=np.int32)
            self.strides = np.array([1, 1, 1], dtype=np.int64)
            return
        self.origin = p.min(axis=0) - 2 * h
        shape = np.floor((p.max(axis=0) + 2 * h - self.origin) / h).astype(np.int64)
        self.shape = shape = np.maximum(shape + 1, 1)
        ijk = np.floor((p - self.origin) / h).astype(np.int64)
        owner = np.full(tuple(shape), -1, dtype=np.int32)
        owner[ijk[:, 0], ijk[:, 1], ijk[:, 2]] = np.arange(len(p), dtype=np.int32)
        near = ndimage.distance_transform_edt(
            owner < 0, return_distances=False, return_indices=True
        )
        self.point = np.ascontiguousarray(owner[tuple(near)].ravel(), dtype=np.int32)
        self.strides = np.array([shape[1] * shape[2], shape[2], 1], dtype=np.int64)

    def arrays(self) -> tuple[Array, float, Array, Array, NDArray[np.int32]]:
        """``origin, 1 / cell, shape - 1, strides, point``, as the compiled body
        loop reads them (floats, so that its index arithmetic is exact)."""
        return (
            np.asarray(self.origin, dtype=np.float64),
            float(1.0 / self.cell),
            np.asarray(self.shape - 1, dtype=np.float64),
            np.asarray(self.strides, dtype=np.float64),
            self.point,
        )


class FingerDepth:
    """Per finger, the depth ``D`` (m) inside its union of spheres at grid nodes
    (see the module docstring), as one of three states per finger and node: held
    (``D > t``), unsure (``-t <= D <= t``), neither (``D < -t``), with ``t`` the
    farthest a point can lie from its nearest node plus ``MARGIN``.

    Each node keeps a code: its row in :attr:`states`, the table of the
    combinations of per-finger states that occur in the grid, ``(K, nf)`` with
    the finger count as a dimension. Any number of fingers fits; the codes are
    one byte a node while at most 256 combinations occur (every gripper with up
    to 5 fingers, where ``3 ** nf <= 243``, and in practice more: a node is
    held or unsure for few fingers at once), wider where more do. The tables
    derived from :attr:`states` (held, unsure, the packed held counts) are
    read by code, so a node's verdict for every finger is one lookup.

    Parameters
    ----------
    centers, radii, finger : (s, 3), (s,), (s,)
        The gripper's spheres and the finger of each.
    num_fingers : int
    cell : float, optional
        Node spacing (m); by default a quarter of the smallest radius within
        1-2 mm, coarser where the grid would exceed 8 million nodes.
    """

    #: a finger's state at a node, as kept in :attr:`states`
    NEITHER, HELD, UNSURE = 0, 1, 2

    def __init__(
        self,
        centers: Array,
        radii: Array,
        finger: NDArray[np.int64],
        num_fingers: int,
        cell: float | None = None,
    ) -> None:
        if num_fingers < 1:
            raise ValueError(
                f"FingerDepth needs at least one finger, got {num_fingers}"
            )
        lo0 = (centers - radii[:, None]).min(axis=0)
        hi0 = (centers + radii[:, None]).max(axis=0)
        h = cell if cell is not None else float(np.clip(radii.min() / 4, 1e-3, 2e-3))
        while np.prod((hi0 - lo0) / h + 8) > 8e6:
            h *= 1.25
        self.cell = h
        self.num_fingers = nf = int(num_fingers)
        self.lim = lim = 0.5 * _SQRT3 * h + MARGIN
        self.centers = np.asarray(centers, dtype=np.float64)
        self.radii = np.asarray(radii, dtype=np.float64)
        self.finger = np.asarray(finger, dtype=np.int64)
        #: each finger's box of spheres, gripper frame: (nf, 3) each
        self.box_lo = np.stack(
            [(centers - radii[:, None])[finger == f].min(0) for f in range(nf)]
        )
        self.box_hi = np.stack(
            [(centers + radii[:, None])[finger == f].max(0) for f in range(nf)]
        )
        self._lists: tuple[NDArray[np.int32], NDArray[np.int32], Array, Array] | None
        self._lists = None
        self._compact: tuple[NDArray[np.int32], NDArray[np.int32]] | None = None
        reach = 2.0 * lim  # nodes farther than this from every sphere: D < -lim
        lo, hi = lo0 - reach - h, hi0 + reach + h
        shape = np.ceil((hi - lo) / h).astype(np.int64) + 1
        self.origin, self.shape = lo, shape
        self.strides = np.array([shape[1] * shape[2], shape[2], 1], dtype=np.int64)
        # each node's code: its fingers' states as base-3 digits (NEITHER 0,
        # HELD 1, UNSURE 2) after the combination the last renumbering gave
        # it, (nodes,) int below ``span``; per renumbered code, the states
        # (K, f) uint8. Renumbered when the digits would pass 2**16 and at the
        # end, so code 0 is every finger neither (the grid's border)
        code: NDArray[np.integer] = np.zeros(int(np.prod(shape)), dtype=np.uint8)
        states = np.zeros((1, 0), dtype=np.uint8)
        digits, span = 0, 1
        for f in range(nf):
            depth = np.full(tuple(shape), -reach, dtype=np.float32)
            # once per gripper: each sphere raises D in the window of nodes it
            # can bring above -reach (those within r + reach of its centre)
            for c, r in zip(centers[finger == f], radii[finger == f], strict=True):
                a = np.maximum(np.floor((c - r - reach - lo) / h).astype(np.int64), 0)
                b = np.ceil((c + r + reach - lo) / h).astype(np.int64) + 1
                b = np.minimum(b, shape)
                axes = [lo[i] + h * np.arange(a[i], b[i]) - c[i] for i in range(3)]
                d = np.sqrt(
                    axes[0][:, None, None] ** 2
                    + axes[1][None, :, None] ** 2
                    + axes[2][None, None, :] ** 2
                )  # (wx, wy, wz) distances to the centre
                win = depth[a[0] : b[0], a[1] : b[1], a[2] : b[2]]
                np.maximum(win, (r - d).astype(np.float32), out=win)
            # float32 moves a value by far less than MARGIN
            flat = depth.ravel()
            if 3 * span > 2**16:
                code, states = _renumber(code, states, digits)
                digits, span = 0, len(states)
            # the narrowest integers that hold the next digit (bandwidth)
            wide = (
                np.uint8
                if 3 * span <= 2**8
                else np.uint16
                if 3 * span <= 2**16
                else np.int32
            )
            if code.dtype != wide:
                code = code.astype(wide)
            code *= 3
            code += flat > lim
            unsure = flat >= -lim
            unsure &= flat <= lim
            code += unsure
            code += unsure
            digits, span = digits + 1, 3 * span
        code, states = _renumber(code, states, digits)
        K = len(states)
        self.codes: NDArray[np.integer] = code  # (nodes,) uint8 to K = 256
        #: per code, each finger's state (NEITHER, HELD, UNSURE): (K, nf) uint8
        self.states: NDArray[np.uint8] = states
        self._held: NDArray[np.bool_] = states == self.HELD  # (K, nf)
        self._unsure_f: NDArray[np.bool_] = states == self.UNSURE  # (K, nf)
        self._unsure: NDArray[np.bool_] = np.asarray(self._unsure_f.any(axis=1))
        # per code, finger f's held bit at bit 16 (f % 4) of word f // 4: one
        # sum of a word over a row's points counts four fingers at once
        words = -(-nf // 4)
        packed = np.zeros((K, words), dtype=np.uint64)  # (K, W)
        for f in range(nf):
            packed[:, f // 4] |= self._held[:, f].astype(np.uint64) << np.uint64(
                16 * (f % 4)
            )
        self._packed = packed
        self._packed_words = [np.ascontiguousarray(packed[:, w]) for w in range(words)]

    def held_points(
        self, Q: Array, ol: NDArray[np.int64], u: Array
    ) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
        """Which object points each finger provably holds, and which it may.

        Parameters
        ----------
        Q : (q, 3, n) float
            Object points per orientation in the gripper axes, untranslated.
        ol : (m,) int
            Each candidate's row of ``Q``, nondecreasing.
        u : (m, 3) float
            Each candidate's translation: its points are ``Q[ol] - u``.

        Returns
        -------
        held : (m, n, nf) bool
            Strictly inside one of the finger's spheres.
        unsure : (m, n) bool
            Some finger neither proven to hold the point nor proven not to.
        """
        code = self.codes_at(Q, ol, u)  # (m, n)
        return self._held[code], self._unsure[code]

    def counts(
        self, Q: Array, ol: NDArray[np.int64], u: Array
    ) -> tuple[NDArray[np.int64], NDArray[np.integer], NDArray[np.int32]]:
        """Per candidate and finger, the points it provably holds, each point's
        code (for :attr:`unsure_fingers`) and nearest node (for
        :meth:`sphere_lists`).

        Parameters as :meth:`held_points`.

        Returns
        -------
        counts : (m, nf) int
        code : (m, n) int
            Each point's row of :attr:`states` (the dtype of :attr:`codes`).
        flat : (m, n) int32
            Each point's nearest node.
        """
        flat = self.nodes_at(Q, ol, u)  # (m, n)
        code = np.take(self.codes, flat)  # faster than self.codes[flat]
        m, n = code.shape
        nf = self.num_fingers
        if n < 2**16:
            # four fingers' held bits in 16-bit lanes of a word: one sum per
            # row and word counts four fingers at once (a row's count stays
            # below 2**16)
            blocks = []
            for w, word in enumerate(self._packed_words):
                total = np.take(word, code).sum(axis=1, dtype=np.uint64)  # (m,)
                shift = (16 * np.arange(min(4, nf - 4 * w))).astype(np.uint64)
                blocks.append((total[:, None] >> shift[None, :]) & np.uint64(0xFFFF))
            lanes = blocks[0] if len(blocks) == 1 else np.concatenate(blocks, axis=1)
            return lanes.astype(np.int64), code, flat  # (m, nf)
        held = np.count_nonzero(self._held[code], axis=1).astype(np.int64)
        return held, code, flat

    @property
    def packed_held(self) -> NDArray[np.int64]:
        """Per code, finger ``f``'s held bit at bit ``16 (f % 4)`` of word
        ``f // 4``: (K, ceil(nf / 4)) int64."""
        return self._packed.astype(np.int64)

    @property
    def held_fingers(self) -> NDArray[np.bool_]:
        """Per code, the fingers it proves to hold a point: (K, nf) bool."""
        return self._held

    @property
    def unsure_fingers(self) -> NDArray[np.bool_]:
        """Per code, the fingers it leaves undecided: (K, nf) bool."""
        return self._unsure_f

    @property
    def unsure_codes(self) -> NDArray[np.bool_]:
        """Per code, whether it leaves some finger undecided: (K,) bool."""
        return self._unsure

    def codes_at(
        self, Q: Array, ol: NDArray[np.int64], u: Array
    ) -> NDArray[np.integer]:
        """The code of each point's nearest node, (m, n) int of :attr:`codes`'
        dtype (parameters as :meth:`held_points`)."""
        return self.codes[self.nodes_at(Q, ol, u)]  # type: ignore[no-any-return]

    def nodes_at(self, Q: Array, ol: NDArray[np.int64], u: Array) -> NDArray[np.int32]:
        """Each point's nearest node (flat index), (m, n) int32 (parameters as
        :meth:`held_points`)."""
        h = self.cell
        m, n = len(ol), Q.shape[2]
        # node coordinates in cells, offset half a cell so that truncation of a
        # non-negative value rounds to the nearest node; float32 errors stay
        # below 1e-7 m, inside MARGIN
        Qn = ((Q - self.origin[None, :, None]) * (1.0 / h) + 0.5).astype(np.float32)
        un = (u * (1.0 / h)).astype(np.float32)  # (m, 3)
        top = (self.shape - 1).astype(np.float32)
        strides = self.strides.astype(np.int32)
        flat = np.empty((m, n), dtype=np.int32)
        t = np.empty((m, n), dtype=np.float32)
        cut = np.flatnonzero(np.diff(ol)) + 1
        if len(cut) > m // 32:  # small groups: one gather beats a loop over them
            groups = [(np.s_[:], ol)]
        else:
            groups = [
                (np.s_[a:b], ol[a])
                for a, b in zip(np.r_[0, cut], np.r_[cut, m], strict=True)
            ]
        for sl, r in groups:
            for k in range(3):
                # beyond the grid a point is clipped onto its border nodes, all
                # farther than `reach` from every sphere (neither held nor unsure)
                np.subtract(Qn[r, k], un[sl, k, None], out=t[sl])  # (g, n)
                np.clip(t[sl], 0.0, top[k], out=t[sl])
                if k == 0:
                    np.multiply(t[sl].astype(np.int32), strides[0], out=flat[sl])
                else:
                    flat[sl] += t[sl].astype(np.int32) * strides[k]
        return flat

    def sphere_lists(
        self,
    ) -> tuple[NDArray[np.int32], NDArray[np.int32], Array, Array]:
        """Per node left unsure for some finger, the spheres a point nearest it
        can lie in (built on first use, then kept).

        A point ``y`` lies within ``lim - MARGIN`` of its nearest node ``n``, so a
        sphere holding it has ``r - |n - c| > -lim``; at an unsure node no sphere
        has ``r - |n - c| > lim``. The list of finger ``f`` at ``n`` is its
        spheres with ``r - |n - c| > -lim``: few (a node is unsure only near the
        surface of the finger's union of spheres).

        Returns
        -------
        node_id : (nodes,) int32
            Compact id of each node unsure for some finger, -1 elsewhere.
        lists : (u, nf, K) int32
            Per compact id and finger, sphere ids (into ``centers``), padded
            with ``len(centers)``, the id of a sphere of radius 0 (holds no point).
        centers : (s + 1, 3) float
        radii : (s + 1,) float
        """
        if self._lists is not None:
            return self._lists
        nf = self._held.shape[1]
        unsure_any = self._unsure[self.codes]  # (nodes,)
        nodes = np.flatnonzero(unsure_any)
        node_id = np.full(len(self.codes), -1, dtype=np.int32)
        node_id[nodes] = np.arange(len(nodes), dtype=np.int32)
        ijk = np.stack(np.unravel_index(nodes, tuple(self.shape)), axis=1)
        pos = self.origin + ijk * self.cell  # (u, 3) node positions
        S = len(self.radii)
        per: list[tuple[int, NDArray[np.int64], NDArray[np.int64]]] = []
        width = 1
        tree = cKDTree(pos) if len(pos) else None
        for f in range(nf):
            mine = np.flatnonzero(self.finger == f)
            open_f = np.flatnonzero(self._unsure_f[self.codes[nodes], f])  # (v,)
            if tree is None or mine.size == 0 or open_f.size == 0:
                continue
            # every (node, sphere) pair closer than r + lim, then r - |n - c| > -lim
            pairs = cKDTree(self.centers[mine]).sparse_distance_matrix(
                tree, float(self.radii[mine].max()) + self.lim, output_type="ndarray"
            )
            k, n, d = pairs["i"], pairs["j"], pairs["v"]
            keep = (self.radii[mine][k] - d > -self.lim) & self._unsure_f[
                self.codes[nodes[n]], f
            ]
            k, n = mine[k[keep]], n[keep]
            order = np.lexsort((k, n))
            k, n = k[order], n[order]
            counts = np.bincount(n, minlength=len(nodes))
            width = max(width, int(counts.max()) if counts.size else 1)
            per.append((f, n, k))
        lists = np.full((len(nodes), nf, width), S, dtype=np.int32)
        for f, n, k in per:
            first = np.searchsorted(n, n, side="left")  # each pair's rank at its node
            rank = np.arange(len(n)) - first
            lists[n, f, rank] = k
        centers = np.vstack([self.centers, np.zeros((1, 3))])
        radii = np.append(self.radii, 0.0)
        self._lists = (node_id, lists, centers, radii)
        return self._lists

    def compact_lists(self) -> tuple[NDArray[np.int32], NDArray[np.int32]]:
        """:meth:`sphere_lists` without the padding, for a loop that reads one
        node at a time (built on first use, then kept).

        Returns
        -------
        start : (nodes,) int32
            Where each node's lists begin in ``listed`` (0 at the nodes unsure
            for no finger, which are never read).
        listed : (e,) int32
            Per node, for each finger its code leaves unsure, in finger order:
            that finger's sphere ids (into :meth:`sphere_lists`' ``centers``,
            ``radii``), then -1.
        """
        if self._compact is not None:
            return self._compact
        node_id, lists, _, radii = self.sphere_lists()
        pad = len(radii) - 1
        nodes = np.flatnonzero(node_id >= 0)  # ascending, so compact ids in order
        L = lists[node_id[nodes]]  # (u, nf, K)
        open_f = self._unsure_f[self.codes[nodes]]  # (u, nf) the fingers listed
        real = (L != pad) & open_f[:, :, None]  # (u, nf, K)
        # entries per (node, finger): its spheres and a terminator, if listed
        per = real.sum(axis=2) + open_f  # (u, nf)
        ends = np.cumsum(per.ravel()).reshape(per.shape)  # (u, nf) exclusive end
        begin = ends - per  # (u, nf) where each finger's list starts
        listed = np.full(int(per.sum()), -1, dtype=np.int32)
        u_i, f_i, k_i = np.nonzero(real)  # spheres in list order (k ascending)
        listed[begin[u_i, f_i] + k_i] = L[u_i, f_i, k_i]  # lists end at padding
        start = np.zeros(len(self.codes), dtype=np.int32)
        start[nodes] = begin[:, 0]
        self._compact = (start, listed)
        return self._compact


def _renumber(
    code: NDArray[np.integer], states: NDArray[np.uint8], digits: int
) -> tuple[NDArray[np.integer], NDArray[np.uint8]]:
    """The codes that occur, renumbered in order from 0.

    Parameters
    ----------
    code : (nodes,) int
        Per node, ``c 3**digits + d``: ``c`` a row of ``states``, ``d`` the
        states of the last ``digits`` fingers as base-3 digits (the first
        finger's the most significant).
    states : (K, f) uint8
    digits : int

    Returns
    -------
    code : (nodes,) int
        Per node, its row of the new table, in the narrowest unsigned
        integers that hold it (int32 beyond 2**16 rows).
    states : (K', f + digits) uint8
    """
    occurs = np.bincount(code)  # (span,)
    present = np.flatnonzero(occurs)  # (K',) ascending
    K = len(present)
    wide = np.uint8 if K <= 2**8 else np.uint16 if K <= 2**16 else np.int32
    renumber = np.zeros(len(occurs), dtype=wide)
    renumber[present] = np.arange(K)
    base = 3 ** np.arange(digits - 1, -1, -1)  # (digits,) the digits' weights
    new = (present[:, None] // base[None, :]) % 3  # (K', digits)
    rows = states[present // 3**digits]  # (K', f)
    return np.take(renumber, code), np.concatenate([rows, new.astype(np.uint8)], axis=1)


_CACHE: weakref.WeakKeyDictionary[FingerSpheres, FingerDepth] = (
    weakref.WeakKeyDictionary()
)


def finger_depth(
    spheres: FingerSpheres,
    centers: Array,
    radii: Array,
    finger: NDArray[np.int64],
    num_fingers: int,
) -> FingerDepth:
    """The :class:`FingerDepth` of a gripper, built once per ``spheres`` index."""
    got = _CACHE.get(spheres)
    if got is None:
        got = FingerDepth(centers, radii, finger, num_fingers)
        _CACHE[spheres] = got
    return got
