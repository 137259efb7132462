"""Stage 4, the holdings: which object points each finger holds, for the feasible
candidates, held densely or computed in blocks on demand.

Evaluation decides feasibility from per-finger counts, scorers read per-finger sums
over the held points, the chosen grasp its own holding: none needs the dense
``(F, no, nf)`` mask at once (~90,000 × 800 × 4 bools for the Allegro's dense
sampling), which :class:`Holdings` builds only for code that reads it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp.planning._fields import BuiltOnRead
from wsgrasp.planning.fingers import FingerVerdicts, count_held

__all__ = ["Holdings", "HoldingField", "feasible_holdings"]

Array = NDArray[np.float64]

#: the held pairs of at most this many (candidate, point, finger) entries at once
_BLOCK_ENTRIES = 4_000_000
#: up to this many entries, a block's sums are one matrix product
_SMALL_BLOCK = 65_536


class Holdings:
    """Which object points each finger holds, per feasible candidate.

    Parameters
    ----------
    counts : (F, nf) int
        Points held per candidate and finger.
    num_points : int
        ``no``, the object points.
    rows : callable, optional
        ``rows(i)`` for positions ``i`` (k,) int: their holdings, (k, no, nf) bool.
    dense : (F, no, nf) bool, optional
        The holdings themselves (then ``rows`` is not needed).
    """

    def __init__(
        self,
        counts: NDArray[np.int64],
        num_points: int,
        rows: Callable[[NDArray[np.int64]], NDArray[np.bool_]] | None = None,
        dense: NDArray[np.bool_] | None = None,
    ) -> None:
        if rows is None and dense is None:
            raise ValueError("Holdings needs the holdings or a function giving rows")
        self.counts = np.asarray(counts, dtype=np.int64)
        self.num_points = int(num_points)
        self._rows = rows
        self._dense = dense

    @classmethod
    def of(cls, holding: NDArray[np.bool_]) -> Holdings:
        """Holdings of a dense ``(F, no, nf)`` bool array."""
        h = np.asarray(holding, dtype=bool)
        return cls(count_held(h), h.shape[1], dense=h)

    @property
    def shape(self) -> tuple[int, int, int]:
        F, nf = self.counts.shape
        return F, self.num_points, nf

    @property
    def is_dense(self) -> bool:
        """Whether the whole mask is held (no work to read it)."""
        return self._dense is not None

    def rows(self, index: NDArray[np.int64] | list[int]) -> NDArray[np.bool_]:
        """The holdings of candidates ``index`` (k,): (k, no, nf) bool."""
        i = np.asarray(index, dtype=np.int64).reshape(-1)
        if self._dense is not None:
            return self._dense[i]
        assert self._rows is not None
        if i.size == 0:
            return np.zeros((0, *self.shape[1:]), dtype=bool)
        return self._rows(i)

    def blocks(self) -> Iterator[tuple[slice, NDArray[np.bool_]]]:
        """The holdings in consecutive blocks of rows, bounded in size."""
        F, no, nf = self.shape
        step = max(1, _BLOCK_ENTRIES // max(no * nf, 1))
        d = self._dense
        for a in range(0, F, step):
            sl = slice(a, min(a + step, F))
            yield sl, d[sl] if d is not None else self.rows(np.arange(a, sl.stop))

    def dense(self) -> NDArray[np.bool_]:
        """The whole ``(F, no, nf)`` mask (built once, then kept)."""
        if self._dense is None:
            out = np.empty(self.shape, dtype=bool)
            for sl, block in self.blocks():
                out[sl] = block
            self._dense = out
        return self._dense

    def sums(self, values: Array) -> Array:
        """Per candidate and finger, the sum of ``values`` (no, d) over the points
        the finger holds: (F, nf, d) float.

        The blocks, and so the sums' rounding, depend only on ``(F, no, nf)``,
        not on how the holdings are stored. A small block is one matrix
        product; a large one sums its held entries (``bincount``), at a cost
        proportional to them.
        """
        v = np.asarray(values, dtype=np.float64).reshape(self.num_points, -1)
        F, _, nf = self.shape
        out = np.zeros((F, nf, v.shape[1]))
        for sl, block in self.blocks():
            n = sl.stop - sl.start
            if block.size <= _SMALL_BLOCK:
                # few entries: one product (its cost is the mask's size)
                out[sl] = block.transpose(0, 2, 1).astype(np.float64) @ v  # (n, nf, d)
                continue
            # (candidate, point, finger) of every held entry, row-major, from
            # flat indices (np.nonzero's three index arrays of the Franka's dense
            # block take 1.5-2 times as long)
            cj, f = np.divmod(np.flatnonzero(block.reshape(-1)), nf)
            c, j = np.divmod(cj, block.shape[1])
            key = c * nf + f  # (pairs,) the (candidate, finger) of each
            for k in range(v.shape[1]):
                out[sl, :, k] = np.bincount(
                    key, weights=v[j, k], minlength=n * nf
                ).reshape(n, nf)
        return out


def feasible_holdings(fingers: FingerVerdicts, feasible: NDArray[np.int64]) -> Holdings:
    """The holdings of the candidates at positions ``feasible`` (F,) of what the
    finger test found: the kept ones, or computed by its kernel when read."""
    p = np.asarray(feasible, dtype=np.int64)
    counts = fingers.counts[p]
    if fingers.held is not None:
        return Holdings(counts, fingers.num_points, dense=fingers.held[p])
    rows = fingers.rows
    return Holdings(counts, fingers.num_points, rows=lambda i: rows(p[i]))


class HoldingField(BuiltOnRead):
    """A dataclass field that stores a bool array or a :class:`Holdings` and
    reads as the ``(F, no, nf)`` bool array (built from the holdings on first
    read). ``holdings_of(obj)`` gives the :class:`Holdings` without building it.
    """

    def read(self, stored: NDArray[np.bool_] | Holdings) -> NDArray[np.bool_]:
        return stored.dense() if isinstance(stored, Holdings) else stored

    def keep(self, value: NDArray[np.bool_] | Holdings) -> Any:
        return value if isinstance(value, Holdings) else np.asarray(value, dtype=bool)

    def holdings_of(self, obj: Any) -> Holdings:
        got = self.stored(obj)
        if isinstance(got, Holdings):
            return got
        h = Holdings.of(got)
        self.__set__(obj, h)  # kept as it is
        return h
