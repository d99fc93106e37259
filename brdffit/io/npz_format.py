"""NumPy ``.npz`` archives of Measurements: lossless, sigma and metadata included.

The archive holds ``wi``, ``wo`` (N, 3), ``values`` (N, C), ``channels`` (C
strings), ``source``, ``units``, ``format_version`` and, when known, ``sigma``
(N, C) and the angles the data were built from (``theta_i, phi_i, theta_o,
phi_o`` and ``angles_in_degrees``). Arrays are stored as they are, so reading
gives back the same doubles; nothing is pickled (``allow_pickle=False``).
"""

from __future__ import annotations

import io
import zipfile

import numpy as np

from ..data.measurements import ANGLE_COLUMNS, Measurements
from ..errors import DataError, FormatError
from .source import as_source, put_bytes

__all__ = ["read_npz", "write_npz"]

FORMAT_VERSION = 1
_REQUIRED = ("wi", "wo", "values", "channels", "source", "units")


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


def read_npz(source) -> Measurements:
    """Read an archive written by :func:`write_npz` from a path, bytes or a binary file
    object."""
    source = as_source(source)
    path, raw = source.name, source.read()
    try:
        with np.load(io.BytesIO(raw), allow_pickle=False) as archive:
            contents = {key: archive[key] for key in archive.files}
    except (zipfile.BadZipFile, ValueError, OSError, EOFError) as exc:
        raise FormatError(f"{path} is not a readable .npz archive: {exc}", "source") from None
    missing = [key for key in _REQUIRED if key not in contents]
    if missing:
        raise FormatError(
            f"{path} lacks the array(s) {', '.join(missing)}; it is not a brdffit .npz file "
            f"(it holds {', '.join(sorted(contents)) or 'nothing'})",
            missing[0],
        )
    version = int(contents.get("format_version", FORMAT_VERSION))
    if version > FORMAT_VERSION:
        raise FormatError(
            f"{path} has format_version {version}; this brdffit reads up to {FORMAT_VERSION}",
            "format_version",
        )
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
