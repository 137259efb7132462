"""`wsgrasp gripper new` and `gripper check` on URDFs as vendors publish them: names
of any form, limits written with 12 digits, wrist joints above the palm, visual
meshes that are missing, `package://` URIs, COLLADA meshes; and the seven real
descriptions of ../shared/grippers, scaffolded and checked with no hand edit."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml
from vendor_factory import (
    DEG10,
    DEG30,
    JAW_PARTS,
    forearm_hand_urdf,
    hand_urdf,
    named_jaw_urdf,
    swing_thumb_hand_urdf,
    write_mesh_jaw,
    write_package_xml,
)

from wsgrasp.cli import main
from wsgrasp.errors import GripperError
from wsgrasp.gripper._urdf import load_kinematics, shape_mesh
from wsgrasp.gripper.check import check_gripper
from wsgrasp.gripper.scaffold import (
    copy_urdf,
    guess_description,
    render_yaml,
    scaffold_plugin,
)
from wsgrasp.spec import GripperDescription

#: the development data of ../shared/grippers (not in the repository)
SHARED = Path(__file__).resolve().parents[2] / "shared" / "grippers"
#: id -> URDF under SHARED
VENDOR = {
    "ability": "ability_hand/ability_hand_right.urdf",
    "barrett": "barrett_hand/bhand_model.urdf",
    "dclaw": "dclaw_gripper/dclaw_gripper.urdf",
    "panda": "panda_gripper/panda_gripper_glb.urdf",
    "shadow": "shadow_hand/shadow_hand_right.urdf",
    "robotiq_2f": "robotiq/robotiq_2f_c2_gripper_visualization/urdf/"
    "robotiq_c2_model.urdf",
    "robotiq_3f": "robotiq/robotiq_3f_gripper_visualization/cfg/"
    "robotiq-3f-gripper_articulated.urdf",
}
#: scaffolded and checked in a few seconds each; the others are marked slow
FAST = {"panda", "robotiq_2f"}


@pytest.fixture(autouse=True)
def _cache(tmp_path_factory, monkeypatch):
    cache = tmp_path_factory.getbasetemp() / "gripper-cache"
    monkeypatch.setenv("WSGRASP_CACHE_DIR", str(cache))
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)


def _read_back(scaffold) -> GripperDescription:
    """The scaffold as written to YAML and read back."""
    return GripperDescription.model_validate(yaml.safe_load(render_yaml(scaffold)))


def _no_errors(yaml_path: Path) -> None:
    report = check_gripper(yaml_path)
    assert not report.errors, report.format()


# ------------------------------------------------------------------------------
# Names
# ------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("joints", "links"),
    [
        (("0", "1.5"), ("null", "1e3", "yes")),
        (("yes", "null"), ("palm: base", "left #1", "~")),
        (("it's", 'say "x"'), ("a,b", "[right]", "{palm}")),
    ],
    ids=["numbers", "yaml-words", "punctuation"],
)
def test_names_of_any_form_survive_the_yaml(tmp_path, joints, links):
    """Joint and link names that YAML would read as numbers, booleans, nulls,
    mappings or comments are quoted, and read back as the same strings."""
    palm, left, right = links
    (tmp_path / "jaw.urdf").write_text(named_jaw_urdf(joints, (left, palm, right)))
    sc = guess_description(tmp_path / "jaw.urdf", "jaw")
    desc = _read_back(sc)
    assert desc.base_link == left  # the root link
    assert {f.pad.link for f in desc.fingers} == {palm, right}
    assert sorted(j for f in desc.fingers for j in f.joints) == sorted(joints)
    assert set(desc.pregrasp) == set(joints) and set(desc.closed) == set(joints)


def test_hand_with_numbered_joints_scaffolds_and_checks(tmp_path):
    """A hand whose joints are named 0 ... 5."""
    names = [str(i) for i in range(6)]
    (tmp_path / "hand.urdf").write_text(hand_urdf(names=names))
    yaml_path, sc = scaffold_plugin("hand", tmp_path / "hand.urdf", tmp_path / "out")
    assert sc.build_error is None
    desc = GripperDescription.model_validate(yaml.safe_load(yaml_path.read_text()))
    assert all(isinstance(j, str) for f in desc.fingers for j in f.joints)
    assert set(desc.pregrasp) == set(names)
    _no_errors(yaml_path)


# ------------------------------------------------------------------------------
# Limits and postures
# ------------------------------------------------------------------------------
def test_limits_with_twelve_digits_stay_inside(tmp_path):
    """Limits written as 0.523598775598: the guessed postures are the limits
    themselves, at full precision, so the model builds."""
    urdf = tmp_path / "hand.urdf"
    urdf.write_text(hand_urdf(limits=(f"-{DEG30}", DEG10)))
    kin = load_kinematics(urdf, "hand")
    sc = guess_description(urdf, "hand")
    desc = _read_back(sc)
    for posture in (desc.pregrasp, desc.closed):
        for joint, value in posture.items():
            j = kin.joints[joint]
            assert j.lower <= value <= j.upper, (joint, value, j.lower, j.upper)
    assert -float(DEG30) in desc.pregrasp.values()
    yaml_path, sc = scaffold_plugin("hand", urdf, tmp_path / "out")
    assert sc.build_error is None
    _no_errors(yaml_path)


def test_wrist_joints_are_held_and_each_finger_closes_its_own_way(tmp_path):
    """Two wrist joints between the root and the palm move every finger: they are
    held (at 0, or mid-range when 0 is outside it) and in no finger. The lone
    finger closes towards its lower limits, the other two towards their upper
    ones; the approach follows the fingers although two are on one side."""
    urdf = tmp_path / "hand.urdf"
    wrist = [("WRJ2", "0 1 0", f"-{DEG30}", DEG10), ("WRJ1", "0 0 1", "0.2", "0.6")]
    urdf.write_text(hand_urdf(wrist=wrist))
    yaml_path, sc = scaffold_plugin("hand", urdf, tmp_path / "out")
    d = sc.data
    assert all("WRJ" not in j for f in d["fingers"] for j in f["joints"])
    assert d["pregrasp"]["WRJ2"] == d["closed"]["WRJ2"] == 0.0
    assert d["pregrasp"]["WRJ1"] == d["closed"]["WRJ1"] == pytest.approx(0.4)
    assert "wrist or palm" in sc.notes["fingers"]
    joints = {f["pad"]["link"]: f["joints"][0] for f in d["fingers"]}
    # each towards its own limit (upper, upper, lower), stopped where the pads
    # meet: the long fingers would curl past each other on to their limits
    pre, closed = d["pregrasp"], d["closed"]
    for link, sign in (
        ("finger0_distal", 1),
        ("finger1_distal", 1),
        ("finger2_distal", -1),
    ):
        j = joints[link]
        assert sign * closed[j] > sign * pre[j], link
        assert abs(closed[j]) < 1.2, link
    assert "stopped where the pads meet" in sc.notes["closed"]
    # their pads pass each other 17 mm from their centroid at the nearest: the
    # comment says so, and what to compare
    assert "pass each other without meeting" in sc.notes["closed"]
    assert "gripper tune" in sc.notes["closed"]
    assert "Tune the closing" in sc.notes["closed"]
    assert d["approach_axis"] == [0.0, 0.0, 1.0]
    # the palm turned 0.4 rad about z by the held wrist joint WRJ1
    np.testing.assert_allclose(
        d["closing_axis"], [-np.sin(0.4), np.cos(0.4), 0.0], atol=1e-6
    )
    report = check_gripper(yaml_path)
    assert not report.errors, report.format()
    assert all(f["pad_closes_mm"] > 10 for f in report.fingers), report.format()


def test_check_names_the_finger_that_closes_the_wrong_way(tmp_path):
    """One finger's pregrasp and closed swapped: `gripper check` reports that
    finger, on the field `closed`, and not the fingers whose distances it spoils.
    (Short fingers' ranges, so that no finger curls past the others.)"""
    urdf = tmp_path / "hand.urdf"
    urdf.write_text(hand_urdf(limits=("-0.3", "0.2")))
    data = guess_description(urdf, "hand").data
    data["joint_samples"] = 9
    lone = next(f for f in data["fingers"] if f["pad"]["link"] == "finger2_distal")
    for j in lone["joints"]:
        data["pregrasp"][j], data["closed"][j] = data["closed"][j], data["pregrasp"][j]
    bad = tmp_path / "swapped.yaml"
    bad.write_text(yaml.safe_dump(data, sort_keys=False))
    report = check_gripper(bad)
    errors = [p for p in report.errors if p.field == "closed"]
    assert len(errors) == 1, report.format()
    assert errors[0].message.startswith(f"finger {lone['name']}'s pad")
    assert str(lone["joints"]) in errors[0].fix


def test_thumb_is_held_where_it_closes_against_the_fingers(tmp_path):
    """A thumb whose flexion curls it in the plane of the palm at 0 of its turn
    joint (the Shadow hand's THJ4, THJ5): the turn joint moves its straight tip
    by nothing, so it is held, but where it holds the thumb decides whether the
    thumb closes beside the fingers or against them. It is held turned towards
    them, in pregrasp and closed alike, and the thumb still closes by flexing."""
    urdf = tmp_path / "hand.urdf"
    urdf.write_text(forearm_hand_urdf())
    sc = guess_description(urdf, "hand")
    d = sc.data
    thumb = next(f for f in d["fingers"] if f["pad"]["link"] == "th_distal")
    assert thumb["joints"] == ["THJ2", "THJ1"]
    assert d["pregrasp"]["THJ_TURN"] == d["closed"]["THJ_TURN"]
    assert 0.5 < d["pregrasp"]["THJ_TURN"] < 1.2  # turned, half-way or so
    assert "opposition" in sc.notes["pregrasp"]
    assert "THJ_TURN at" in sc.notes["pregrasp"]
    for j in ("THJ2", "THJ1"):
        assert (d["pregrasp"][j], d["closed"][j]) == (-0.3, 1.2)
    # a turn joint that cannot turn the thumb far enough keeps its hold value
    urdf.write_text(forearm_hand_urdf(thumb_turn=("0", "0.1")))
    d = guess_description(urdf, "hand").data
    assert d["pregrasp"]["THJ_TURN"] == d["closed"]["THJ_TURN"] == 0.0


def test_a_thumb_swung_about_the_fingers_is_held_closing_against_them(tmp_path):
    """A thumb whose swing joint turns it about a line near where the fingers
    reach (Dexmate's F5D6 hand): swinging brings it barely nearer them, but at
    0 it curls across the palm, beside the fingers, and swung it curls back
    against their pads. It is held swung, where it closes most straight against
    the fingers, and still closes by flexing; a swing too short to turn it much
    keeps its hold value."""
    urdf = tmp_path / "hand.urdf"
    urdf.write_text(swing_thumb_hand_urdf())
    sc = guess_description(urdf, "hand")
    d = sc.data
    thumb = next(f for f in d["fingers"] if f["pad"]["link"] == "th")
    assert thumb["joints"] == ["THJ1"]
    assert d["pregrasp"]["THJ0"] == d["closed"]["THJ0"]
    assert d["pregrasp"]["THJ0"] > 0.8  # in front of the palm
    assert "straight against the other fingers" in sc.notes["pregrasp"]
    assert sc.thumb_turning is not None
    assert sc.thumb_turning["turned"] == {"THJ0": (0.0, d["closed"]["THJ0"])}
    urdf.write_text(swing_thumb_hand_urdf(swing=("0", "0.1")))
    d = guess_description(urdf, "hand").data
    assert d["pregrasp"]["THJ0"] == d["closed"]["THJ0"] == 0.0


def test_a_held_thumb_has_a_turning_alternative_and_choose_thumb_picks(
    tmp_path, monkeypatch
):
    """Beside the thumb held opposed, the guess carries the same hand with the
    thumb's turn joint closing with it: open at its hold value (beside the
    palm), closed where it was held. ``choose_thumb`` keeps the held thumb
    where it finds grasps on half the low test objects or more, and turns it
    where it finds fewer and turning finds more; the note says which and why."""
    from wsgrasp.gripper import _approach

    urdf = tmp_path / "hand.urdf"
    urdf.write_text(forearm_hand_urdf())
    sc = guess_description(urdf, "hand")
    alt = sc.thumb_turning
    assert alt is not None
    held, opposed = sc.data["pregrasp"]["THJ_TURN"], sc.data["closed"]["THJ_TURN"]
    assert alt["turned"] == {"THJ_TURN": (0.0, opposed)}
    thumb = next(f for f in alt["data"]["fingers"] if f["pad"]["link"] == "th_distal")
    assert thumb["joints"] == ["THJ_TURN", "THJ2", "THJ1"]
    assert alt["data"]["pregrasp"]["THJ_TURN"] == 0.0 != held
    assert alt["data"]["closed"] == sc.data["closed"]
    for k in ("approach_axis", "closing_axis", "tool_frame"):
        assert alt["data"][k] == sc.data[k]
    n = len(_approach.low_object_scenes())
    for counts, turns, says in (
        ({"held": n // 2, "turning": n}, False, "so it is not turned"),
        ({"held": 0, "turning": n}, True, "it turns (THJ_TURN from 0 to"),
        ({"held": 1, "turning": 0}, False, "it stays held"),
    ):
        guess = guess_description(urdf, "hand")
        monkeypatch.setattr(
            _approach,
            "grasps_on_low_objects",
            lambda path, scenes, c=counts: c[path.stem.rsplit("-", 1)[-1]],
        )
        _approach.choose_thumb(guess, tmp_path)
        joints = next(
            f["joints"]
            for f in guess.data["fingers"]
            if f["pad"]["link"] == "th_distal"
        )
        assert ("THJ_TURN" in joints) == turns
        assert says in guess.notes["pregrasp"]
        assert not list(tmp_path.glob(".hand-thumb-*.yaml"))  # trial files removed
    # a gripper without a thumb held opposed has no alternative
    jaw = tmp_path / "jaw.urdf"
    jaw.write_text(named_jaw_urdf(("a", "b"), ("base", "l", "r")))
    assert guess_description(jaw, "jaw").thumb_turning is None


def _pad_centres(urdf: Path, data: dict, posture: dict) -> np.ndarray:
    """Each finger's pad centre (base frame) at ``posture``, ``(F, 3)``."""
    from wsgrasp.gripper import _guess as G

    u = G._read(urdf, "hand", None)
    return np.stack(
        [G._pad_points(u, f["pad"], posture, 1)[0] for f in data["fingers"]]
    )


def test_close_past_moves_closed_on_along_the_closing_line(tmp_path):
    """``--close-past``: a hand stopped where its pads come nearest closes on,
    along the same line in joint space, until the pads have travelled that
    much more on average; the comment says so instead of advising it."""
    urdf = tmp_path / "hand.urdf"
    urdf.write_text(hand_urdf())
    at = guess_description(urdf, "hand")
    on = guess_description(urdf, "hand", close_past=0.03)
    pre, c0, c1 = at.data["pregrasp"], at.data["closed"], on.data["closed"]
    moving = [j for j in pre if c0[j] != pre[j]]
    assert moving
    # the same line, farther along it: one fraction for every joint
    frac = {j: (c1[j] - pre[j]) / (c0[j] - pre[j]) for j in moving}
    assert min(frac.values()) > 1.0
    assert max(frac.values()) - min(frac.values()) < 1e-9
    # the pads' mean path from one posture to the other: 3 cm, to a step
    steps = np.linspace(0.0, 1.0, 400)
    path = [
        _pad_centres(
            urdf, at.data, {**c0, **{j: c0[j] + s * (c1[j] - c0[j]) for j in moving}}
        )
        for s in steps
    ]
    travel = np.linalg.norm(np.diff(np.stack(path), axis=0), axis=2).mean(axis=1).sum()
    assert 0.03 <= travel < 0.033
    assert "--close-past 0.03" in on.notes["closed"]
    assert "without meeting" in at.notes["closed"]
    assert "without meeting" not in on.notes["closed"]


def test_close_past_from_a_pinch_moves_each_finger_on(tmp_path):
    """From the posture where a hand's pads come nearest a common point, each
    finger goes on along its own line from ``pregrasp`` until its pad has
    travelled ``close_past`` more, or to the end of its joints' range."""
    urdf = tmp_path / "hand.urdf"
    urdf.write_text(forearm_hand_urdf())
    at = guess_description(urdf, "hand")
    on = guess_description(urdf, "hand", close_past=0.02)
    assert "nearest a common point" in at.notes["closed"]
    assert "--close-past 0.02" in on.notes["closed"]
    pre, c0, c1 = at.data["pregrasp"], at.data["closed"], on.data["closed"]
    moved = np.linalg.norm(
        _pad_centres(urdf, on.data, c1) - _pad_centres(urdf, at.data, c0), axis=1
    )
    for f, d in zip(at.data["fingers"], moved, strict=True):
        js = [j for j in f["joints"] if c0[j] != pre[j]]
        ratio = {j: (c1[j] - pre[j]) / (c0[j] - pre[j]) for j in js}
        # on along the finger's own line (or stopped at a limit) ...
        assert all(r >= 1.0 - 1e-9 for r in ratio.values()), f["name"]
        # ... its pad no farther than 2 cm of path (a chord is shorter)
        assert d <= 0.0205, f["name"]
    assert moved.max() > 0.015


def test_close_past_out_of_range_is_refused(tmp_path):
    urdf = tmp_path / "hand.urdf"
    urdf.write_text(hand_urdf())
    with pytest.raises(GripperError, match="close-past"):
        scaffold_plugin("hand", urdf, tmp_path / "out", close_past=-0.01)
    assert (
        main(
            [
                "gripper",
                "new",
                "hand",
                "--urdf",
                str(urdf),
                "-o",
                str(tmp_path / "o2"),
                "--close-past",
                "0.5",
            ]
        )
        != 0
    )
    yaml_path, _ = scaffold_plugin(
        "hand", urdf, tmp_path / "ok", close_past=0.03, check=False
    )
    assert "scaffolded with --close-past 0.03" in yaml_path.read_text()


def test_pinch_brings_the_pads_nearer_a_common_point(tmp_path):
    """The pinch search over each finger's joints between its pregrasp and
    closed values finds a posture whose pads lie no farther from their centroid
    than at any posture on the straight closing line, every joint inside its
    range, and reports that distance and point."""
    from wsgrasp.gripper import _guess as G

    urdf = tmp_path / "hand.urdf"
    urdf.write_text(forearm_hand_urdf())
    u = G._read(urdf, "hand", None)
    fingers = G._fingers(u)
    distal = list(fingers)
    targets = G._targets(u, fingers)
    pregrasp, closed = G._postures(u, fingers, targets)
    G._hold_postures(
        u, {k: list(v) for k, v in fingers.items()}, fingers, targets, pregrasp, closed
    )
    pads = G._pads(u, distal, G._finger_names(distal), pregrasp, closed, targets)
    t = np.linspace(0.0, 1.0, 65)
    values = {m: pregrasp[m] + t * (closed[m] - pregrasp[m]) for m in pregrasp}
    line = np.stack([G._pad_points(u, p, values, len(t)) for p in pads])  # (F, S, 3)
    least = np.linalg.norm(line - line.mean(axis=0), axis=2).mean(axis=0).min()
    pinch = G._pinch(u, fingers, pads, pregrasp, closed, line[:, -1].mean(axis=0))
    assert pinch is not None
    posture, gap, point = pinch
    assert gap <= least + 1e-12  # no farther apart than anywhere on the line
    for m, v in posture.items():
        lo, hi = sorted((pregrasp[m], closed[m]))
        assert lo - 1e-12 <= v <= hi + 1e-12, m
    # the gap is the pads' mean distance from the point, at that posture
    at = {**pregrasp, **posture}
    pts = np.stack([G._pad_points(u, p, at, 1)[0] for p in pads])
    np.testing.assert_allclose(pts.mean(axis=0), point, atol=1e-9)
    assert np.linalg.norm(pts - point, axis=1).mean() == pytest.approx(gap)


def test_fingers_side_by_side_keep_their_spread():
    """The built-in Allegro hand's URDF: its index and ring fingers' spread joints
    would bring them nearer the others turned inwards, but the fingers flex
    about parallel axes, side by side, and keep their spread at 0; the thumb,
    flexing about its own axis, is turned to oppose them (as the hand-written
    YAML turns it: joint_12.0 at its 1.396 limit)."""
    from wsgrasp.plugins import get_registry

    yaml_path = Path(get_registry().get("grippers", "allegro_right").obj)
    d = guess_description(yaml_path.with_suffix(".urdf"), "allegro").data
    for spread in ("joint_0.0", "joint_4.0", "joint_8.0"):
        assert d["pregrasp"][spread] == d["closed"][spread] == 0.0
    assert d["pregrasp"]["joint_12.0"] == d["closed"]["joint_12.0"] == 1.396


def test_hand_on_a_forearm_approaches_palm_first_and_finds_grasps(tmp_path):
    """The root of the URDF is a forearm, and the palm faces sideways from it:
    the approach axis is the palm's normal (not along the forearm, where the
    fingertips' centre lies), `gripper check` finds no error, and the
    package's default spec finds a grasp on a 5 cm cube, as it does for hands
    without a forearm."""
    from wsgrasp.api import Pipeline
    from wsgrasp.default_specs import default_spec
    from wsgrasp.perception.synth import synth_scene
    from wsgrasp.spec import PipelineSpec

    urdf = tmp_path / "hand.urdf"
    urdf.write_text(forearm_hand_urdf())
    yaml_path, sc = scaffold_plugin("hand", urdf, tmp_path / "out")
    assert sc.build_error is None, sc.build_error
    assert sc.data["approach_axis"] == [0.0, 1.0, 0.0]
    assert "palm link 'palm'" in sc.notes["approach_axis"]
    report = check_gripper(yaml_path)
    assert not report.errors, report.format()
    spec, _ = default_spec(str(yaml_path))
    assert "reach_down" not in [s["name"] for s in spec["scorers"]]  # palm first
    pipeline = Pipeline(PipelineSpec.model_validate(spec))
    cube = synth_scene("box", size=(0.05, 0.05, 0.05), seed=3)
    result = pipeline.plan(cube.points)
    assert result.found, result.hint


def test_a_hand_scaffolded_fingertips_first_scores_by_reach_down(tmp_path, monkeypatch):
    """Where `gripper new` keeps the fingertips-first approach, the package's
    default spec is the generic default with reach_down added and
    approach_direction preferring a level approach."""
    from wsgrasp.default_specs import default_spec
    from wsgrasp.gripper import _approach

    def count(path, scenes):  # the fingertips-first guess leaves more grasps
        alt = yaml.safe_load(Path(path).read_text())["approach_axis"]
        return 10 if alt == sc_alt["approach_axis"] else 1

    urdf = tmp_path / "hand.urdf"
    urdf.write_text(forearm_hand_urdf())
    sc_alt = guess_description(urdf, "hand").fingertips_first
    monkeypatch.setattr(_approach, "feasible_on_low_objects", count)
    yaml_path, sc = scaffold_plugin("hand", urdf, tmp_path / "out", check=False)
    assert sc.approaches_fingertips_first
    assert sc.data["approach_axis"] == sc_alt["approach_axis"]
    spec, source = default_spec(str(yaml_path))
    assert source.endswith("specs/default.yaml")
    assert [s["name"] for s in spec["scorers"]][-1] == "reach_down"
    (direction,) = [s for s in spec["scorers"] if s["name"] == "approach_direction"]
    assert direction["options"] == {"direction": "level"}


def test_hand_gets_a_fingertips_first_alternative_and_claws_none(tmp_path):
    """A hand of four fingers gets a second approach along its open fingers
    (a unit axis with a closing axis across it); a jaw gets none."""
    urdf = tmp_path / "hand.urdf"
    urdf.write_text(forearm_hand_urdf())
    sc = guess_description(urdf, "hand")
    alt = sc.fingertips_first
    assert alt is not None and alt["notes"]["approach_axis"].startswith("fingertips")
    a, c = np.array(alt["approach_axis"]), np.array(alt["closing_axis"])
    assert abs(np.linalg.norm(a) - 1) < 1e-5 and abs(float(a @ c)) < 1e-5
    # the fingers stand on the palm's top (+z), leaning towards its front (+y)
    assert a[2] > 0.5 and a[1] > 0.3
    assert np.degrees(np.arccos(a @ np.array(sc.data["approach_axis"]))) > 30
    (tmp_path / "jaw.urdf").write_text(
        named_jaw_urdf(("left_joint", "right_joint"), ("palm", "left", "right"))
    )
    assert guess_description(tmp_path / "jaw.urdf", "jaw").fingertips_first is None


@pytest.mark.parametrize(
    ("palm", "tips", "first"), [(10, 30, "tips"), (30, 10, "palm"), (5, 5, "palm")]
)
def test_approach_with_more_feasible_grasps_on_flat_objects_is_kept(
    tmp_path, monkeypatch, palm, tips, first
):
    """`gripper new` plans both approaches on flat objects and keeps the one
    that leaves more feasible grasps (palm first on a tie), saying so."""
    from wsgrasp.gripper import _approach

    urdf = tmp_path / "hand.urdf"
    urdf.write_text(forearm_hand_urdf())
    sc = guess_description(urdf, "hand")
    palm_axes = sc.data["approach_axis"], sc.data["closing_axis"]
    alt = sc.fingertips_first
    seen = []

    def count(path, scenes):
        assert len(scenes) == 6  # 3 flat objects, 2 renderings each
        d = yaml.safe_load(Path(path).read_text())
        seen.append(path.name)
        return tips if d["approach_axis"] == alt["approach_axis"] else palm

    monkeypatch.setattr(_approach, "feasible_on_low_objects", count)
    _approach.choose_approach(sc, tmp_path)
    assert len(seen) == 2 and not list(tmp_path.glob(".hand-*"))  # removed
    note = sc.notes["approach_axis"]
    assert f"{tips} feasible grasps fingertips first and {palm} palm first" in note
    assert sc.approaches_fingertips_first == (first == "tips")
    if first == "tips":
        assert (sc.data["approach_axis"], sc.data["closing_axis"]) == (
            alt["approach_axis"],
            alt["closing_axis"],
        )
        assert note.startswith("fingertips first")
        assert sc.notes["closing_axis"] == alt["notes"]["closing_axis"]
    else:
        assert (sc.data["approach_axis"], sc.data["closing_axis"]) == palm_axes
    GripperDescription.model_validate(sc.data)


def test_approach_trial_that_cannot_plan_keeps_palm_first(tmp_path, monkeypatch):
    """Where planning a trial approach fails, the guess stays palm first and the
    note says why, instead of `gripper new` failing."""
    from wsgrasp.errors import GripperError
    from wsgrasp.gripper import _approach

    urdf = tmp_path / "hand.urdf"
    urdf.write_text(forearm_hand_urdf())
    sc = guess_description(urdf, "hand")
    palm_axis = sc.data["approach_axis"]

    def fail(path, scenes):
        raise GripperError("the model does not build", hint="")

    monkeypatch.setattr(_approach, "feasible_on_low_objects", fail)
    _approach.choose_approach(sc, tmp_path)
    assert sc.data["approach_axis"] == palm_axis
    assert (
        "palm-first guess cannot plan (the model does not build"
        in (sc.notes["approach_axis"])
    )
    assert not list(tmp_path.glob(".hand-*"))


# ------------------------------------------------------------------------------
# Meshes
# ------------------------------------------------------------------------------
def test_missing_visual_meshes_are_a_warning(tmp_path):
    """Visual meshes named .STL that do not exist, an unreadable one, collision
    meshes present: scaffolded from the collision meshes, each visual mesh left
    out named with its link; a missing collision mesh stays an error."""
    src = tmp_path / "src"
    urdf = write_mesh_jaw(
        src / "jaw.urdf", src / "meshes", visual=lambda f: f"meshes/visual/{f}"
    )
    (src / "meshes" / "visual").mkdir()
    (src / "meshes" / "visual" / "palm.STL").write_text("not a mesh")
    yaml_path, sc = scaffold_plugin("jaw", urdf, tmp_path / "out")
    assert sc.build_error is None
    left = [w for w in sc.warnings if "meshes/visual/left.STL" in w]
    assert left and "left_finger" in left[0] and "not found" in left[0]
    palm = [w for w in sc.warnings if "meshes/visual/palm.STL" in w]
    assert palm and "link palm" in palm[0] and "cannot be read" in palm[0]
    copied = yaml_path.with_suffix(".urdf").read_text()
    assert "visual/" not in copied.replace("visual mesh meshes/visual", "")
    assert "<visual>" not in copied
    _no_errors(yaml_path)
    (src / "meshes" / "right.stl").unlink()
    with pytest.raises(GripperError) as err:
        copy_urdf(urdf, tmp_path / "again", "jaw")
    assert "right.stl" in str(err.value) and "link right_finger" in str(err.value)


def test_package_uri_found_through_package_xml(tmp_path):
    """package://gripper_description/... where the package's folder has another
    name and its package.xml names it, the URDF four folders down."""
    pkg = tmp_path / "gripper_description_src"
    write_package_xml(pkg, "gripper_description")
    urdf = write_mesh_jaw(
        pkg / "robots" / "a" / "b" / "c" / "jaw.urdf",
        pkg / "meshes",
        uri=lambda f: f"package://gripper_description/meshes/{f}",
    )
    kin = load_kinematics(urdf, "jaw")
    assert kin.shapes["palm"][0].mesh_path == pkg / "meshes" / "palm.stl"
    copy, notes = copy_urdf(urdf, tmp_path / "out", "jaw")
    assert len(notes) == 3 and "package://" not in copy.read_text()


def test_package_path_option(tmp_path, capsys):
    """The package lives in a workspace away from the URDF: `--package-path WS`
    finds it (like ROS_PACKAGE_PATH), and without it the error names the option."""
    ws = tmp_path / "ws"
    pkg = ws / "src" / "vendor_grippers" / "description"
    write_package_xml(pkg, "jaw_description")
    urdf = write_mesh_jaw(
        tmp_path / "downloads" / "jaw.urdf",
        pkg / "meshes",
        uri=lambda f: f"package://jaw_description/meshes/{f}",
    )
    out = tmp_path / "plugin"
    args = ["gripper", "new", "jaw", "--urdf", str(urdf), "--out", str(out)]
    assert main(args) == 2
    assert "--package-path" in capsys.readouterr().err
    assert main([*args, "--package-path", str(ws)]) == 0
    out_text = " ".join(capsys.readouterr().out.split())  # unwrapped
    assert "left [left_joint], right [left_joint]" in out_text
    assert (out / "wsgrasp_jaw" / "meshes" / "palm.stl").is_file()


@pytest.mark.parametrize("ext", ["dae", "glb", "obj"])
def test_meshes_of_each_format_load(tmp_path, ext):
    """COLLADA (through pycollada), GLB and OBJ collision meshes load at their
    size."""
    urdf = write_mesh_jaw(tmp_path / "jaw.urdf", tmp_path / "meshes", ext=ext)
    kin = load_kinematics(urdf, "jaw")
    for link, (_, extents, centre) in JAW_PARTS.items():
        mesh = shape_mesh(kin.shapes[link][0])
        np.testing.assert_allclose(mesh.extents, extents, atol=1e-6)
        np.testing.assert_allclose(mesh.bounds.mean(axis=0), centre, atol=1e-6)


def test_collada_gripper_scaffolds_and_checks(tmp_path):
    urdf = write_mesh_jaw(
        tmp_path / "src" / "jaw.urdf", tmp_path / "src" / "m", ext="dae"
    )
    yaml_path, sc = scaffold_plugin("jaw", urdf, tmp_path / "out")
    assert sc.build_error is None
    assert (yaml_path.parent / "meshes" / "palm.dae").is_file()
    assert sc.data["approach_axis"] == [0.0, 0.0, 1.0]
    _no_errors(yaml_path)


# ------------------------------------------------------------------------------
# The development descriptions
# ------------------------------------------------------------------------------
@pytest.mark.skipif(
    not SHARED.is_dir(),
    reason=f"the vendor URDFs of ../shared/grippers are not here ({SHARED}): "
    "development data, kept out of the repository",
)
def test_barrett_spread_stays_a_spread_with_its_distal_joints_coupled(tmp_path):
    """The BarrettHand with each distal joint a mimic of its middle one (its
    real 1:3 drive, as other descriptions write it): one master flexes each
    finger, yet its joints turned about the flexion axis are still two, so the
    spread joints are held as in the URDF as published; they were taken for
    closers and closed the two spreading fingers 146 degrees round the palm,
    onto each other."""
    import re

    source = SHARED / VENDOR["barrett"]
    folder = tmp_path / "coupled"
    shutil.copytree(source.parent, folder)
    text = (folder / source.name).read_text()

    def couple(m: re.Match[str]) -> str:
        k = m.group(1)
        return m.group(0).replace(
            "</joint>",
            f'  <mimic joint="finger_{k}_med_joint" multiplier="0.32"/>\n  </joint>',
        )

    coupled = re.sub(
        r'<joint name="finger_(\d)_dist_joint".*?</joint>', couple, text, flags=re.S
    )
    assert coupled.count("<mimic") >= 3
    (folder / source.name).write_text(coupled)
    plain = guess_description(source, "barrett").data
    d = guess_description(folder / source.name, "barrett").data
    spread = [j for j in plain["closed"] if "prox" in j]
    assert spread and all(d["closed"][j] == plain["closed"][j] == 0.0 for j in spread)
    fingers = [f["joints"] for f in d["fingers"]]
    assert fingers == [f["joints"] for f in plain["fingers"]]


@pytest.mark.skipif(
    not SHARED.is_dir(),
    reason=f"the vendor URDFs of ../shared/grippers are not here ({SHARED}): "
    "development data, kept out of the repository",
)
@pytest.mark.parametrize(
    "name",
    [
        pytest.param(n, marks=() if n in FAST else pytest.mark.slow, id=n)
        for n in VENDOR
    ],
)
def test_vendor_gripper_scaffolds_and_checks(tmp_path, name):
    """`gripper new` then `gripper check` with no hand edit: no error."""
    yaml_path, sc = scaffold_plugin(name, SHARED / VENDOR[name], tmp_path / name)
    assert sc.build_error is None, sc.build_error
    report = check_gripper(yaml_path)
    assert not report.errors, report.format()
    d = sc.data
    if name == "shadow":
        assert all("WRJ" not in j for f in d["fingers"] for j in f["joints"])
        assert len(d["fingers"]) == 5
    if name in ("barrett", "dclaw", "panda"):
        assert d["approach_axis"] == [0.0, 0.0, 1.0]
    if name in ("ability", "shadow"):
        # fingertips meeting the thumb's, not curled past it
        assert "nearest a common point" in sc.notes["closed"]
        # both approaches planned on flat objects: for both hands the palm (+x)
        # leaves more grasps than the fingertips (the Shadow hand's +z, along
        # its fingers), whose sweeps may graze the table 8 mm deep at most
        note = sc.notes["approach_axis"]
        assert "feasible grasps fingertips first" in note
        assert d["approach_axis"] == [1.0, 0.0, 0.0] and "palm" in note
    if name in ("barrett", "dclaw", "robotiq_3f"):  # tips that cross or part
        assert "closing all joints together" in sc.notes["closed"]
        # the D'Claw's pads meet; the others' pass each other apart
        apart = "pass each other without meeting" in sc.notes["closed"]
        assert apart == (name != "dclaw")
    if name == "robotiq_3f":
        assert sum("visual mesh" in w for w in sc.warnings) == 5


def test_hand_with_a_thumb_needs_a_tripod(tmp_path):
    """A hand of four fingers grasps between its thumb and the two fingers
    nearest it in the open hand: the guess names them in ``contact_fingers``
    (finger order), says why in a comment, and round-trips through the YAML.
    A three-finger hand needs every finger: no field."""
    urdf = tmp_path / "hand.urdf"
    urdf.write_text(forearm_hand_urdf())
    sc = guess_description(urdf, "hand")
    names = [f["name"] for f in sc.data["fingers"]]
    links = {f["name"]: f["pad"]["link"] for f in sc.data["fingers"]}
    chosen = sc.data["contact_fingers"]
    assert len(chosen) == 3 and chosen == [n for n in names if n in chosen]
    assert "th_distal" in {links[n] for n in chosen}
    # the two fingers beside the thumb's side of the palm (+x): f1 and f2
    assert {links[n] for n in chosen} == {"th_distal", "f1_distal", "f2_distal"}
    assert "thumb" in sc.notes["contact_fingers"]
    text = render_yaml(sc)
    assert "contact_fingers: [" in text
    desc = GripperDescription.model_validate(yaml.safe_load(text))
    assert desc.contact_fingers == chosen
    (tmp_path / "claw.urdf").write_text(hand_urdf())
    assert (
        "contact_fingers" not in guess_description(tmp_path / "claw.urdf", "claw").data
    )


def _pybullet_data() -> Path:
    data = pytest.importorskip("pybullet_data", reason="pybullet's data is not here")
    return Path(data.getDataPath())


def test_a_robot_urdf_as_pybullet_ships_it_gives_its_hand(tmp_path):
    """pybullet's ``franka_panda/panda.urdf`` (a 7-joint arm, then the hand), as
    a user points ``gripper new`` at it: the plugin is the hand alone, and it
    checks without errors."""
    urdf = _pybullet_data() / "franka_panda" / "panda.urdf"
    yaml_path, sc = scaffold_plugin("panda_arm", urdf, tmp_path / "out")
    assert sc.data["base_link"] == "panda_hand"
    assert "arm of 7 joints" in sc.notes["base_link"]
    kin = load_kinematics(yaml_path.parent / "panda_arm.urdf", "panda_arm")
    assert "panda_link0" not in kin.links
    assert len(sc.data["fingers"]) == 2
    _no_errors(yaml_path)


def test_placeholder_inertias_as_pybullet_ships_them_are_recomputed(tmp_path):
    """pybullet's PR2 gripper gives every link ``ixx=iyy=izz=1``: the simulator
    recomputes each from its geometry, and says so."""
    pytest.importorskip("mujoco")
    from wsgrasp.sim.gripper import load_sim_gripper

    urdf = _pybullet_data() / "pr2_gripper.urdf"
    yaml_path, _ = scaffold_plugin("pr2", urdf, tmp_path / "out")
    g = load_sim_gripper(str(yaml_path))
    fixed = {r.item for r in g.repairs if "too large for the link" in r.problem}
    assert {"left_gripper", "right_gripper", "gripper_pole"} <= fixed


def test_a_linkage_gripper_below_an_arm_as_pybullet_ships_it(tmp_path):
    """pybullet's ``xarm/xarm6_with_gripper.urdf``: a 6-joint arm, then a
    gripper of two four-bar linkages whose six joints follow one
    (``drive_joint``; the other five mimic it). The plugin is the gripper alone,
    both fingers driven by that joint, and it checks without errors."""
    urdf = _pybullet_data() / "xarm" / "xarm6_with_gripper.urdf"
    yaml_path, sc = scaffold_plugin("xarm_gripper", urdf, tmp_path / "out")
    assert sc.data["base_link"] == "xarm_gripper_base_link"
    kin = load_kinematics(yaml_path.parent / "xarm_gripper.urdf", "xarm_gripper")
    assert "link1" not in kin.links
    fingers = sc.data["fingers"]
    assert len(fingers) == 2
    assert all(f["joints"] == ["drive_joint"] for f in fingers)
    _no_errors(yaml_path)


def test_an_sdformat_gripper_as_pybullet_ships_it_is_refused_by_name(tmp_path):
    """pybullet's WSG 50 comes as SDFormat: ``gripper new`` names the file and
    says it is no URDF, and writes nothing."""
    sdf = _pybullet_data() / "gripper" / "wsg50_one_motor_gripper_new.sdf"
    with pytest.raises(GripperError) as err:
        scaffold_plugin("wsg50", sdf, tmp_path / "out")
    assert "SDFormat" in str(err.value) and str(sdf) in str(err.value)
    assert not (tmp_path / "out").exists()
