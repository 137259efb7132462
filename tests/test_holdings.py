"""Holdings given densely or built in blocks on demand read the same, and their
per-finger sums are those of the held points."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wsgrasp.planning import holdings as _holdings
from wsgrasp.planning.holdings import HoldingField, Holdings


def _lazy(holding: np.ndarray, calls: list[int]) -> Holdings:
    """Holdings of ``holding`` that compute rows on demand, counting the calls."""

    def rows(i):
        calls.append(len(i))
        return holding[i]

    return Holdings(np.count_nonzero(holding, axis=1), holding.shape[1], rows=rows)


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    F=st.integers(0, 40),
    no=st.integers(1, 60),
    nf=st.integers(1, 4),
    block=st.integers(1, 500),
    small=st.sampled_from([0, 100, 10**9]),
)
def test_lazy_and_dense_holdings_read_the_same(seed, F, no, nf, block, small):
    """Sums by held entries (bincount) or by one product per block, in blocks of
    any size: lazy and dense holdings give the same bits, and the sums are the
    held points' to rounding."""
    rng = np.random.default_rng(seed)
    holding = rng.random((F, no, nf)) < 0.3
    values = rng.normal(size=(no, 3))
    saved = _holdings._BLOCK_ENTRIES, _holdings._SMALL_BLOCK
    _holdings._BLOCK_ENTRIES, _holdings._SMALL_BLOCK = block, small
    try:
        _check_lazy_and_dense(holding, values, rng, F)
    finally:
        _holdings._BLOCK_ENTRIES, _holdings._SMALL_BLOCK = saved


def _check_lazy_and_dense(holding, values, rng, F):
    calls: list[int] = []
    lazy, dense = _lazy(holding, calls), Holdings.of(holding)
    assert lazy.shape == dense.shape == holding.shape
    np.testing.assert_array_equal(lazy.counts, dense.counts)
    # each (candidate, finger) sum adds its held points in point order: the
    # same bits whatever the blocks
    np.testing.assert_array_equal(lazy.sums(values), dense.sums(values))
    want = np.einsum("fnk,nd->fkd", holding.astype(float), values)
    np.testing.assert_allclose(dense.sums(values), want, rtol=1e-12, atol=1e-15)
    some = rng.integers(0, max(F, 1), 3) if F else np.zeros(0, dtype=np.int64)
    np.testing.assert_array_equal(lazy.rows(some), holding[some])
    assert not lazy.is_dense
    np.testing.assert_array_equal(lazy.dense(), holding)
    assert lazy.is_dense
    before = len(calls)
    lazy.dense()  # kept
    lazy.sums(values)
    assert len(calls) == before


def test_holdings_need_rows_or_the_mask():
    with pytest.raises(ValueError, match="holdings or a function"):
        Holdings(np.zeros((1, 2), dtype=np.int64), 3)


@dataclass
class _Batch:
    name: str
    holding: np.ndarray = HoldingField()  # type: ignore[assignment]
    after: int = 0


def test_holding_field_reads_as_the_mask_and_builds_it_once():
    holding = np.random.default_rng(0).random((5, 7, 2)) < 0.5
    calls: list[int] = []
    b = _Batch("lazy", _lazy(holding, calls), 3)
    assert calls == []  # nothing built on construction
    h = _Batch.__dict__["holding"].holdings_of(b)
    np.testing.assert_array_equal(h.counts, np.count_nonzero(holding, axis=1))
    assert calls == []
    np.testing.assert_array_equal(b.holding, holding)
    assert b.holding is b.holding  # built once
    c = _Batch("dense", holding)  # an array reads back as itself
    np.testing.assert_array_equal(c.holding, holding)
    assert _Batch.__dict__["holding"].holdings_of(c).is_dense
    with pytest.raises(TypeError):
        _Batch("missing")  # type: ignore[call-arg]  # the field has no default
