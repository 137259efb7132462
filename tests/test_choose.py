"""``Pipeline.plan(..., choose=i)``: the plan that takes candidate ``i`` as its
choice, finished as the plan finishes its own (back-off, pre-grasp, targets)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from wsgrasp.api import Pipeline, as_scene
from wsgrasp.errors import InputError
from wsgrasp.planning.sweeps import sweep_back_offs
from wsgrasp.planning.targets import pregrasp_pose
from wsgrasp.spec import load_spec

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "examples" / "scenes" / "box_upright.npz"


@pytest.fixture(scope="module", params=["franka", "allegro"])
def planned(request):
    pipe = Pipeline(load_spec(ROOT / "examples" / "specs" / f"{request.param}.yaml"))
    return pipe, pipe.plan(SCENE)


def test_choosing_the_plans_own_choice_gives_the_same_plan(planned):
    pipe, result = planned
    assert result.found
    again = pipe.plan(SCENE, choose=result.best_index)
    assert again.best_index == result.best_index
    np.testing.assert_array_equal(again.T_world_ee, result.T_world_ee)
    np.testing.assert_array_equal(again.T_world_pregrasp, result.T_world_pregrasp)
    assert again.joints_grasp == result.joints_grasp
    assert again.joints_pregrasp == result.joints_pregrasp


def test_an_alternative_taken_is_finished_as_a_choice(planned):
    pipe, result = planned
    cands = result.candidates
    feasible = np.flatnonzero(cands.reason == 0)
    # the lowest-ranked feasible candidate whose pre-grasp pose is clear
    order = feasible[np.argsort(-cands.score[feasible], kind="stable")]
    for index in map(int, order[::-1]):
        taken = pipe.plan(SCENE, choose=index)
        if taken.found:
            break
    assert taken.found and taken.best_index == index != result.best_index
    assert taken.score == pytest.approx(cands.score[index])
    g = pipe.gripper
    T = cands.T_world_ee[index]  # the candidate's pose before any back-off
    inp = pipe.prepare(as_scene(SCENE)).search_input
    d = sweep_back_offs(g, T[None], inp.table.T_world_table, inp.object_points)[0]
    # backed off where its fingers' closing sweeps would pass through the table
    # before they reach the object, never moved otherwise
    want = pregrasp_pose(g, T, d) if d > 0.0 else T
    np.testing.assert_allclose(taken.T_world_ee, want, atol=1e-12)
    # its contacts are its own: every finger holds points, and targets exist
    assert all(len(c.points) for c in taken.contacts)
    assert set(taken.joints_grasp) == set(g.actuated_joints)
    assert [a.index for a in taken.alternatives] == []  # nothing ranks below it


def test_an_infeasible_candidate_is_refused_with_its_reason(planned):
    pipe, result = planned
    rejected = int(np.flatnonzero(result.candidates.reason != 0)[0])
    with pytest.raises(InputError, match=f"candidate {rejected}"):
        pipe.plan(SCENE, choose=rejected)
    with pytest.raises(InputError, match="candidate"):
        pipe.plan(SCENE, choose=len(result.candidates))


def test_plan_choose_on_the_command_line(capsys):
    import json

    from wsgrasp.cli import main

    base = ["plan", str(SCENE), "-g", "franka_hand", "--no-record", "--json"]
    assert main(base) == 0
    first = json.loads(capsys.readouterr().out)
    alt = first["alternatives"][1]
    assert main([*base, "--choose", str(alt["index"])]) == 0
    taken = json.loads(capsys.readouterr().out)
    assert taken["found"] and taken["score"] == pytest.approx(alt["score"])
    # the alternatives: the candidates ranked after it, as many as the spec keeps
    after = first["alternatives"][2:]
    assert taken["alternatives"][: len(after)] == after
    assert len(taken["alternatives"]) == len(first["alternatives"])
    # no such candidate: one line naming it, exit status 2, no traceback
    n = first["candidates"]
    assert main([*base, "--choose", str(n)]) == 2
    err = capsys.readouterr().err
    assert f"candidate {n}" in err and "Traceback" not in err


def test_a_run_that_took_a_candidate_replays_taking_it(planned, tmp_path):
    from wsgrasp.record import RunRecorder, open_run, replay_run

    pipe, result = planned
    index = result.alternatives[-1].index
    path = tmp_path / "chosen.mcap"
    recorder = RunRecorder(path)
    taken = pipe.plan(SCENE, observers=[recorder], choose=index)
    recorder.close()
    assert taken.best_index == index
    assert open_run(path).stages["choice"] == {"candidate": index}
    report = replay_run(path)
    assert report.identical, report.differences
    # with another spec, its candidates are others: the re-plan takes its best
    other = replay_run(path, spec=pipe.spec)
    assert any("by choice" in n for n in other.notes)


def test_plan_choices_gives_each_choose_plan_from_one_search(planned):
    pipe, result = planned
    picks = [result.best_index, *(a.index for a in result.alternatives[:3])]
    many = pipe.plan_choices(SCENE, picks)
    assert [r.best_index for r in many] == picks
    for i, got in zip(picks, many, strict=True):
        _assert_same_plan(got, pipe.plan(SCENE, choose=i))
    with pytest.raises(InputError, match="candidate"):
        pipe.plan_choices(SCENE, [len(result.candidates)])


def _assert_same_plan(got, one) -> None:
    """Two results are the same plan: pose, pre-grasp, targets, alternatives and
    contacts."""
    np.testing.assert_array_equal(got.T_world_ee, one.T_world_ee)
    np.testing.assert_array_equal(got.T_world_pregrasp, one.T_world_pregrasp)
    assert got.joints_grasp == one.joints_grasp
    assert got.joints_pregrasp == one.joints_pregrasp
    assert [a.index for a in got.alternatives] == [a.index for a in one.alternatives]
    assert [c.points.tolist() for c in got.contacts] == [
        c.points.tolist() for c in one.contacts
    ]


def test_plan_and_choices_gives_the_plan_and_its_picks_from_one_search(
    planned, monkeypatch
):
    pipe, result = planned
    searches = []
    search = pipe.search
    monkeypatch.setattr(pipe, "search", lambda prep: searches.append(1) or search(prep))
    seen = []

    def pick(res):
        seen.append(res.best_index)
        return [a.index for a in res.alternatives[:2]]

    own, many = pipe.plan_and_choices(SCENE, pick)
    assert len(searches) == 1
    assert seen == [result.best_index] == [own.best_index]
    _assert_same_plan(own, result)
    picks = [a.index for a in result.alternatives[:2]]
    assert [r.best_index for r in many] == picks
    for i, got in zip(picks, many, strict=True):
        _assert_same_plan(got, pipe.plan(SCENE, choose=i))
    with pytest.raises(InputError, match="candidate"):
        pipe.plan_and_choices(SCENE, lambda res: [len(res.candidates)])


class _Stages:
    """An observer that keeps what it is told, in order."""

    def __init__(self) -> None:
        self.seen: list[str] = []

    def on_start(self, spec, gripper, scene):  # type: ignore[no-untyped-def]
        self.seen.append("start")

    def on_stage(self, stage, data):  # type: ignore[no-untyped-def]
        self.seen.append(stage)

    def on_result(self, result):  # type: ignore[no-untyped-def]
        self.seen.append(f"result {result.best_index}")

    def on_error(self, error):  # type: ignore[no-untyped-def]
        self.seen.append("error")


def test_observed_plan_and_choices_searches_once_and_tells_what_plan_tells(
    planned, monkeypatch
):
    """With observers, ``plan_and_choices`` still searches once; the observers
    hear the first plan exactly as ``plan`` tells it, and nothing of the picks."""
    pipe, result = planned
    alone = _Stages()
    pipe.plan(SCENE, observers=[alone])
    searches = []
    search = pipe.search
    monkeypatch.setattr(pipe, "search", lambda prep: searches.append(1) or search(prep))
    both = _Stages()
    picks = [a.index for a in result.alternatives[:2]]
    own, many = pipe.plan_and_choices(SCENE, lambda res: picks, observers=[both])
    assert len(searches) == 1
    assert both.seen == alone.seen
    assert both.seen[-1] == f"result {result.best_index}"
    _assert_same_plan(own, result)
    assert [r.best_index for r in many] == picks


def test_a_best_whose_pregrasp_hits_the_table_gives_way_to_the_first_clear_one(
    planned, monkeypatch
):
    """When the best's pre-grasp pose hits the table, the plan takes the first
    alternative clear of it, finished as choosing that alternative finishes it
    (its pose as taken, contacts, pre-grasp pose, targets)."""
    import wsgrasp.api as api

    pipe, result = planned
    assert result.alternatives
    best_pre = result.T_world_pregrasp
    real = api._hits_table

    def best_hits(g, table, T):  # type: ignore[no-untyped-def]
        return bool(np.array_equal(T, best_pre)) or real(g, table, T)

    monkeypatch.setattr(api, "_hits_table", best_hits)
    fallback = pipe.plan(SCENE)
    assert fallback.found and fallback.best_index != result.best_index
    assert fallback.best_index in [a.index for a in result.alternatives]
    monkeypatch.setattr(api, "_hits_table", real)
    # the first alternative a plan can take (its pre-grasp pose clear)
    first = next(
        a.index for a in result.alternatives if pipe.plan(SCENE, choose=a.index).found
    )
    assert fallback.best_index == first
    chosen = pipe.plan(SCENE, choose=fallback.best_index)
    np.testing.assert_array_equal(fallback.T_world_ee, chosen.T_world_ee)
    np.testing.assert_array_equal(fallback.T_world_pregrasp, chosen.T_world_pregrasp)
    assert fallback.joints_grasp == chosen.joints_grasp
    assert [len(c.points) for c in fallback.contacts] == [
        len(c.points) for c in chosen.contacts
    ]
    assert [a.index for a in fallback.alternatives] == [
        a.index for a in chosen.alternatives
    ]


def test_a_hand_closes_on_the_object_when_three_contact_fingers_reach_it():
    """``_closing_reaches``: the Allegro hand (four fingers) closes on
    points its fingers' sweeps reach when three of them do, not two; a jaw
    needs both fingers."""
    import wsgrasp.api as api
    from wsgrasp.gripper import load_gripper
    from wsgrasp.planning.closing import closing_paths

    hand = load_gripper("allegro_right")
    pads = closing_paths(hand)[:, -1]  # (nf, 3) each pad at the closed posture
    eye = np.eye(4)[None]
    assert api._closing_reaches(hand, eye, pads[:3])[0]
    assert not api._closing_reaches(hand, eye, pads[:2])[0]
    far = pads + np.array([0.0, 0.0, 0.5])  # half a metre off: nothing reaches
    assert not api._closing_reaches(hand, eye, far)[0]
    # a pose moved the same way as the points keeps the answer, per pose
    T = np.tile(np.eye(4), (2, 1, 1))
    T[1, :3, 3] = (0.0, 0.0, 0.5)
    np.testing.assert_array_equal(api._closing_reaches(hand, T, far), [False, True])
    jaw = load_gripper("franka_hand")
    path = closing_paths(jaw)
    jaw_pads = path[:, path.shape[1] // 2]  # half closed: apart
    assert api._closing_reaches(jaw, eye, jaw_pads)[0]
    assert not api._closing_reaches(jaw, eye, jaw_pads[:1])[0]


def test_a_closing_hand_whose_best_closes_beside_the_object_takes_the_next():
    """With ``close_to: closed``, a best whose fingers would close beside the
    object gives way to the best-scored candidate that closes on it, looked
    for past the alternatives; none: no grasp."""
    import wsgrasp.api as api

    spec = load_spec(ROOT / "examples" / "specs" / "allegro.yaml")
    assert spec.approach.close_to == "closed"
    pipe = Pipeline(spec)
    result = pipe.plan(SCENE)
    cands = result.candidates
    feasible = np.flatnonzero(cands.feasible)
    order = feasible[np.argsort(-cands.score[feasible], kind="stable")]
    beyond = order[len(result.alternatives) + 3]  # not an alternative
    real = api._closing_reaches
    at = cands.T_world_ee[beyond]

    def only_beyond(g, T, points):  # type: ignore[no-untyped-def]
        T = np.asarray(T).reshape(-1, 4, 4)
        ok = np.array([np.allclose(t[:3, :3], at[:3, :3]) for t in T])
        return ok & real(g, T, points)

    api_real = api._closing_reaches
    try:
        api._closing_reaches = only_beyond
        other = pipe.plan(SCENE)
        assert other.found
        picked = other.candidates.T_world_ee[other.best_index]
        np.testing.assert_allclose(picked[:3, :3], at[:3, :3])
        assert cands.score[other.best_index] <= cands.score[result.best_index]
        api._closing_reaches = lambda g, T, points: np.zeros(len(T), dtype=bool)
        assert not pipe.plan(SCENE).found
    finally:
        api._closing_reaches = api_real


def test_no_grasp_that_closes_on_the_object_says_so(monkeypatch):
    import wsgrasp.api as api

    pipe = Pipeline(load_spec(ROOT / "examples" / "specs" / "allegro.yaml"))
    monkeypatch.setattr(
        api, "_closing_reaches", lambda g, T, p: np.zeros(len(T), dtype=bool)
    )
    result = pipe.plan(SCENE)
    assert not result.found
    assert "closes beside the object" in result.hint
    assert "close_to: contacts" in result.hint
