"""The grids the body and finger tests read, compiled (``_compiled``) or numpy's.

``FingerDepth``
    Per finger, ``D(y) = max_k (r_k - |y - c_k|)`` at the nodes of a grid in the
    gripper frame (the depth of ``y`` inside the finger's union of spheres, exact
    outside it, a lower bound inside). ``D`` is 1-Lipschitz, so a point within
    ``t`` of a node is held where ``D > t`` (strictly inside the sphere that
    gives ``D``) and not held where ``D < -t`` (outside every sphere). At the
    nodes it leaves unsure, a short list of the finger's spheres that can hold a
    point nearest the node decides (``FingerDepth.sphere_lists``). Its bounds
    keep ``MARGIN`` (m) on the safe side, far above rounding in the coordinates
    and in the float32 grid, so a verdict decided there is the exact test's.
``FingerSpheres``
    A gripper's ``FingerDepth`` with its sphere lists, built once: the index
    every finger test of a pipeline's searches reads.
``NearestPoint``
    Per voxel around the object, an object point near it: where the body loop
    looks first (a hint; the verdict is the exact test's).
"""

from __future__ import annotations

from functools import cached_property

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from scipy.spatial import cKDTree

from wsgrasp.gripper.model import GripperModel

__all__ = ["NearestPoint", "FingerDepth", "FingerSpheres"]

Array = NDArray[np.float64]

#: bounds decide a verdict only this far (m) from it
MARGIN = 1e-6
_SQRT3 = float(np.sqrt(3.0))
#: ``FingerDepth.compact_lists``: list codes, their codes, starts, spheres, fingers
_Ints = NDArray[np.int32]
_Compact = tuple[NDArray[np.integer], NDArray[np.int64], _Ints, _Ints, _Ints]


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
    read by code, so a node's verdict for every finger is one lookup. The nodes
    lie a quarter of the smallest radius apart within 1-2 mm (or ``cell``),
    farther where the grid would exceed 8 million nodes.

    Parameters
    ----------
    centers, radii, finger : (s, 3), (s,), (s,)
        The gripper's spheres and the finger of each.
    num_fingers : int
    cell : float, optional
        The nodes' spacing (m).
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
        lo_s, hi_s = centers - radii[:, None], centers + radii[:, None]  # (s, 3)
        lo0, hi0 = lo_s.min(axis=0), hi_s.max(axis=0)
        h = float(cell) if cell else float(np.clip(radii.min() / 4, 1e-3, 2e-3))
        while np.prod((hi0 - lo0) / h + 8) > 8e6:
            h *= 1.25
        self.cell = h
        self.num_fingers = nf = int(num_fingers)
        self.lim = lim = 0.5 * _SQRT3 * h + MARGIN
        self.centers = np.asarray(centers, dtype=np.float64)
        self.radii = np.asarray(radii, dtype=np.float64)
        self.finger = np.asarray(finger, dtype=np.int64)
        #: each finger's box of spheres, gripper frame: (nf, 3) each
        self.box_lo = np.stack([lo_s[finger == f].min(0) for f in range(nf)])
        self.box_hi = np.stack([hi_s[finger == f].max(0) for f in range(nf)])
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
            wide = _narrowest(3 * span)
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
        #: per code, the fingers it proves to hold a point: (K, nf) bool
        self.held_fingers: NDArray[np.bool_] = states == self.HELD
        #: per code, the fingers it leaves undecided: (K, nf) bool
        self.unsure_fingers: NDArray[np.bool_] = states == self.UNSURE
        #: per code, whether it leaves some finger undecided: (K,) bool
        self.unsure_codes: NDArray[np.bool_] = self.unsure_fingers.any(axis=1)
        #: per code, finger ``f``'s held bit at bit ``16 (f % 4)`` of word
        #: ``f // 4``: (K, ceil(nf / 4)) int64; one sum of a word over a row's
        #: points counts four fingers at once
        self.packed_held = np.zeros((K, -(-nf // 4)), dtype=np.int64)
        for f in range(nf):
            bit = self.held_fingers[:, f].astype(np.int64) << (16 * (f % 4))
            self.packed_held[:, f // 4] |= bit

    @cached_property
    def sphere_lists(self) -> tuple[NDArray[np.int32], NDArray[np.int32], Array, Array]:
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
        nf = self.num_fingers
        unsure_any = self.unsure_codes[self.codes]  # (nodes,)
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
            open_f = np.flatnonzero(self.unsure_fingers[self.codes[nodes], f])  # (v,)
            if tree is None or mine.size == 0 or open_f.size == 0:
                continue
            # every (node, sphere) pair closer than r + lim, then r - |n - c| > -lim
            pairs = cKDTree(self.centers[mine]).sparse_distance_matrix(
                tree, float(self.radii[mine].max()) + self.lim, output_type="ndarray"
            )
            k, n, d = pairs["i"], pairs["j"], pairs["v"]
            keep = (self.radii[mine][k] - d > -self.lim) & self.unsure_fingers[
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
        return node_id, lists, centers, radii

    @cached_property
    def compact_lists(self) -> _Compact:
        """:attr:`sphere_lists` as the compiled count loop reads them: one code
        per node that names its lists too, so that a point's code says both
        its fingers' states and where its spheres are listed (built on first
        use, then kept).

        A node unsure for no finger keeps its code; one unsure for some finger
        gets ``K`` (the number of codes) plus the rank of its combination of
        code and lists among those that occur (a few thousand on the Allegro
        hand's 156,000 unsure nodes).

        Returns
        -------
        codes : (nodes,) int
            Per node its list code, in the narrowest unsigned integers that
            hold it (int32 beyond 2**16).
        of : (L,) int
            Per list code, its code: the row of :attr:`states`.
        start : (L + 1,) int32
            List code ``c``'s entries are ``start[c]`` to ``start[c + 1]``.
        listed, owner : (e,) int32
            Per entry, a sphere (into :attr:`sphere_lists`' ``centers``,
            ``radii``) and its finger, one that the code leaves unsure.
        """
        node_id, lists, _, radii = self.sphere_lists
        K, pad = len(self.states), len(radii) - 1
        nodes = np.flatnonzero(node_id >= 0)
        L = lists[node_id[nodes]]  # (u, nf, w)
        key = np.concatenate(
            [self.codes[nodes, None].astype(np.int32), L.reshape(len(nodes), -1)], 1
        )  # (u, 1 + nf w) a node's code and lists, one byte string a row
        rows = key.view(np.dtype((np.void, 4 * key.shape[1]))).ravel()
        _, first, rank = np.unique(rows, return_index=True, return_inverse=True)
        total = K + len(first)
        wide = _narrowest(total)
        codes: NDArray[np.integer] = self.codes.astype(wide)
        codes[nodes] = K + rank.ravel()
        of: NDArray[np.int64] = np.concatenate([np.arange(K), self.codes[nodes[first]]])
        U = L[first]  # (L - K, nf, w) each combination's lists
        real = (U != pad) & self.unsure_fingers[of[K:]][:, :, None]
        c_i, f_i, k_i = np.nonzero(real)  # entries by combination, finger, rank
        start = np.zeros(total + 1, dtype=np.int32)
        start[K + 1 :] = np.cumsum(np.bincount(c_i, minlength=len(first)))
        listed = U[c_i, f_i, k_i].astype(np.int32)
        return codes, of, start, listed, f_i.astype(np.int32)

    def holding_coordinates(self, x: Array, y: Array, z: Array) -> NDArray[np.bool_]:
        """Which fingers' spheres hold each point, given as coordinate arrays
        ``x, y, z`` (gripper frame, all of one shape): (..., nf) bool. numpy's
        form of the count loop's test (``_loops._count_loop``): the states at
        the point's nearest node, and for a finger they leave unsure, the
        spheres its lists name, ``dx * dx + dy * dy + dz * dz < r * r``. A
        point outside the grid reads a border node, where no finger is held."""
        codes, of, start, listed, owner = self.compact_lists
        _, _, centers, radii = self.sphere_lists
        shape = np.shape(x)
        # the nearest node's flat index, in floats (exact below 2**53)
        flat = np.zeros(shape)
        for axis, c in enumerate((x, y, z)):
            q = np.floor((c - self.origin[axis]) * (1.0 / self.cell) + 0.5)
            np.clip(q, 0.0, float(self.shape[axis] - 1), out=q)
            q *= float(self.strides[axis])
            flat += q
        # (n,) list codes, widened: ``code + 1`` of a byte's last code is 256
        code = codes[flat.astype(np.int64).ravel()].astype(np.int64)
        out = self.held_fingers[of[code]]  # (n, nf)
        # one row per (point, listed sphere): the entries of each point's code
        count = start[code + 1] - start[code]  # (n,) none where no finger is unsure
        point = np.repeat(np.arange(len(code)), count)  # (e,)
        first = np.repeat(start[code] - (np.cumsum(count) - count), count)
        entry = first + np.arange(len(point))
        s = listed[entry]
        d = [np.ravel(c)[point] - centers[s, k] for k, c in enumerate((x, y, z))]
        inside = d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < radii[s] * radii[s]
        out[point[inside], owner[entry[inside]]] = True
        return out.reshape(*shape, self.num_fingers)


class FingerSpheres(FingerDepth):
    """The :class:`FingerDepth` of ``gripper``'s workspace spheres, its sphere
    lists built here rather than in the first search: the index the finger
    tests of a pipeline's searches read, compiled or numpy's.

    Parameters
    ----------
    gripper : GripperModel
    cell : float, optional
        The nodes' spacing (m); by default as :class:`FingerDepth` sets it.
    """

    def __init__(self, gripper: GripperModel, cell: float | None = None) -> None:
        super().__init__(
            gripper.sphere_centers,
            gripper.sphere_radii,
            gripper.sphere_finger,
            gripper.num_fingers,
            cell,
        )
        _ = self.compact_lists  # built here, not in the first search


def _narrowest(count: int) -> type[np.integer]:
    """The narrowest integers that number ``count`` codes from 0: unsigned 8 or
    16 bits, else int32."""
    return np.uint8 if count <= 2**8 else np.uint16 if count <= 2**16 else np.int32


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
    wide = _narrowest(K)
    renumber = np.zeros(len(occurs), dtype=wide)
    renumber[present] = np.arange(K)
    base = 3 ** np.arange(digits - 1, -1, -1)  # (digits,) the digits' weights
    new = (present[:, None] // base[None, :]) % 3  # (K', digits)
    rows = states[present // 3**digits]  # (K', f)
    return np.take(renumber, code), np.concatenate([rows, new.astype(np.uint8)], axis=1)
