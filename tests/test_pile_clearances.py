"""The instances' clearances: each instance's distance to the nearest point of
any other instance or of the unsegmented points."""

from __future__ import annotations

import numpy as np
import pytest

from wsgrasp.perception.pile import _clearances


def _brute(clusters, stray):
    out = []
    for k, c in enumerate(clusters):
        others = [o for i, o in enumerate(clusters) if i != k]
        if len(stray):
            others.append(stray)
        if not others:
            out.append(np.inf)
            continue
        o = np.concatenate(others)
        out.append(np.sqrt(((c[:, None, :] - o[None, :, :]) ** 2).sum(axis=2)).min())
    return np.array(out)


@pytest.mark.parametrize("n_clusters", [0, 1, 2, 5])
@pytest.mark.parametrize("n_stray", [0, 7])
def test_clearances_are_the_least_distances_to_the_others(n_clusters, n_stray):
    rng = np.random.default_rng(n_clusters * 10 + n_stray)
    # clouds of different sizes around different centres
    clusters = [
        rng.normal(size=3) * 0.1 + rng.normal(scale=0.02, size=(int(n), 3))
        for n in rng.integers(5, 300, n_clusters)
    ]
    stray = rng.uniform(-0.2, 0.2, size=(n_stray, 3))
    got = _clearances(clusters, stray)
    assert got.shape == (n_clusters,)
    np.testing.assert_allclose(got, _brute(clusters, stray), rtol=1e-12)
    if n_clusters == 1 and not n_stray:
        assert np.isinf(got).all()
