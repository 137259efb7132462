"""The simulator takes URDFs as vendors publish them: inertials MuJoCo refuses,
placeholder efforts and mimic linkages whose followers carry limits of the wrong
sign are repaired, the repairs are reported, and a linkage of mimic joints closes
and holds."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

pytest.importorskip("mujoco")

from wsgrasp.sim import (  # noqa: E402
    SimParams,
    build_report,
    build_scene,
    execute_grasp,
    report_markdown,
    require_mujoco,
    sim_gripper_from_files,
)
from wsgrasp.sim.objects import Part, SimObject  # noqa: E402

#: the development data of ../shared/grippers (not in the repository)
SHARED = Path(__file__).resolve().parents[2] / "shared" / "grippers"
ROBOTIQ_2F = (
    SHARED / "robotiq/robotiq_2f_c2_gripper_visualization/urdf/robotiq_c2_model.urdf"
)

#: the claw's pads: 2 x 1 x 4 cm boxes, their centres 4 cm off the axis, open
PAD_OFFSET, BAR = 0.04, 0.05
#: the palm's inertial: a plausible mass, principal moments with A + B < C
PALM_MASS, PALM_INERTIA = 0.4, (1e-4, 1e-4, 5e-4)
#: a welded frame without geometry: a mass, an inertia of zeros
SENSOR_MASS = 0.005
#: the right pad's inertial, valid: kept as it is
PAD_MASS, PAD_INERTIA = 0.03, (4e-6, 5e-6, 2e-6)


def _box(size: str, xyz: str) -> str:
    return (
        f'<collision><origin xyz="{xyz}"/><geometry><box size="{size}"/>'
        "</geometry></collision>"
    )


def _inertial(mass: float, ixx: float, iyy: float, izz: float, ixy: float = 0) -> str:
    return (
        f'<inertial><mass value="{mass}"/><inertia ixx="{ixx}" iyy="{iyy}" '
        f'izz="{izz}" ixy="{ixy}" ixz="0" iyz="0"/></inertial>'
    )


def claw_urdf(effort: float = 0.0) -> str:
    """A parallel-linkage claw along y, approach +z, as a vendor might write it.

    One actuated knuckle (``left_knuckle_joint``, effort ``effort``); the right
    knuckle follows it with multiplier -1 and each pad with multiplier -1 of its
    own knuckle (the right pad through the chain: +1 of the leader), so the pads
    stay parallel. The pads' URDF limits have the wrong sign (0 to 1.5 and -1.5
    to 0, where the leader drives them through -0.8..0 and 0..0.8), as the
    Robotiq 2F-C2's finger tips have. Inertials: the palm's violates A + B >= C,
    the left knuckle weighs 0 kg, the right knuckle has none, the left pad's is
    not positive definite, the right pad's is valid; a welded ``tcp`` frame has
    neither geometry nor inertial, a welded ``sensor`` frame a mass and an
    inertia of zeros.
    """
    lim = f'effort="{effort}" velocity="1"'
    bar = _box(f"0.012 0.01 {BAR}", f"0 0 {BAR / 2}")
    return f"""<?xml version="1.0"?>
<robot name="claw">
  <link name="palm">{_inertial(PALM_MASS, *PALM_INERTIA)}
    {_box("0.04 0.12 0.05", "0 0 0.025")}</link>
  <link name="tcp"/>
  <joint name="tcp_joint" type="fixed">
    <parent link="palm"/><child link="tcp"/><origin xyz="0 0 0.17"/>
  </joint>
  <link name="sensor">{_inertial(SENSOR_MASS, 0, 0, 0)}</link>
  <joint name="sensor_joint" type="fixed">
    <parent link="palm"/><child link="sensor"/><origin xyz="0 0 0.01"/>
  </joint>
  <link name="left_knuckle">{_inertial(0.0, 1e-6, 1e-6, 1e-6)}{bar}</link>
  <joint name="left_knuckle_joint" type="revolute">
    <parent link="palm"/><child link="left_knuckle"/>
    <origin xyz="0 {PAD_OFFSET} 0.05"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="0.8" {lim}/>
  </joint>
  <link name="left_pad">{_inertial(0.03, 1e-6, 1e-6, 1e-6, ixy=5e-6)}
    {_box("0.02 0.01 0.04", "0 0 0.02")}</link>
  <joint name="left_pad_joint" type="revolute">
    <parent link="left_knuckle"/><child link="left_pad"/>
    <origin xyz="0 0 {BAR}"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="1.5" {lim}/>
    <mimic joint="left_knuckle_joint" multiplier="-1" offset="0"/>
  </joint>
  <link name="right_knuckle">{bar}</link>
  <joint name="right_knuckle_joint" type="revolute">
    <parent link="palm"/><child link="right_knuckle"/>
    <origin xyz="0 -{PAD_OFFSET} 0.05"/><axis xyz="1 0 0"/>
    <limit lower="-0.8" upper="0" {lim}/>
    <mimic joint="left_knuckle_joint" multiplier="-1" offset="0"/>
  </joint>
  <link name="right_pad">{_inertial(PAD_MASS, *PAD_INERTIA)}
    {_box("0.02 0.01 0.04", "0 0 0.02")}</link>
  <joint name="right_pad_joint" type="revolute">
    <parent link="right_knuckle"/><child link="right_pad"/>
    <origin xyz="0 0 {BAR}"/><axis xyz="1 0 0"/>
    <limit lower="-1.5" upper="0" {lim}/>
    <mimic joint="right_knuckle_joint" multiplier="-1" offset="0"/>
  </joint>
</robot>
"""


def claw_description() -> dict:
    return {
        "name": "claw",
        "urdf": "claw.urdf",
        "base_link": "palm",
        "approach_axis": (0.0, 0.0, 1.0),
        "closing_axis": (0.0, 1.0, 0.0),
        "pregrasp": {"left_knuckle_joint": 0.0},
        "closed": {"left_knuckle_joint": 0.8},
    }


@pytest.fixture(autouse=True)
def _cache(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch):
    cache = tmp_path_factory.getbasetemp() / "gripper-cache"
    monkeypatch.setenv("WSGRASP_CACHE_DIR", str(cache))


@pytest.fixture
def claw_dir(tmp_path: Path) -> Path:
    (tmp_path / "claw.urdf").write_text(claw_urdf())
    return tmp_path


def _T(xyz=(0.0, 0.0, 0.0), R=None) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = xyz
    if R is not None:
        T[:3, :3] = R
    return T


#: the gripper pointing down (its z along world -z), closing along world x
R_DOWN = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def _box_object(xyz=(0.0, 0.0, 0.04), mass: float = 0.1) -> SimObject:
    """A 4 cm (world x) x 6 cm x 8 cm box."""
    return SimObject("box", [Part("box", (0.04, 0.06, 0.08), _T(xyz))], mass)


def _body_id(scene, name: str) -> int:
    mujoco = require_mujoco()
    return mujoco.mj_name2id(scene.model, mujoco.mjtObj.mjOBJ_BODY, "g/" + name)


def test_mujoco_refuses_the_palms_inertial_as_written():
    """The test's URDF is one MuJoCo would not compile as it is."""
    mujoco = require_mujoco()
    xml = (
        '<mujoco><worldbody><body><joint type="hinge"/><inertial pos="0 0 0" '
        f'mass="{PALM_MASS}" diaginertia="{" ".join(map(str, PALM_INERTIA))}"/>'
        "</body></worldbody></mujoco>"
    )
    with pytest.raises(ValueError, match=r"A \+ B >= C"):
        mujoco.MjModel.from_xml_string(xml)


def test_an_inertia_too_large_for_its_link_is_recomputed():
    """A placeholder inertia (1 kg·m² on a 100 g finger: a radius of gyration of
    3 m) is no property of the link: the URDF's mass is kept, the inertia comes
    from the geometry. A plausible one, and one at the bound, stay as written."""
    import trimesh

    from wsgrasp.gripper._urdf import Inertial
    from wsgrasp.sim._repairs import link_mass_properties
    from wsgrasp.sim.params import SimParams

    p = SimParams()
    finger = [trimesh.creation.box((0.1, 0.02, 0.02))]  # centred on the origin

    def inertial(inertia):
        return Inertial(0.1, np.eye(4), np.diag(inertia))

    props, fix = link_mass_properties("f", inertial((1.0, 1.0, 1.0)), finger, True, p)
    assert fix is not None and "too large for the link" in fix.problem
    assert "3162 mm" in fix.problem  # sqrt(1 / 0.1)
    assert props.mass == pytest.approx(0.1)
    # the box's own inertia at 100 g
    want = 0.1 / 12 * np.array([0.02**2 + 0.02**2, 0.1**2 + 0.02**2, 0.1**2 + 0.02**2])
    np.testing.assert_allclose(np.diag(props.inertia), want, rtol=1e-9)
    # the bound: the mass at the corners' distance from the centre of mass
    reach2 = 0.05**2 + 0.01**2 + 0.01**2
    for inertia in (want, (0.1 * reach2,) * 3):
        props, fix = link_mass_properties("f", inertial(inertia), finger, True, p)
        assert fix is None
        np.testing.assert_allclose(np.diag(props.inertia), inertia)
    _, fix = link_mass_properties("f", inertial((0.11 * reach2,) * 3), finger, True, p)
    assert fix is not None


def test_inertials_are_repaired_and_the_model_compiles(claw_dir: Path):
    g = sim_gripper_from_files(claw_description(), claw_dir)
    scene = build_scene(_box_object((0.3, 0.3, 0.04)), g)  # compiles
    m = scene.model
    repaired = {r.item: r for r in g.repairs if r.kind == "inertial"}
    assert set(repaired) == {
        "palm",
        "left_knuckle",
        "right_knuckle",
        "left_pad",
        "sensor",
    }
    assert "A + B >= C" in repaired["palm"].problem
    assert "below 0.001 kg" in repaired["left_knuckle"].problem
    assert "no inertial" in repaired["right_knuckle"].problem
    assert "not positive definite" in repaired["left_pad"].problem
    # a plausible mass is kept, the inertia comes from the geometry
    assert m.body_mass[_body_id(scene, "palm")] == pytest.approx(PALM_MASS)
    assert m.body_mass[_body_id(scene, "left_pad")] == pytest.approx(0.03)
    # an implausible or missing mass: 1000 kg/m³ over the 12 x 10 x 50 mm bar
    bar = 1000.0 * 0.012 * 0.01 * BAR
    for link in ("left_knuckle", "right_knuckle"):
        assert m.body_mass[_body_id(scene, link)] == pytest.approx(bar, rel=1e-6)
    # the box's inertia about its centre, at the bar's centre
    b = _body_id(scene, "right_knuckle")
    expected = bar / 12 * np.array([0.01**2 + BAR**2, 0.012**2 + BAR**2, 2.44e-4])
    np.testing.assert_allclose(np.sort(m.body_inertia[b]), np.sort(expected), rtol=1e-6)
    np.testing.assert_allclose(m.body_ipos[b], (0, 0, BAR / 2), atol=1e-9)
    # a valid inertial as the URDF gives it; a welded frame stays massless
    pad = _body_id(scene, "right_pad")
    assert m.body_mass[pad] == pytest.approx(PAD_MASS)
    np.testing.assert_allclose(
        np.sort(m.body_inertia[pad]), np.sort(PAD_INERTIA), rtol=1e-9
    )
    assert "tcp" not in repaired and m.body_mass[_body_id(scene, "tcp")] < 1e-3
    # a frame's plausible mass is kept, as a 1 cm sphere
    assert "not positive definite" in repaired["sensor"].problem
    assert m.body_mass[_body_id(scene, "sensor")] == pytest.approx(SENSOR_MASS)


def test_repairs_reach_the_report(claw_dir: Path):
    g = sim_gripper_from_files(claw_description(), claw_dir)
    records = [{"object": "box", "trial": 0, "gripper": "claw", "spec": "default"}]
    records[0].update(outcome="success", plan_ms=1.0)
    report = build_report(records, meta={"sim_grippers": {"claw": g.notes_json()}})
    notes = report["sim_grippers"]["claw"]
    assert {r["item"] for r in notes["repairs"]} >= {"palm", "left_pad_joint"}
    assert notes["efforts"]["left_knuckle_joint"] == {
        "effort": 5.0,
        "unit": "N·m",
        "source": "default",
    }
    md = report_markdown(report)
    assert "| palm | inertial |" in md
    assert "left_knuckle_joint 5 N·m (default)" in md


@pytest.mark.parametrize(
    "kind, effort, expected, source",
    [
        ("revolute", 0.0, 5.0, "default"),
        ("revolute", 1e6, 5.0, "default"),
        ("revolute", 1000.0, 5.0, "default"),
        ("revolute", 0.1, 0.1, "urdf"),
        ("revolute", 15.0, 15.0, "urdf"),
        ("revolute", 200.0, 200.0, "urdf"),
        ("prismatic", 0.0, 100.0, "default"),
        ("prismatic", 1e6, 100.0, "default"),
        ("prismatic", 40.0, 40.0, "urdf"),
        ("prismatic", 2000.0, 2000.0, "urdf"),
    ],
    ids=lambda v: f"{v:g}" if isinstance(v, float) else str(v),
)
def test_effort_limits_follow_the_documented_rule(
    tmp_path: Path, kind: str, effort: float, expected: float, source: str
):
    """The URDF's effort within 0.1-200 N·m (revolute) or 1-2000 N (prismatic),
    else 5 N·m or 100 N; the compiled actuator is limited to it."""
    upper = 0.04 if kind == "prismatic" else 0.8
    urdf = f"""<?xml version="1.0"?>
<robot name="one">
  <link name="palm">{_box("0.04 0.04 0.04", "0 0 0")}</link>
  <link name="finger">{_box("0.01 0.01 0.04", "0 0 0.02")}</link>
  <joint name="finger_joint" type="{kind}">
    <parent link="palm"/><child link="finger"/><origin xyz="0 0 0.02"/>
    <axis xyz="1 0 0"/>
    <limit lower="0" upper="{upper}" effort="{effort}" velocity="1"/>
  </joint>
</robot>"""
    (tmp_path / "one.urdf").write_text(urdf)
    desc = {
        **claw_description(),
        "urdf": "one.urdf",
        "pregrasp": {"finger_joint": 0.0},
        "closed": {"finger_joint": upper},
    }
    g = sim_gripper_from_files(desc, tmp_path)
    unit = "N" if kind == "prismatic" else "N·m"
    assert g.efforts["finger_joint"] == (expected, unit, source)
    assert [r.kind for r in g.repairs if r.item == "finger_joint"] == (
        ["effort"] if source == "default" else []
    )
    scene = build_scene(_box_object((0.3, 0.3, 0.04)), g)
    np.testing.assert_allclose(
        scene.model.actuator_forcerange[6], (-expected, expected)
    )


def _close_in_air(g, seconds: float = 1.5):
    """Close ``g`` from its pregrasp to its closed posture, 30 cm over the table;
    returns the scene."""
    mujoco = require_mujoco()
    p = SimParams()
    scene = build_scene(_box_object((0.25, 0.25, 0.04)), g, p)
    m, d = scene.model, scene.data
    d.qpos[scene.gripper_qpos][2] = d.ctrl[2] = 0.3
    for joint, q in g.qpos_pregrasp.items():
        d.qpos[scene.joint_qpos[joint]] = q
    n = int(round(p.close_time / p.timestep))
    for i in range(1, int(round(seconds / p.timestep)) + 1):
        d.ctrl[6:] = g.pregrasp + (g.closed - g.pregrasp) * min(1.0, i / n)
        mujoco.mj_step(m, d)
    return scene


def _mimic_errors(g, scene) -> dict[str, float]:
    """Each mimic joint's distance (rad or m) from where its leader puts it."""
    d = scene.data
    q = {j: float(d.qpos[a]) for j, a in scene.joint_qpos.items()}
    return {
        j: abs(q[j] - (off + mult * q[master]))
        for j, (master, mult, off) in g.mimics.items()
    }


def test_mimic_chain_with_negative_multipliers_closes(claw_dir: Path):
    g = sim_gripper_from_files(claw_description(), claw_dir)
    assert g.mimics == {
        "left_pad_joint": ("left_knuckle_joint", -1.0, 0.0),
        "right_knuckle_joint": ("left_knuckle_joint", -1.0, 0.0),
        "right_pad_joint": ("left_knuckle_joint", 1.0, 0.0),
    }
    limits = {r.item: r.action for r in g.repairs if r.kind == "mimic limits"}
    assert limits == {
        "left_pad_joint": "limited to [-0.8, 0]",
        "right_pad_joint": "limited to [0, 0.8]",
    }
    scene = _close_in_air(g)
    leader = scene.data.qpos[scene.joint_qpos["left_knuckle_joint"]]
    assert leader == pytest.approx(0.8, abs=0.01)  # closed, not stalled at a limit
    errors = _mimic_errors(g, scene)
    assert max(errors.values()) < 2e-3, errors


def test_mimic_linkage_grips_and_holds(claw_dir: Path):
    """The pads, carried by the mimic joints, squeeze a 4 cm box hard enough to
    lift it and hold it for 2 s; the linkage stays in step under the load."""
    p = SimParams(hold_time=2.0)
    g = sim_gripper_from_files(claw_description(), claw_dir)
    obj = _box_object()
    scene = build_scene(obj, g, p)
    # pads' centres 7 cm up the box, open: 5 + 5 + 2 cm below the palm
    ex = execute_grasp(scene, _T((0, 0, 0.0)), _T((0, 0, 0.19), R_DOWN), p)
    assert ex.outcome == "success", ex.metrics
    assert ex.metrics["grip_force"] > 5.0
    # the pads' faces, 3.5 cm off the axis open, stopped at the box's, 2 cm off
    q = ex.metrics["joints_closed"]["left_knuckle_joint"]
    assert q == pytest.approx(np.arcsin(0.015 / BAR), abs=0.03)
    errors = _mimic_errors(g, scene)  # after the hold, still gripping
    assert max(errors.values()) < 0.02, errors


@pytest.mark.skipif(
    not ROBOTIQ_2F.is_file(),
    reason=f"the vendor URDFs of ../shared/grippers are not here ({SHARED}): "
    "development data kept out of the repository",
)
def test_vendor_robotiq_2f_linkage_closes():
    """The Robotiq 2F-C2 as published: its finger tips follow the knuckle with
    multiplier -1 under limits of the other sign, no inertials, effort 1000."""
    desc = {
        "name": "robotiq_2f_c2",
        "urdf": str(ROBOTIQ_2F),
        "base_link": "robotiq_85_adapter_link",
        "approach_axis": (1.0, 0.0, 0.0),
        "closing_axis": (0.0, 1.0, 0.0),
        "pregrasp": {"robotiq_85_left_knuckle_joint": 0.0},
        "closed": {"robotiq_85_left_knuckle_joint": 0.8575},
    }
    g = sim_gripper_from_files(desc, ROBOTIQ_2F.parent)
    kinds = {(r.item, r.kind) for r in g.repairs}
    assert ("robotiq_85_left_finger_tip_joint", "mimic limits") in kinds
    assert ("robotiq_85_left_knuckle_joint", "effort") in kinds
    scene = _close_in_air(g)
    leader = scene.data.qpos[scene.joint_qpos["robotiq_85_left_knuckle_joint"]]
    assert leader == pytest.approx(0.8575, abs=0.01)
    errors = _mimic_errors(g, scene)
    assert max(errors.values()) < 2e-3, errors


def test_eval_reports_the_repairs(
    claw_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture
):
    """``wsgrasp eval`` of the scaffolded claw: its JSON and Markdown reports
    list the claw's repairs, force limits and finger gains."""
    from wsgrasp.cli import main
    from wsgrasp.gripper.scaffold import scaffold_plugin

    yaml_path, _ = scaffold_plugin("claw", claw_dir / "claw.urdf", tmp_path / "pkg")
    md = tmp_path / "report.md"
    argv = ["eval", "-g", str(yaml_path), "--objects", "realsense_box", "-n", "1"]
    rc = main([*argv, "-j", "1", "--no-paper", "--json", "--md-out", str(md)])
    assert rc == 0
    report = json.loads(capsys.readouterr().out)
    notes = report["sim_grippers"][str(yaml_path)]
    assert {(r["item"], r["kind"]) for r in notes["repairs"]} >= {
        ("palm", "inertial"),
        ("left_pad_joint", "mimic limits"),
        ("left_knuckle_joint", "effort"),
    }
    assert notes["efforts"]["left_knuckle_joint"]["source"] == "default"
    assert "| left_pad_joint | mimic limits |" in md.read_text()
    # two revolute jaws: a drive guessed, and the report says whose gain it is
    kp = yaml.safe_load(yaml_path.read_text())["drive"]["kp_revolute"]
    assert (
        f"claw.yaml: finger position gains {kp:g} N·m/rad (the gripper YAML's drive)"
        in md.read_text()
    )


def test_flat_mesh_collides_as_a_thin_box(tmp_path: Path):
    """A collision mesh without volume (MuJoCo refuses its hull) becomes a box of
    its extent, 1 mm thick, and the repair says so."""
    import trimesh

    flat = trimesh.Trimesh(
        vertices=[[0, 0, 0], [0.01, 0, 0], [0, 0.02, 0], [0.01, 0.02, 0]],
        faces=[[0, 1, 2], [1, 3, 2]],
    )
    flat.export(tmp_path / "decal.stl")
    urdf = claw_urdf().replace(
        '<link name="tcp"/>',
        '<link name="tcp"><collision><geometry><mesh filename="decal.stl"/>'
        "</geometry></collision></link>",
    )
    (tmp_path / "claw.urdf").write_text(urdf)
    g = sim_gripper_from_files(claw_description(), tmp_path)
    (fix,) = [r for r in g.repairs if r.kind == "geometry"]
    assert fix.item == "tcp" and "decal.stl is flat" in fix.problem
    scene = build_scene(_box_object((0.3, 0.3, 0.04)), g)  # compiles
    m = scene.model
    (geom,) = np.flatnonzero(m.geom_bodyid == _body_id(scene, "tcp"))
    np.testing.assert_allclose(m.geom_size[geom], (0.005, 0.01, 0.0005), atol=1e-12)
