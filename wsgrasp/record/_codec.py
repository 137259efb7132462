"""The full-fidelity encoding of a run: exact arrays inside a protobuf record.

Each full-fidelity message is one ``wsgrasp.Record`` of the proto3 file below;
:data:`DESCRIPTOR_SET`, the schema the MCAP file declares, lets any protobuf
reader (Foxglove included) decode it. ``json`` holds the record's structure, in
which ``{"$array": i}`` stands for ``arrays[i]`` (raw little-endian bytes: arrays
decode bit for bit) and ``{"$float": "nan"}`` for a float JSON cannot hold. A
float64 array whose every value is exactly a float32 (sensor clouds usually are)
is stored as float32 and marked ``"$as": "<f8"``: the test is on the bits, so it
decodes to the very float64 bits it was recorded from.
"""

from __future__ import annotations

import json
import math
from dataclasses import fields, is_dataclass
from typing import Any

import numpy as np
from google.protobuf import (
    descriptor_pb2,
    descriptor_pool,
    message_factory,
    text_format,
)
from numpy.typing import NDArray

from wsgrasp.errors import RecordingError

__all__ = [
    "DESCRIPTOR_SET",
    "FORMAT_VERSION",
    "PROFILE",
    "SCHEMA_NAME",
    "TOPICS",
    "encode",
    "loads",
]

#: Version of the recording layout. A reader refuses files with a larger one.
#: 3: the merged points always stored; spec and versions in ``/wsgrasp/run``.
#: 2: float64 arrays as float32 (``"$as"``), merged points as ``"merge(views)"``.
FORMAT_VERSION = 3


#: MCAP header profile of wsgrasp runs.
PROFILE = "wsgrasp"
SCHEMA_NAME = "wsgrasp.Record"

#: Full-fidelity channels, in the order they are written.
TOPICS = {
    "run": "/wsgrasp/run",
    "inputs": "/wsgrasp/inputs",
    "preprocess": "/wsgrasp/stage/preprocess",
    "segmentation": "/wsgrasp/stage/segmentation",
    "object_frame": "/wsgrasp/stage/object_frame",
    "candidates": "/wsgrasp/stage/candidates",
    "result": "/wsgrasp/result",
    "error": "/wsgrasp/error",
}


_FILE = text_format.Parse(
    """
    name: "wsgrasp/record.proto" package: "wsgrasp" syntax: "proto3"
    message_type { name: "Array"
      field { name: "dtype" number: 1 type: TYPE_STRING label: LABEL_OPTIONAL }
      field { name: "shape" number: 2 type: TYPE_UINT64 label: LABEL_REPEATED }
      field { name: "data" number: 3 type: TYPE_BYTES label: LABEL_OPTIONAL } }
    message_type { name: "Record"
      field { name: "format_version" number: 1 type: TYPE_UINT32 label: LABEL_OPTIONAL }
      field { name: "kind" number: 2 type: TYPE_STRING label: LABEL_OPTIONAL }
      field { name: "json" number: 3 type: TYPE_STRING label: LABEL_OPTIONAL }
      field { name: "arrays" number: 4 type: TYPE_MESSAGE label: LABEL_REPEATED
              type_name: ".wsgrasp.Array" } }
    """,
    descriptor_pb2.FileDescriptorProto(),
)
_POOL = descriptor_pool.DescriptorPool()
_POOL.Add(_FILE)
Record = message_factory.GetMessageClass(_POOL.FindMessageTypeByName(SCHEMA_NAME))
Array = message_factory.GetMessageClass(_POOL.FindMessageTypeByName("wsgrasp.Array"))

#: Serialized ``google.protobuf.FileDescriptorSet`` of ``wsgrasp/record.proto``.
DESCRIPTOR_SET: bytes = descriptor_pb2.FileDescriptorSet(
    file=[_FILE]
).SerializeToString()

_DTYPES = {"<f8", "<i8", "|b1", "<f4", "<i4", "|u1"}
#: float64 arrays at least this long are tried as float32 (smaller ones gain little)
F32_MIN_SIZE = 1024


def as_float32_exact(a: NDArray[Any]) -> NDArray[np.float32] | None:
    """``a`` (contiguous ``<f8``) as float32 when that keeps every bit, else None.
    The first values are tried first, so an array that is not float32 at heart
    costs almost nothing."""
    with np.errstate(over="ignore", invalid="ignore"):  # those fail the test
        head = a.reshape(-1)[:64]
        if not _same_bits(head.astype("<f4").astype("<f8"), head):
            return None
        f32 = a.astype("<f4")
        same = f32 == a  # equal values are equal bits (a cast keeps the sign)
        if same.all():
            return f32
        odd = ~same  # NaNs pass when their bits survive the round trip
        return f32 if _same_bits(f32[odd].astype("<f8"), a[odd]) else None


def _same_bits(x: NDArray[Any], y: NDArray[Any]) -> bool:
    return bool(np.array_equal(x.view("<i8"), y.view("<i8")))


def _stored_dtype(dtype: np.dtype[Any]) -> str:
    """The little-endian dtype an array of ``dtype`` is stored as."""
    wide = dtype.itemsize == 8
    out = {"f": "<f8" if wide else "<f4", "b": "|b1"}.get(dtype.kind, dtype.str)
    if dtype.kind in "iu" and dtype != np.uint8:
        out = "<i8" if wide else "<i4"
    if out not in _DTYPES:
        raise RecordingError(f"cannot record an array of dtype {dtype}")
    return out


class _Arrays(list):  # type: ignore[type-arg]
    """A record's arrays, ``(dtype, shape, bytes)``; ``seen``: the reference of
    each array object met, so that one met twice (a scene whose merged points are
    its only view's very array) is stored once."""

    def __init__(self) -> None:
        super().__init__()
        self.seen: dict[int, dict[str, Any]] = {}


def _encode_array(value: NDArray[Any], arrays: _Arrays) -> dict[str, Any]:
    if id(value) in arrays.seen:
        return dict(arrays.seen[id(value)])
    a = np.ascontiguousarray(value, dtype=_stored_dtype(value.dtype))
    ref: dict[str, Any] = {"$array": len(arrays)}
    if a.dtype.str == "<f8" and a.size >= F32_MIN_SIZE:
        f32 = as_float32_exact(a)
        if f32 is not None:
            a, ref["$as"] = f32, "<f8"
    arrays.append((a.dtype.str, a.shape, a.tobytes()))
    arrays.seen[id(value)] = ref
    return dict(ref)


def _float(f: float) -> Any:
    if math.isfinite(f):
        return f
    return {"$float": "nan" if math.isnan(f) else ("inf" if f > 0 else "-inf")}


def encode_value(value: Any, arrays: _Arrays) -> Any:
    """``value`` as plain JSON data, its arrays moved into ``arrays``: dataclasses
    as dicts, pydantic models as their JSON dump, anything unknown as its repr."""
    t = type(value)
    if t is float:  # plain scalars by exact type first (a record holds thousands)
        return _float(value)
    if t is int or t is str or t is bool or value is None:
        return value
    if isinstance(value, np.ndarray):
        return _encode_array(value, arrays)
    if isinstance(value, dict):
        return {str(k): encode_value(v, arrays) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [encode_value(v, arrays) for v in value]
    if is_dataclass(value) and not isinstance(value, type):
        return {
            f.name: encode_value(getattr(value, f.name), arrays) for f in fields(value)
        }
    if isinstance(value, np.generic):  # numpy scalars as Python ones
        value = value.item()
    for kind in (bool, int, str):  # and subclasses (enums) as their base
        if isinstance(value, kind):
            return kind(value)
    if isinstance(value, float):
        return _float(float(value))
    if hasattr(value, "model_dump"):  # pydantic models
        return encode_value(value.model_dump(mode="json"), arrays)
    return repr(value)


def decode_value(
    data: Any, arrays: list[Any], memo: dict[int, Any] | None = None
) -> Any:
    """Inverse of :func:`encode_value` (dataclasses come back as dicts; an array
    stored once for two references comes back as one array, as it was)."""
    memo = {} if memo is None else memo
    if isinstance(data, dict):
        if "$array" in data and set(data) <= {"$array", "$as"}:
            i = int(data["$array"])
            if i not in memo:
                memo[i] = _decode_array(arrays[i], data.get("$as"))
            return memo[i]
        if "$float" in data and len(data) == 1:
            return float(data["$float"])
        return {k: decode_value(v, arrays, memo) for k, v in data.items()}
    if isinstance(data, list):
        return [decode_value(v, arrays, memo) for v in data]
    return data


def _decode_array(a: Any, cast: str | None) -> NDArray[Any]:
    if a.dtype not in _DTYPES:
        raise ValueError(f"unknown array dtype {a.dtype!r}")
    # the record's own shape, e.g. (n, 3) points or (C, 4, 4) poses
    out = np.frombuffer(a.data, dtype=a.dtype).reshape(tuple(a.shape))
    if cast is None:
        return out.copy()
    if (a.dtype, cast) != ("<f4", "<f8"):
        raise ValueError(f"cannot read {a.dtype!r} array as {cast!r}")
    return out.astype("<f8")


def encode(value: Any, kind: str = "") -> tuple[bytes, Any]:
    """The bytes of one ``wsgrasp.Record`` holding ``value``, and ``value`` as the
    record holds it: plain data whose arrays are read-only views of the recorded
    array bytes (as stored: float32-exact arrays as float32), a snapshot that
    nothing the caller does later changes."""
    arrays = _Arrays()
    plain = encode_value(value, arrays)
    text = json.dumps(plain, allow_nan=False, separators=(",", ":"))
    msg = Record(format_version=FORMAT_VERSION, kind=kind, json=text)
    stored: dict[int, Any] = {}
    for i, (dtype, shape, data) in enumerate(arrays):  # data: our own copy
        msg.arrays.add(dtype=dtype, shape=shape, data=data)
        stored[i] = np.frombuffer(data, dtype=dtype).reshape(shape)
    return bytes(msg.SerializeToString()), decode_value(plain, [], stored)


def loads(data: bytes) -> Any:
    """Decode the bytes of one ``wsgrasp.Record``."""
    msg = Record.FromString(data)
    return decode_value(json.loads(msg.json), list(msg.arrays))
