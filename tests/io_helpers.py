"""Builders of small files in each measured format, shared by the tests of brdffit.io.

Imported by name (``from io_helpers import ...``; pytest puts tests/ on the path).
Byte layouts are packed here with struct from the formats' primary sources, never
with the reading module's own code.
"""

from __future__ import annotations

import io
import math
import struct
import tracemalloc
import warnings

import numpy as np

import brdffit
from brdffit.data.measurements import Measurements


def named(raw: bytes, name: str) -> io.BytesIO:
    """``raw`` as a binary file object called ``name`` (the readers take its extension)."""
    f = io.BytesIO(raw)
    f.name = name
    return f


def quiet_read(source, **options):
    """``brdffit.read`` with its notes (UserWarning) silenced."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return brdffit.read(source, **options)


def peak_of(function) -> tuple:
    """What ``function()`` returned or raised, and the peak of traced memory (bytes) meanwhile."""
    tracemalloc.start()
    try:
        outcome = function()
    except Exception as exc:
        outcome = exc
    finally:
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    return outcome, peak


def rgb_data(n=60, seed=0, from_angles=True, sigma=True):
    """Random RGB measurements over the hemisphere, with sigma, one value below zero."""
    rng = np.random.default_rng(seed)
    ti, to = rng.uniform(0, 89, (2, n))
    pi_, po = rng.uniform(0, 360, (2, n))
    values = rng.lognormal(-2, 2, (n, 3))
    values[0, 1] = -1e-3  # a negative value survives every format
    s = rng.uniform(1e-4, 1e-2, (n, 3)) if sigma else None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        m = Measurements.from_angles(ti, pi_, to, po, values, ["r", "g", "b"], s,
                                     source="round trip", units="1/sr")  # fmt: skip
        if not from_angles:
            m = Measurements(m.wi, m.wo, m.values, m.channels, m.sigma, m.source, m.units)
    return m


def pbrt_text() -> str:
    """A pbrt-v2 .brdf file of 3 wavelengths and 2 records, one spanning two lines."""
    return (
        "# num wls\n3\n# wls\n400 550\n700\n# records\n"
        "0.1 0 0.1 3.14 1 2 3\n"
        "0.2 0 0.2 3.14 4 5\n6\n"  # a record may span lines
    )


# ------------------------------------------------------------------ RGL
CODES = {"u1": 1, "i1": 2, "<u2": 3, "<i2": 4, "<u4": 5, "<i4": 6, "<u8": 7, "<i8": 8}
CODES.update({"<f2": 9, "<f4": 10, "<f8": 11})


def pack_tensor(fields: dict, align: int = 8, version=(1, 0), magic=b"tensor_file\x00") -> bytes:
    """A tensor file (layout of Mitsuba's TensorFile / RGL's write_tensor)."""
    arrays = {k: np.ascontiguousarray(v) for k, v in fields.items()}
    header = magic + struct.pack("<BBI", *version, len(arrays))
    entries = []
    for name, a in arrays.items():
        label = name.encode()
        entries.append((struct.pack("<H", len(label)) + label, a))
    size = len(header) + sum(len(e) + 2 + 1 + 8 + 8 * a.ndim for e, a in entries)
    body, blobs, pos = b"", b"", size
    for label, a in entries:
        pos = -(-pos // align) * align
        code = CODES[a.dtype.str.replace("|", "").replace("=", "<")]
        body += label + struct.pack(f"<HBQ{a.ndim}Q", a.ndim, code, pos, *a.shape)
        blobs += (
            b"\x00" * (pos - size - len(blobs)) + a.astype(a.dtype.newbyteorder("<")).tobytes()
        )
        pos += a.nbytes
    return header + body + blobs


def tiny_rgl(**changes) -> dict:
    """A small RGL-shaped file: 2 incident angles, 5 x 4 vndf grid, 3 x 3 rgb grid."""
    rng = np.random.default_rng(0)
    fields = {
        "description": np.frombuffer(b"tiny", dtype="u1"),
        "phi_i": np.zeros(1, "<f4"),
        "theta_i": np.array([0.0, 0.5], "<f4"),
        "sigma": np.ones((2, 4), "<f4"),
        "ndf": np.full((2, 4), 1 / math.pi, "<f4"),
        "vndf": rng.uniform(0.5, 1, (1, 2, 5, 4)).astype("<f4"),
        "rgb": rng.uniform(0, 1, (1, 2, 3, 3, 3)).astype("<f4"),
        "jacobian": np.ones(1, "u1"),
    }
    fields.update(changes)
    return {k: v for k, v in fields.items() if v is not None}


# ---------------------------------------------------------------- MBSDF
MAGIC = b"NVIDIA ARC MBSDF V1\n"
REFLECTION = b"MBSDF_DATA_REFLECTION=\n"
TRANSMISSION = b"MBSDF_DATA_TRANSMISSION=\n"


def pack_block(kind, n_theta, n_phi, values):
    """An MBSDF data block: uint32 type and resolutions, then float32 values."""
    return struct.pack("<3I", kind, n_theta, n_phi) + struct.pack(f"<{len(values)}f", *values)


# ------------------------------------------------------- one small file per format
def small_files() -> dict:
    """``{format: (file name, bytes)}``: a small valid file of every readable format.

    Text and NPZ files come from brdffit's writers (``rgb_data``), pbrt from
    :func:`pbrt_text`, MBSDF and RGL are packed here, MERL is written by
    ``write_merl`` (a full 35 MB table, mostly cells without a measurement).
    """
    import io

    from brdffit.io import write

    data = rgb_data(n=12)
    files = {}
    for name in ("csv", "astm", "npz"):
        buffer = io.BytesIO()
        write(buffer, data, format=name)
        files[name] = (f"small.{name}", buffer.getvalue())
    files["pbrt"] = ("small.brdf", pbrt_text().encode())
    values = np.linspace(0.1, 1.0, 3 * 2 * 2 * 3)
    files["mbsdf"] = ("small.mbsdf", MAGIC + REFLECTION + pack_block(1, 2, 3, values))
    files["rgl"] = ("small.bsdf", pack_tensor(tiny_rgl()))
    positive = Measurements(data.wi, data.wo, np.abs(data.values), data.channels)
    positive = positive.subset(np.flatnonzero((data.wi[:, 2] > 0) & (data.wo[:, 2] > 0)))
    buffer = io.BytesIO()
    write(buffer, positive, format="merl")
    files["merl"] = ("small.binary", buffer.getvalue())
    return files
