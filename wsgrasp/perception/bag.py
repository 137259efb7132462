"""ROS 2 bags (MCAP) as planner input: ``sensor_msgs/msg/PointCloud2`` clouds, or
``sensor_msgs/msg/Image`` depth images (or ``compressedDepth`` ones,
``sensor_msgs/msg/CompressedImage``) with the ``camera_info`` beside them, and
their camera poses from ``/tf`` and ``/tf_static``:
``read_bag_scene("capture.mcap", "/camera/points", frame="world")``.

A bag is read through its summary (topics, start time) and chunk index: only the
chunks with the cloud wanted and the transforms up to its time are read. A bag
without a summary (cut short) is read from the start up to where it stops.
"""

from __future__ import annotations

import functools
import struct
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp.errors import InputError

if TYPE_CHECKING:
    from collections.abc import Iterator

    from wsgrasp.perception.depth import ImageKind

__all__ = ["CAMERA_INFO", "COMPRESSED_IMAGE", "IMAGE", "POINTCLOUD2", "TF_MESSAGE"]
__all__ += ["BagCloud", "bag_topics", "compressed_depth", "decode_rvl", "image_depth"]
__all__ += ["is_mcap"]
__all__ += ["read_bag_clouds", "read_bag_scene"]

Array = NDArray[np.float64]

POINTCLOUD2 = "sensor_msgs/msg/PointCloud2"
IMAGE = "sensor_msgs/msg/Image"
COMPRESSED_IMAGE = "sensor_msgs/msg/CompressedImage"
CAMERA_INFO = "sensor_msgs/msg/CameraInfo"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
#: depth image encodings (REP 118): 16-bit millimetres, 32-bit float metres
_DEPTH_ENCODINGS = {"16UC1": "u2", "mono16": "u2", "32FC1": "f4"}
#: PointField datatypes 1..8 → numpy scalar types
_POINTFIELD_DTYPES = dict(
    enumerate(("i1", "u1", "i2", "u2", "i4", "u4", "f4", "f8"), 1)
)


@dataclass
class BagCloud:
    """One PointCloud2 message, or one depth Image deprojected with its
    ``camera_info``, decoded: ``points`` (n, 3) float64 x, y, z in ``frame_id``
    (NaN points kept; a pixel without depth at (0, 0, 0)), ``stamp_ns`` its
    ``header.stamp`` (the log time when the stamp is zero), ``log_time_ns`` when
    the bag recorded it."""

    topic: str
    frame_id: str
    stamp_ns: int
    points: Array
    log_time_ns: int = 0


def is_mcap(path: str | Path) -> bool:
    """Whether ``path`` is a file that starts with the MCAP magic."""
    from mcap.writer import MCAP0_MAGIC

    try:
        with open(path, "rb") as fh:
            return fh.read(len(MCAP0_MAGIC)) == MCAP0_MAGIC
    except OSError:
        return False


def _open(path: str | Path) -> Path:
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{p}: no such bag file", hint="check the path")
    if not is_mcap(p):
        raise InputError(
            f"{p}: not an MCAP file",
            hint="give a ROS 2 bag recorded in MCAP (ros2 bag record -s mcap); "
            "convert a .db3 bag with `ros2 bag convert`",
        )
    return p


def _summary(p: Path) -> Any:
    """The bag's summary, or None (a bag cut short has none)."""
    from mcap.reader import make_reader

    try:
        with open(p, "rb") as fh:
            return make_reader(fh).get_summary()
    except Exception:  # noqa: BLE001 - no summary: read the messages
        return None


def _messages(
    p: Path,
    topics: Sequence[str] | None = None,
    *,
    ending_at: int | None = None,
    starting_at: int | None = None,
    reverse: bool = False,
) -> Iterator[tuple[Any, Any, Any]]:
    """``(schema, channel, message)`` on ``topics`` (all when None) logged between
    ``starting_at`` and ``ending_at`` (ns, inclusive), in log-time order (latest
    first with ``reverse``): through the chunk index, or, in a bag without a
    summary, read up to where it stops."""
    from mcap.exceptions import McapError
    from mcap.reader import NonSeekingReader, make_reader

    indexed = _summary(p) is not None
    try:
        with open(p, "rb") as fh:
            reader = make_reader(fh) if indexed else NonSeekingReader(fh)
            it = reader.iter_messages(
                topics,
                log_time_order=indexed,
                reverse=reverse,
                starting_at=starting_at,
                ending_at=ending_at,
            )
            if indexed:
                yield from it
                return
            out: list[tuple[Any, Any, Any]] = []
            try:
                out.extend(it)
            except (McapError, EOFError, ValueError, struct.error):
                if not out:
                    raise
            yield from sorted(out, key=lambda m: m[2].log_time, reverse=reverse)
    except (McapError, OSError, ValueError, struct.error) as exc:
        raise InputError(
            f"{p}: cannot read the bag: {exc}", hint="check the file is a complete MCAP"
        ) from None


def bag_topics(path: str | Path) -> dict[str, str]:
    """Topic → message type of every channel in a bag."""
    p = _open(path)
    summary = _summary(p)
    if summary is not None:
        return {
            ch.topic: getattr(summary.schemas.get(ch.schema_id), "name", "")
            for ch in summary.channels.values()
        }
    return {ch.topic: "" if s is None else s.name for s, ch, _ in _messages(p)}


def _first_time(p: Path) -> int:
    """The log time of the bag's first message (its statistics, when summed up)."""
    summary = _summary(p)
    if summary is not None and summary.statistics is not None:
        return int(summary.statistics.message_start_time)
    return next((int(m.log_time) for _, _, m in _messages(p)), 0)


def _decode(schema: Any, channel: Any, message: Any) -> Any:
    decoder = None
    if schema is not None:
        decoder = _decoder(
            channel.message_encoding, schema.name, schema.encoding, bytes(schema.data)
        )
    if decoder is None:
        raise InputError(
            f"topic {channel.topic!r} is not ROS 2 (encoding "
            f"{channel.message_encoding!r}, schema "
            f"{'none' if schema is None else schema.encoding!r})",
            hint="give a ROS 2 bag (cdr messages with ros2msg schemas)",
        )
    return decoder(message.data)


@functools.lru_cache(maxsize=64)
def _decoder(encoding: str, name: str, schema_encoding: str, data: bytes) -> Any:
    """The decoder of one message definition. Keyed by the definition itself:
    ``DecoderFactory`` keys its decoders by the schema's id, which is only a
    number within one file (two bags may give id 1 to different types)."""
    from mcap.records import Schema
    from mcap_ros2.decoder import DecoderFactory

    schema = Schema(id=0, data=data, encoding=schema_encoding, name=name)
    return DecoderFactory().decoder_for(encoding, schema)


def pointcloud2_xyz(msg: Any, topic: str = "") -> Array:
    """``(n, 3)`` float64 x, y, z of a decoded ``PointCloud2`` (row padding and
    either byte order handled).

    Raises
    ------
    InputError
        The cloud has no x, y or z field, or they are not numbers.
    """
    fields = {f.name: f for f in msg.fields}
    missing = [a for a in "xyz" if a not in fields]
    if missing:
        found = ", ".join(
            f"{f.name}:{_POINTFIELD_DTYPES.get(f.datatype, '?')}" for f in msg.fields
        )
        raise InputError(
            f"PointCloud2 on {topic or 'the topic'} has no {'/'.join(missing)} "
            f"field; its fields are: {found or 'none'}",
            hint="plan on a cloud of 3D points (x, y, z fields), e.g. the "
            "camera's points topic rather than a depth image or a 2D scan",
        )
    unknown = [fields[a] for a in "xyz" if fields[a].datatype not in _POINTFIELD_DTYPES]
    if unknown:
        raise InputError(
            f"PointCloud2 on {topic}: field {unknown[0].name} has unknown datatype "
            f"{unknown[0].datatype}",
            hint="x, y and z must be numbers (PointField datatypes 1..8)",
        )
    h, w, step = int(msg.height), int(msg.width), int(msg.point_step)
    data = bytes(msg.data)
    row = int(msg.row_step) if msg.row_step else step * w
    if h * w == 0:
        return np.zeros((0, 3))
    if len(data) < row * (h - 1) + step * w:
        raise InputError(
            f"PointCloud2 on {topic}: data has {len(data)} bytes, fewer than "
            f"{h} rows × {w} points × {step} bytes",
            hint="the message is malformed; re-record the bag",
        )
    order = ">" if msg.is_bigendian else "<"
    formats = [order + _POINTFIELD_DTYPES[fields[a].datatype] for a in "xyz"]
    offsets = [fields[a].offset for a in "xyz"]
    dtype = np.dtype(
        {"names": list("xyz"), "formats": formats, "offsets": offsets, "itemsize": step}
    )
    # (h, w) records over the bytes: rows may be padded (row_step)
    rec = np.ndarray((h, w), dtype=dtype, buffer=data, strides=(row, step))
    return np.stack([rec[a].reshape(-1).astype(np.float64) for a in "xyz"], axis=1)


def image_depth(msg: Any, topic: str = "") -> NDArray[np.generic]:
    """The depth ``(h, w)`` of a decoded ``sensor_msgs/Image``: ``16UC1`` (or
    ``mono16``) millimetres as uint16, ``32FC1`` metres as float32 (row padding
    and either byte order handled).

    Raises
    ------
    InputError
        Another encoding (a colour or 8-bit image), or data shorter than the
        image.
    """
    encoding = str(msg.encoding)
    if encoding not in _DEPTH_ENCODINGS:
        raise InputError(
            f"Image on {topic or 'the topic'} has encoding {encoding!r}, not a "
            f"depth encoding ({', '.join(_DEPTH_ENCODINGS)})",
            hint="pass --topic with the depth camera's image (e.g. "
            "/camera/depth/image_rect_raw), not its colour or infrared image",
        )
    h, w, step = int(msg.height), int(msg.width), int(msg.step)
    kind = ">" if msg.is_bigendian else "<"
    dtype = np.dtype(kind + _DEPTH_ENCODINGS[encoding])
    data = bytes(msg.data)
    step = step or w * dtype.itemsize
    if h * w == 0 or len(data) < step * (h - 1) + w * dtype.itemsize:
        raise InputError(
            f"Image on {topic}: {len(data)} bytes of data for {h} rows of {w} "
            f"pixels ({step} bytes a row)",
            hint="the message is malformed; re-record the bag",
        )
    rows = np.ndarray((h, w), dtype=dtype, buffer=data, strides=(step, dtype.itemsize))
    return rows.astype(dtype.newbyteorder("="))


#: compressed_depth_image_transport's ConfigHeader before the PNG: the
#: compression (an enum) and the two inverse-depth quantisation parameters
_CONFIG_HEADER = struct.Struct("<iff")


def compressed_depth(msg: Any, topic: str = "") -> NDArray[np.generic]:
    """The depth ``(h, w)`` of a decoded ``sensor_msgs/CompressedImage`` that
    ``compressed_depth_image_transport`` wrote (``format`` ``"16UC1;
    compressedDepth png"``: millimetres as uint16; ``"32FC1; compressedDepth
    png"``: its quantised inverse depth back to metres as float32, NaN where it
    has none).

    Raises
    ------
    InputError
        Another format (a colour image's ``jpeg``/``png``), or data that is no
        PNG or RVL image.
    """
    import io

    from PIL import Image, UnidentifiedImageError

    fmt = str(msg.format)
    encoding, _, rest = (part.strip() for part in fmt.partition(";"))
    codec = rest.removeprefix("compressedDepth").strip() or "png"
    # an old publisher's format is the encoding alone
    if encoding not in _DEPTH_ENCODINGS or (
        rest and not rest.startswith("compressedDepth")
    ):
        raise InputError(
            f"CompressedImage on {topic or 'the topic'} has format {fmt!r}, not a "
            "depth image's compressedDepth",
            hint="pass --topic with the depth image's compressedDepth topic (e.g. "
            "/camera/depth/image_rect_raw/compressedDepth), not a colour image's",
        )
    if codec not in ("png", "rvl"):
        raise InputError(
            f"CompressedImage on {topic}: compressedDepth {codec!r} is not read "
            "(png and rvl are)",
            hint="record the raw depth image, or set the publisher's "
            "compressedDepth format to png or rvl",
        )
    data = bytes(msg.data)
    try:
        _, quant_a, quant_b = _CONFIG_HEADER.unpack_from(data)
        if codec == "rvl":
            stored = decode_rvl(data[_CONFIG_HEADER.size :])
        else:
            with Image.open(io.BytesIO(data[_CONFIG_HEADER.size :])) as png:
                stored = np.asarray(png)
    except (struct.error, UnidentifiedImageError, OSError, ValueError) as exc:
        raise InputError(
            f"CompressedImage on {topic}: its compressedDepth data is no "
            f"{codec.upper()} image ({exc})",
            hint="the message is malformed; re-record the bag",
        ) from None
    if _DEPTH_ENCODINGS[encoding] == "u2":
        return stored.astype(np.uint16)
    q = stored.astype(np.float32)
    with np.errstate(divide="ignore"):
        return np.where(q > 0, np.float32(quant_a) / (q - np.float32(quant_b)), np.nan)


#: the most pixels an RVL image is decoded to: far past any depth camera's, short
#: of what a corrupt size would have it allocate
_RVL_MAX_PIXELS = 1 << 26


def decode_rvl(data: bytes) -> NDArray[np.uint16]:
    """A 16-bit image ``(rows, cols)`` from ``compressed_depth_image_transport``'s
    RVL data (after its 12-byte header): ``cols`` and ``rows`` (uint32), then
    Wilson's run-length and variable-length code ("Fast lossless depth image
    compression", 2017) in 32-bit little-endian words, read from each word's
    high nibble down. Its values are 3 bits a nibble, low bits first, the
    nibble's fourth bit set while more follow; they come as runs: zeros, then
    nonzeros, then each nonzero's difference from the previous one, zigzag
    coded (``2 d`` for ``d >= 0``, ``-2 d - 1`` below).

    No package on PyPI decodes it (the codec lives in ROS's C++ plugin). Here
    in numpy, the runs alone read one by one: a 640 x 480 image with holes in
    about 20 ms on the 2-core development machine.

    Raises
    ------
    ValueError
        Data cut short, sizes of zero, or runs that overrun the image.
    """
    if len(data) < 8:
        raise ValueError("RVL data shorter than its 8-byte size")
    cols, rows = struct.unpack_from("<II", data)
    n = rows * cols
    # (not bounded by the data's size: runs of zeros, a sparse image's holes,
    # cost a few nibbles however long)
    if n == 0 or n > _RVL_MAX_PIXELS:
        raise ValueError(f"RVL data of {len(data)} bytes says {cols} x {rows} pixels")
    body = data[8 : 8 + (len(data) - 8) // 4 * 4]
    words = np.frombuffer(body, dtype="<u4").astype(np.int64)
    nibbles = ((words[:, None] >> np.arange(28, -4, -4)) & 0xF).reshape(-1)
    ends = np.flatnonzero((nibbles & 8) == 0)  # each value's last nibble
    if not len(ends):
        raise ValueError("RVL data holds no whole value")
    starts = np.concatenate([[0], ends[:-1] + 1]).astype(np.int64)
    whole = int(ends[-1]) + 1  # a value cut short at the end: dropped
    place = np.arange(whole) - np.repeat(starts, ends - starts + 1)
    bits = (nibbles[:whole] & 7) << (3 * place)
    values = np.add.reduceat(bits, starts)
    # the runs: where each nonzero run starts in the image and in ``values``
    at, v, runs = 0, 0, []
    while at < n:
        if v + 1 >= len(values):
            raise ValueError(f"RVL data ends after {at} of {n} pixels")
        zeros, nonzeros = int(values[v]), int(values[v + 1])
        at += zeros
        runs.append((at, nonzeros, v + 2))
        at += nonzeros
        v += 2 + nonzeros
    if at != n or v > len(values):
        raise ValueError(f"RVL runs cover {at} pixels of an image of {n}")
    first, count, source = np.array(runs, dtype=np.int64).T  # (runs,) each
    mask = np.zeros(n + 1, dtype=np.int64)
    np.add.at(mask, first, 1)
    np.add.at(mask, first + count, -1)
    pixel = np.cumsum(mask[:n]) > 0
    index = np.repeat(source - np.cumsum(count) + count, count) + np.arange(
        int(count.sum())
    )
    zigzag = values[index]
    delta = (zigzag >> 1) ^ -(zigzag & 1)
    out = np.zeros(n, dtype=np.uint16)
    out[pixel] = (np.cumsum(delta) & 0xFFFF).astype(np.uint16)
    return out.reshape(rows, cols)


def _image_topic(topic: str, compressed: bool = False) -> str:
    """The image topic a depth topic carries: itself, or for a compressed one
    the topic its transport follows (``.../image_rect_raw/compressedDepth`` →
    ``.../image_rect_raw``)."""
    return topic.rsplit("/", 1)[0] if compressed else topic


def _camera_info_topic(image_topic: str) -> str:
    """The ``camera_info`` topic beside an image's (``/camera/depth/image_rect_raw``
    → ``/camera/depth/camera_info``), as ROS camera drivers publish them."""
    return image_topic.rsplit("/", 1)[0] + "/camera_info"


def _image_kind(image_topic: str) -> ImageKind:
    """Which image an image topic carries, by ROS's names: a rectified one where
    a part of its name says ``rect`` (``image_rect``, RealSense's
    ``image_rect_raw``), else the camera's raw image (``image_raw``), whose
    ``camera_info`` gives the lens distortion to undo."""
    parts = image_topic.strip("/").split("/")
    return "rect" if any("rect" in part for part in parts) else "raw"


def _image_points(
    p: Path, topic: str, msg: Any, log_time: int, types: dict[str, str]
) -> Array:
    """A depth Image's points in its frame, by the intrinsics of the
    ``camera_info`` beside it (the latest at or before the image, else the first
    after it): for a rectified image (:func:`_image_kind`) its ``P``, for a raw
    one its ``K`` and the lens distortion ``D``, undone."""
    from wsgrasp.perception.depth import Intrinsics, depth_points

    compressed = types.get(topic) == COMPRESSED_IMAGE
    image_topic = _image_topic(topic, compressed)
    info_topic = _camera_info_topic(image_topic)
    if types.get(info_topic) != CAMERA_INFO:
        infos = [t for t, ty in sorted(types.items()) if ty == CAMERA_INFO]
        raise InputError(
            f"{p}: the depth image on {topic!r} has no {CAMERA_INFO} beside it on "
            f"{info_topic!r}; CameraInfo topics in the bag: "
            f"{', '.join(infos) or 'none'}",
            hint="record the depth camera's camera_info with its image (ros2 bag "
            "record includes it when listed), or plan on its PointCloud2 topic",
        )
    info = next(_messages(p, [info_topic], ending_at=log_time, reverse=True), None)
    if info is None:
        info = next(_messages(p, [info_topic], starting_at=log_time), None)
    if info is None:
        raise InputError(
            f"{p}: no message on {info_topic!r}",
            hint="record the depth camera's camera_info with its image",
        )
    depth = compressed_depth(msg, topic) if compressed else image_depth(msg, topic)
    intrinsics = Intrinsics.from_camera_info(
        _decode(*info),
        _image_kind(image_topic),
        f"{p}: the camera_info on {info_topic!r}",
    )
    return depth_points(depth, intrinsics, name=topic)


def _stamp(msg: Any, log_time: int) -> int:
    try:
        s = int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec)
    except AttributeError:
        s = 0
    return s or int(log_time)


def read_bag_clouds(
    path: str | Path, topics: str | Sequence[str], *, at: float | None = None
) -> list[BagCloud]:
    """The latest cloud on each of ``topics`` (``sensor_msgs/msg/PointCloud2``, or
    ``sensor_msgs/msg/Image`` depth images with their ``camera_info`` beside
    them), or the latest at or before ``at``: seconds since the bag's first
    message, or a UNIX time in seconds (values above 1e9)."""
    p = _open(path)
    tlist = [topics] if isinstance(topics, str) else list(topics)
    t_limit: int | None = None
    if at is not None:
        t_limit = int(at * 1e9) if at > 1e9 else _first_time(p) + int(at * 1e9)
    types = bag_topics(p)
    out = []
    for topic in tlist:
        latest = next(_messages(p, [topic], ending_at=t_limit, reverse=True), None)
        if topic not in types or (latest is None and t_limit is None):
            listing = ", ".join(f"{t} ({ty})" for t, ty in sorted(types.items()))
            raise InputError(
                f"{p}: has no messages on topic {topic!r}; its topics are: "
                f"{listing or 'none'}",
                hint="pass --topic with one of the PointCloud2 or depth Image "
                "topics above",
            )
        if types[topic] not in (POINTCLOUD2, IMAGE, COMPRESSED_IMAGE):
            raise InputError(
                f"{p}: topic {topic!r} carries {types[topic] or 'untyped messages'}, "
                f"not {POINTCLOUD2} or a depth {IMAGE}",
                hint="pass --topic with a PointCloud2 or depth Image topic",
            )
        if latest is None:
            raise InputError(
                f"{p}: no cloud on {topic!r} at or before --at {at}",
                hint="give a later time, in seconds since the bag's start",
            )
        msg = _decode(*latest)
        log_time = int(latest[2].log_time)
        if types[topic] in (IMAGE, COMPRESSED_IMAGE):
            points = _image_points(p, topic, msg, log_time, types)
        else:
            points = pointcloud2_xyz(msg, topic)
        stamp = _stamp(msg, log_time)
        out.append(BagCloud(topic, str(msg.header.frame_id), stamp, points, log_time))
    return out


# -- transforms ---------------------------------------------------------------------
#: the /tf messages recorded within this long (ns) of a cloud are searched for
#: the transforms stamped at its time
TF_WINDOW_NS = 2_000_000_000


def _tf_edges(
    p: Path, t_ns: int, log_ns: int | None = None
) -> dict[str, tuple[str, Array]]:
    """child → (parent, T_parent_child): static transforms, and per child the
    dynamic one stamped latest at or before ``t_ns`` (the earliest after it
    when none is before).

    The stamps compared are the messages' ``header.stamp``, the clock the
    cloud's ``t_ns`` is on (a bag recorded with ``use_sim_time`` stamps them in
    simulated time, and records them in wall-clock time); the messages looked
    at are those recorded within ``TF_WINDOW_NS`` of the cloud, ``log_ns``.
    Without ``log_ns``, or with no /tf message there, the messages recorded at
    or before ``t_ns``, then after it."""
    from scipy.spatial.transform import Rotation

    def pose(tr: Any) -> tuple[str, Array]:
        q, v = tr.transform.rotation, tr.transform.translation
        T = np.eye(4)
        T[:3, :3] = Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix()
        T[:3, 3] = [v.x, v.y, v.z]
        return str(tr.header.frame_id).lstrip("/"), T

    def transforms(read: Iterator[tuple[Any, Any, Any]]) -> Iterator[tuple[Any, int]]:
        for schema, channel, message in read:
            if schema is not None and schema.name == TF_MESSAGE:
                for tr in _decode(schema, channel, message).transforms:
                    yield tr, _stamp(tr, int(message.log_time))

    edges = {
        str(tr.child_frame_id).lstrip("/"): pose(tr)
        for tr, _ in transforms(_messages(p, ["/tf_static"]))
    }
    static = set(edges)
    if log_ns is not None:
        # per child, the latest stamp at or before t_ns, else the earliest after
        best: dict[str, tuple[bool, int, Any]] = {}
        window = _messages(
            p,
            ["/tf"],
            starting_at=max(0, log_ns - TF_WINDOW_NS),
            ending_at=log_ns + TF_WINDOW_NS,
        )
        for tr, stamp in transforms(window):
            child = str(tr.child_frame_id).lstrip("/")
            key = (stamp <= t_ns, stamp if stamp <= t_ns else -stamp)
            if child not in static and (child not in best or key > best[child][:2]):
                best[child] = (*key, tr)
        if best:
            edges.update({child: pose(b[2]) for child, b in best.items()})
            return edges
    # recorded from t_ns back, then after it (each child keeps the first met)
    for read in (
        _messages(p, ["/tf"], ending_at=t_ns, reverse=True),
        _messages(p, ["/tf"], starting_at=t_ns + 1),
    ):
        for tr, _ in transforms(read):
            child = str(tr.child_frame_id).lstrip("/")
            if child not in edges:
                edges[child] = pose(tr)
    return edges


def _up(edges: dict[str, tuple[str, Array]], frame: str) -> tuple[str, Array]:
    """The root of the tree above ``frame`` and ``T_root_frame``."""
    T = np.eye(4)
    for _ in range(256):  # a cycle in /tf stops here
        if frame not in edges:
            break
        frame, T_parent_frame = edges[frame]
        T = T_parent_frame @ T
    return frame, T


def camera_pose(
    edges: dict[str, tuple[str, Array]], target: str | None, cloud_frame: str
) -> tuple[str, Array]:
    """``(world frame name, T_world_camera)`` for a cloud in ``cloud_frame``."""
    cloud_frame = cloud_frame.lstrip("/")
    root, T_root_cloud = _up(edges, cloud_frame)
    if target is None:
        return root, T_root_cloud
    target = target.lstrip("/")
    if target == cloud_frame:
        return target, np.eye(4)
    target_root, T_root_target = _up(edges, target)
    if target_root != root:
        known = sorted(set(edges) | {e[0] for e in edges.values()})
        raise InputError(
            f"no transform from {target!r} to the cloud's frame {cloud_frame!r} in "
            f"/tf or /tf_static; frames in the bag: {', '.join(known) or 'none'}",
            hint="pass --frame with a frame connected to the cloud's, or leave it "
            "out to use the root of the cloud's transform tree",
        )
    return target, np.linalg.inv(T_root_target) @ T_root_cloud


def read_bag_scene(
    path: str | Path,
    topic: str | Sequence[str],
    frame: str | None = None,
    at: float | None = None,
) -> Any:
    """A planner ``Scene`` of a ROS 2 bag's clouds: one view per ``topic``, the
    latest cloud (at or before ``at``, as in :func:`read_bag_clouds`), its
    ``T_world_camera`` the transform from ``frame`` (by default the root of the
    clouds' transform tree, or the cloud's own frame when the bag has no
    transforms) to the cloud's ``header.frame_id`` at the cloud's time.

    Raises
    ------
    InputError
        Missing file, not MCAP, no such topic (the bag's topics are listed), not a
        PointCloud2 or depth Image, no x/y/z fields (the fields found are
        listed), an image without its camera_info, or no transform to ``frame``.
    """
    from wsgrasp.perception.io import scene_from_arrays

    p = _open(path)
    clouds = read_bag_clouds(p, topic, at=at)
    latest = max(clouds, key=lambda c: c.stamp_ns)
    edges = _tf_edges(p, latest.stamp_ns, latest.log_time_ns or None)
    poses = [camera_pose(edges, frame, c.frame_id) for c in clouds]
    worlds = {world for world, _ in poses}
    if len(worlds) > 1:
        raise InputError(
            f"the clouds' frames are not connected by /tf: roots {sorted(worlds)}",
            hint="pass --frame with a frame every cloud's frame is connected to",
        )
    views = [(c.points, T) for c, (_, T) in zip(clouds, poses, strict=True)]
    scene = scene_from_arrays(views)
    for v, c in zip(scene.views, clouds, strict=True):
        v.name = f"{c.topic} ({c.frame_id})"
    return scene
