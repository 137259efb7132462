"""Synthetic hands written by tests: ``n`` two-joint revolute fingers standing on a
round palm, evenly spaced around it and closing towards its axis (approach +z),
with primitive geometry only, and the gripper YAML that describes them."""

from __future__ import annotations

from pathlib import Path

import numpy as np

#: palm radius and thickness, finger base circle radius (m)
PALM_RADIUS, PALM_THICKNESS, BASE_RADIUS = 0.05, 0.02, 0.045
#: proximal and distal link lengths (m)
PROXIMAL, DISTAL = 0.05, 0.04


def _collision(geometry: str, xyz: str) -> str:
    return (
        f'<collision><origin xyz="{xyz}" rpy="0 0 0"/>'
        f"<geometry>{geometry}</geometry></collision>"
    )


def hand_urdf(n: int) -> str:
    """The URDF of an ``n``-finger hand (see the module docstring).

    Finger ``i`` stands at angle ``2 pi i / n`` on a circle of
    :data:`BASE_RADIUS` around the palm's axis; both its joints turn about the
    circle's tangent, so that positive angles tilt the finger towards the axis.
    """
    palm = _collision(
        f'<cylinder radius="{PALM_RADIUS}" length="{PALM_THICKNESS}"/>',
        f"0 0 {PALM_THICKNESS / 2}",
    )
    proximal = _collision(
        f'<box size="0.014 0.014 {PROXIMAL}"/>', f"0 0 {PROXIMAL / 2}"
    )
    distal = _collision(
        f'<cylinder radius="0.006" length="{DISTAL}"/>', f"0 0 {DISTAL / 2}"
    )
    parts = [f'<link name="palm">{palm}</link>']
    for i in range(n):
        theta = 2.0 * np.pi * i / n
        c, s = np.cos(theta), np.sin(theta)
        axis = f"{s:.9f} {-c:.9f} 0"  # axis x z = -radial: tilts towards the axis
        base = f"{BASE_RADIUS * c:.9f} {BASE_RADIUS * s:.9f} {PALM_THICKNESS}"
        parts.append(
            f"""<link name="f{i}_proximal">{proximal}</link>
  <joint name="f{i}_base" type="revolute">
    <parent link="palm"/><child link="f{i}_proximal"/>
    <origin xyz="{base}" rpy="0 0 0"/><axis xyz="{axis}"/>
    <limit lower="-0.3" upper="1.0" effort="1" velocity="1"/>
  </joint>
  <link name="f{i}_distal">{distal}</link>
  <joint name="f{i}_tip" type="revolute">
    <parent link="f{i}_proximal"/><child link="f{i}_distal"/>
    <origin xyz="0 0 {PROXIMAL}" rpy="0 0 0"/><axis xyz="{axis}"/>
    <limit lower="0" upper="1.2" effort="1" velocity="1"/>
  </joint>"""
        )
    body = "\n  ".join(parts)
    return f'<?xml version="1.0"?>\n<robot name="hand{n}">\n  {body}\n</robot>\n'


def hand_yaml(n: int, urdf: str, name: str | None = None) -> str:
    """The gripper YAML of :func:`hand_urdf`'s hand: each finger's pad the inner
    side of its distal link's end, a few spheres per finger."""
    name = name or f"hand{n}"
    fingers = []
    for i in range(n):
        theta = 2.0 * np.pi * i / n
        inner = -0.004 * np.array([np.cos(theta), np.sin(theta)])  # towards the axis
        fingers.append(
            f"  - name: f{i}\n"
            f"    joints: [f{i}_base, f{i}_tip]\n"
            f"    pad: {{link: f{i}_distal, center: [{inner[0]:.6f}, {inner[1]:.6f}, "
            f"{DISTAL - 0.006}], size: [0.012, 0.012, 0.012], samples: 3}}\n"
        )
    pregrasp = ", ".join(f"f{i}_base: -0.2, f{i}_tip: 0.0" for i in range(n))
    closed = ", ".join(f"f{i}_base: 0.8, f{i}_tip: 1.0" for i in range(n))
    return (
        "version: 1\n"
        f"name: {name}\n"
        f"urdf: {urdf}\n"
        "base_link: palm\n"
        f"tool_frame: {{link: palm, xyz: [0.0, 0.0, {PALM_THICKNESS + PROXIMAL}]}}\n"
        "approach_axis: [0.0, 0.0, 1.0]\n"
        "closing_axis: [1.0, 0.0, 0.0]\n"
        "fingers:\n" + "".join(fingers) + "joint_samples: 8\n"
        "spheres_per_finger: 6\n"
        "workspace_voxel: 0.003\n"
        "min_sphere_radius: 0.003\n"
        f"ellipsoids: {{count: {min(n + 1, 7)}, exponent: 10.0}}\n"
        "cloud_points: 300\n"
        f"pregrasp: {{{pregrasp}}}\n"
        f"closed: {{{closed}}}\n"
    )


def write_hand(folder: Path, n: int, name: str | None = None) -> Path:
    """Write :func:`hand_urdf` and :func:`hand_yaml` for ``n`` fingers into
    ``folder``; the YAML's path."""
    folder.mkdir(parents=True, exist_ok=True)
    urdf = f"hand{n}.urdf"
    (folder / urdf).write_text(hand_urdf(n))
    path = folder / f"{name or f'hand{n}'}.yaml"
    path.write_text(hand_yaml(n, urdf, name))
    return path
