"""Reading and writing measured reflectance: ``read(source) -> Measurements``, ``write``.

A source is a path, bytes, or a binary file object; a target a path or a
binary file object (:mod:`brdffit.io.source`). Errors name the file: its path,
the ``name`` of a file object, else ``<bytes>``. The format is named by
``format=``, or inferred from the extension of that name, or, when there is
none or it says nothing, from the first bytes: an MBSDF file starts
with ``NVIDIA ARC MBSDF``, a MERL ``.binary`` file with the little-endian int32
90, 90, 180, an NPZ archive is a zip (``PK``), an RGL ``.bsdf`` file (Mitsuba
``tensor_file``) with ``tensor_file\\0``; text is recognised by its first
line (a CSV header naming ``theta_i``, an ASTM ``KEY value`` line, or the
wavelength count that starts a pbrt file).

Reading is bounded and total: ``max_samples`` (:mod:`brdffit.io.limits`) is
checked by every reader before it allocates (an NPZ archive's headers before it
inflates anything), and whatever a reader meets inside a file ends as a
:class:`~brdffit.errors.FormatError` or ``DataError`` naming the file, an
unforeseen exception (``MemoryError`` too) chained to it (:func:`read`).

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
from ..errors import BrdfFitError, DataError, FormatError
from .astm import read_astm, write_astm
from .csv_format import read_csv, write_csv
from .limits import DEFAULT_MAX_SAMPLES, check_samples, checked_limit
from .npz_format import read_npz, write_npz
from .pbrt import read_pbrt
from .source import NAMELESS, Source, as_source, file_name

__all__ = ["DEFAULT_MAX_SAMPLES", "FORMATS", "NAMELESS", "Format", "Source", "detect_format"]
__all__ += ["read", "write"]


class Format(NamedTuple):
    """A file format: its reader, its writer (None if read only), its extensions."""

    read: Callable | None
    write: Callable | None
    extensions: tuple
    description: str


def _read_merl(source, subsample=None, max_samples=DEFAULT_MAX_SAMPLES) -> Measurements:
    from .merl import read_merl

    return read_merl(source, subsample=subsample, max_samples=max_samples)


def _write_merl(target, data) -> None:
    from .merl import write_merl

    write_merl(target, data)


def _read_mbsdf(source, max_samples=DEFAULT_MAX_SAMPLES) -> Measurements:
    from .mbsdf import read_mbsdf

    return read_mbsdf(source, max_samples=max_samples)


def _read_rgl(source, max_samples=DEFAULT_MAX_SAMPLES) -> Measurements:
    from .rgl import read_rgl

    return read_rgl(source, max_samples=max_samples)


FORMATS: dict[str, Format] = {
    "csv": Format(read_csv, write_csv, (".csv",), "brdffit CSV, angles in degrees unless stated"),
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


def _by_extension(filename) -> str | None:
    """The format whose extension ``filename`` has (None for no name or no match)."""
    if filename is None:
        return None
    extension = os.path.splitext(str(filename))[1].lower()
    for name, f in FORMATS.items():
        if extension in f.extensions:
            return name
    return None


def _sniff_text(head: bytes) -> str | None:
    utf16 = head.startswith((b"\xff\xfe", b"\xfe\xff"))
    text = head.decode("utf-16" if utf16 else "utf-8-sig", errors="replace")
    for line in text.splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        if "theta_i" in line and any(sep in line for sep in ",;\t"):
            return "csv"
        if _ASTM_KEY.match(line):
            return "astm"
        if re.match(r"^\d+(\s|#|$)", line):
            return "pbrt"
        return None
    return None


def _sniff(head: bytes) -> str | None:
    """The format that the first bytes of a file announce, if any."""
    if head.startswith(b"NVIDIA ARC MBSDF"):
        return "mbsdf"
    if head.startswith(_MERL_MAGIC):
        return "merl"
    if head.startswith((b"PK\x03\x04", b"PK\x05\x06")):
        return "npz"
    if head.startswith(b"tensor_file\x00"):
        return "rgl"
    return _sniff_text(head)


def detect_format(source) -> str:
    """The format of a source (path, bytes, binary file object): the extension of its
    name, or else its first bytes. FormatError (field ``format``) when neither tells."""
    source = as_source(source)
    name = _by_extension(source.filename) or _sniff(source.head())
    if name is None:
        how = "its extension or its first bytes" if source.filename else "its first bytes"
        raise FormatError(
            f"cannot tell the format of {source.name} from {how}; pass format= one of {_known()}",
            "format",
        )
    return name


def _call(function: Callable, role: str, name: str, *args, **options):
    """Call a reader or writer, turning unknown options into a FormatError."""
    _check_options(function, role, name, args, options)
    return function(*args, **options)


def _check_options(function: Callable, role: str, name: str, args: tuple, options: dict):
    try:
        inspect.signature(function).bind(*args, **options)
    except TypeError:
        hidden = ("max_samples",) if role == "reader" else ()
        given = [o for o in options if o not in hidden]
        accepted = [p for p in list(inspect.signature(function).parameters)[len(args) :]
                    if p not in hidden]  # fmt: skip
        raise FormatError(
            f"the {name} {role} does not take the option(s) {', '.join(given)}; "
            f"it takes {', '.join(accepted) or 'no options'}",
            next(iter(given), "options"),
        ) from None


def _with_name(exc: BrdfFitError, where: str) -> BrdfFitError:
    """``exc`` when its message names the file, else the same error prefixed with it."""
    if where in str(exc):
        return exc
    try:
        named = type(exc)(f"{where}: {exc}", exc.field)
    except TypeError:  # a subclass with another constructor
        named = FormatError(f"{where}: {exc}", exc.field)
    return named


def _unexpected(exc: BaseException, where: str, name: str) -> FormatError:
    """The FormatError that stands for an exception a reader did not foresee."""
    what = "is too large to read in memory" if isinstance(exc, MemoryError) else "is damaged"
    error = FormatError(
        f"{where} cannot be read as {FORMATS[name].description}: the file {what} or not in "
        f"this format (the {name} reader failed with {type(exc).__name__}: {exc})",
        "source",
    )
    return error


def read(source, format: str | None = None, *, max_samples=DEFAULT_MAX_SAMPLES,
         **options) -> Measurements:  # fmt: skip
    """Read measured reflectance from a path, bytes or a binary file object.

    Parameters
    ----------
    source : str, os.PathLike, bytes or binary file object
        A file object is read from its position to its end; its ``name``, when it
        has one, names it in errors and gives the extension the format is inferred
        from (name an ``io.BytesIO`` with ``buffer.name = "upload.csv"``).
    format : str, optional
        One of :data:`FORMATS`; inferred when None (:func:`detect_format`).
    max_samples : int or None
        The most samples (direction pairs) to build: a file whose header or rows
        give more is a FormatError before anything is allocated or decompressed
        (:mod:`brdffit.io.limits`; default :data:`DEFAULT_MAX_SAMPLES`, None for
        no limit).
    **options
        Go to the format's reader: ``subsample`` for MERL, ``angle_unit``
        (``"degrees"`` or ``"radians"``) for CSV, ASTM and pbrt.

    Raises
    ------
    FormatError, DataError
        Every fault of the file's content, naming the file: a reader's unforeseen
        exception (``MemoryError`` included) becomes a FormatError on the field
        ``source`` whose message names the exception's type, chained to it. Errors
        of the operating system (a missing file, no permission) are raised as
        they are.
    """
    source = as_source(source)
    limit = checked_limit(max_samples)
    source.read()  # a missing or unreadable file raises its OSError here, as it is
    name = _named(format) if format is not None else detect_format(source)
    reader = FORMATS[name].read
    options["max_samples"] = limit
    _check_options(reader, "reader", name, (source,), options)
    try:
        data = reader(source, **options)
    except BrdfFitError as exc:
        named = _with_name(exc, source.name)
        if named is exc:
            raise
        raise named from exc
    except Exception as exc:  # every unforeseen fault is the file's (MemoryError too)
        raise _unexpected(exc, source.name, name) from exc
    check_samples(data.n, limit, source.name, "counted in what was read")
    return data


def write(target, data: Measurements, format: str | None = None, **options) -> None:
    """Write ``data`` to a path or a binary file object in ``format`` (inferred from
    the extension of the path or of the file object's ``name`` when None)."""
    if not isinstance(data, Measurements):
        raise DataError(f"data must be Measurements, not {type(data).__name__}", "data")
    filename = file_name(target)
    name = _named(format) if format is not None else _by_extension(filename)
    if name is None:
        raise FormatError(
            f"cannot tell which format to write {filename or 'a file object without a name'} "
            f"in from its extension; pass format= one of {_known()}",
            "format",
        )
    writer = FORMATS[name].write
    if writer is None:
        writable = ", ".join(n for n, f in FORMATS.items() if f.write is not None)
        raise FormatError(
            f"the {name} format can be read but not written; writable formats: {writable}",
            "format",
        )
    _call(writer, "writer", name, target, data, **options)
