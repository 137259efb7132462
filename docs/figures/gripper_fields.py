"""Draw docs/gripper-fields.png: the gripper YAML's fields on the Robotiq 2F-85-like
example, seen along its x axis (the plane of approach and closing).

Run from the repository root: ``python docs/figures/gripper_fields.py``.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from wsgrasp.geometry import box_grid_points, transform_points  # noqa: E402
from wsgrasp.gripper import load_gripper  # noqa: E402
from wsgrasp.gripper._urdf import load_kinematics  # noqa: E402
from wsgrasp.spec import load_gripper_description  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
PKG = ROOT / "examples/plugins/robotiq_2f85_like/wsgrasp_robotiq_2f85_like"
YAML = PKG / "robotiq_2f85_like.yaml"
OUT = ROOT / "docs" / "gripper-fields.png"


def main() -> None:
    model = load_gripper(YAML)
    desc, base_dir = load_gripper_description(YAML)
    kin = load_kinematics(base_dir / desc.urdf, desc.name)
    fig, ax = plt.subplots(figsize=(7.5, 6.2), dpi=90)
    cloud = model.cloud
    ax.scatter(cloud[:, 1], cloud[:, 2], s=2, c="0.6", label="cloud (pregrasp)")
    colours = ("tab:red", "tab:green")
    for k, finger in enumerate(desc.fingers):
        pad = box_grid_points(finger.pad.center, finger.pad.size, 4)  # (P, 3)
        for posture, style in ((desc.pregrasp, "o"), (desc.closed, "x")):
            T = kin.chain_poses(desc.base_link, finger.pad.link, posture)
            p = transform_points(T, pad)
            ax.scatter(p[:, 1], p[:, 2], s=8, marker=style, c=colours[k])
        sel = model.sphere_finger == k
        for c, r in zip(
            model.sphere_centers[sel], model.sphere_radii[sel], strict=True
        ):
            ax.add_patch(plt.Circle((c[1], c[2]), r, fill=False, color=colours[k]))
    tcp = model.T_gripper_tcp[:3, 3]
    gwc = model.T_gripper_gwc[:3, 3]
    ax.plot(*tcp[1:], "k+", ms=14, mew=2)
    ax.plot(*gwc[1:], "b*", ms=10)
    arrow = {"arrowstyle": "->", "lw": 2}
    ax.annotate("", (0, 0.05), (0, 0), arrowprops={**arrow, "color": "tab:blue"})
    ax.annotate("", (0.05, 0), (0, 0), arrowprops={**arrow, "color": "tab:orange"})
    notes = [
        ((0.003, 0.045), "approach_axis [0, 0, 1]", "tab:blue"),
        ((0.03, -0.012), "closing_axis [0, 1, 0]", "tab:orange"),
        ((-0.075, -0.012), "base_link origin\n(the arm's flange)", "k"),
        ((tcp[1] - 0.052, tcp[2] - 0.014), "tool_frame (TCP) +", "k"),
        ((gwc[1] + 0.006, gwc[2] - 0.016), "* workspace centroid (GWC)", "b"),
        (
            (-0.088, 0.166),
            "fingers[left].pad: o pregrasp, x closed;\ncircles: its workspace spheres",
            colours[0],
        ),
        ((0.03, 0.166), "fingers[right].pad", colours[1]),
    ]
    for xy, text, colour in notes:
        ax.text(*xy, text, color=colour, fontsize=8.5)
    ax.plot(0, 0, "ko")
    ax.set_xlabel("y (m): closing")
    ax.set_ylabel("z (m): approach")
    ax.set_title("robotiq_2f85_like: the gripper YAML's fields (seen along x)")
    ax.set_aspect("equal")
    ax.set_xlim(-0.09, 0.09)
    ax.set_ylim(-0.02, 0.185)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(OUT)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
