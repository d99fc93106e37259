"""Reading and writing measured reflectance: ``read(path) -> Measurements``, ``write``.

The format is named by ``format=``, or inferred from the file's extension, or,
when the extension says nothing, from its first bytes: an MBSDF file starts
with ``NVIDIA ARC MBSDF``, a MERL ``.binary`` file with the little-endian int32
90, 90, 180, an NPZ archive is a zip (``PK``), an RGL ``.bsdf`` file (Mitsuba
``tensor_file``) with ``tensor_file\\0``; text is recognised by its first
line (a CSV header naming ``theta_i``, an ASTM ``KEY value`` line, or the
wavelength count that starts a pbrt file).

:data:`FORMATS` maps each name to its reader, writer (None when the format is
read only) and extensions. The MERL, MBSDF and RGL functions are imported
when first used.
"""

from __future__ import annotations

import inspect
import os
import re
import struct
from collections.abc import Callable
from typing import NamedTuple

from ..data.measurements import Measurements
from ..errors import DataError, FormatError
from .astm import read_astm, read_pbrt, write_astm
from .csv_format import read_csv, write_csv
from .npz_format import read_npz, write_npz

__all__ = ["FORMATS", "Format", "detect_format", "read", "write"]


class Format(NamedTuple):
    """A file format: its reader, its writer (None if read only), its extensions."""

    read: Callable | None
    write: Callable | None
    extensions: tuple
    description: str


def _read_merl(path, subsample=None) -> Measurements:
    from .merl import read_merl

    return read_merl(path, subsample=subsample)


def _write_merl(path, data) -> None:
    from .merl import write_merl

    write_merl(path, data)


def _read_mbsdf(path) -> Measurements:
    from .mbsdf import read_mbsdf

    return read_mbsdf(path)


def _read_rgl(path) -> Measurements:
    from .rgl import read_rgl

    return read_rgl(path)


FORMATS: dict[str, Format] = {
    "csv": Format(read_csv, write_csv, (".csv",), "brdffit CSV, angles in degrees"),
    "astm": Format(read_astm, write_astm, (".astm",), "ASTM E1392 text, angles in radians"),
    "pbrt": Format(read_pbrt, None, (".brdf",), "pbrt-v2 measured .brdf text (read only)"),
    "merl": Format(_read_merl, _write_merl, (".binary",), "MERL BRDF database binary"),
    "mbsdf": Format(_read_mbsdf, None, (".mbsdf",), "NVIDIA MDL measured BSDF (read only)"),
    "npz": Format(read_npz, write_npz, (".npz",), "NumPy archive, lossless"),
    "rgl": Format(_read_rgl, None, (".bsdf",), "RGL-EPFL material (read only)"),
}

_MERL_MAGIC = struct.pack("<3i", 90, 90, 180)
_ASTM_KEY = re.compile(r"^[A-Z][A-Z0-9_]*(\s|$)")


def _known() -> str:
    return ", ".join(f"{name} ({' '.join(f.extensions)})" for name, f in FORMATS.items())


def _named(format: str) -> str:
    name = str(format).lower().lstrip(".")
    if name not in FORMATS:
        raise FormatError(f"unknown format {format!r}; the formats are {_known()}", "format")
    return name


def _by_extension(path) -> str | None:
    extension = os.path.splitext(str(path))[1].lower()
    for name, f in FORMATS.items():
        if extension in f.extensions:
            return name
    return None


def _sniff_text(head: bytes) -> str | None:
    text = head.decode("utf-8", errors="replace")
    for line in text.splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        if "theta_i" in line and "," in line:
            return "csv"
        if _ASTM_KEY.match(line):
            return "astm"
        if re.match(r"^\d+(\s|#|$)", line):
            return "pbrt"
        return None
    return None


def detect_format(path) -> str:
    """The format of an existing file: its extension, or else its first bytes."""
    name = _by_extension(path)
    if name is not None:
        return name
    with open(path, "rb") as f:
        head = f.read(4096)
    if head.startswith(b"NVIDIA ARC MBSDF"):
        return "mbsdf"
    if head.startswith(_MERL_MAGIC):
        return "merl"
    if head.startswith((b"PK\x03\x04", b"PK\x05\x06")):
        return "npz"
    if head.startswith(b"tensor_file\x00"):
        return "rgl"
    name = _sniff_text(head)
    if name is None:
        raise FormatError(
            f"cannot tell the format of {path} from its extension or its first bytes; "
            f"pass format= one of {_known()}",
            "format",
        )
    return name


def _call(function: Callable, role: str, name: str, *args, **options):
    """Call a reader or writer, turning unknown options into a FormatError."""
    try:
        inspect.signature(function).bind(*args, **options)
    except TypeError:
        accepted = list(inspect.signature(function).parameters)[len(args) :]
        raise FormatError(
            f"the {name} {role} does not take the option(s) {', '.join(options)}; "
            f"it takes {', '.join(accepted) or 'no options'}",
            next(iter(options), "options"),
        ) from None
    return function(*args, **options)


def read(path, format: str | None = None, **options) -> Measurements:
    """Read measured reflectance from ``path``.

    ``format`` is one of :data:`FORMATS` (inferred when None); ``options`` go
    to its reader (``subsample`` for MERL, ``angle_unit`` for ASTM).
    """
    name = _named(format) if format is not None else detect_format(path)
    return _call(FORMATS[name].read, "reader", name, path, **options)


def write(path, data: Measurements, format: str | None = None, **options) -> None:
    """Write ``data`` to ``path`` in ``format`` (inferred from the extension when None)."""
    if not isinstance(data, Measurements):
        raise DataError(f"data must be Measurements, not {type(data).__name__}", "data")
    name = _named(format) if format is not None else _by_extension(path)
    if name is None:
        raise FormatError(
            f"cannot tell which format to write {path} in from its extension; "
            f"pass format= one of {_known()}",
            "format",
        )
    writer = FORMATS[name].write
    if writer is None:
        writable = ", ".join(n for n, f in FORMATS.items() if f.write is not None)
        raise FormatError(
            f"the {name} format can be read but not written; writable formats: {writable}",
            "format",
        )
    _call(writer, "writer", name, path, data, **options)
