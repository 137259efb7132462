"""A writer of small ROS 2 bags (MCAP) for the tests: PointCloud2 clouds, depth
Images with their CameraInfo, and ``/tf`` / ``/tf_static`` transforms, written with
``mcap_ros2.writer``."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from wsgrasp.perception.bag import (
    CAMERA_INFO,
    COMPRESSED_IMAGE,
    IMAGE,
    POINTCLOUD2,
    TF_MESSAGE,
)

_HEADER = "builtin_interfaces/Time stamp\nstring frame_id\n"
_TIME = "int32 sec\nuint32 nanosec\n"
_SEP = "=" * 80 + "\n"
#: the definitions a message with a ``std_msgs/Header`` appends for it
_HEADER_DEFS = (
    _SEP + "MSG: std_msgs/Header\n" + _HEADER + _SEP + "MSG: builtin_interfaces/Time\n"
) + _TIME
POINTCLOUD2_DEF = (
    "std_msgs/Header header\nuint32 height\nuint32 width\n"
    "sensor_msgs/PointField[] fields\nbool is_bigendian\nuint32 point_step\n"
    "uint32 row_step\nuint8[] data\nbool is_dense\n"
    + _HEADER_DEFS
    + _SEP
    + "MSG: sensor_msgs/PointField\n"
    "uint8 INT8=1\nuint8 UINT8=2\nuint8 INT16=3\nuint8 UINT16=4\nuint8 INT32=5\n"
    "uint8 UINT32=6\nuint8 FLOAT32=7\nuint8 FLOAT64=8\n"
    "string name\nuint32 offset\nuint8 datatype\nuint32 count\n"
)
IMAGE_DEF = (
    "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\n"
    "uint8 is_bigendian\nuint32 step\nuint8[] data\n" + _HEADER_DEFS
)
COMPRESSED_IMAGE_DEF = "std_msgs/Header header\nstring format\nuint8[] data\n" + (
    _HEADER_DEFS
)
CAMERA_INFO_DEF = (
    "std_msgs/Header header\nuint32 height\nuint32 width\n"
    "string distortion_model\nfloat64[] d\nfloat64[9] k\nfloat64[9] r\n"
    "float64[12] p\nuint32 binning_x\nuint32 binning_y\n"
    "sensor_msgs/RegionOfInterest roi\n"
    + _HEADER_DEFS
    + _SEP
    + "MSG: sensor_msgs/RegionOfInterest\n"
    "uint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\n"
    "bool do_rectify\n"
)
TF_MESSAGE_DEF = (
    "geometry_msgs/TransformStamped[] transforms\n"
    + _SEP
    + "MSG: geometry_msgs/TransformStamped\n"
    "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/Transform transform\n"
    + _HEADER_DEFS
    + _SEP
    + "MSG: geometry_msgs/Transform\n"
    "geometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation\n"
    + _SEP
    + "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n"
    + _SEP
    + "MSG: geometry_msgs/Quaternion\n"
    "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n"
)


def _time(t_ns: int) -> dict[str, int]:
    return {"sec": t_ns // 1_000_000_000, "nanosec": t_ns % 1_000_000_000}


def write_cloud_bag(
    path: str | Path,
    clouds: Sequence[tuple[str, str, Any, int]],
    transforms: Sequence[tuple[str, str, str, Any, int]] = (),
    *,
    fields: Sequence[str] = ("x", "y", "z"),
    chunk_size: int = 1024 * 1024,
    clock: int = 0,
) -> Path:
    """Write a ROS 2 bag (MCAP) of PointCloud2 clouds and transforms.

    Parameters
    ----------
    clouds
        ``(topic, frame_id, points (n, 3), t_ns)``; points stored as float32.
    transforms
        ``(topic, parent, child, T_parent_child (4, 4), t_ns)`` with topic ``/tf``
        or ``/tf_static``.
    fields
        Names of the three float32 fields (to write clouds without x/y/z).
    chunk_size
        Bytes after which a chunk ends.
    clock
        The messages are recorded at ``t_ns`` and stamped ``t_ns - clock``: a
        bag recorded with ``use_sim_time``, its stamps in simulated time.
    """
    from mcap_ros2.writer import Writer
    from scipy.spatial.transform import Rotation

    out = Path(path)
    with open(out, "wb") as fh:
        w = Writer(fh, chunk_size=chunk_size)
        pc_schema = w.register_msgdef(POINTCLOUD2, POINTCLOUD2_DEF)
        tf_schema = w.register_msgdef(TF_MESSAGE, TF_MESSAGE_DEF)
        events: list[tuple[int, int, Any]] = []
        for i, (topic, frame_id, pts, t) in enumerate(clouds):
            events.append((t, i, ("cloud", topic, frame_id, pts)))
        for i, (topic, parent, child, T, t) in enumerate(transforms):
            events.append((t, len(clouds) + i, ("tf", topic, parent, child, T)))
        for t, _, ev in sorted(events, key=lambda e: (e[0], e[1])):
            if ev[0] == "cloud":
                _, topic, frame_id, pts = ev
                p32 = np.ascontiguousarray(np.asarray(pts, dtype="<f4").reshape(-1, 3))
                msg = {
                    "header": {"stamp": _time(t - clock), "frame_id": frame_id},
                    "height": 1,
                    "width": len(p32),
                    "fields": [
                        {"name": n, "offset": 4 * k, "datatype": 7, "count": 1}
                        for k, n in enumerate(fields)
                    ],
                    "is_bigendian": False,
                    "point_step": 12,
                    "row_step": 12 * len(p32),
                    "data": p32.tobytes(),
                    "is_dense": bool(np.isfinite(p32).all()),
                }
                w.write_message(topic, pc_schema, msg, log_time=t, publish_time=t)
            else:
                _, topic, parent, child, T = ev
                T = np.asarray(T, dtype=np.float64)
                q = Rotation.from_matrix(T[:3, :3]).as_quat()
                msg = {
                    "transforms": [
                        {
                            "header": {"stamp": _time(t - clock), "frame_id": parent},
                            "child_frame_id": child,
                            "transform": {
                                "translation": dict(
                                    zip("xyz", T[:3, 3].tolist(), strict=True)
                                ),
                                "rotation": dict(zip("xyzw", q.tolist(), strict=True)),
                            },
                        }
                    ]
                }
                w.write_message(topic, tf_schema, msg, log_time=t, publish_time=t)
        w.finish()
    return out


#: compressed_depth_image_transport's inverse-depth quantisation at its defaults
#: (depth_quantization 100, depth_max 10 m): A = 100 * 101, B = 1 - A / 10
DEPTH_QUANT = (10100.0, -1009.0)


def write_depth_bag(
    path: str | Path,
    topic: str,
    frame_id: str,
    depth: np.ndarray,
    k: Sequence[float] | None,
    t_ns: int = 1_000_000_000,
    *,
    encoding: str = "16UC1",
    pad: int = 0,
    big_endian: bool = False,
    cut: int = 0,
    compressed: str | None = None,
    distortion: Sequence[float] = (0.0,) * 5,
    distortion_model: str = "plumb_bob",
    p: Sequence[float] | None = None,
    binning: tuple[int, int] = (0, 0),
    roi: tuple[int, int] = (0, 0),
) -> Path:
    """Write a ROS 2 bag of one depth Image on ``topic`` and, unless ``k`` is
    None, its CameraInfo (``K`` row by row) on the ``camera_info`` beside it.
    ``pad`` bytes end each row; ``big_endian`` stores the pixels so; the data
    lacks its last ``cut`` bytes. With ``compressed`` (a format, as
    ``"16UC1; compressedDepth png"``), a CompressedImage on ``topic`` +
    ``/compressedDepth`` instead, as compressed_depth_image_transport writes it:
    a 12-byte header, then ``depth`` (uint16: millimetres, or the quantised
    inverse depth ``A / z + B`` of a 32FC1 image, with the transport's default
    ``DEPTH_QUANT``) as a 16-bit PNG, or where the format ends in ``rvl``,
    as :func:`encode_rvl` codes it. The CameraInfo's ``D`` is ``distortion``
    (of ``distortion_model``), its ``P`` ``p`` (by default ``K`` with a zero
    column), its ``binning_x``, ``binning_y`` ``binning`` and its ``roi``'s
    offsets ``roi``."""
    from mcap_ros2.writer import Writer

    d = np.ascontiguousarray(depth)
    dtype = d.dtype.newbyteorder(">" if big_endian else "<")
    rows = d.astype(dtype).view(np.uint8).reshape(d.shape[0], -1)
    data = np.pad(rows, ((0, 0), (0, pad))).tobytes()
    data = data[: len(data) - cut]
    out = Path(path)
    header = {"stamp": _time(t_ns), "frame_id": frame_id}
    with open(out, "wb") as fh:
        w = Writer(fh)
        image = {
            "header": header,
            "height": d.shape[0],
            "width": d.shape[1],
            "encoding": encoding,
            "is_bigendian": int(big_endian),
            "step": rows.shape[1] + pad,
            "data": data,
        }
        if compressed is None:
            schema = w.register_msgdef(IMAGE, IMAGE_DEF)
            w.write_message(topic, schema, image, log_time=t_ns, publish_time=t_ns)
        else:
            import io
            import struct

            from PIL import Image

            if compressed.endswith("rvl"):
                payload = encode_rvl(d.astype(np.uint16))
            else:
                png = io.BytesIO()
                Image.fromarray(d.astype(np.uint16)).save(png, format="PNG")
                payload = png.getvalue()
            message = {
                "header": header,
                "format": compressed,
                "data": struct.pack("<iff", 0, *DEPTH_QUANT) + payload,
            }
            schema = w.register_msgdef(COMPRESSED_IMAGE, COMPRESSED_IMAGE_DEF)
            w.write_message(
                topic + "/compressedDepth",
                schema,
                message,
                log_time=t_ns,
                publish_time=t_ns,
            )
        if k is not None:
            info = {
                "header": header,
                "height": d.shape[0],
                "width": d.shape[1],
                "distortion_model": distortion_model,
                "d": [float(v) for v in distortion],
                "k": list(k),
                "r": [1.0, 0, 0, 0, 1.0, 0, 0, 0, 1.0],
                "p": [float(v) for v in p]
                if p is not None
                else [*k[:3], 0.0, *k[3:6], 0.0, *k[6:], 0.0],
                "binning_x": binning[0],
                "binning_y": binning[1],
                "roi": {
                    "x_offset": roi[0],
                    "y_offset": roi[1],
                    "height": 0,
                    "width": 0,
                    "do_rectify": False,
                },
            }
            schema = w.register_msgdef(CAMERA_INFO, CAMERA_INFO_DEF)
            info_topic = topic.rsplit("/", 1)[0] + "/camera_info"
            w.write_message(info_topic, schema, info, log_time=t_ns, publish_time=t_ns)
        w.finish()
    return out


def encode_rvl(image: np.ndarray) -> bytes:
    """A uint16 image as ``compressed_depth_image_transport`` codes it with RVL:
    ``cols``, ``rows`` (uint32), then, pixel by pixel, runs of zeros and of
    nonzeros, each nonzero as its zigzag-coded difference from the last,
    every number 3 bits a nibble (low bits first, the fourth bit set while
    more follow), eight nibbles to a little-endian 32-bit word, high nibble
    first; the last word padded with zero nibbles. Written as a plain loop,
    the decoder's reference."""
    flat = [int(v) for v in np.asarray(image, dtype=np.uint16).reshape(-1)]
    nibbles: list[int] = []

    def put(value: int) -> None:
        while True:
            nibble, value = value & 7, value >> 3
            nibbles.append(nibble | (8 if value else 0))
            if not value:
                return

    i, previous = 0, 0
    while i < len(flat):
        zeros = 0
        while i < len(flat) and flat[i] == 0:
            zeros, i = zeros + 1, i + 1
        put(zeros)
        j = i
        while j < len(flat) and flat[j] != 0:
            j += 1
        put(j - i)
        for value in flat[i:j]:
            delta = value - previous
            put(2 * delta if delta >= 0 else -2 * delta - 1)
            previous = value
        i = j
    nibbles += [0] * (-len(nibbles) % 8)
    words = [
        sum(n << (28 - 4 * k) for k, n in enumerate(nibbles[w : w + 8]))
        for w in range(0, len(nibbles), 8)
    ]
    h, w = np.asarray(image).shape
    return np.array([w, h, *words], dtype="<u4").tobytes()
