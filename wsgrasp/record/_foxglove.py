"""Messages in Foxglove's well-known schemas, so that Foxglove shows a run as it is.

Each builder returns ``(schema_name, encoded_bytes)``; the schema name is the exact
well-known name (``foxglove.PointCloud``, ...) and :func:`schema_of` gives the
protobuf ``FileDescriptorSet`` the writer registers for it.

Messages are built with foxglove-sdk, except the long repeated fields (the poses of
a ``PosesInFrame``, the spheres of a ``SceneEntity``): one Python object per pose
costs microseconds each, thousands per run, so these are encoded a whole array at a
time (:func:`_rows`) and appended to the SDK's encoding of the rest of the message
(protobuf concatenates repeated fields). Every field is written, zeros included,
which any protobuf reader accepts; the tests decode them with the schemas.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

try:  # foxglove-sdk >= 0.16 names them ``messages``
    import foxglove.messages as fm
except ImportError:  # pragma: no cover - older foxglove-sdk
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        import foxglove.schemas as fm  # type: ignore[no-redef]

__all__ = [
    "REASON_RGBA",
    "schema_of",
    "point_cloud",
    "frame_transform",
    "pose_in_frame",
    "poses_in_frame",
    "scene_update",
    "cube",
    "sphere",
]

Array = NDArray[np.float64]

#: Colour (r, g, b, a in 0..1) of each rejection reason, feasible first; the same
#: order as :data:`wsgrasp.planning.result.REASONS`.
REASON_RGBA: dict[str, tuple[float, float, float, float]] = {
    "feasible": (0.10, 0.75, 0.20, 1.0),
    "table_collision": (0.55, 0.35, 0.15, 0.8),
    "object_collision": (0.90, 0.15, 0.15, 0.8),
    "obstacle_collision": (0.60, 0.20, 0.75, 0.8),
    "finger_without_contact": (0.55, 0.60, 0.70, 0.8),
}
_OTHER_RGBA = (0.3, 0.3, 0.3, 0.8)


def reason_rgba(name: str) -> tuple[float, float, float, float]:
    """Colour of a rejection reason (grey for reasons this version does not know)."""
    return REASON_RGBA.get(name, _OTHER_RGBA)


_SCHEMAS: dict[str, Any] = {}


def schema_of(name: str) -> tuple[str, bytes]:
    """Encoding and data of the well-known schema ``name`` (e.g.
    ``"foxglove.PointCloud"``)."""
    if name not in _SCHEMAS:
        cls = getattr(fm, name.removeprefix("foxglove."))
        _SCHEMAS[name] = cls.get_schema()
    s = _SCHEMAS[name]
    return s.encoding, bytes(s.data)


# -- vectorised protobuf --------------------------------------------------------------
#: A row template: bytes are copied as they are, None is the next float64 column.
_Parts = list[bytes | None]


def _tag(field: int) -> int:
    """Key byte of a length-delimited field (fields 1..15)."""
    return (field << 3) | 2


def _vec3(field: int) -> _Parts:
    """A ``Vector3`` (x, y, z doubles: fields 1, 2, 3, 27 bytes) as ``field``."""
    return [bytes([_tag(field), 27, 0x09]), None, b"\x11", None, b"\x19", None]


def _vec4(field: int) -> _Parts:
    """A ``Quaternion`` (x, y, z, w) or ``Color`` (r, g, b, a): 4 doubles, 36 bytes."""
    head = bytes([_tag(field), 36, 0x09])
    return [head, None, b"\x11", None, b"\x19", None, b"\x21", None]


def _pose(field: int) -> _Parts:
    """A ``Pose`` (position 1, orientation 2: 67 bytes) as ``field``; columns
    x, y, z, qx, qy, qz, qw."""
    return [bytes([_tag(field), 67]), *_vec3(1), *_vec4(2)]


_ROW_LAYOUTS: dict[
    tuple[bytes | None, ...], tuple[np.dtype[Any], NDArray[Any], int]
] = {}


def _row_layout(parts: _Parts) -> tuple[np.dtype[Any], NDArray[Any], int]:
    """The structured dtype of a row of ``parts`` (constant runs merged), one row
    holding the constant bytes (doubles zero), and the number of doubles; made
    once per template."""
    key = tuple(parts)
    layout = _ROW_LAYOUTS.get(key)
    if layout is None:
        merged: list[bytes | None] = []
        for part in parts:
            if part is not None and merged and merged[-1] is not None:
                merged[-1] += part
            else:
                merged.append(part)
        names, formats = [], []
        for i, part in enumerate(merged):
            names.append(f"f{i}")
            formats.append("<f8" if part is None else f"V{len(part)}")
        dtype = np.dtype({"names": names, "formats": formats})
        template = np.zeros(1, dtype=dtype)
        for i, part in enumerate(merged):
            if part is not None:
                template[f"f{i}"] = np.void(part)
        doubles = sum(part is None for part in merged)
        layout = _ROW_LAYOUTS[key] = (dtype, template, doubles)
    return layout


def _rows(parts: _Parts, values: Array) -> bytes:
    """``len(values)`` protobuf fields, one per row: the constant bytes of
    ``parts`` with the row's doubles ``values`` (k, m) in place of the Nones."""
    dtype, template, doubles = _row_layout(parts)
    assert doubles == values.shape[1]
    rec = np.repeat(template, len(values))
    column = 0
    for name in dtype.names or ():
        if dtype[name] == np.float64:
            rec[name] = values[:, column]
            column += 1
    return rec.tobytes()


def pose_columns(T: ArrayLike) -> Array:
    """Columns x, y, z, qx, qy, qz, qw (k, 7) of transforms (k, 4, 4)."""
    T = np.asarray(T, dtype=np.float64).reshape(-1, 4, 4)  # (k, 4, 4)
    return np.concatenate([T[:, :3, 3], quaternions_xyzw(T[:, :3, :3])], axis=1)


def _stamp(t_ns: int) -> Any:
    return fm.Timestamp(t_ns // 1_000_000_000, t_ns % 1_000_000_000)


def quaternions_xyzw(R: ArrayLike) -> Array:
    """Unit quaternions ``q_xyzw`` ``(k, 4)`` of rotation matrices ``(k, 3, 3)``
    (Shepperd's method: the largest of w, x, y, z is found first, so every branch is
    well conditioned). The four branches are computed for every matrix and the
    right one picked: no masks, a few dozen whole-array operations."""
    R = np.asarray(R, dtype=np.float64).reshape(-1, 3, 3)  # (k, 3, 3)
    if len(R) == 1:  # one pose: plain floats beat a dozen tiny numpy calls
        return np.array([_quaternion_xyzw(R[0].tolist())])
    m00, m01, m02 = R[:, 0, 0], R[:, 0, 1], R[:, 0, 2]
    m10, m11, m12 = R[:, 1, 0], R[:, 1, 1], R[:, 1, 2]
    m20, m21, m22 = R[:, 2, 0], R[:, 2, 1], R[:, 2, 2]
    tr = m00 + m11 + m22  # (k,)
    best = np.argmax(np.stack([m00, m11, m22, tr], axis=1), axis=1)  # 3: w largest
    # 2 * (the largest component) for each branch: x, y, z, w
    s = 2.0 * np.sqrt(
        np.maximum(
            np.stack(
                [
                    1.0 + m00 - m11 - m22,
                    1.0 + m11 - m00 - m22,
                    1.0 + m22 - m00 - m11,
                    1.0 + tr,
                ]
            ),
            1e-300,
        )
    )  # (4, k)
    a, b, c = m01 + m10, m02 + m20, m12 + m21  # symmetric parts
    d, e, f = m21 - m12, m02 - m20, m10 - m01  # skew parts
    q = np.stack(
        [
            np.stack([0.25 * s[0], a / s[0], b / s[0], d / s[0]], axis=1),  # x largest
            np.stack([a / s[1], 0.25 * s[1], c / s[1], e / s[1]], axis=1),  # y largest
            np.stack([b / s[2], c / s[2], 0.25 * s[2], f / s[2]], axis=1),  # z largest
            np.stack([d / s[3], e / s[3], f / s[3], 0.25 * s[3]], axis=1),  # w largest
        ],
        axis=1,
    )  # (k, 4 branches, 4)
    q = q[np.arange(len(R)), best]  # (k, 4)
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def _quaternion_xyzw(R: list[list[float]]) -> list[float]:
    """:func:`quaternions_xyzw` of one rotation matrix (3, 3), the same branches."""
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = R
    d = [r00, r11, r22, r00 + r11 + r22]
    best = max(range(4), key=d.__getitem__)
    q = [0.0, 0.0, 0.0, 0.0]
    if best == 3:
        s = math.sqrt(max(1.0 + d[3], 1e-300))
        q = [(r21 - r12) * 0.5 / s, (r02 - r20) * 0.5 / s, (r10 - r01) * 0.5 / s]
        q.append(0.5 * s)
    else:
        i = best
        j, k = (i + 1) % 3, (i + 2) % 3
        s = math.sqrt(max(1.0 + 2.0 * R[i][i] - r00 - r11 - r22 + 0.0, 1e-300))
        q[i] = 0.5 * s
        q[j] = 0.5 * (R[j][i] + R[i][j]) / s
        q[k] = 0.5 * (R[k][i] + R[i][k]) / s
        q[3] = 0.5 * (R[k][j] - R[j][k]) / s
    n = math.sqrt(sum(c * c for c in q))
    return [c / n for c in q]


def _pq(T: ArrayLike) -> tuple[list[list[float]], list[list[float]]]:
    """Positions ``(k, 3)`` and quaternions ``q_xyzw`` ``(k, 4)`` of ``(k, 4, 4)``."""
    T = np.asarray(T, dtype=np.float64).reshape(-1, 4, 4)  # (k, 4, 4)
    if len(T) == 0:
        return [], []
    return T[:, :3, 3].tolist(), quaternions_xyzw(T[:, :3, :3]).tolist()


def _poses(T: ArrayLike) -> list[Any]:
    """Foxglove poses of transforms ``(k, 4, 4)``."""
    ps, qs = _pq(T)
    return [
        fm.Pose(
            position=fm.Vector3(x=p[0], y=p[1], z=p[2]),
            orientation=fm.Quaternion(x=q[0], y=q[1], z=q[2], w=q[3]),
        )
        for p, q in zip(ps, qs, strict=True)
    ]


def point_cloud(
    points: ArrayLike,
    frame_id: str,
    t_ns: int,
    *,
    rgba: ArrayLike | None = None,
    T_frame_points: ArrayLike | None = None,
) -> tuple[str, list[bytes | memoryview]]:
    """A ``foxglove.PointCloud`` of float32 x, y, z and optional uint8 colours.

    The encoded message is returned in pieces (their concatenation), the points'
    bytes a view of a fresh array.

    Parameters
    ----------
    points : (n, 3) float
    frame_id : str
    t_ns : int
        Timestamp (ns since the epoch).
    rgba : (4,) or (n, 4) float in 0..1, optional
    T_frame_points : (4, 4) float, optional
        Pose of the points' origin in ``frame_id``.
    """
    p = np.asarray(points).reshape(-1, 3)  # (n, 3)
    F = fm.PackedElementFieldNumericType
    fields = [
        fm.PackedElementField(name=axis, offset=4 * i, type=F.Float32)
        for i, axis in enumerate("xyz")
    ]
    if rgba is None:
        rows = np.ascontiguousarray(p, dtype="<f4")  # (n, 3)
        stride = 12
    else:
        c = np.asarray(rgba, dtype=np.float64)  # (4,) or (n, 4)
        c8 = np.ascontiguousarray(np.clip(np.round(c * 255.0), 0, 255), np.uint8)
        # one row of 4 x 4 bytes per point: x, y, z (float32), r, g, b, a (uint8)
        rows = np.empty((len(p), 4), dtype="<f4")
        rows[:, :3] = p
        rows.view("<u4")[:, 3] = c8.view("<u4")[..., 0]  # the colour's bytes
        stride = 16
        fields += [
            fm.PackedElementField(name=ch, offset=12 + i, type=F.Uint8)
            for i, ch in enumerate(("red", "green", "blue", "alpha"))
        ]
    pose = _poses(np.eye(4) if T_frame_points is None else T_frame_points)[0]
    msg = fm.PointCloud(
        timestamp=_stamp(t_ns),
        frame_id=frame_id,
        pose=pose,
        point_stride=stride,
        fields=fields,
    )
    # the data (field 6, bytes) appended to the rest as a view of ``rows``: a
    # cloud is copied once, into the file, not three times
    data = rows.reshape(-1).view(np.uint8).data
    head = b"\x32" + _varint(len(data)) if len(data) else b""
    return "foxglove.PointCloud", [bytes(msg.encode()), head, data]


def frame_transform(
    T_parent_child: ArrayLike, parent: str, child: str, t_ns: int
) -> tuple[str, bytes]:
    """A ``foxglove.FrameTransform``: ``T_parent_child`` (4, 4)."""
    (p,), (q,) = _pq(T_parent_child)
    msg = fm.FrameTransform(
        timestamp=_stamp(t_ns),
        parent_frame_id=parent,
        child_frame_id=child,
        translation=fm.Vector3(x=p[0], y=p[1], z=p[2]),
        rotation=fm.Quaternion(x=q[0], y=q[1], z=q[2], w=q[3]),
    )
    return "foxglove.FrameTransform", msg.encode()


def pose_in_frame(T: ArrayLike, frame_id: str, t_ns: int) -> tuple[str, bytes]:
    """A ``foxglove.PoseInFrame`` of one transform (4, 4)."""
    msg = fm.PoseInFrame(timestamp=_stamp(t_ns), frame_id=frame_id, pose=_poses(T)[0])
    return "foxglove.PoseInFrame", msg.encode()


def poses_in_frame(T: ArrayLike, frame_id: str, t_ns: int) -> tuple[str, bytes]:
    """A ``foxglove.PosesInFrame`` of transforms ``(k, 4, 4)``."""
    return poses_in_frame_columns(pose_columns(T), frame_id, t_ns)


def poses_in_frame_columns(
    columns: Array, frame_id: str, t_ns: int
) -> tuple[str, bytes]:
    """:func:`poses_in_frame` of :func:`pose_columns` ``(k, 7)``."""
    msg = fm.PosesInFrame(timestamp=_stamp(t_ns), frame_id=frame_id, poses=[])
    poses = _rows(_pose(3), columns)  # field 3: poses
    return "foxglove.PosesInFrame", bytes(msg.encode()) + poses


def poses_in_frame_groups(
    columns: Array, counts: Sequence[int], frame_id: str, t_ns: int
) -> list[tuple[str, bytes]]:
    """:func:`poses_in_frame_columns` of consecutive groups of rows of
    ``columns`` (k, 7), ``counts[i]`` rows in the i-th: every pose encoded in one
    pass."""
    rows = _rows(_pose(3), columns)  # field 3: poses
    size = len(rows) // len(columns) if len(columns) else 0
    msg = fm.PosesInFrame(timestamp=_stamp(t_ns), frame_id=frame_id, poses=[])
    head = bytes(msg.encode())
    out = []
    start = 0
    for n in counts:
        out.append(
            ("foxglove.PosesInFrame", head + rows[start * size : (start + n) * size])
        )
        start += n
    return out


def _color(rgba: tuple[float, ...]) -> Any:
    return fm.Color(r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3])


def cube(T: ArrayLike, size: ArrayLike, rgba: tuple[float, ...]) -> Any:
    """A cube primitive at pose ``T`` (4, 4) with full extents ``size`` (3,)."""
    s = np.asarray(size, dtype=np.float64).tolist()
    return fm.CubePrimitive(
        pose=_poses(T)[0], size=fm.Vector3(x=s[0], y=s[1], z=s[2]), color=_color(rgba)
    )


#: A ``SpherePrimitive`` as ``SceneEntity.spheres`` (field 9): pose 1, size 2,
#: color 3 (136 bytes: a two-byte length); columns pose (7), size (3), color (4)
_SPHERE: _Parts = [b"\x4a\x88\x01", *_pose(1), *_vec3(2), *_vec4(3)]


class Spheres(bytes):
    """Encoded ``SceneEntity.spheres`` entries (see :func:`spheres`)."""


def spheres(centers: ArrayLike, radii: ArrayLike, rgba: tuple[float, ...]) -> Spheres:
    """Sphere primitives at ``centers`` (k, 3) with ``radii`` (k,), for
    :func:`scene_update`."""
    c = np.asarray(centers, dtype=np.float64).reshape(-1, 3)  # (k, 3)
    d = 2.0 * np.asarray(radii, dtype=np.float64).reshape(-1, 1)  # (k, 1)
    k = len(c)
    cols = np.empty((k, 14))
    cols[:, 0:3] = c
    cols[:, 3:7] = (0.0, 0.0, 0.0, 1.0)  # identity orientation
    cols[:, 7:10] = d
    cols[:, 10:14] = rgba
    return Spheres(_rows(_SPHERE, cols))


def sphere(center: ArrayLike, radius: float, rgba: tuple[float, ...]) -> Spheres:
    """One sphere primitive."""
    return spheres(np.asarray(center).reshape(1, 3), [radius], rgba)


def scene_update(
    entities: Sequence[tuple[str, Sequence[Any], Sequence[Any]]],
    frame_id: str,
    t_ns: int,
) -> tuple[str, bytes]:
    """A ``foxglove.SceneUpdate`` of entities ``(id, cubes, spheres)``; spheres
    from :func:`spheres` (or a list of SDK ``SpherePrimitive``)."""
    stamp = _stamp(t_ns)
    out: list[bytes] = []
    for eid, cubes, sph in entities:
        packed = isinstance(sph, Spheres)
        entity = fm.SceneEntity(
            timestamp=stamp,
            frame_id=frame_id,
            id=eid,
            frame_locked=False,
            cubes=list(cubes),
            spheres=[] if packed else list(sph),
        )
        body = bytes(entity.encode()) + (bytes(sph) if packed else b"")
        out += [b"\x12", _varint(len(body)), body]  # SceneUpdate.entities: field 2
    return "foxglove.SceneUpdate", b"".join(out)


def _varint(n: int) -> bytes:
    out = bytearray()
    while n >= 0x80:
        out.append((n & 0x7F) | 0x80)
        n >>= 7
    out.append(n)
    return bytes(out)
