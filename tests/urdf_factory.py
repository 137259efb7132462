"""Small URDFs written by tests: jaw grippers with knobs for bad input, and a claw
with odd conventions (approach along x, revolute fingers, mesh geometry)."""

from __future__ import annotations

from pathlib import Path


def _box(size: str, xyz: str = "0 0 0") -> str:
    return (
        f'<collision><origin xyz="{xyz}" rpy="0 0 0"/>'
        f'<geometry><box size="{size}"/></geometry></collision>'
    )


def jaw_urdf(
    *,
    mimic: bool = True,
    actuated: bool = True,
    stray_tree: bool = False,
    continuous: bool = False,
    scale: float = 1.0,
    apart: bool = False,
) -> str:
    """A parallel jaw along y, approach +z: palm box, two prismatic fingers.

    ``mimic=False`` drives the second finger by its own joint; ``actuated=False``
    makes both finger joints fixed; ``stray_tree`` adds a link joined to nothing;
    ``continuous`` adds an unlimited continuous joint to the left finger's chain;
    ``scale`` multiplies every length (1000 gives a URDF in millimetres);
    ``apart`` mounts the fingers 60 mm apart, so they never meet.
    """
    s = scale

    def v(*xs: float) -> str:
        return " ".join(f"{x * s:g}" for x in xs)

    kind = "prismatic" if actuated else "fixed"
    lim = f'<limit lower="0" upper="{0.04 * s:g}" effort="1" velocity="1"/>'
    mim = '<mimic joint="left_joint"/>' if mimic else ""
    y0 = 0.03 if apart else 0.005
    left_parent = "palm"
    extra = ""
    if continuous:
        extra = f"""
  <link name="swivel">{_box(v(0.01, 0.01, 0.01))}</link>
  <joint name="swivel_joint" type="continuous">
    <parent link="palm"/><child link="swivel"/>
    <origin xyz="{v(0, 0, 0.05)}"/><axis xyz="0 0 1"/>
  </joint>"""
        left_parent = "swivel"
    stray = (
        f'\n  <link name="stray_camera">{_box(v(0.02, 0.02, 0.02))}</link>'
        if stray_tree
        else ""
    )
    return f"""<?xml version="1.0"?>
<robot name="jaw">
  <link name="palm">{_box(v(0.04, 0.16, 0.05), v(0, 0, 0.025))}</link>{extra}
  <link name="left_finger">{_box(v(0.02, 0.015, 0.05), v(0, 0.0075, 0.025))}</link>
  <joint name="left_joint" type="{kind}">
    <parent link="{left_parent}"/><child link="left_finger"/>
    <origin xyz="{v(0, y0, 0.05 if not continuous else 0.0)}"/>
    <axis xyz="0 1 0"/>{lim if actuated else ""}
  </joint>
  <link name="right_finger">{_box(v(0.02, 0.015, 0.05), v(0, -0.0075, 0.025))}</link>
  <joint name="right_joint" type="{kind}">
    <parent link="palm"/><child link="right_finger"/>
    <origin xyz="{v(0, -y0, 0.05)}"/>
    <axis xyz="0 -1 0"/>{lim if actuated else ""}{mim if actuated else ""}
  </joint>{stray}
</robot>
"""


def write_claw(folder: Path, *, mesh_scale: float = 1.0) -> Path:
    """An odd claw: approach along +x, two fingers of two links each turning about
    z (revolute, the distal joint a mimic), STL meshes referenced as
    ``package://claw_description/meshes/...``, a camera on a fixed joint.

    ``mesh_scale`` writes the mesh files in other units (1000: millimetres).
    """
    import trimesh

    folder.mkdir(parents=True, exist_ok=True)
    meshes = folder / "meshes"
    meshes.mkdir(exist_ok=True)
    parts = {
        "palm.stl": ((0.06, 0.12, 0.05), (0.03, 0.0, 0.0)),
        "proximal.stl": ((0.05, 0.014, 0.02), (0.025, 0.0, 0.0)),
        "distal.stl": ((0.04, 0.012, 0.018), (0.02, 0.0, 0.0)),
        "camera.stl": ((0.025, 0.09, 0.025), (0.0, 0.0, 0.0)),
    }
    for name, (extents, centre) in parts.items():
        mesh = trimesh.creation.box(extents=extents)
        mesh.apply_translation(centre)
        mesh.apply_scale(mesh_scale)
        mesh.export(meshes / name)

    def mesh(name: str) -> str:
        return (
            '<collision><geometry><mesh filename="package://claw_description/'
            f'meshes/{name}"/></geometry></collision>'
        )

    def finger(side: str, y: float, axis: str) -> str:
        return f"""
  <link name="{side}_proximal">{mesh("proximal.stl")}</link>
  <joint name="{side}_knuckle" type="revolute">
    <parent link="claw_base"/><child link="{side}_proximal"/>
    <origin xyz="0.06 {y:g} 0"/><axis xyz="{axis}"/>
    <limit lower="-0.3" upper="0.7" effort="1" velocity="1"/>
  </joint>
  <link name="{side}_distal">{mesh("distal.stl")}</link>
  <joint name="{side}_tip_joint" type="revolute">
    <parent link="{side}_proximal"/><child link="{side}_distal"/>
    <origin xyz="0.05 0 0"/><axis xyz="{axis}"/>
    <limit lower="-0.15" upper="0.35" effort="1" velocity="1"/>
    <mimic joint="{side}_knuckle" multiplier="0.5" offset="0"/>
  </joint>"""

    text = f"""<?xml version="1.0"?>
<robot name="claw">
  <link name="claw_base">{mesh("palm.stl")}</link>
  <link name="camera">{mesh("camera.stl")}</link>
  <joint name="camera_mount" type="fixed">
    <parent link="claw_base"/><child link="camera"/>
    <origin xyz="0.0 0 0.045"/>
  </joint>{finger("upper", 0.04, "0 0 -1")}{finger("lower", -0.04, "0 0 1")}
</robot>
"""
    path = folder / "claw.urdf"
    path.write_text(text)
    return path


def rigid_jaw_urdf(width: float = 0.02) -> str:
    """One moving jaw closing on a jaw fixed to the palm (approach +z): the palm
    carries a box body and, on the same link, a rigid jaw plate (inner face at
    y = -20 mm, 40 to 100 mm up); the moving jaw turns about x on a hinge at
    y = +25 mm, tilting its tip towards the rigid jaw for positive angles, its
    limits running past where the two meet (about 0.68 rad). Both jaws are
    ``width`` (m) wide along x."""
    plate = f"{width:g} 0.01 0.06"
    return f"""<?xml version="1.0"?>
<robot name="rigid_jaw">
  <link name="palm">{_box(f"{max(0.04, width):g} 0.08 0.04", "0 0 0.02")}{
        _box(plate, "0 -0.025 0.07")
    }</link>
  <link name="jaw">{_box(plate, "0 0 0.03")}</link>
  <joint name="jaw_joint" type="revolute">
    <parent link="palm"/><child link="jaw"/>
    <origin xyz="0 0.025 0.04"/><axis xyz="1 0 0"/>
    <limit lower="-0.6" upper="1.0" effort="2" velocity="1"/>
  </joint>
</robot>
"""


def swing_jaw_urdf(opening: float = 0.96) -> str:
    """Two long jaws hinged on a palm, swinging open outwards (approach +z,
    closing along x), as on a gripper whose jaws tilt open rather than slide:
    a palm box 120 x 80 x 160 mm under hinges at x = +-26 mm, 30 mm up; each
    jaw a bar 12 x 20 x 140 mm standing up from its hinge, upright and 4 mm
    from the other jaw at 0, tilted out by ``opening`` (rad) at its upper
    limit (the right jaw a mimic of the left)."""

    def jaw(side: str, sign: int, mimic: str) -> str:
        return f"""
  <link name="{side}_jaw">{_box("0.012 0.02 0.14", f"{-0.018 * sign:g} 0 0.07")}</link>
  <joint name="{side}_hinge" type="revolute">
    <parent link="palm"/><child link="{side}_jaw"/>
    <origin xyz="{0.026 * sign:g} 0 0.03"/><axis xyz="0 {sign} 0"/>
    <limit lower="0" upper="{opening:g}" effort="2" velocity="1"/>{mimic}
  </joint>"""

    return f"""<?xml version="1.0"?>
<robot name="swing_jaw">
  <link name="palm">{_box("0.12 0.08 0.16", "0 0 -0.05")}</link>{jaw("left", -1, "")}{
        jaw("right", 1, '<mimic joint="left_hinge"/>')
    }
</robot>
"""
