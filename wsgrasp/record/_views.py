"""The Foxglove views of a run: ``(topic, message)`` pairs of foxglove-sdk's
message classes (``PointCloud``, ``PoseInFrame``, ``PosesInFrame``,
``FrameTransform``, ``SceneUpdate``), so that Foxglove shows a run as it is. The
quaternions (``q_xyzw``, Foxglove's order) come from one scipy ``Rotation`` for all
the poses of a stage.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

try:  # foxglove-sdk >= 0.16 names them ``messages``
    import foxglove.messages as fm
except ImportError:  # pragma: no cover - older foxglove-sdk
    import foxglove.schemas as fm  # type: ignore[no-redef]

if TYPE_CHECKING:
    from wsgrasp.gripper.model import GripperModel

__all__ = ["FOXGLOVE_MAX_POINTS", "REASON_RGBA", "point_cloud", "views_of"]

#: Most points of the input views, all together, in their Foxglove channels
#: (``/inputs/view<i>``; the exact views are in ``/wsgrasp/inputs``).
FOXGLOVE_MAX_POINTS = 30_000

#: Colour (r, g, b, a in 0..1) of each rejection reason, feasible first; the same
#: order as :data:`wsgrasp.planning.result.REASONS`.
REASON_RGBA: dict[str, tuple[float, float, float, float]] = {
    "feasible": (0.10, 0.75, 0.20, 1.0),
    "table_collision": (0.55, 0.35, 0.15, 0.8),
    "object_collision": (0.90, 0.15, 0.15, 0.8),
    "obstacle_collision": (0.60, 0.20, 0.75, 0.8),
    "finger_without_contact": (0.55, 0.60, 0.70, 0.8),
    "finger_sweeps_table": (0.54, 0.54, 0.0, 0.8),
}
_OTHER_RGBA = (0.3, 0.3, 0.3, 0.8)

View = tuple[str, Any]  # (topic, foxglove-sdk message)
PQ = tuple[list[float], list[float]]  # a position (3,) and q_xyzw (4,)
_UNROTATED = [0.0, 0.0, 0.0, 1.0]


def _stamp(t_ns: int) -> Any:
    return fm.Timestamp(sec=t_ns // 1_000_000_000, nsec=t_ns % 1_000_000_000)


def _pqs(T: ArrayLike) -> list[PQ]:
    """Position and ``q_xyzw`` of each transform ``(k, 4, 4)``: one Rotation."""
    T = np.asarray(T, dtype=np.float64).reshape(-1, 4, 4)  # (k, 4, 4)
    if len(T) == 0:
        return []
    q = Rotation.from_matrix(T[:, :3, :3]).as_quat()  # (k, 4)
    return list(zip(T[:, :3, 3].tolist(), q.tolist(), strict=True))


def _v3(v: Any) -> Any:
    return fm.Vector3(x=float(v[0]), y=float(v[1]), z=float(v[2]))


def _quat(q: list[float]) -> Any:
    return fm.Quaternion(x=q[0], y=q[1], z=q[2], w=q[3])


def _pose(pq: PQ) -> Any:
    return fm.Pose(position=_v3(pq[0]), orientation=_quat(pq[1]))


def _at(p: ArrayLike) -> list[Any]:
    """Unrotated poses at positions ``p`` (k, 3)."""
    xyz = np.asarray(p, np.float64).reshape(-1, 3).tolist()  # (k, 3)
    return [_pose((x, _UNROTATED)) for x in xyz]


def _color(rgba: tuple[float, ...]) -> Any:
    return fm.Color(r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3])


def point_cloud(
    points: ArrayLike, frame_id: str, t_ns: int, *, rgba: ArrayLike | None = None
) -> Any:
    """A ``foxglove.PointCloud`` of float32 x, y, z and optional uint8 colours.

    Parameters
    ----------
    points : (n, 3) float
    rgba : (4,) or (n, 4) float in 0..1, optional
    """
    p = np.asarray(points).reshape(-1, 3)  # (n, 3)
    F = fm.PackedElementFieldNumericType
    fields = [
        fm.PackedElementField(name=axis, offset=4 * i, type=F.Float32)
        for i, axis in enumerate("xyz")
    ]
    if rgba is None:
        rows = np.ascontiguousarray(p, dtype="<f4")  # (n, 3)
    else:
        # one row per point: x, y, z (float32), r, g, b, a (uint8)
        rows = np.empty(len(p), dtype=[("xyz", "<f4", 3), ("rgba", "u1", 4)])
        rows["xyz"] = p
        rows["rgba"] = np.clip(np.round(np.asarray(rgba, np.float64) * 255), 0, 255)
        fields += [
            fm.PackedElementField(name=ch, offset=12 + i, type=F.Uint8)
            for i, ch in enumerate(("red", "green", "blue", "alpha"))
        ]
    return fm.PointCloud(
        timestamp=_stamp(t_ns),
        frame_id=frame_id,
        pose=_pose(([0.0, 0.0, 0.0], _UNROTATED)),
        point_stride=12 if rgba is None else 16,
        fields=fields,
        data=rows.tobytes(),
    )


def _transform(pq: PQ, parent: str, child: str, t: int) -> Any:
    """A ``foxglove.FrameTransform`` putting ``child`` at ``pq`` in ``parent``."""
    return fm.FrameTransform(
        timestamp=_stamp(t),
        parent_frame_id=parent,
        child_frame_id=child,
        translation=_v3(pq[0]),
        rotation=_quat(pq[1]),
    )


def _pose_in_frame(pq: PQ, t: int) -> Any:
    return fm.PoseInFrame(timestamp=_stamp(t), frame_id="world", pose=_pose(pq))


def _cube(pq: PQ, size: ArrayLike, rgba: tuple[float, ...]) -> Any:
    """A cube primitive at ``pq`` with full extents ``size`` (3,)."""
    return fm.CubePrimitive(pose=_pose(pq), size=_v3(size), color=_color(rgba))


def _entity(eid: str, frame_id: str, t: int, **shapes: Any) -> Any:
    return fm.SceneEntity(
        timestamp=_stamp(t), frame_id=frame_id, id=eid, frame_locked=False, **shapes
    )


def views_of(
    stage: str,
    d: dict[str, Any],
    t: int,
    gripper: GripperModel,
    table_axes: tuple[float, float, float],
) -> list[View]:
    """The views of the record ``d`` of ``stage`` (``table_axes``: the semi-axes
    of the spec's table superellipsoid, for the table's shape)."""
    if stage == "inputs":
        return _input_views([(v["points"], v["T_world_camera"]) for v in d["views"]], t)
    if stage == "result":
        return _result_views(d, gripper, t)
    if stage == "candidates":
        return _candidate_views(d.get("candidates"), t)
    if stage == "segmentation":  # the obstacles' points, (k, 3) in all
        obstacles = [np.asarray(o).reshape(-1, 3) for o in d.get("obstacles") or []]
        d = d | {"obstacles": np.concatenate(obstacles) if obstacles else None}
    out: list[View] = [
        (topic, point_cloud(d[key], "world", t, rgba=rgba))
        for key, topic, rgba in _CLOUDS.get(stage, ())
        if d.get(key) is not None
    ]
    if stage == "object_frame":
        out += _frame_views(d, t, table_axes)
    return out


#: The clouds of a stage: (record key, topic, colour).
_CLOUDS = {
    "preprocess": [
        ("points", "/scene/downsampled", (0.7, 0.7, 0.7, 1.0)),
        ("flying_points", "/scene/flying_pixels", (0.9, 0.1, 0.6, 1.0)),
    ],
    "segmentation": [
        ("table_points", "/scene/table_points", (0.6, 0.5, 0.4, 1.0)),
        ("object_points", "/scene/object", (0.1, 0.4, 0.9, 1.0)),
        ("obstacles", "/scene/obstacles", (0.9, 0.5, 0.1, 1.0)),
    ],
    "object_frame": [("samples_world", "/object/samples", (1.0, 0.85, 0.1, 1.0))],
    "fallback": [("samples_world", "/object/fallback_samples", (1.0, 0.55, 0.1, 1.0))],
}


def _input_views(views: list[tuple[NDArray[Any], NDArray[Any]]], t: int) -> list[View]:
    """The input views ``(points (n, 3), T_world_camera (4, 4))``, thinned by one
    step to at most :data:`FOXGLOVE_MAX_POINTS` points in all."""
    step = max(1, -(-sum(len(p) for p, _ in views) // FOXGLOVE_MAX_POINTS))
    out: list[View] = []
    for i, ((points, _), pq) in enumerate(
        zip(views, _pqs([T for _, T in views]), strict=True)
    ):
        out.append(("/tf", _transform(pq, "world", f"camera{i}", t)))
        out.append((f"/inputs/view{i}", point_cloud(points[::step], f"camera{i}", t)))
    return out


def _frame_views(
    d: dict[str, Any], t: int, table_axes: tuple[float, float, float]
) -> list[View]:
    """The object's and the table's frames, the object's box and the table."""
    names = [k for k in ("object", "table") if d.get(f"T_world_{k}") is not None]
    T = {k: np.asarray(d[f"T_world_{k}"], dtype=np.float64) for k in names}
    pq = dict(zip(names, _pqs(list(T.values())), strict=True))
    out: list[View] = [("/tf", _transform(pq[k], "world", k, t)) for k in pq]
    ents = []
    if "object" in pq:
        out.append(("/object/frame", _pose_in_frame(pq["object"], t)))
        if d.get("extents") is not None:
            box = _cube(pq["object"], d["extents"], (0.1, 0.4, 0.9, 0.15))
            ents.append(_entity("object_box", "world", t, cubes=[box]))
    if "table" in pq:
        a, b, c = table_axes  # the superellipsoid's centre is c below the surface
        centre = (T["table"][:3, :3] @ [0.0, 0.0, -c] + T["table"][:3, 3]).tolist()
        size, rgba = (2 * a, 2 * b, 2 * c), (0.6, 0.5, 0.4, 0.3)
        slab = _cube((centre, pq["table"][1]), size, rgba)
        ents.append(_entity("table_se", "world", t, cubes=[slab]))
    if ents:
        out.append(("/scene/shapes", fm.SceneUpdate(entities=ents)))
    return out


def _candidate_views(cs: Any, t: int) -> list[View]:
    """Every candidate's pose (``cs``: the recorded candidates), one
    ``PosesInFrame`` per rejection reason, and their grasp centres coloured by
    reason."""
    from wsgrasp.planning.result import REASONS

    if not isinstance(cs, dict) or len(cs["reason"]) == 0:
        return []
    reason = np.asarray(cs["reason"])
    poses = [_pose(pq) for pq in _pqs(cs["T_world_ee"])]
    out: list[View] = []
    names = [*REASONS, *(f"reason_{i}" for i in range(len(REASONS), reason.max() + 1))]
    for code, name in enumerate(names):
        picked = np.flatnonzero(reason == code).tolist()
        if picked:
            msg = fm.PosesInFrame(
                timestamp=_stamp(t), frame_id="world", poses=[poses[i] for i in picked]
            )
            out.append((f"/candidates/{name}", msg))
    colors = np.array([REASON_RGBA.get(n, _OTHER_RGBA) for n in REASONS])  # (R, 4)
    rgba = colors[np.clip(reason, 0, len(REASONS) - 1)]  # (C, 4)
    pts = np.asarray(cs["T_world_gwc"])[:, :3, 3]  # (C, 3)
    out.append(("/candidates/points", point_cloud(pts, "world", t, rgba=rgba)))
    return out


def _result_views(result: dict[str, Any], g: GripperModel, t: int) -> list[View]:
    """Of the recorded ``result``: the chosen pose, the gripper there (its cloud,
    body superellipsoids as boxes and workspace spheres, the ones holding object
    points highlighted) and the contacts. The gripper is drawn in frame
    ``gripper``, which ``/tf`` puts at the chosen pose."""
    if not result.get("found") or result.get("T_world_ee") is None:
        return []
    (pq,) = _pqs(result["T_world_ee"])
    out: list[View] = [
        ("/grasp/pose", _pose_in_frame(pq, t)),
        ("/tf", _transform(pq, "world", "gripper", t)),
        ("/grasp/gripper_cloud", point_cloud(g.cloud, "gripper", t)),
    ]
    grey = _color((0.5, 0.5, 0.55, 0.35))
    semi_axes = np.asarray(g.se_semi_axes).reshape(-1, 3)  # (B, 3)
    body = [
        fm.CubePrimitive(pose=at, size=_v3(2 * s), color=grey)
        for at, s in zip(_at(g.se_centers), semi_axes, strict=True)
    ]
    centers = np.asarray(g.sphere_centers, dtype=np.float64).reshape(-1, 3)  # (S, 3)
    radii = np.asarray(g.sphere_radii, dtype=np.float64).reshape(-1)  # (S,)
    held = np.zeros(len(radii), dtype=bool)
    contacts = result.get("contacts") or []
    for contact in contacts:
        held[np.asarray(contact["spheres"], dtype=np.int64)] = True

    def spheres(eid: str, mask: NDArray[np.bool_], rgba: tuple[float, ...]) -> Any:
        color = _color(rgba)
        shapes = [
            fm.SpherePrimitive(pose=at, size=_v3((2 * r,) * 3), color=color)
            for at, r in zip(_at(centers[mask]), radii[mask].tolist(), strict=True)
        ]
        return _entity(eid, "gripper", t, spheres=shapes)

    ents = [
        _entity("gripper_body", "gripper", t, cubes=body),
        spheres("workspace_spheres", ~held, (0.3, 0.6, 1.0, 0.15)),
        spheres("holding_spheres", held, (0.1, 0.9, 0.2, 0.6)),
    ]
    out.append(("/grasp/gripper", fm.SceneUpdate(entities=ents)))
    pts = [np.asarray(c["points"]).reshape(-1, 3) for c in contacts]
    if pts:
        cloud = point_cloud(np.concatenate(pts), "world", t, rgba=(0.1, 0.9, 0.2, 1.0))
        out.append(("/grasp/contacts", cloud))
    return out
