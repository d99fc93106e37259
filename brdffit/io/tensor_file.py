"""Mitsuba's ``tensor_file`` container, the file format of the RGL-EPFL database.

Sources checked (public code; rewritten here, nothing copied): Mitsuba 3
``src/core/tensor.cpp`` (``TensorFile``), RGL ``brdf-loader``
``powitacq_rgb.inl`` (``Tensor::Tensor``) and its Python ``visualize.py``
(``read_tensor``/``write_tensor``, which give the dtype codes and say
little-endian).

Container (all little-endian): the 12 bytes ``tensor_file\\0``; version bytes
``1 0``; uint32 field count; per field uint16 name length, the name, uint16
``ndim``, uint8 dtype code (1 uint8, 2 int8, 3 uint16, 4 int16, 5 uint32,
6 int32, 7 uint64, 8 int64, 9 float16, 10 float32, 11 float64), uint64 offset of
the data, ``ndim`` uint64 sizes; the data (C order) at the offsets.
"""

from __future__ import annotations

import math
import struct
from typing import NamedTuple

import numpy as np

from ..errors import FormatError
from .source import as_source

__all__ = ["DTYPES", "MAGIC", "TensorField", "read_tensor_file"]

MAGIC = b"tensor_file\x00"
#: The most dimensions a field may have (NumPy's own limit is 64; RGL fields have <= 5).
MAX_NDIM = 32
DTYPES = {1: "u1", 2: "i1", 3: "<u2", 4: "<i2", 5: "<u4", 6: "<i4", 7: "<u8", 8: "<i8"}
DTYPES.update({9: "<f2", 10: "<f4", 11: "<f8"})


class TensorField(NamedTuple):
    """One field of a tensor file."""

    name: str
    dtype: np.dtype
    offset: int  #: byte offset of the data in the file
    shape: tuple
    data: np.ndarray  #: read-only view of the bytes, with ``shape``


def _unpack(raw: bytes, fmt: str, pos: int, what: str, path) -> tuple:
    size = struct.calcsize(fmt)
    if pos + size > len(raw):
        raise FormatError(
            f"{path} is truncated: the {what} needs {size} bytes at byte {pos}, "
            f"but the file ends at byte {len(raw)}",
            "source",
        )
    return struct.unpack_from(fmt, raw, pos)


def _field_header(raw: bytes, pos: int, index: int, path) -> tuple:
    """Parse field ``index``'s header at ``pos``; return (name, code, offset, shape, end)."""
    (length,) = _unpack(raw, "<H", pos, f"name length of field {index}", path)
    name_bytes = raw[pos + 2 : pos + 2 + length]
    if len(name_bytes) < length:
        raise FormatError(
            f"{path} is truncated: the name of field {index} needs {length} bytes at byte "
            f"{pos + 2}, but the file ends at byte {len(raw)}",
            "source",
        )
    try:
        name = name_bytes.decode("utf-8")
    except UnicodeDecodeError:
        raise FormatError(
            f"{path}: the name of field {index} at byte {pos + 2} is not UTF-8", "source"
        ) from None
    pos += 2 + length
    ndim, code, offset = _unpack(raw, "<HBQ", pos, f"header of field {name!r}", path)
    if ndim > MAX_NDIM:
        raise FormatError(
            f"{path}: field {name!r} has {ndim} dimensions (header at byte {pos}); a tensor "
            f"has at most {MAX_NDIM}",
            "source",
        )
    if code not in DTYPES:
        raise FormatError(
            f"{path}: field {name!r} has the unknown dtype code {code} at byte {pos + 2}; "
            "the codes are 1..11 (uint8 .. float64)",
            "source",
        )
    shape = _unpack(raw, f"<{ndim}Q", pos + 11, f"shape of field {name!r}", path)
    if max(shape, default=0) > len(raw):  # impossible data, even beside a size of 0
        raise FormatError(
            f"{path}: field {name!r} has the shape {list(shape)} (header at byte {pos + 11}), "
            f"a size beyond the file's {len(raw)} bytes",
            "source",
        )
    return name, code, offset, shape, pos + 11 + 8 * ndim


def read_tensor_file(source) -> dict[str, TensorField]:
    """Read every field of a Mitsuba ``tensor_file`` (a path, bytes or a binary file
    object; see the module doc)."""
    source = as_source(source)
    path, raw = source.name, source.read()
    if raw[:12] != MAGIC:
        raise FormatError(
            f"{path}: wrong magic at byte 0: found {raw[:12]!r}, expected {MAGIC!r}; "
            "this is not a Mitsuba tensor file (RGL .bsdf)",
            "source",
        )
    version = _unpack(raw, "<BB", 12, "version", path)
    if version != (1, 0):
        raise FormatError(
            f"{path}: version {version} at byte 12 is not 1.0, the one known", "source"
        )
    (count,) = _unpack(raw, "<I", 14, "field count", path)
    fields, pos = {}, 18
    for index in range(count):
        name, code, offset, shape, pos = _field_header(raw, pos, index, path)
        dtype = np.dtype(DTYPES[code])
        end = offset + dtype.itemsize * math.prod(shape)
        if end > len(raw):
            raise FormatError(
                f"{path} is truncated: the data of field {name!r} ({dtype}, shape "
                f"{list(shape)}) from byte {offset} needs the file to reach byte {end}, "
                f"but it ends at byte {len(raw)}",
                "source",
            )
        count_ = math.prod(shape)
        data = np.frombuffer(raw, dtype=dtype, count=count_, offset=offset).reshape(shape)
        fields[name] = TensorField(name, dtype, offset, tuple(shape), data)
    return fields
