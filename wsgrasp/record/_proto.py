"""The ``wsgrasp.Record`` protobuf message, encoded and decoded by hand.

::

    syntax = "proto3";
    package wsgrasp;
    message Array  { string dtype = 1; repeated uint64 shape = 2; bytes data = 3; }
    message Record { uint32 format_version = 1; string kind = 2; string json = 3;
                     repeated Array arrays = 4; }

``json`` holds the record's structure, in which ``{"$array": i}`` stands for
``arrays[i]``: the array's raw little-endian bytes, so arrays round-trip bit for bit
and cost no text encoding. :data:`DESCRIPTOR_SET` is the ``FileDescriptorSet`` the
MCAP schema declares, so any protobuf reader (Foxglove included) decodes it.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "ArrayBytes",
    "DESCRIPTOR_SET",
    "SCHEMA_NAME",
    "encode_record",
    "encode_record_parts",
    "decode_record",
]

SCHEMA_NAME = "wsgrasp.Record"


@dataclass
class ArrayBytes:
    """One array: dtype string (``"<f8"``), shape and raw bytes."""

    dtype: str
    shape: tuple[int, ...]
    data: bytes | memoryview


# -- wire format ---------------------------------------------------------------------
_SMALL = [bytes((i,)) for i in range(0x80)]


def _varint(n: int) -> bytes:
    if n < 0x80:
        return _SMALL[n]
    out = bytearray()
    while True:
        b = n & 0x7F
        n >>= 7
        if n:
            out.append(b | 0x80)
        else:
            out.append(b)
            return bytes(out)


def _key(field: int, wire: int) -> bytes:
    return _varint((field << 3) | wire)


def _len_field(field: int, payload: bytes | memoryview) -> list[bytes | memoryview]:
    return [_key(field, 2), _varint(len(payload)), payload]


def _str_field(field: int, text: str) -> list[bytes | memoryview]:
    return _len_field(field, text.encode("utf-8")) if text else []


def _read_varint(buf: memoryview, pos: int) -> tuple[int, int]:
    result = shift = 0
    while True:
        if pos >= len(buf):
            raise ValueError("protobuf varint runs past the end of the message")
        b = buf[pos]
        pos += 1
        result |= (b & 0x7F) << shift
        if not b & 0x80:
            return result, pos
        shift += 7
        if shift > 63:
            raise ValueError("protobuf varint is too long")


def _fields(buf: memoryview) -> list[tuple[int, int | memoryview]]:
    """``(field number, value)`` pairs of a message: ints for varints, views of the
    payload for length-delimited fields."""
    out: list[tuple[int, int | memoryview]] = []
    pos = 0
    while pos < len(buf):
        key, pos = _read_varint(buf, pos)
        field, wire = key >> 3, key & 7
        if wire == 0:
            value, pos = _read_varint(buf, pos)
            out.append((field, value))
        elif wire == 2:
            n, pos = _read_varint(buf, pos)
            if pos + n > len(buf):
                raise ValueError("protobuf field runs past the end of the message")
            out.append((field, buf[pos : pos + n]))
            pos += n
        elif wire == 5:
            pos += 4
        elif wire == 1:
            pos += 8
        else:
            raise ValueError(f"unsupported protobuf wire type {wire}")
    return out


# -- Record ----------------------------------------------------------------------------
def encode_record(
    kind: str, json_text: str, arrays: list[ArrayBytes], format_version: int
) -> bytes:
    """Bytes of one ``wsgrasp.Record``."""
    return b"".join(encode_record_parts(kind, json_text, arrays, format_version))


def encode_record_parts(
    kind: str, json_text: str, arrays: list[ArrayBytes], format_version: int
) -> list[bytes | memoryview]:
    """:func:`encode_record` in pieces, the arrays' bytes not copied (views)."""
    parts: list[bytes | memoryview] = [_key(1, 0), _varint(format_version)]
    parts += _str_field(2, kind)
    parts += _str_field(3, json_text)
    for a in arrays:
        # Array: dtype 1, shape 2 (packed varints), data 3; the bytes before the
        # data joined into one piece
        head = _DTYPE_FIELDS.get(a.dtype) or b"".join(_str_field(1, a.dtype))
        if a.shape:
            shape = b"".join([_varint(int(n)) for n in a.shape])
            head += b"\x12" + _varint(len(shape)) + shape
        n = len(a.data)
        if n:
            head += b"\x1a" + _varint(n)
        parts += [b"\x22" + _varint(len(head) + n) + head]
        if n:
            parts.append(a.data)
    return parts


#: the dtype field (1) of an ``Array``, encoded, by dtype
_DTYPE_FIELDS = {
    d: b"".join(_str_field(1, d)) for d in ("<f8", "<i8", "|b1", "<f4", "<i4", "|u1")
}


def decode_record(data: bytes | memoryview) -> tuple[int, str, str, list[ArrayBytes]]:
    """``(format_version, kind, json, arrays)`` of one ``wsgrasp.Record``."""
    version, kind, text = 0, "", ""
    arrays: list[ArrayBytes] = []
    for field, value in _fields(memoryview(data)):
        if field == 1 and isinstance(value, int):
            version = value
        elif field == 2 and isinstance(value, memoryview):
            kind = bytes(value).decode("utf-8")
        elif field == 3 and isinstance(value, memoryview):
            text = bytes(value).decode("utf-8")
        elif field == 4 and isinstance(value, memoryview):
            dtype, shape, raw = "", [], memoryview(b"")
            for f, v in _fields(value):
                if f == 1 and isinstance(v, memoryview):
                    dtype = bytes(v).decode("utf-8")
                elif f == 2 and isinstance(v, memoryview):
                    pos = 0
                    while pos < len(v):
                        n, pos = _read_varint(v, pos)
                        shape.append(n)
                elif f == 2 and isinstance(v, int):  # unpacked encoding
                    shape.append(v)
                elif f == 3 and isinstance(v, memoryview):
                    raw = v
            arrays.append(ArrayBytes(dtype, tuple(shape), raw))
    return version, kind, text, arrays


# -- descriptor -----------------------------------------------------------------
def _field_descriptor(
    name: str, number: int, label: int, type_: int, type_name: str = ""
) -> bytes:
    # FieldDescriptorProto: name 1, number 3, label 4, type 5, type_name 6, json_name 10
    parts: list[bytes | memoryview] = _str_field(1, name)
    parts += [_key(3, 0), _varint(number), _key(4, 0), _varint(label)]
    parts += [_key(5, 0), _varint(type_)]
    parts += _str_field(6, type_name)
    camel = name.split("_")[0] + "".join(w.title() for w in name.split("_")[1:])
    parts += _str_field(10, camel)
    return b"".join(parts)


def _message_descriptor(name: str, fields: list[bytes]) -> bytes:
    parts: list[bytes | memoryview] = _str_field(1, name)
    for f in fields:
        parts += _len_field(2, f)
    return b"".join(parts)


def _descriptor_set() -> bytes:
    OPTIONAL, REPEATED = 1, 3
    UINT64, STRING, MESSAGE, BYTES, UINT32 = 4, 9, 11, 12, 13
    array = _message_descriptor(
        "Array",
        [
            _field_descriptor("dtype", 1, OPTIONAL, STRING),
            _field_descriptor("shape", 2, REPEATED, UINT64),
            _field_descriptor("data", 3, OPTIONAL, BYTES),
        ],
    )
    record = _message_descriptor(
        "Record",
        [
            _field_descriptor("format_version", 1, OPTIONAL, UINT32),
            _field_descriptor("kind", 2, OPTIONAL, STRING),
            _field_descriptor("json", 3, OPTIONAL, STRING),
            _field_descriptor("arrays", 4, REPEATED, MESSAGE, ".wsgrasp.Array"),
        ],
    )
    # FileDescriptorProto: name 1, package 2, message_type 4, syntax 12
    file = b"".join(
        [
            *_str_field(1, "wsgrasp/record.proto"),
            *_str_field(2, "wsgrasp"),
            *_len_field(4, array),
            *_len_field(4, record),
            *_str_field(12, "proto3"),
        ]
    )
    return b"".join(_len_field(1, file))  # FileDescriptorSet.file


#: Serialized ``google.protobuf.FileDescriptorSet`` of ``wsgrasp/record.proto``.
DESCRIPTOR_SET: bytes = _descriptor_set()
