"""NVIDIA's measured BSDF format (``.mbsdf``, MDL SDK).

The layout, as read and written by the MDL SDK
(``io/scene/bsdf_measurement/i_bsdf_measurement.cpp``:
``import_measurement_from_reader``, ``import_data_from_reader``,
``export_to_file``; checked also against the independent reader of the ``smdl``
project and the SDK's CUDA and CPU evaluators):

- the line ``NVIDIA ARC MBSDF V1\\n``;
- optional metadata lines (``KEY="value"``), skipped by the SDK, up to one of the
  marker lines ``MBSDF_DATA=\\n`` (an old name of the reflection part),
  ``MBSDF_DATA_REFLECTION=\\n`` or ``MBSDF_DATA_TRANSMISSION=\\n``;
- a data block: uint32 ``type`` (0 scalar, 1 RGB; anything else is rejected),
  uint32 ``theta resolution`` and uint32 ``phi resolution`` (0 is rejected), then
  ``theta^2 * phi`` values of 1 (scalar) or 3 (RGB) float32 each, laid out
  ``[theta_in][theta_out][delta_phi][channel]`` (the SDK's evaluator indexes
  ``channels * (i_in * phi * theta + i_out * phi + i_phi)``). The SDK copies
  the bytes into memory as they are, so they are little-endian as written on
  x86; the ``smdl`` reader says little-endian explicitly;
- after a reflection block, optionally ``MBSDF_DATA_TRANSMISSION=\\n`` and a
  transmission block (the BTDF); then the end of the file.

Angles: ``theta`` covers ``[0, pi/2)`` and ``delta_phi = |phi_out - phi_in|``
folded into ``[0, pi]`` (the SDK's ``bsdf_compute_uvw``). Index ``k`` stands for
the cell ``[k, k+1) / N`` of that range, as the SDK's importance sampling draws
within it and its CUDA evaluator samples a texture whose texel centres are at
``(k + 1/2) / N``; this reader gives each value the cell centre. The SDK's CPU
evaluator places values at the lower cell edge instead (an inconsistency of the
SDK, half a cell at most). The mirror direction is ``delta_phi = pi``.

Directions follow MODELS.md: ``wi`` at ``phi_i = 0`` and ``wo`` at
``phi_o = delta_phi``, so the mirror of ``wi`` is at ``phi_o = phi_i + pi``.
Only the reflection part is read; a transmission part is checked and skipped.
Small negative values (measurement noise) are kept as they are.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..errors import FormatError
from .limits import DEFAULT_MAX_SAMPLES, check_samples
from .source import as_source

__all__ = ["MAGIC", "MbsdfSamples", "mbsdf_directions", "read_mbsdf", "read_mbsdf_arrays"]

MAGIC = b"NVIDIA ARC MBSDF V1\n"
REFLECTION_MARKERS = (b"MBSDF_DATA=\n", b"MBSDF_DATA_REFLECTION=\n")
TRANSMISSION_MARKER = b"MBSDF_DATA_TRANSMISSION=\n"
TYPES = {0: ("value",), 1: ("r", "g", "b")}


class MbsdfSamples(NamedTuple):
    """The reflection part of an MBSDF file, as plain arrays."""

    wi: np.ndarray  #: (N, 3), N = theta^2 * phi, in file order
    wo: np.ndarray  #: (N, 3)
    values: np.ndarray  #: (N, C) float64, C = 1 (scalar) or 3 (RGB)
    channels: tuple  #: ("value",) or ("r", "g", "b")
    theta_resolution: int
    phi_resolution: int
    metadata: dict  #: the KEY=value lines before the data, values unquoted
    has_transmission: bool  #: whether a transmission part followed (skipped)


def mbsdf_directions(theta_resolution: int, phi_resolution: int):
    """Cell-centre directions ``(wi, wo)`` of an MBSDF grid, in file order."""
    theta = (np.arange(theta_resolution) + 0.5) / theta_resolution * (math.pi / 2)
    dphi = (np.arange(phi_resolution) + 0.5) / phi_resolution * math.pi
    ti, to, dp = np.meshgrid(theta, theta, dphi, indexing="ij")
    ti, to, dp = ti.ravel(), to.ravel(), dp.ravel()
    wi = np.stack([np.sin(ti), np.zeros_like(ti), np.cos(ti)], axis=-1)
    wo = np.stack([np.sin(to) * np.cos(dp), np.sin(to) * np.sin(dp), np.cos(to)], axis=-1)
    return wi, wo


def _next_line(raw: bytes, pos: int, path: str) -> tuple[bytes, int]:
    """The line starting at ``pos`` (with its newline) and the position after it."""
    end = raw.find(b"\n", pos)
    if end < 0:
        raise FormatError(
            f"{path}: no data block: the text from byte {pos} to the end of the file (byte "
            f"{len(raw)}) has no line MBSDF_DATA_REFLECTION= (or MBSDF_DATA=)",
            "source",
        )
    return raw[pos : end + 1], end + 1


def _metadata_entry(line: bytes, pos: int, path: str) -> tuple[str, str]:
    try:
        text = line.decode("utf-8").rstrip("\n")
    except UnicodeDecodeError:
        raise FormatError(
            f"{path}: the header line at byte {pos} is not text; before its data an MBSDF "
            "file has only KEY=value lines and a line MBSDF_DATA_REFLECTION=",
            "source",
        ) from None
    key, _, value = text.partition("=")
    if len(value) >= 2 and value[0] == value[-1] == '"':
        value = value[1:-1].replace('\\"', '"').replace("\\n", "\n").replace("\\\\", "\\")
    return key, value


def _block_header(raw: bytes, pos: int, path: str, part: str) -> tuple[int, int, int, int]:
    """Check a data block at ``pos``; return (type, theta res, phi res, end of block)."""
    if len(raw) < pos + 12:
        raise FormatError(
            f"{path} is truncated: the {part} block needs 12 bytes of type and resolutions "
            f"at byte {pos}, but the file ends at byte {len(raw)}",
            "source",
        )
    kind, n_theta, n_phi = np.frombuffer(raw, dtype="<u4", count=3, offset=pos).tolist()
    if kind not in TYPES:
        raise FormatError(
            f"{path}: the {part} type at byte {pos} is {kind}; it must be 0 (scalar) or 1 (RGB)",
            "source",
        )
    for value, offset, name in ((n_theta, pos + 4, "theta"), (n_phi, pos + 8, "phi")):
        if value == 0:
            raise FormatError(
                f"{path}: the {part} {name} resolution at byte {offset} is 0; it must be >= 1",
                "source",
            )
    end = pos + 12 + n_theta * n_theta * n_phi * len(TYPES[kind]) * 4
    if end > len(raw):
        raise FormatError(
            f"{path} is truncated: the {part} block of {len(TYPES[kind])} x {n_theta} x "
            f"{n_theta} x {n_phi} float32 values from byte {pos + 12} needs the file to reach "
            f"byte {end}, but it ends at byte {len(raw)}",
            "source",
        )
    return kind, n_theta, n_phi, end


def _find_reflection(raw: bytes, path: str) -> tuple[int, dict]:
    """Position of the reflection block after its marker, and the metadata before it."""
    if not raw.startswith(MAGIC):
        found = raw[: len(MAGIC)]
        raise FormatError(
            f"{path}: wrong magic at byte 0: found {found!r}, expected {MAGIC!r}; "
            "this is not an NVIDIA MBSDF file",
            "source",
        )
    pos, metadata = len(MAGIC), {}
    while True:
        line, after = _next_line(raw, pos, path)
        if line in REFLECTION_MARKERS:
            return after, metadata
        if line == TRANSMISSION_MARKER:
            raise FormatError(
                f"{path}: the first data block, at byte {pos}, is a transmission (BTDF) part; "
                "brdffit reads reflection (MBSDF_DATA_REFLECTION=) data",
                "source",
            )
        key, value = _metadata_entry(line, pos, path)
        metadata[key] = value
        pos = after


def _check_tail(raw: bytes, pos: int, path: str) -> bool:
    """Check what follows the reflection block; True when a transmission part does."""
    if pos == len(raw):
        return False
    if raw.startswith(TRANSMISSION_MARKER, pos):
        end = _block_header(raw, pos + len(TRANSMISSION_MARKER), path, "transmission")[3]
        if end == len(raw):
            return True
        pos = end
    raise FormatError(
        f"{path}: unexpected data at byte {pos} of {len(raw)}: after its data blocks an MBSDF "
        "file ends (only a MBSDF_DATA_TRANSMISSION= block may follow the reflection block)",
        "source",
    )


def read_mbsdf_arrays(source, max_samples: int | None = DEFAULT_MAX_SAMPLES) -> MbsdfSamples:
    """Read the reflection part of an MBSDF file (a path, bytes or a binary file object)
    into arrays (see the module doc); at most ``max_samples`` cells
    (:mod:`brdffit.io.limits`)."""
    source = as_source(source)
    path, raw = source.name, source.read()
    pos, metadata = _find_reflection(raw, path)
    kind, n_theta, n_phi, end = _block_header(raw, pos, path, "reflection")
    check_samples(n_theta * n_theta * n_phi, max_samples, path, f"by its header at byte {pos}")
    has_transmission = _check_tail(raw, end, path)
    channels = TYPES[kind]
    count = n_theta * n_theta * n_phi * len(channels)
    values = np.frombuffer(raw, dtype="<f4", count=count, offset=pos + 12)
    bad = ~np.isfinite(values)
    if bad.any():
        first = int(np.flatnonzero(bad)[0])
        raise FormatError(
            f"{path}: the value {values[first]} at byte {pos + 12 + 4 * first} is not finite",
            "source",
        )
    wi, wo = mbsdf_directions(n_theta, n_phi)
    return MbsdfSamples(
        wi,
        wo,
        values.astype(float).reshape(-1, len(channels)),
        channels,
        n_theta,
        n_phi,
        metadata,
        has_transmission,
    )


def read_mbsdf(source, max_samples: int | None = DEFAULT_MAX_SAMPLES):
    """Read the reflection part of an MBSDF file as :class:`~brdffit.Measurements`.

    Units are not stated by the format; they are taken as 1/sr (a BRDF).
    """
    from ..data.measurements import Measurements

    source = as_source(source)
    s = read_mbsdf_arrays(source, max_samples)
    return Measurements(
        s.wi, s.wo, s.values, channels=s.channels, source=source.name, units="1/sr"
    )
