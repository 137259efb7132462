"""Build a :class:`GripperModel` from a gripper description (paper, section II)."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp.errors import GripperError
from wsgrasp.geometry import (
    JOINT_FIXED,
    points_in_superellipsoids,
    rot_x,
    rot_y,
    rot_z,
    transform_from,
)
from wsgrasp.gripper._body import (
    WORKSPACE_SUBSAMPLE,
    fit_superellipsoids,
    group_links,
    sample_body,
    thin_cloud,
)
from wsgrasp.gripper._sweep import finger_sweeps
from wsgrasp.gripper._urdf import Kinematics, load_kinematics
from wsgrasp.gripper._workspace import SphereFill, Workspace, fill_spheres
from wsgrasp.gripper._workspace import sample_workspace as _sample_workspace
from wsgrasp.gripper.model import GripperModel
from wsgrasp.spec import GripperDescription

Array = NDArray[np.float64]
Progress = Callable[[str], None]

#: bumped whenever the builder's output changes for the same inputs (cache key)
BUILDER_VERSION = 9


def _noop(_: str) -> None:
    pass


def urdf_path(desc: GripperDescription, base_dir: Path) -> Path:
    """The description's URDF, resolved against ``base_dir``."""
    p = Path(desc.urdf).expanduser()
    return p if p.is_absolute() else Path(base_dir) / p


def xyz_rpy_transform(xyz: Any, rpy: Any) -> Array:
    """URDF-style ``(4, 4)`` transform: ``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)``."""
    r, p, y = (float(v) for v in rpy)
    return transform_from(rot_z(y) @ rot_y(p) @ rot_x(r), np.asarray(xyz, float))


def _check_names(kin: Kinematics, desc: GripperDescription) -> dict[str, float]:
    """Check every link and joint the description names; return the pre-grasp
    posture as actuated-joint values."""
    kin.check_link(desc.base_link, desc.name, "base_link")
    kin.check_link(desc.tool_frame.link, desc.name, "tool_frame.link")
    for field in ("pregrasp", "closed"):
        posture: dict[str, float] = getattr(desc, field)
        for joint, value in posture.items():
            kin.check_joint(joint, desc.name, field)
            j = kin.joints[joint]
            if j.mimic is not None:
                raise GripperError(
                    f"gripper {desc.name!r}: {field} sets {joint!r}, a mimic joint "
                    f"of {kin.master(joint)!r}",
                    hint=f"set {kin.master(joint)!r} instead; mimics follow it",
                )
            if j.kind != JOINT_FIXED and not j.lower - 1e-9 <= value <= j.upper + 1e-9:
                raise GripperError(
                    f"gripper {desc.name!r}: {field}.{joint} is {value}, outside the "
                    f"joint's limits [{j.lower}, {j.upper}]",
                    hint=f"choose a value within the limits for {field}.{joint}",
                )
    return dict(desc.pregrasp)


def build_model(
    desc: GripperDescription,
    base_dir: Path,
    *,
    progress: Progress | None = None,
) -> GripperModel:
    """Turn a gripper description into a :class:`GripperModel`.

    Steps (timed into ``stats["stage_s"]``): read the URDF; per finger, sample the
    joint space, forward kinematics of the pad, voxelize and fill with spheres;
    sample the body cloud in the pre-grasp posture; fit (or take) the body
    superellipsoids; place the TCP and GWC frames.

    Parameters
    ----------
    desc
        The validated description.
    base_dir
        Directory that relative paths in ``desc`` (the URDF) are relative to.
    progress
        Called with a short label as each stage starts.

    Raises
    ------
    GripperError
        Naming the gripper, the field at fault and the fix.
    """
    say = progress or _noop
    t0 = time.perf_counter()
    stages: dict[str, float] = {}

    def stage(label: str, key: str, t: float) -> float:
        now = time.perf_counter()
        stages[key] = round(now - t, 4)
        say(label)
        return now

    say(f"{desc.name}: reading URDF")
    kin = load_kinematics(urdf_path(desc, base_dir), desc.name)
    pregrasp = _check_names(kin, desc)
    t = stage(f"{desc.name}: sampling finger workspaces", "urdf", t0)

    workspaces: list[Workspace] = []
    fills: list[SphereFill] = []
    for finger in desc.fingers:
        ws = _sample_workspace(kin, desc, finger)
        say(f"{desc.name}: filling finger {finger.name!r} with spheres")
        fills.append(
            fill_spheres(ws, desc.spheres_per_finger, desc.min_sphere_radius, desc.name)
        )
        workspaces.append(ws)
    t = stage(f"{desc.name}: sampling the gripper cloud", "spheres", t)

    body = sample_body(kin, desc.base_link, pregrasp, desc.cloud_points)
    cloud = thin_cloud(body.points, desc.cloud_points)
    t = stage(f"{desc.name}: fitting body superellipsoids", "cloud", t)

    ws_voxels = [ws.centers(np.argwhere(ws.occupied)) for ws in workspaces]
    se = desc.ellipsoids
    if se.given is not None:
        se_centers = np.array([e.center for e in se.given], dtype=np.float64)
        se_axes = np.array([e.semi_axes for e in se.given], dtype=np.float64)
        if np.any(se_axes <= 0):
            raise GripperError(
                f"gripper {desc.name!r}: ellipsoids.given has a semi-axis <= 0",
                hint="give positive semi_axes (m)",
            )
    else:
        all_ws = np.concatenate(ws_voxels)  # (W, 3)
        rng = np.random.default_rng(0)
        if len(all_ws) > WORKSPACE_SUBSAMPLE:
            all_ws = all_ws[rng.choice(len(all_ws), WORKSPACE_SUBSAMPLE, replace=False)]
        cell = sum(ws.volume for ws in workspaces) / max(len(all_ws), 1)
        groups = group_links(body, se.count, all_ws, cell)
        se_centers, se_axes = fit_superellipsoids(groups, se.exponent)
    t = stage(f"{desc.name}: placing frames", "ellipsoids", t)

    poses = kin.link_poses(desc.base_link, pregrasp)
    tf = desc.tool_frame
    T_gripper_tcp = poses[tf.link] @ xyz_rpy_transform(tf.xyz, tf.rpy)
    approach = np.asarray(desc.approach_axis, dtype=np.float64)
    closing = np.asarray(desc.closing_axis, dtype=np.float64)
    approach /= np.linalg.norm(approach)
    closing -= (closing @ approach) * approach
    closing /= np.linalg.norm(closing)
    centers = np.concatenate([f.centers for f in fills])  # (S, 3)
    radii = np.concatenate([f.radii for f in fills])  # (S,)
    finger_idx = np.repeat(np.arange(len(fills)), [len(f.radii) for f in fills])
    R_gwc = np.stack([np.cross(closing, approach), closing, approach], axis=1)
    T_gripper_gwc = transform_from(R_gwc, centers.mean(axis=0))
    # widest span along the closing axis between two different fingers' workspaces
    proj = [ws.points @ closing for ws in workspaces]
    hi = np.array([p.max() for p in proj])
    lo = np.array([p.min() for p in proj])
    span = hi[:, None] - lo[None, :]  # (F, F)
    if len(workspaces) > 1:
        np.fill_diagonal(span, -np.inf)
    max_opening = float(max(span.max(), 0.0))

    config_pad, config_finger, ptr, index = _sphere_configurations(workspaces, fills)
    # float32 values, as the model file keeps them (see _sphere_configurations)
    sweep = finger_sweeps(kin, desc, workspaces).astype(np.float32).astype(np.float64)
    inside = points_in_superellipsoids(cloud, se_centers, se_axes, se.exponent)
    fingers_stats: list[dict[str, Any]] = []
    for finger, ws, fill in zip(desc.fingers, workspaces, fills, strict=True):
        in_se = points_in_superellipsoids(
            ws_voxels[len(fingers_stats)], se_centers, se_axes, se.exponent
        )
        fingers_stats.append(
            {
                "name": finger.name,
                "joint_samples": desc.joint_samples
                ** len({kin.master(j) for j in finger.joints}),
                "workspace_points": int(len(ws.points)),
                "workspace_voxels": int(ws.occupied.sum()),
                "workspace_volume_m3": ws.volume,
                "closing_voxels": ws.closing,
                "sphere_candidates": fill.candidates,
                "covered_fraction": round(fill.covered_fraction, 4),
                "radius_min": float(fill.radii.min()),
                "radius_max": float(fill.radii.max()),
                "workspace_inside_se": round(float(in_se.mean()), 4),
            }
        )
    stage("", "frames", t)
    stats: dict[str, Any] = {
        "fingers": fingers_stats,
        "cloud_inside_se": round(float(inside.mean()), 4),
        "ellipsoids_fitted": se.given is None,
        "stage_s": stages,
        "build_s": round(time.perf_counter() - t0, 4),
    }
    return GripperModel(
        name=desc.name,
        cloud=cloud,
        sphere_centers=centers,
        sphere_radii=radii,
        sphere_finger=finger_idx.astype(np.int64),
        finger_names=[f.name for f in desc.fingers],
        se_centers=se_centers,
        se_semi_axes=se_axes,
        se_exponent=float(se.exponent),
        T_gripper_tcp=T_gripper_tcp,
        T_gripper_gwc=T_gripper_gwc,
        approach_axis=approach,
        closing_axis=closing,
        pregrasp={k: float(v) for k, v in desc.pregrasp.items()},
        closed={k: float(v) for k, v in desc.closed.items()},
        max_opening=max_opening,
        stats=stats,
        description=desc.model_dump(mode="json"),
        finger_joints=[list(ws.joints) for ws in workspaces],
        finger_limits=[np.stack([ws.lower, ws.upper], axis=1) for ws in workspaces],
        joint_samples=desc.joint_samples,
        config_pad=config_pad,
        config_finger=config_finger,
        sphere_config_ptr=ptr,
        sphere_config_index=index,
        finger_sweep=sweep,
    )


def _sphere_configurations(
    workspaces: list[Workspace], fills: list[SphereFill]
) -> tuple[Array, NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """For each sphere, the finger configurations with a pad sample inside it.

    Returns
    -------
    config_pad : (Q, 3) float
        Pad centres of every finger's joint grid, finger after finger.
    config_finger : (Q,) int
    sphere_config_ptr : (S + 1,) int
    sphere_config_index : (M,) int
        CSR lists of indices into ``config_pad``, sphere after sphere.
    """
    from scipy.spatial import cKDTree

    lists: list[NDArray[np.int64]] = []
    offset = 0
    for ws, fill in zip(workspaces, fills, strict=True):
        per = ws.points_per_configuration
        tree = cKDTree(ws.points)
        # a sample exactly on a sphere's surface counts, as in points_in_spheres
        hits = tree.query_ball_point(fill.centers, fill.radii * (1 + 1e-9))
        for h in hits:
            lists.append(offset + np.unique(np.asarray(h, dtype=np.int64) // per))
        offset += len(ws.pad_centers)
    counts = np.array([len(x) for x in lists], dtype=np.int64)
    ptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    index = np.concatenate(lists) if lists else np.zeros(0, dtype=np.int64)
    # float32 values, as the model file keeps them: a built and a loaded model
    # plan identically
    config_pad = np.concatenate([ws.pad_centers for ws in workspaces])
    config_pad = config_pad.astype(np.float32).astype(np.float64)
    config_finger = np.repeat(
        np.arange(len(workspaces)), [len(ws.pad_centers) for ws in workspaces]
    ).astype(np.int64)
    return config_pad, config_finger, ptr, index


def sample_workspace(
    desc: GripperDescription, base_dir: Path, finger: str
) -> Workspace:
    """The voxelized sampled workspace of one finger (for checks and pictures)."""
    kin = load_kinematics(urdf_path(desc, base_dir), desc.name)
    for f in desc.fingers:
        if f.name == finger:
            return _sample_workspace(kin, desc, f)
    raise GripperError(
        f"gripper {desc.name!r} has no finger {finger!r}",
        hint="use one of " + ", ".join(f.name for f in desc.fingers),
    )
