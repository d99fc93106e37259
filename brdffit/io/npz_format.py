"""NumPy ``.npz`` archives of Measurements: lossless, sigma and metadata included.

The archive holds ``wi``, ``wo`` (N, 3), ``values`` (N, C), ``channels`` (C
strings), ``source``, ``units``, ``format_version`` and, when known, ``sigma``
(N, C) and the angles the data were built from (``theta_i, phi_i, theta_o,
phi_o`` and ``angles_in_degrees``). Arrays are stored as they are, so reading
gives back the same doubles; nothing is pickled (``allow_pickle=False``).
"""

from __future__ import annotations

import io
import math
import zipfile
import zlib

import numpy as np

from ..data.measurements import ANGLE_COLUMNS, Measurements
from ..errors import DataError, FormatError
from .limits import DEFAULT_MAX_SAMPLES, ELEMENTS_PER_SAMPLE, check_samples
from .source import as_source, put_bytes

__all__ = ["read_npz", "write_npz"]

FORMAT_VERSION = 1
_REQUIRED = ("wi", "wo", "values", "channels", "source", "units")
_KNOWN = (*_REQUIRED, "sigma", "format_version", "angles_in_degrees", *ANGLE_COLUMNS)
_NUMBER_KINDS, _TEXT_KINDS = "biuf", "U"


def write_npz(target, data: Measurements) -> None:
    """Write ``data`` as a compressed ``.npz`` archive to a path or a binary file object."""
    arrays = {
        "format_version": np.array(FORMAT_VERSION),
        "wi": data.wi,
        "wo": data.wo,
        "values": data.values,
        "channels": np.array(data.channels, dtype=str),
        "source": np.array(data.source, dtype=str),
        "units": np.array(data.units, dtype=str),
    }
    if data.sigma is not None:
        arrays["sigma"] = data.sigma
    stored = data._angles
    if stored is not None:
        arrays.update(zip(ANGLE_COLUMNS, stored[0]))
        arrays["angles_in_degrees"] = np.array(stored[1])
    # np.savez appends ".npz" to a name without it, and a zip archive needs to seek:
    # build it in memory.
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **arrays)
    put_bytes(target, buffer.getvalue())


def _header(archive: zipfile.ZipFile, info: zipfile.ZipInfo, path: str) -> tuple:
    """Shape and dtype of an ``.npy`` member, from its first bytes alone, checked
    against the member's size in the zip directory (which bounds what it inflates to)."""
    with archive.open(info) as member:
        version = np.lib.format.read_magic(member)
        if version == (1, 0):
            shape, _, dtype = np.lib.format.read_array_header_1_0(member)
        elif version in ((2, 0), (3, 0)):
            shape, _, dtype = np.lib.format.read_array_header_2_0(member)
        else:
            raise FormatError(f"{path}: member {info.filename} is .npy version {version}",
                              "source")  # fmt: skip
        header_bytes = member.tell()
    shape, dtype = tuple(int(x) for x in shape), np.dtype(dtype)
    claimed = math.prod(shape) * dtype.itemsize
    if header_bytes + claimed != info.file_size:
        raise FormatError(
            f"{path}: the array {info.filename[:-4]!r} claims shape {list(shape)} of {dtype} "
            f"({claimed:,} bytes) but its member holds {info.file_size - header_bytes:,} bytes "
            "of data; the archive is damaged or forged",
            "source",
        )
    return shape, dtype


def _check_member(key: str, shape: tuple, dtype: np.dtype, path: str, limit) -> int:
    """The member's size in numbers, after checking its kind and its rows."""
    kinds = _TEXT_KINDS if key in ("channels", "source", "units") else _NUMBER_KINDS
    if dtype.kind not in kinds or dtype.hasobject or len(shape) > 2:
        raise FormatError(
            f"{path}: the array {key!r} is {dtype} with shape {list(shape)}; a brdffit .npz "
            f"file stores it as {'text' if kinds == _TEXT_KINDS else 'numbers'} with at "
            "most 2 dimensions",
            key,
        )
    if key in ("format_version", "angles_in_degrees", "source", "units") and shape:
        raise FormatError(f"{path}: {key!r} has shape {list(shape)}; it is one value", key)
    if shape and key != "channels":
        check_samples(shape[0], limit, path, f"by the header of its array {key!r}")
    return math.prod(shape) * max(1, dtype.itemsize // 8)


def _load(raw: bytes, path: str, limit) -> dict:
    """The arrays of a brdffit archive, their headers checked before decompressing any."""
    with zipfile.ZipFile(io.BytesIO(raw)) as archive:
        members = {info.filename[:-4]: info for info in archive.infolist()
                   if info.filename.endswith(".npy")}  # fmt: skip
        wanted = [key for key in _KNOWN if key in members]
        missing = [key for key in _REQUIRED if key not in members]
        if missing:
            raise FormatError(
                f"{path} lacks the array(s) {', '.join(missing)}; it is not a brdffit .npz "
                f"file (it holds {', '.join(sorted(members)) or 'nothing'})",
                missing[0],
            )
        headers = {key: _header(archive, members[key], path) for key in wanted}
        total = sum(_check_member(key, *headers[key], path, limit) for key in wanted)
        if limit is not None and total > ELEMENTS_PER_SAMPLE * limit:
            raise FormatError(
                f"{path}: its arrays hold {total:,} numbers, more than the "
                f"{ELEMENTS_PER_SAMPLE} per sample of the sample limit {limit:,} allow "
                "(max_samples)",
                "source",
            )
        contents = {}
        for key in wanted:
            with archive.open(members[key]) as member:
                contents[key] = np.lib.format.read_array(member, allow_pickle=False)
    return contents


def _version(value, path: str) -> int:
    value = np.asarray(value).item()
    if isinstance(value, bool) or not math.isfinite(value) or value != int(value) or value < 0:
        raise FormatError(
            f"{path}: format_version {value!r} is not a whole number >= 0", "format_version"
        )
    version = int(value)
    if version > FORMAT_VERSION:
        raise FormatError(
            f"{path} has format_version {version}; this brdffit reads up to {FORMAT_VERSION}",
            "format_version",
        )
    return version


def read_npz(source, max_samples: int | None = DEFAULT_MAX_SAMPLES) -> Measurements:
    """Read an archive written by :func:`write_npz` from a path, bytes or a binary file
    object.

    Only the arrays of the format are read, and each one's ``.npy`` header (shape
    and dtype) is checked before anything is decompressed: at most
    ``max_samples`` rows, and at most :data:`~brdffit.io.limits.ELEMENTS_PER_SAMPLE`
    numbers per sample of that limit in all (:mod:`brdffit.io.limits`), so an
    archive that would inflate beyond it costs only its headers.
    """
    source = as_source(source)
    path, raw = source.name, source.read()
    try:
        contents = _load(raw, path, max_samples)
    except (zipfile.BadZipFile, zlib.error, ValueError, OSError, EOFError,
            NotImplementedError, RuntimeError) as exc:  # fmt: skip
        if isinstance(exc, FormatError):
            raise
        raise FormatError(
            f"{path} is not a readable .npz archive: {type(exc).__name__}: {exc}", "source"
        ) from exc
    _version(contents.get("format_version", FORMAT_VERSION), path)
    try:
        data = Measurements(
            contents["wi"],
            contents["wo"],
            contents["values"],
            channels=[str(c) for c in np.atleast_1d(contents["channels"])],
            sigma=contents.get("sigma"),
            source=str(contents["source"]),
            units=str(contents["units"]),
        )
    except DataError as exc:
        raise FormatError(f"{path}: {exc}", exc.field) from None
    if all(name in contents for name in ANGLE_COLUMNS):
        angles = tuple(np.asarray(contents[name], dtype=float) for name in ANGLE_COLUMNS)
        if any(a.shape != (data.n,) for a in angles):
            raise FormatError(f"{path}: the angle arrays do not have {data.n} entries", "angles")
        degrees = bool(contents.get("angles_in_degrees", True))
        data = data._replace(angles=(angles, degrees))
    return data
