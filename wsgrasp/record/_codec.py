"""The full-fidelity encoding of a run: exact arrays inside a structured record.

Each full-fidelity message is one ``wsgrasp.Record`` (protobuf, see :mod:`._proto`):
a JSON text for the structure, in which ``{"$array": i}`` stands for the i-th raw
little-endian array of the record, so arrays decode bit for bit. A float that JSON
cannot hold (NaN, ±inf) is ``{"$float": "nan"}``. Everything else is plain JSON.

A float64 array whose every value is exactly a float32 (sensor clouds usually are)
is stored as float32, half the bytes, and marked ``{"$array": i, "$as": "<f8"}``:
it decodes to the very float64 bits it was recorded from. The test is on the bits
(float64 -> float32 -> float64 gives the same 64 bits), so ``-0.0``, infinities and
NaNs with the standard payload survive it and any other NaN stays float64.
"""

from __future__ import annotations

import json
import math
from dataclasses import fields, is_dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from wsgrasp.errors import RecordingError
from wsgrasp.record._proto import ArrayBytes, decode_record, encode_record_parts

__all__ = [
    "FORMAT_VERSION",
    "PROFILE",
    "TOPICS",
    "encode_value",
    "decode_value",
    "dumps",
    "dumps_parts",
    "loads",
]

#: Version of the recording layout. A reader refuses files with a larger one.
#: 2: float64 arrays may be stored as float32 (``"$as"``), the merged scene points
#: as ``"merge(views)"`` (see :mod:`._writer`). Version 1 files still read.
FORMAT_VERSION = 2

#: MCAP header profile of wsgrasp runs.
PROFILE = "wsgrasp"

#: Full-fidelity channels, in the order they are written.
TOPICS = {
    "inputs": "/wsgrasp/inputs",
    "preprocess": "/wsgrasp/stage/preprocess",
    "segmentation": "/wsgrasp/stage/segmentation",
    "object_frame": "/wsgrasp/stage/object_frame",
    "candidates": "/wsgrasp/stage/candidates",
    "result": "/wsgrasp/result",
    "error": "/wsgrasp/error",
}

_DTYPES = {"<f8", "<i8", "|b1", "<f4", "<i4", "|u1"}

#: float64 arrays at least this long are tried as float32 (smaller ones gain little,
#: and trying costs tens of microseconds an array)
F32_MIN_SIZE = 1024
_PROBE = 64
_BLOCK = 32768


def as_float32_exact(a: NDArray[Any]) -> NDArray[np.float32] | None:
    """``a`` (contiguous ``<f8``) as float32 when that keeps every bit, else None.

    The first values are tried first, so an array that is not float32 at heart
    costs almost nothing; the rest is converted and checked block by block.
    """
    with np.errstate(over="ignore", invalid="ignore"):  # those fail the test
        return _as_float32_exact(a)


def _as_float32_exact(a: NDArray[Any]) -> NDArray[np.float32] | None:
    flat = a.reshape(-1)
    head = flat[:_PROBE]
    if not _same_bits(head.astype("<f4").astype("<f8"), head):
        return None
    out = np.empty(a.shape, dtype="<f4")
    out_flat = out.reshape(-1)
    same = np.empty(min(_BLOCK, flat.size), dtype=bool)
    back: NDArray[np.float64] | None = None
    for i in range(0, flat.size, _BLOCK):  # a block stays in cache
        seg = flat[i : i + _BLOCK]
        f32 = out_flat[i : i + _BLOCK]
        np.copyto(f32, seg, casting="same_kind")  # rounds to float32
        # Equal values are equal bits, save for NaN (never equal) and zeros
        # (float32 keeps a zero's sign); only a block with a NaN or a value
        # float32 cannot hold needs its bits compared.
        eq = same[: len(seg)]
        np.equal(f32, seg, out=eq)
        if eq.all():
            continue
        if back is None:
            back = np.empty(min(_BLOCK, flat.size), dtype="<f8")
        b = back[: len(seg)]
        np.copyto(b, f32)  # exact
        if not _same_bits(b, seg):
            return None
    return out


def _same_bits(x: NDArray[Any], y: NDArray[Any]) -> bool:
    return bool(np.array_equal(x.view("<i8"), y.view("<i8")))


#: the little-endian dtype an array is stored as, by its dtype (None: refused)
_STORED: dict[np.dtype[Any], str | None] = {}


def _stored_dtype(dtype: np.dtype[Any]) -> str | None:
    out = _STORED.get(dtype)
    if out is None and dtype not in _STORED:
        if dtype.kind == "f":
            out = "<f8" if dtype.itemsize == 8 else "<f4"
        elif dtype.kind in "iu" and dtype != np.uint8:
            out = "<i8" if dtype.itemsize == 8 else "<i4"
        elif dtype.kind == "b":
            out = "|b1"
        else:
            out = dtype.str
        if out not in _DTYPES:
            out = None
        _STORED[dtype] = out
    return out


def _encode_array(a: NDArray[Any], arrays: list[ArrayBytes]) -> dict[str, Any]:
    stored = _stored_dtype(a.dtype)
    if stored is None:
        raise RecordingError(f"cannot record an array of dtype {a.dtype}")
    if a.dtype.str != stored:
        a = a.astype(stored)
    a = np.ascontiguousarray(a)
    ref: dict[str, Any] = {"$array": len(arrays)}
    if stored == "<f8" and a.size >= F32_MIN_SIZE:
        f32 = as_float32_exact(a)
        if f32 is not None:
            a, ref["$as"] = f32, "<f8"
    raw = a.reshape(-1).view(np.uint8).data  # (nbytes,) view, no copy
    arrays.append(ArrayBytes(a.dtype.str, a.shape, raw))
    return ref


#: field names of the dataclasses met so far
_FIELDS: dict[type, tuple[str, ...]] = {}


def _float(f: float) -> Any:
    if math.isfinite(f):
        return f
    return {"$float": "nan" if math.isnan(f) else ("inf" if f > 0 else "-inf")}


def encode_value(value: Any, arrays: list[ArrayBytes]) -> Any:
    """Turn ``value`` into plain JSON data, moving arrays into ``arrays``.

    Dataclasses become dicts of their fields, pydantic models their JSON dump, numpy
    scalars Python numbers; anything else its ``repr``.
    """
    t = type(value)
    # plain scalars by exact type first (a run's records hold thousands)
    if t is float:
        return _float(value)
    if t is int or t is str or t is bool or value is None:
        return value
    if isinstance(value, np.ndarray):
        return _encode_array(np.asarray(value), arrays)
    if isinstance(value, dict):
        return {str(k): encode_value(v, arrays) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [encode_value(v, arrays) for v in value]
    names = _FIELDS.get(t)
    if names is None and is_dataclass(value) and not isinstance(value, type):
        names = _FIELDS[t] = tuple(f.name for f in fields(value))
    if names is not None:
        return {n: encode_value(getattr(value, n), arrays) for n in names}
    # numpy scalars and subclasses of the plain types
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return _float(float(value))
    if isinstance(value, str):
        return str(value)
    if hasattr(value, "model_dump"):  # pydantic models
        return encode_value(value.model_dump(mode="json"), arrays)
    return repr(value)


def decode_value(data: Any, arrays: list[ArrayBytes]) -> Any:
    """Inverse of :func:`encode_value` (dataclasses come back as dicts)."""
    if isinstance(data, dict):
        if "$array" in data and set(data) <= {"$array", "$as"}:
            a = arrays[int(data["$array"])]
            if a.dtype not in _DTYPES:
                raise ValueError(f"unknown array dtype {a.dtype!r}")
            flat = np.frombuffer(a.data, dtype=np.dtype(a.dtype))
            # the record's own shape, e.g. (n, 3) points or (C, 4, 4) poses
            out = flat.reshape(a.shape)
            cast = data.get("$as")
            if cast is None:
                return out.copy()
            if (a.dtype, cast) != ("<f4", "<f8"):
                raise ValueError(f"cannot read {a.dtype!r} array as {cast!r}")
            return out.astype("<f8")
        if "$float" in data and len(data) == 1:
            return float(data["$float"])
        return {k: decode_value(v, arrays) for k, v in data.items()}
    if isinstance(data, list):
        return [decode_value(v, arrays) for v in data]
    return data


def dumps(value: Any, kind: str = "") -> bytes:
    """Encode ``value`` to the bytes of one ``wsgrasp.Record``."""
    return b"".join(dumps_parts(value, kind))


def dumps_parts(value: Any, kind: str = "") -> list[bytes | memoryview]:
    """:func:`dumps` in pieces: the arrays' bytes are views of the arrays (or of
    their float32 copies), valid while those arrays are unchanged."""
    arrays: list[ArrayBytes] = []
    text = json.dumps(
        encode_value(value, arrays), allow_nan=False, separators=(",", ":")
    )
    return encode_record_parts(kind, text, arrays, FORMAT_VERSION)


def loads(data: bytes | memoryview) -> Any:
    """Decode the bytes of one ``wsgrasp.Record``."""
    _, _, text, arrays = decode_record(data)
    return decode_value(json.loads(text), arrays)
