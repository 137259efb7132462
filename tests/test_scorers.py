"""Built-in scorers on hand-made batches: each prefers what it says it prefers."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import make_jaw_gripper

from wsgrasp.errors import PluginError
from wsgrasp.planning.scoring import CandidateBatch, combine_scores
from wsgrasp.plugins import get_registry


def _batch(
    holding, normals, approach=((0, 0, -1),), closing=((0, 1, 0),), heights=None
):
    holding = np.asarray(holding, dtype=bool)
    F = holding.shape[0]
    T = np.tile(np.eye(4), (F, 1, 1))
    a = np.broadcast_to(np.asarray(approach, float), (F, 3))
    c = np.broadcast_to(np.asarray(closing, float), (F, 3))
    T[:, :3, 2] = a
    T[:, :3, 1] = c
    T[:, :3, 0] = np.cross(c, a)
    points = np.array([[0.0, 0.03, 0.0], [0.0, -0.03, 0.0], [0.03, 0.0, 0.0]])
    heights = np.zeros(F) if heights is None else np.asarray(heights)
    return _jaw_batch(T, holding, points, np.asarray(normals, dtype=float), heights)


def _jaw_batch(T, holding, points, normals, heights, T_world_table=None):
    """A batch of the jaw gripper at poses ``T`` over ``points`` with ``normals``."""
    return CandidateBatch(
        gripper=make_jaw_gripper(),
        T_world_gwc=T,
        T_world_gripper=T,
        theta=np.zeros(len(T)),
        holding=holding,
        object_points=points,
        T_world_object=np.eye(4),
        extents=np.array([0.06, 0.06, 0.1]),
        table_normal=np.array([0.0, 0.0, 1.0]),
        min_table_height=heights,
        normals_fn=lambda p: normals,
        T_world_table=T_world_table,
    )


def _scorer(name):
    entry = get_registry().get("scorers", name)
    return entry.obj(), entry.obj.Options()


NORMALS = [[0, 1, 0], [0, -1, 0], [1, 0, 0]]
# candidate 0: fingers on opposite faces; candidate 1: one face and a side face
HOLD = [
    [[True, False], [False, True], [False, False]],
    [[True, False], [False, False], [False, True]],
]


def test_antipodal_prefers_opposite_faces_along_the_closing_axis():
    scorer, opts = _scorer("antipodal")
    s = scorer.score(_batch(HOLD, NORMALS), opts)
    assert s[0] == pytest.approx(1.0)
    assert s[1] < 0.7


def test_wrench_balance_prefers_pushes_that_cancel():
    scorer, opts = _scorer("wrench_balance")
    s = scorer.score(_batch(HOLD, NORMALS), opts)
    assert s[0] == pytest.approx(1.0)  # opposite faces, on one line
    # a face and a side face: the net force is |(1, 1, 0)| / 2, no torque
    assert s[1] == pytest.approx(1.0 - 0.5 * np.sqrt(2.0) / 2.0)


def test_wrench_balance_sees_a_couple():
    """Opposite normals whose contacts are offset across the closing line push
    the object round: the same net force (none), a torque, a lower score."""
    scorer, opts = _scorer("wrench_balance")
    points = np.array([[0.0, 0.03, 0.0], [0.0, -0.03, 0.0], [0.04, -0.03, 0.0]])
    normals = np.array([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [0.0, -1.0, 0.0]])
    holding = np.zeros((2, 3, 2), dtype=bool)
    holding[0, 0, 0] = holding[0, 1, 1] = True  # on one line
    holding[1, 0, 0] = holding[1, 2, 1] = True  # offset 4 cm along x
    T = np.tile(np.eye(4), (2, 1, 1))
    s = scorer.score(_jaw_batch(T, holding, points, normals, np.zeros(2)), opts)
    assert s[0] == pytest.approx(1.0) and s[1] < 0.9


def test_contact_depth_prefers_contacts_down_the_object():
    """Approach straight down (-z) over an object 10 cm tall: contacts at its
    top score 0, halfway down (the default ``depth``) and deeper score 1."""
    scorer, opts = _scorer("contact_depth")
    z = np.array([0.1, 0.1, 0.05, 0.05, 0.0, 0.0])
    points = np.stack([np.tile([0.03, -0.03], 3), np.zeros(6), z], axis=1)
    normals = np.stack([np.tile([1.0, -1.0], 3), np.zeros(6), np.zeros(6)], axis=1)
    holding = np.zeros((3, 6, 2), dtype=bool)
    for k, (i, j) in enumerate([(0, 1), (2, 3), (4, 5)]):
        holding[k, i, 0] = holding[k, j, 1] = True
    T = np.tile(np.eye(4), (3, 1, 1))
    T[:, :3, 2] = [0.0, 0.0, -1.0]  # approach axis
    T[:, :3, 0] = [1.0, 0.0, 0.0]
    T[:, :3, 1] = np.cross(T[0, :3, 2], T[0, :3, 0])
    s = scorer.score(_jaw_batch(T, holding, points, normals, np.zeros(3)), opts)
    np.testing.assert_allclose(s, [0.0, 1.0, 1.0])
    shallow = scorer.Options(depth=1.0)
    np.testing.assert_allclose(
        scorer.score(_jaw_batch(T, holding, points, normals, np.zeros(3)), shallow),
        [0.0, 0.5, 1.0],
    )


def test_contact_balance():
    scorer, opts = _scorer("contact_balance")
    hold = [[[True, False], [True, False], [False, True]], HOLD[0]]
    s = scorer.score(_batch(hold, NORMALS), opts)
    np.testing.assert_allclose(s, [0.5, 1.0])


def test_table_clearance_saturates():
    scorer, opts = _scorer("table_clearance")
    s = scorer.score(_batch(HOLD * 2, NORMALS, heights=[0.0, 0.015, 0.03, 0.5]), opts)
    np.testing.assert_allclose(s, [0.0, 0.5, 1.0, 1.0])


def test_approach_direction_prefers_top_down():
    scorer, opts = _scorer("approach_direction")
    b = _batch(HOLD, NORMALS, approach=[(0, 0, -1), (1, 0, 0)])
    np.testing.assert_allclose(scorer.score(b, opts), [1.0, 0.5])


def test_approach_direction_level_prefers_the_side_from_any_side():
    scorer, _ = _scorer("approach_direction")
    opts = scorer.Options(direction="level")
    tilted = (np.sin(np.pi / 6), 0.0, -np.cos(np.pi / 6))  # 30 degrees off down
    approaches = [(0, 0, -1), tilted, (1, 0, 0), (0, -1, 0)]
    b = _batch(HOLD * 2, NORMALS, approach=approaches)
    np.testing.assert_allclose(
        scorer.score(b, opts), [0.0, 1.0 - np.cos(np.pi / 6), 1.0, 1.0], atol=1e-12
    )


def test_centroid_distance_is_monotone_in_distance():
    scorer, opts = _scorer("centroid_distance")
    b = _batch(HOLD * 3, NORMALS)
    b.T_world_gwc[:, 0, 3] = [0.0, 0.01, 0.02, 0.05, 0.02, 0.0]
    s = scorer.score(b, opts)
    assert s[0] == s[5] == pytest.approx(1.0)
    assert s[0] > s[1] > s[2] > s[3]


def _cap(toward: np.ndarray, r: float = 0.035, n: int = 2000) -> np.ndarray:
    """The points of a ball of radius ``r`` resting on the table z = 0 at the
    origin that a camera in direction ``toward`` (unit, from the ball) sees."""
    rng = np.random.default_rng(0)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    return (r * d + [0.0, 0.0, r])[d @ toward > 0.0]


def _seen_from(*cameras):
    """The ball's centroid as the scorers see it, from ``cameras`` (each a
    direction from the ball, unit), and the ball's centre."""
    from wsgrasp.perception.sides import behind_the_side

    seen = np.concatenate([_cap(np.asarray(c) / np.linalg.norm(c)) for c in cameras])
    centroid = seen.mean(axis=0)
    viewpoints = np.array([0.0, 0.0, 0.035]) + 0.5 * np.asarray(cameras, float)
    shift = behind_the_side(seen, centroid, np.array([0.0, 0.0, 1.0]), viewpoints)
    return centroid, centroid + shift, np.array([0.0, 0.0, 0.035])


@pytest.mark.parametrize("camera", [(1.0, 0.0, 1.0), (0.3, -0.8, 0.5), (1.0, 1.0, 0.2)])
def test_a_ball_seen_from_one_side_is_centred_behind_what_is_seen(camera):
    # the seen cap's centroid lies towards the camera; the ball's crest, which
    # a camera above the table sees, runs over its middle
    centroid, shifted, centre = _seen_from(camera)
    assert np.linalg.norm((centroid - centre)[:2]) > 0.008
    assert np.linalg.norm((shifted - centre)[:2]) < 0.005


def test_a_ball_seen_from_around_or_above_is_left_as_seen():
    for cameras in (
        [(1.0, 0.0, 1.0), (-1.0, 0.1, 1.0)],  # two sides
        [(1.0, 0.0, 1.0), (-0.5, 0.87, 1.0), (-0.5, -0.87, 1.0)],  # all round
        [(0.05, 0.0, 1.0)],  # straight above
    ):
        centroid, shifted, _ = _seen_from(*cameras)
        np.testing.assert_array_equal(shifted, centroid)
    # a box seen from one side, its top face whole, and a rod lying across the
    # camera's view, its crest over its middle: about as seen, however much
    # wider than deep they look
    from wsgrasp.perception.sides import behind_the_side

    rng = np.random.default_rng(1)
    box = rng.uniform([-0.02, -0.05, 0.0], [0.02, 0.05, 0.1], (500, 3))
    t = rng.uniform(0.0, np.pi, 800)  # the half of a rod along x facing -y
    rod = np.column_stack(
        [rng.uniform(-0.1, 0.1, 800), -0.01 * np.sin(t), 0.01 + 0.01 * np.cos(t)]
    )
    for seen in (box, rod):
        shift = behind_the_side(
            seen,
            seen.mean(axis=0),
            np.array([0.0, 0.0, 1.0]),
            np.array([[0.0, -0.5, 0.3]]),
        )
        assert np.linalg.norm(shift) < 0.003


def test_centroid_distance_scores_from_the_centroid_behind_one_side():
    scorer, opts = _scorer("centroid_distance")
    seen = _cap(np.array([1.0, 0.0, 1.0]) / np.sqrt(2.0))
    T_object = np.eye(4)
    T_object[:3, 3] = seen.mean(axis=0)
    T = np.tile(np.eye(4), (2, 1, 1))
    T[0, :3, 3] = seen.mean(axis=0)  # at the seen points' centroid
    T[1, :3, 3] = [0.0, 0.0, T_object[2, 3]]  # over the ball's centre
    batch = CandidateBatch(
        gripper=make_jaw_gripper(),
        T_world_gwc=T,
        T_world_gripper=T,
        theta=np.zeros(2),
        holding=np.zeros((2, len(seen), 2), dtype=bool),
        object_points=seen,
        T_world_object=T_object,
        extents=np.array([0.07, 0.07, 0.07]),
        table_normal=np.array([0.0, 0.0, 1.0]),
        min_table_height=np.zeros(2),
        T_world_table=np.eye(4),
        viewpoints=np.array([[0.4, 0.0, 0.4]]),
    )
    s = scorer.score(batch, opts)
    assert s[1] > s[0]
    batch.viewpoints = None  # no camera poses: the points' centroid
    del batch.__dict__["centroid"]
    s = scorer.score(batch, opts)
    assert s[0] > s[1]


def test_weighted_sum_and_a_failing_scorer_named():
    b = _batch(HOLD, NORMALS)
    cd, cd_opts = _scorer("centroid_distance")
    ap, ap_opts = _scorer("antipodal")
    total, terms = combine_scores(
        b, [("centroid_distance", cd, cd_opts, 1.0), ("antipodal", ap, ap_opts, 2.0)]
    )
    np.testing.assert_allclose(
        total, terms["centroid_distance"] + 2 * terms["antipodal"]
    )

    class Broken:
        def score(self, batch, options):
            return np.zeros(len(batch) + 1)

    with pytest.raises(PluginError, match="scorer 'broken'"):
        combine_scores(b, [("broken", Broken(), None, 1.0)])


def test_mass_center_prefers_a_grasp_axis_through_the_centre():
    """Two pairs of opposite points, 4 cm apart in height, on an object resting
    on a table 4 cm below the lower pair: the estimated centre of mass lies at
    half the object's height, on the lower pair's axis."""
    scorer, opts = _scorer("mass_center")
    points = np.array([[0, 0.03, 0], [0, -0.03, 0], [0, 0.03, 0.04], [0, -0.03, 0.04]])
    holding = np.zeros((2, 4, 2), dtype=bool)
    holding[0, 0, 0] = holding[0, 1, 1] = True  # the lower pair
    holding[1, 2, 0] = holding[1, 3, 1] = True  # the upper pair
    T = np.tile(np.eye(4), (2, 1, 1))  # closing along y
    T_world_table = np.eye(4)
    T_world_table[2, 3] = -0.04
    batch = CandidateBatch(
        gripper=make_jaw_gripper(),
        T_world_gwc=T,
        T_world_gripper=T,
        theta=np.zeros(2),
        holding=holding,
        object_points=points,
        T_world_object=np.eye(4),
        extents=np.array([0.01, 0.06, 0.04]),
        table_normal=np.array([0.0, 0.0, 1.0]),
        min_table_height=np.zeros(2),
        T_world_table=T_world_table,
    )
    np.testing.assert_allclose(batch.mass_center, [0.0, 0.0, 0.0], atol=1e-12)
    s = scorer.score(batch, opts)
    assert s[0] == pytest.approx(1.0) and s[1] < 0.7


def test_joint_margin_prefers_contacts_inside_the_joint_range():
    """On the Franka hand, an object as wide as the opening and a sliver both sit
    at a joint limit; one 4 cm wide sits mid-range."""
    from wsgrasp.gripper import load_gripper

    g = load_gripper("franka_hand")
    scorer, opts = _scorer("joint_margin")
    y = g.closing_axis
    ws = (g.sphere_centers - g.T_gripper_gwc[:3, 3]) @ g.approach_axis
    depth = g.T_gripper_gwc[:3, 3] + g.approach_axis * float(np.median(ws))
    scores = []
    for half in (0.039, 0.02, 0.002):
        points = np.array([depth + half * y, depth - half * y])
        batch = CandidateBatch(
            gripper=g,
            T_world_gwc=g.T_gripper_gwc[None],
            T_world_gripper=np.eye(4)[None],
            theta=np.zeros(1),
            holding=np.array([[[True, False], [False, True]]]),
            object_points=points,
            T_world_object=np.eye(4),
            extents=np.array([0.08, 0.05, 0.05]),
            table_normal=np.array([0.0, 0.0, 1.0]),
            min_table_height=np.zeros(1),
        )
        scores.append(float(scorer.score(batch, opts)[0]))
    assert scores[1] > 0.8 and scores[0] < 0.2 and scores[2] < 0.2, scores


@pytest.mark.parametrize("seed", range(4), ids=lambda s: f"seed{s}")
def test_contact_quantities_from_held_points_match_the_mask(seed):
    """Counts, centroids and normals per finger equal those of the float mask's
    products (to rounding), and every built-in scorer gives the same values
    from holdings built on demand as from the mask, without building it."""
    from wsgrasp.planning.holdings import Holdings

    rng = np.random.default_rng(seed)
    F, no, nf = 30, 50, 2
    holding = rng.random((F, no, nf)) < 0.2
    holding[0, :, 1] = False  # a finger that holds nothing
    points = rng.normal(0.0, 0.05, (no, 3))
    normals = rng.normal(size=(no, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    T = np.tile(np.eye(4), (F, 1, 1))
    T[:, :3, 3] = rng.normal(0.0, 0.05, (F, 3))

    def batch(h):
        return _jaw_batch(T, h, points, normals, np.full(F, 0.01), np.eye(4))

    dense = batch(holding)
    weights = holding.transpose(0, 2, 1).astype(np.float64)  # (F, nf, no)
    counts = np.count_nonzero(holding, axis=1)
    np.testing.assert_array_equal(dense.contacts, counts)
    with np.errstate(invalid="ignore", divide="ignore"):
        centroids = (weights @ points) / counts[..., None]
    np.testing.assert_allclose(dense.contact_centroids, centroids, rtol=1e-12)
    n = weights @ normals
    norm = np.linalg.norm(n, axis=-1, keepdims=True)
    unit = np.divide(n, norm, out=np.zeros_like(n), where=norm > 0)
    np.testing.assert_allclose(dense.contact_normals, unit, rtol=1e-12, atol=1e-15)

    built: list[int] = []

    def rows(i):
        built.append(len(i))
        return holding[i]

    lazy = batch(Holdings(counts, no, rows=rows))
    for name in ("contact_balance", "antipodal", "mass_center", "centroid_distance"):
        scorer, opts = _scorer(name)
        np.testing.assert_array_equal(
            scorer.score(lazy, opts), scorer.score(dense, opts)
        )
    assert "holding" not in lazy.__dict__ and isinstance(lazy._holding, Holdings)
    assert not lazy._holding.is_dense  # the sums read blocks; no mask was kept


def test_closing_centre_prefers_fingers_closing_on_the_centre_of_mass():
    """The Franka hand closes its pads together between the fingertips; a
    candidate that puts that point on the object's centre of mass scores 1, one
    5 cm beside it less. A model without finger configurations closes on its
    tool frame's origin."""
    from wsgrasp.gripper import load_gripper
    from wsgrasp.planning.closing import closing_centre

    g = load_gripper("franka_hand")
    c = closing_centre(g)
    assert abs(c[0]) < 1e-3 and abs(c[1]) < 1e-3
    assert np.linalg.norm(c - g.T_gripper_tcp[:3, 3]) < 0.02
    jaw = make_jaw_gripper()
    np.testing.assert_allclose(closing_centre(jaw), jaw.T_gripper_tcp[:3, 3])

    scorer, opts = _scorer("closing_centre")
    T = np.tile(np.eye(4), (2, 1, 1))
    T[:, :3, 3] = -c  # the closing centre at the origin ...
    T[1, 0, 3] += 0.05  # ... and 5 cm beside it
    points = np.array([[0.0, 0.02, -0.01], [0.0, -0.02, 0.01]])
    batch = CandidateBatch(
        gripper=g,
        T_world_gwc=T,
        T_world_gripper=T,
        theta=np.zeros(2),
        holding=np.ones((2, 2, g.num_fingers), dtype=bool),
        object_points=points,
        T_world_object=np.eye(4),
        extents=np.array([0.02, 0.04, 0.02]),
        table_normal=np.array([0.0, 0.0, 1.0]),
        min_table_height=np.zeros(2),
    )
    s = scorer.score(batch, opts)
    assert s[0] == pytest.approx(1.0) and s[1] < 0.5


def test_squeeze_inward_prefers_a_push_towards_the_palm():
    """From above, pads on an object's upper edges (normals up and out) push it
    down and out of the hand; on its side faces (normals across) they push
    neither way; under a rounded overhang (normals down and out) they push it up
    into the palm."""
    scorer, opts = _scorer("squeeze_inward")
    s = np.sqrt(0.5)
    points = np.array([[0, 0.03, 0], [0, -0.03, 0]] * 3, dtype=float)
    normals = np.array(
        [[0, s, s], [0, -s, s], [0, 1, 0], [0, -1, 0], [0, s, -s], [0, -s, -s]]
    )
    holding = np.zeros((3, 6, 2), dtype=bool)
    for c in range(3):
        holding[c, 2 * c, 0] = holding[c, 2 * c + 1, 1] = True
    T = np.tile(np.eye(4), (3, 1, 1))
    T[:, :3, 2] = [0, 0, -1]  # approach straight down
    T[:, :3, 0] = [-1, 0, 0]
    batch = _jaw_batch(T, holding, points, normals, np.zeros(3))
    np.testing.assert_allclose(
        scorer.score(batch, opts), [0.5 - 0.5 * s, 0.5, 0.5 + 0.5 * s], atol=1e-12
    )
    # a finger holding nothing (one outside the gripper's contact_fingers) is
    # left out: the other's push alone, the same share as both edges'
    holding[0, 1, 1] = False
    batch = _jaw_batch(T, holding, points, normals, np.zeros(3))
    assert scorer.score(batch, opts)[0] == pytest.approx(0.5 - 0.5 * s)


def test_reach_down_prefers_a_gripper_down_at_the_table():
    """An object 4 cm tall on a table: a gripper whose lowest point is at the
    table scores 1, one 1 cm up 0.75, one level with the top or above it 0;
    without a table every candidate scores 1."""
    scorer, opts = _scorer("reach_down")
    points = np.array([[0, 0.03, 0.0], [0, -0.03, 0.04]])
    holding = np.ones((4, 2, 2), dtype=bool)
    T = np.tile(np.eye(4), (4, 1, 1))
    heights = np.array([0.0, 0.01, 0.04, 0.07])
    batch = _jaw_batch(T, holding, points, np.zeros((2, 3)), heights, np.eye(4))
    np.testing.assert_allclose(scorer.score(batch, opts), [1.0, 0.75, 0.0, 0.0])
    batch = _jaw_batch(T, holding, points, np.zeros((2, 3)), heights)
    np.testing.assert_array_equal(scorer.score(batch, opts), np.ones(4))


def test_reach_down_depth_asks_a_tall_object_for_its_top_alone():
    """With ``depth`` 2 cm, on an object 4 cm tall a gripper 2 cm down from the
    top already scores 1 and one 1 cm down 0.5; on one 1 cm tall the full score
    still needs the table."""
    entry = get_registry().get("scorers", "reach_down")
    scorer, opts = entry.obj(), entry.obj.Options(depth=0.02)
    holding = np.ones((3, 2, 2), dtype=bool)
    T = np.tile(np.eye(4), (3, 1, 1))
    heights = np.array([0.0, 0.02, 0.03])
    tall = np.array([[0, 0.03, 0.0], [0, -0.03, 0.04]])
    batch = _jaw_batch(T, holding, tall, np.zeros((2, 3)), heights, np.eye(4))
    np.testing.assert_allclose(scorer.score(batch, opts), [1.0, 1.0, 0.5])
    flat = np.array([[0, 0.03, 0.0], [0, -0.03, 0.01]])
    batch = _jaw_batch(
        T, holding, flat, np.zeros((2, 3)), np.array([0.0, 0.005, 0.01]), np.eye(4)
    )
    np.testing.assert_allclose(scorer.score(batch, opts), [1.0, 0.5, 0.0])


def test_pose_margin_counts_the_moved_poses_that_stay_feasible():
    """With a scene on which a pose is feasible while its origin stays within
    4 mm of the object's centroid along x, a candidate at the centroid keeps 10
    of its 12 moved poses (the two 5 mm moves along x leave), one 2 mm along x
    keeps 11 (the move away from the centroid leaves; 3-degree turns about the
    centroid shift it by microns) and one 6 mm along keeps 1 (the move back)."""
    scorer, opts = _scorer("pose_margin")
    T = np.tile(np.eye(4), (3, 1, 1))
    T[:, 0, 3] = [0.0, 0.002, 0.006]
    seen = []

    def feasible_at(poses):
        seen.append(poses.shape)
        return np.abs(poses[:, 0, 3]) < 0.004

    batch = _jaw_batch(T, np.ones((3, 3, 2), bool), np.zeros((3, 3)), None, np.zeros(3))
    batch.feasible_fn = feasible_at
    np.testing.assert_allclose(scorer.score(batch, opts), [10 / 12, 11 / 12, 1 / 12])
    assert seen == [(36, 4, 4)]  # every moved pose in one call


def test_pose_margin_turns_about_the_object_centroid():
    """A 3-degree turn about the centroid moves a pose 10 cm from it by about
    5 mm: on a scene that allows 4 mm of drift in any direction, the four turns
    about the two axes across the offset leave, the two about it stay, and the
    six 5 mm moves all leave."""
    scorer, opts = _scorer("pose_margin")
    T = np.eye(4)[None].copy()
    T[0, :3, 3] = [0.1, 0.0, 0.0]
    batch = _jaw_batch(T, np.ones((1, 3, 2), bool), np.zeros((3, 3)), None, np.zeros(1))
    batch.feasible_fn = lambda poses: (
        np.linalg.norm(poses[:, :3, 3] - [0.1, 0.0, 0.0], axis=1) < 0.004
    )
    np.testing.assert_allclose(scorer.score(batch, opts), [2 / 12])


def test_pose_margin_needs_a_batch_that_can_test_poses():
    scorer, opts = _scorer("pose_margin")
    batch = _jaw_batch(
        np.eye(4)[None], np.ones((1, 3, 2), bool), np.zeros((3, 3)), None, np.zeros(1)
    )
    with pytest.raises(PluginError, match="cannot test other poses"):
        scorer.score(batch, opts)


def test_a_plans_batch_tests_poses_as_its_search_does(monkeypatch):
    """Through a plan, ``feasible_at`` gives the search's own verdict: true at
    every feasible candidate's pose, false at every rejected one's; and
    ``pose_margin`` is recorded as a share of 12 moved poses."""
    from pathlib import Path

    from wsgrasp_scorers import PoseMarginScorer

    from wsgrasp.api import Pipeline, as_scene
    from wsgrasp.spec import load_spec

    root = Path(__file__).resolve().parents[1]
    seen = []
    score = PoseMarginScorer.score

    def keep(self, batch, options):
        seen.append(batch)
        return score(self, batch, options)

    monkeypatch.setattr(PoseMarginScorer, "score", keep)
    spec = load_spec(root / "examples" / "specs" / "franka.yaml").model_dump()
    spec["scorers"].append({"name": "pose_margin", "weight": 0.0})
    result = Pipeline(load_spec(spec)).plan(
        as_scene(root / "examples" / "scenes" / "box_upright.npz")
    )
    (batch,) = seen
    c = result.candidates
    feasible = np.flatnonzero(c.feasible)
    assert feasible.size == len(batch)
    assert batch.feasible_at(c.T_world_ee[feasible]).all()
    rejected = np.flatnonzero(~c.feasible)[:200]
    assert not batch.feasible_at(c.T_world_ee[rejected]).any()
    margin = c.terms["pose_margin"][feasible]
    np.testing.assert_allclose(margin * 12, np.round(margin * 12))
    assert (margin > 0).all() and (margin <= 1).all()
