"""Each finger's closing path, pre-grasp to closed: what the closing centre and a
model without sweeps are built from."""

from __future__ import annotations

import numpy as np
import pytest

from wsgrasp.gripper import load_gripper
from wsgrasp.planning.closing import closing_paths


@pytest.fixture(scope="module")
def allegro():
    return load_gripper("allegro_right")


def test_closing_paths_run_from_pregrasp_to_closed(allegro):
    paths = closing_paths(allegro)
    assert paths.shape == (allegro.num_fingers, 32, 3)
    # the curling fingers' pads sweep several centimetres along the approach
    depth = paths @ allegro.approach_axis  # (nf, K)
    assert np.ptp(depth[1:], axis=1).min() > 0.05
