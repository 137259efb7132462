"""The contact posture each finger takes: the configuration the joint targets
choose equals the plain definition (every allowed configuration scored by its pad
centre's distance to the nearest held point, with a full KD-tree query, pads
inside the object excluded), on random held points, spheres and grasp middles."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from wsgrasp.gripper import load_gripper
from wsgrasp.planning import targets


def _plain_contact(g, f, held, spheres, centre):
    """Index into the finger's grid, pad centre and gap, from the definition."""
    start = int(g.config_offsets[f])
    count = int(g.config_offsets[f + 1]) - start
    allowed = g.sphere_configurations(spheres) - start
    if len(allowed) == 0 or len(held) == 0:
        allowed = np.arange(count)
    _, near = targets.config_tree(g, f).query(held, k=min(16, count))
    is_near = np.zeros(count, dtype=bool)
    is_near[np.asarray(near).reshape(-1)] = True
    first = allowed[is_near[allowed]]
    for local in (first, allowed):
        if len(local) == 0:
            continue
        pads = g.config_pad[start + local]  # (c, 3)
        if len(held) == 0:
            nearest = np.zeros(len(pads))
        else:
            nearest, _ = cKDTree(held).query(pads)  # (c,)
            c_f = held.mean(axis=0)
            out = c_f - centre
            if np.linalg.norm(out) > 1e-9:
                inside = (pads - c_f) @ (out / np.linalg.norm(out)) < 0.0
                nearest = np.where(inside, np.inf, nearest)
        if np.isfinite(nearest).any():
            break
    best = int(np.argmin(nearest))
    return int(local[best]), pads[best], float(nearest[best])


def _cases(g, rng, n):
    """``n`` random (finger, held, spheres, centre): held points around some of
    the finger's pad centres, at several spreads; a middle far off, at the held
    points' centroid, or beyond them; a few points just off one pad centre with
    the middle towards their nearest pads (none of which qualifies, so farther
    ones must); sometimes no spheres or no points."""
    for i in range(n):
        f = int(rng.integers(g.num_fingers))
        own = np.flatnonzero(g.sphere_finger == f)
        spheres = rng.choice(own, int(rng.integers(0, min(len(own), 50) + 1)), False)
        o = g.config_offsets
        pads = g.config_pad[o[f] : o[f + 1]]
        count = 0 if i % 7 == 6 else int(rng.integers(1, 400))
        seeds = pads[rng.integers(0, len(pads), max(count // 20, 1))]
        spread = (0.002, 0.01, 0.03)[i % 3]
        held = seeds[rng.integers(0, len(seeds), count)] + rng.normal(
            0.0, spread, (count, 3)
        )  # (count, 3)
        centre = rng.normal(0.0, 0.05, 3)
        if count and i % 5 == 3:
            # a few points just off one pad centre, outwards, the middle inwards
            # along the line to their nearest pads: those pads lie inside, pads
            # farther out than the points do not
            p0 = pads[rng.integers(len(pads))]
            out = p0 - pads.mean(axis=0)
            held = p0 + 0.01 * out / np.linalg.norm(out) + rng.normal(0, 1e-3, (3, 3))
            _, near = targets.config_tree(g, f).query(held, k=min(16, len(pads)))
            inward = pads[np.asarray(near).reshape(-1)].mean(axis=0) - held.mean(0)
            centre = held.mean(axis=0) + inward
        elif count and i % 5 == 1:
            centre = held.mean(axis=0)
        elif count and i % 5 == 2:
            centre = held.mean(axis=0) + rng.normal(0.0, 0.5, 3)
        yield f, held, spheres, centre


@pytest.mark.parametrize("name", ["franka_hand", "allegro_right"])
def test_contact_posture_equals_the_plain_definition(name):
    g = load_gripper(name)
    rng = np.random.default_rng(0)
    for f, held, spheres, centre in _cases(g, rng, 150):
        got = targets._finger_target(g, f, held, spheres, 0.01, {}, centre)
        if len(held) == 0:  # a finger that holds nothing has no contact
            assert got.contact == {} and got.gap is None and got.squeeze == 0.0
            for j, v in got.grasp.items():
                lo, hi = g.finger_limits[f][g.finger_joints[f].index(j)]
                assert v == min(max(g.closed[j], lo), hi)
            continue
        local, pad, gap = _plain_contact(g, f, held, spheres, centre)
        q = g.finger_configurations(f)[local]
        np.testing.assert_array_equal(list(got.contact.values()), q)
        np.testing.assert_array_equal(got.pad_world, pad)
        assert got.gap == gap


def test_sphere_bits_list_each_spheres_configurations():
    """The packed per-sphere bits hold exactly the sphere's configuration list,
    and their union over spheres is ``sphere_configurations``."""
    g = load_gripper("allegro_right")
    rng = np.random.default_rng(0)
    assert (
        g.config_finger[g.sphere_config_index]
        == np.repeat(g.sphere_finger, np.diff(g.sphere_config_ptr))
    ).all()  # a sphere lists configurations of its own finger only
    for _ in range(20):
        f = int(rng.integers(g.num_fingers))
        own = np.flatnonzero(g.sphere_finger == f)
        spheres = rng.choice(own, int(rng.integers(0, 40)), replace=False)
        mask = targets._allowed_mask(g, f, spheres)
        expected = g.sphere_configurations(spheres) - g.config_offsets[f]
        np.testing.assert_array_equal(np.flatnonzero(mask), expected)
