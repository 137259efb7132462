"""The simulated gripper reads its URDF as the planner does: a hand mounted deep in
an arm's URDF is simulated as the subtree of its base link, and it can be scaffolded,
planned with and simulated end to end."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from urdf_factory import jaw_urdf

pytest.importorskip("mujoco")

from wsgrasp.sim import (  # noqa: E402
    EvalConfig,
    SimParams,
    build_scene,
    load_sim_gripper,
    run_eval,
    sim_gripper_from_files,
    spec_entries,
)
from wsgrasp.sim.objects import Part, SimObject  # noqa: E402

#: the camera mesh: a box of these extents, centred here in its shape frame
CAMERA_EXTENTS, CAMERA_CENTRE = (0.03, 0.08, 0.02), (0.01, 0.0, 0.0)
#: the camera's shape frame in the camera link, and the camera link on the palm
CAMERA_SHAPE_XYZ, CAMERA_MOUNT_XYZ = (0.0, 0.0, -0.01), (-0.03, 0.0, 0.0)
CAMERA_MASS = 0.05


def _inertial(mass: float, xyz: str = "0 0 0") -> str:
    return (
        f'<inertial><origin xyz="{xyz}"/><mass value="{mass}"/>'
        '<inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/>'
        "</inertial>"
    )


def _box(size: str, xyz: str = "0 0 0") -> str:
    return (
        f'<collision><origin xyz="{xyz}"/><geometry><box size="{size}"/>'
        "</geometry></collision>"
    )


def _link(mass: float, size: str, z: float) -> str:
    """An arm link: a box centred ``z`` up its axis, with its mass there."""
    return _inertial(mass, f"0 0 {z}") + _box(size, f"0 0 {z}")


def write_arm_with_jaw(folder: Path) -> Path:
    """A 3-joint arm (revolute, with inertials and boxes) whose flange carries the
    jaw of ``urdf_factory.jaw_urdf`` (fingers of 40 N) and a camera whose geometry
    is an STL mesh; the jaw's ``palm`` is four joints below the root."""
    import trimesh

    folder.mkdir(parents=True, exist_ok=True)
    mesh = trimesh.creation.box(extents=CAMERA_EXTENTS)
    mesh.apply_translation(CAMERA_CENTRE)
    mesh.export(folder / "camera.stl")
    jaw = jaw_urdf().replace('effort="1"', 'effort="40"')
    hand = jaw.split('<robot name="jaw">', 1)[1].rsplit("</robot>", 1)[0]
    cam_xyz = " ".join(map(str, CAMERA_SHAPE_XYZ))
    mount_xyz = " ".join(map(str, CAMERA_MOUNT_XYZ))
    arm = f"""
  <link name="arm_base">{_link(4.0, "0.2 0.2 0.1", 0.05)}</link>
  <link name="upper_arm">{_link(2.0, "0.08 0.08 0.4", 0.2)}</link>
  <joint name="shoulder" type="revolute">
    <parent link="arm_base"/><child link="upper_arm"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="80" velocity="1"/>
  </joint>
  <link name="forearm">{_link(1.5, "0.06 0.06 0.3", 0.15)}</link>
  <joint name="elbow" type="revolute">
    <parent link="upper_arm"/><child link="forearm"/>
    <origin xyz="0 0 0.4" rpy="0 1.2 0"/><axis xyz="0 1 0"/>
    <limit lower="-2.5" upper="2.5" effort="40" velocity="1"/>
  </joint>
  <link name="flange">{_inertial(0.2)}{_box("0.06 0.06 0.02", "0 0 0.01")}</link>
  <joint name="wrist" type="revolute">
    <parent link="forearm"/><child link="flange"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="10" velocity="1"/>
  </joint>
  <joint name="flange_palm" type="fixed">
    <parent link="flange"/><child link="palm"/>
    <origin xyz="0 0 0.02" rpy="0 0 0.7853981633974483"/>
  </joint>
  <link name="camera">{_inertial(CAMERA_MASS)}
    <collision><origin xyz="{cam_xyz}"/>
      <geometry><mesh filename="camera.stl"/></geometry></collision>
  </link>
  <joint name="camera_mount" type="fixed">
    <parent link="palm"/><child link="camera"/><origin xyz="{mount_xyz}"/>
  </joint>"""
    text = f'<?xml version="1.0"?>\n<robot name="arm_jaw">{arm}{hand}</robot>\n'
    path = folder / "arm_jaw.urdf"
    path.write_text(text)
    return path


@pytest.fixture(autouse=True)
def _cache(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch):
    cache = tmp_path_factory.getbasetemp() / "gripper-cache"
    monkeypatch.setenv("WSGRASP_CACHE_DIR", str(cache))


def _description(urdf: Path) -> dict:
    return {
        "name": "arm_jaw",
        "urdf": urdf.name,
        "base_link": "palm",
        "approach_axis": (0.0, 0.0, 1.0),
        "closing_axis": (0.0, 1.0, 0.0),
        "pregrasp": {"left_joint": 0.04},
        "closed": {"left_joint": 0.0},
    }


def _box_object() -> SimObject:
    T = np.eye(4)
    T[2, 3] = 0.04
    return SimObject("box", [Part("box", (0.04, 0.05, 0.08), T)], 0.2)


def test_hand_deep_in_an_arm_is_simulated_alone(tmp_path: Path):
    import mujoco

    urdf = write_arm_with_jaw(tmp_path)
    g = sim_gripper_from_files(_description(urdf), tmp_path)
    assert g.actuated == ["left_joint"]  # not the arm's shoulder, elbow, wrist
    assert g.mimics == {"right_joint": ("left_joint", 1.0, 0.0)}
    assert g.root_body == "g/palm"
    scene = build_scene(_box_object(), g)
    m, d = scene.model, scene.data
    names = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(m.nbody)}
    gripper = {n for n in names if n.startswith("g/")}
    assert gripper == {"g/palm", "g/left_finger", "g/right_finger", "g/camera"}
    joints = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(m.njnt)}
    assert {"g/left_joint", "g/right_joint"} <= joints
    assert not joints & {"g/shoulder", "g/elbow", "g/wrist"}

    def body(name: str) -> int:
        return mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)

    # the camera keeps its URDF mass; the fingers, without <inertial>, get
    # 1000 kg/m³ over their 20 x 15 x 50 mm boxes
    assert m.body_mass[body("g/camera")] == pytest.approx(CAMERA_MASS)
    assert m.body_mass[body("g/left_finger")] == pytest.approx(1000 * 15e-6, rel=1e-6)
    # the mesh sits where the URDF puts it: palm → camera link → shape → centre
    d.qpos[scene.gripper_qpos] = 0.0
    mujoco.mj_forward(m, d)
    mesh_geom = next(
        i
        for i in range(m.ngeom)
        if m.geom_type[i] == mujoco.mjtGeom.mjGEOM_MESH
        and m.geom_bodyid[i] == body("g/camera")
    )
    palm = body("g/palm")
    R_palm = d.xmat[palm].reshape(3, 3)
    centre_palm = R_palm.T @ (d.geom_xpos[mesh_geom] - d.xpos[palm])
    expected = np.add(np.add(CAMERA_MOUNT_XYZ, CAMERA_SHAPE_XYZ), CAMERA_CENTRE)
    np.testing.assert_allclose(centre_palm, expected, atol=1e-9)
    # the hull keeps the mesh's size
    vert = m.mesh_vert[m.mesh_vertadr[m.geom_dataid[mesh_geom]] :][
        : m.mesh_vertnum[m.geom_dataid[mesh_geom]]
    ]  # (n, 3) in the mesh's own (centred, principal) frame
    np.testing.assert_allclose(
        np.sort(np.ptp(vert, axis=0)), np.sort(CAMERA_EXTENTS), atol=1e-9
    )


def test_posture_naming_an_arm_joint_is_refused(tmp_path: Path):
    from wsgrasp.errors import SimulationError

    urdf = write_arm_with_jaw(tmp_path)
    desc = _description(urdf)
    desc["closed"] = {"left_joint": 0.0, "elbow": 0.3}
    with pytest.raises(SimulationError, match="'elbow'.*below base_link 'palm'"):
        sim_gripper_from_files(desc, tmp_path)


def test_scaffold_plan_and_simulate_a_hand_on_an_arm(tmp_path: Path):
    """`wsgrasp gripper new --base-link palm` on the arm's URDF, then one eval
    trial: drop, look, plan, approach, close, lift, hold; its recording lands in
    the record folder (named by the YAML's stem), not beside the gripper YAML."""
    from wsgrasp.gripper.scaffold import scaffold_plugin

    urdf = write_arm_with_jaw(tmp_path / "src")
    yaml_path, sc = scaffold_plugin("arm-jaw", urdf, tmp_path / "pkg", base_link="palm")
    assert sc.data["base_link"] == "palm"
    g = load_sim_gripper(str(yaml_path))
    assert g.actuated == ["left_joint"]
    config = EvalConfig(
        objects=[_box_object()],
        specs=spec_entries([str(yaml_path)], paper=False),
        trials=1,
        seed=0,
        params=SimParams(hold_time=1.0),
        workers=1,
        record_dir=tmp_path / "runs",
    )
    (tmp_path / "runs").mkdir()
    records, _ = run_eval(config, progress=False)
    (rec,) = records
    assert rec["found"], rec.get("hint")
    assert Path(rec["record"]).parent == tmp_path / "runs"
    assert Path(rec["record"]).name.startswith(f"{yaml_path.stem}-")
    assert Path(rec["record"]).is_file()
    # approached from the plan's pre-grasp pose, closed to its joint targets
    assert rec["approach_from"] == "plan" and rec["finger_targets"] == "plan"
    assert set(rec["joints_grasp"]) == {"left_joint"}
    assert rec["outcome"] == "success", rec


PYBULLET_PANDA = None
try:  # pybullet_data ships the real Franka Panda URDF (arm + hand, vendor meshes)
    import pybullet_data  # type: ignore[import-not-found]

    PYBULLET_PANDA = Path(pybullet_data.getDataPath()) / "franka_panda" / "panda.urdf"
except ImportError:
    pass


@pytest.mark.slow
@pytest.mark.skipif(
    PYBULLET_PANDA is None or not PYBULLET_PANDA.exists(),
    reason="pybullet_data is not installed: it carries the real panda.urdf "
    "(pip install pybullet to run this test)",
)
def test_real_panda_urdf_with_base_link_panda_hand(tmp_path: Path):
    from wsgrasp.gripper.scaffold import scaffold_plugin

    assert PYBULLET_PANDA is not None
    yaml_path, _ = scaffold_plugin(
        "panda", PYBULLET_PANDA, tmp_path / "pkg", base_link="panda_hand"
    )
    g = load_sim_gripper(str(yaml_path))
    assert g.actuated == ["panda_finger_joint1"]
    config = EvalConfig(
        objects=[_box_object()],
        specs=spec_entries([str(yaml_path)], paper=False),
        trials=2,
        seed=0,
        params=SimParams(hold_time=2.0),
        workers=min(2, os.cpu_count() or 1),
    )
    records, _ = run_eval(config, progress=False)
    assert [r["finger_targets"] for r in records] == ["plan", "plan"]
    assert [r["outcome"] for r in records] == ["success", "success"], records


def test_a_jaw_closing_on_a_rigid_one_holds_a_box(tmp_path: Path):
    """`gripper new` on a gripper of one moving jaw and a rigid one, then one
    eval trial: its default spec plans, the moving jaw pushes the box onto the
    rigid jaw, and the box is lifted and held (the lift protocol); the rigid
    jaw's finger has no joint to drive."""
    from urdf_factory import rigid_jaw_urdf

    from wsgrasp.gripper.scaffold import scaffold_plugin

    (tmp_path / "rj.urdf").write_text(rigid_jaw_urdf())
    yaml_path, _ = scaffold_plugin("rj", tmp_path / "rj.urdf", tmp_path / "pkg")
    g = load_sim_gripper(str(yaml_path))
    assert g.actuated == ["jaw_joint"]
    T = np.eye(4)
    T[2, 3] = 0.03
    config = EvalConfig(
        objects=[SimObject("box", [Part("box", (0.03, 0.04, 0.06), T)], 0.1)],
        specs=spec_entries([str(yaml_path)], paper=False),
        trials=1,
        seed=0,
        params=SimParams.for_protocol("lift", hold_time=1.0),
        workers=1,
    )
    records, _ = run_eval(config, progress=False)
    (rec,) = records
    assert rec["found"], rec.get("hint")
    assert rec["outcome"] == "success", rec


def test_a_rigid_jaws_concave_link_collides_as_its_convex_parts(tmp_path: Path):
    """A rigid jaw standing out of its gripper's body on one link (an L-shaped
    mesh): its convex hull would fill the corner in front of the jaw, where
    the moving jaw pushes the object, so that link collides as its convex
    decomposition (several mesh geoms, none holding the corner); a moving
    finger's mesh is still one convex hull."""
    pytest.importorskip("coacd")
    import re

    import trimesh
    from urdf_factory import rigid_jaw_urdf

    from wsgrasp.gripper.scaffold import scaffold_plugin

    block = trimesh.creation.box((0.04, 0.08, 0.04))
    block.apply_translation((0.0, 0.0, 0.02))
    plate = trimesh.creation.box((0.02, 0.01, 0.06))
    plate.apply_translation((0.0, -0.025, 0.07))
    trimesh.util.concatenate([block, plate]).export(tmp_path / "palm.stl")
    urdf = rigid_jaw_urdf().replace(
        '<link name="palm">',
        '<link name="palm"><collision><geometry><mesh filename="palm.stl"/>'
        "</geometry></collision>",
    )
    # the palm's geometry is the mesh alone
    head, rest = urdf.split('<link name="palm">', 1)
    palm, tail = rest.split("</link>", 1)
    palm = palm[: palm.index("</collision>") + len("</collision>")]
    (tmp_path / "rj.urdf").write_text(f'{head}<link name="palm">{palm}</link>{tail}')
    yaml_path, sc = scaffold_plugin("rj", tmp_path / "rj.urdf", tmp_path / "pkg")
    assert [f["joints"] for f in sc.data["fingers"]] == [["jaw_joint"], []]
    g = load_sim_gripper(str(yaml_path))
    build_scene(_box_object(), g)  # MuJoCo compiles it
    # each part's vertices, in the palm's frame (the mesh has no origin)
    parts = re.findall(r'<mesh name="g/palm/0/part\d+" vertex="([^"]+)"', g.asset_xml)
    assert len(parts) >= 2, g.asset_xml[:500]
    # a point in the corner in front of the jaw: inside the palm mesh's hull,
    # outside every convex part
    corner = np.array([0.0, 0.0, 0.06])
    assert trimesh.load(tmp_path / "palm.stl").convex_hull.contains([corner])[0]
    for text in parts:
        verts = np.array(text.split(), dtype=float).reshape(-1, 3)
        assert not trimesh.convex.convex_hull(verts).contains([corner])[0]
    # the moving jaw (a box here) is one geom as before
    assert 'name="g/jaw/0"' in g.body_xml


def test_an_effort_too_weak_to_close_the_fingers_is_replaced(tmp_path: Path):
    """A jaw whose URDF effort (0.1 N·m, within the plausible range) cannot turn
    it against its joint's damping in the closing time: free of any object it
    closes a fraction of the way, the default effort nearly all of it, so it is
    driven with the default and the repair says how far each closed. With the
    damping light enough for 0.1 N·m to close it, the URDF's effort stays."""
    from dataclasses import replace

    from urdf_factory import rigid_jaw_urdf

    from wsgrasp.gripper.scaffold import scaffold_plugin
    from wsgrasp.sim.gripper import EFFORT_SHORTFALL, free_closing

    urdf = rigid_jaw_urdf().replace('effort="2"', 'effort="0.1"')
    (tmp_path / "rj.urdf").write_text(urdf)
    yaml_path, _ = scaffold_plugin("rj", tmp_path / "rj.urdf", tmp_path / "pkg")
    stiff = replace(SimParams(), damping_revolute=0.3)
    g = load_sim_gripper(str(yaml_path), stiff)
    assert g.efforts["jaw_joint"] == (stiff.effort_revolute, "N·m", "default")
    (fix,) = [r for r in g.repairs if r.kind == "effort"]
    assert fix.item == "jaw_joint" and "effort 0.1 N·m closes the finger" in fix.problem
    assert free_closing(g, stiff)[0] > 0.9
    light = load_sim_gripper(str(yaml_path), SimParams())
    assert light.efforts["jaw_joint"] == (0.1, "N·m", "urdf")
    assert free_closing(light, SimParams())[0] > 1.0 - EFFORT_SHORTFALL
