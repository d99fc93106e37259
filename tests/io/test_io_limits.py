"""The sample limit of the readers (read's max_samples): checked before allocating, and
before decompressing an NPZ archive (a zip bomb costs its headers, not its claim)."""

from __future__ import annotations

import io
import struct
import warnings
import zlib

import numpy as np
import pytest
from io_helpers import named, peak_of, small_files

import brdffit
from brdffit.errors import FormatError
from brdffit.io import DEFAULT_MAX_SAMPLES

SMALL = small_files()


def npy_header(shape, descr="<f8") -> bytes:
    buffer = io.BytesIO()
    header = {"descr": descr, "fortran_order": False, "shape": tuple(shape)}
    np.lib.format.write_array_header_1_0(buffer, header)
    return buffer.getvalue()


def deflated(prefix: bytes, zeros: int, chunk: int = 1 << 20) -> tuple:
    """A raw deflate stream of ``prefix`` then ``zeros`` zero bytes, and its CRC-32.

    After a full flush the compressor starts afresh, so the block of one chunk of
    zeros can be repeated: a large stream is built without compressing it.
    """
    c = zlib.compressobj(9, zlib.DEFLATED, -15)
    head = c.compress(prefix) + c.flush(zlib.Z_FULL_FLUSH)
    block = c.compress(bytes(chunk)) + c.flush(zlib.Z_FULL_FLUSH)
    full, rest = divmod(zeros, chunk)
    tail = c.compress(bytes(rest)) + c.flush()
    crc = zlib.crc32(prefix)
    zero_chunk = bytes(chunk)
    for _ in range(full):
        crc = zlib.crc32(zero_chunk, crc)
    return head + block * full + tail, zlib.crc32(bytes(rest), crc)


def zip_of(members: list) -> bytes:
    """A zip archive (PKWARE APPNOTE 4.3: local headers, central directory, end record)
    of ``(name, deflated bytes, crc, uncompressed size)`` members."""
    out, central = b"", b""
    for name, data, crc, size in members:
        n = name.encode()
        fixed = (8, 0, 0x21, crc, len(data), size, len(n))
        local = struct.pack("<4s5H3I2H", b"PK\x03\x04", 20, 0, *fixed, 0)
        central += struct.pack("<4s6H3I5H2I", b"PK\x01\x02", 20, 20, 0, *fixed, 0, 0, 0, 0, 0,
                               len(out)) + n  # fmt: skip
        out += local + n + data
    count = len(members)
    end = struct.pack("<4s4H2IH", b"PK\x05\x06", 0, 0, count, count, len(central), len(out), 0)
    return out + central + end


def npz_claiming(n: int, data_bytes: int | None = None) -> bytes:
    """A brdffit-shaped archive whose wi, wo and values claim (n, 3) float64 zeros;
    ``data_bytes`` deflates fewer zeros than claimed (a truncated member)."""
    members = []
    for key in ("wi", "wo", "values"):
        header = npy_header((n, 3))
        size = n * 24 if data_bytes is None else data_bytes
        body, crc = deflated(header, size)
        members.append((key + ".npy", body, crc, len(header) + size))
    for key, value in (("channels", ["r", "g", "b"]), ("source", "bomb"), ("units", "1/sr")):
        buffer = io.BytesIO()
        np.lib.format.write_array(buffer, np.array(value))
        raw = buffer.getvalue()
        c = zlib.compressobj(9, zlib.DEFLATED, -15)
        members.append((key + ".npy", c.compress(raw) + c.flush(), zlib.crc32(raw), len(raw)))
    return zip_of(members)


def test_the_helper_archive_is_a_valid_npz():
    small = npz_claiming(1000)
    with np.load(io.BytesIO(small)) as archive:
        assert archive["wi"].shape == (1000, 3) and not archive["values"].any()


def test_an_npz_zip_bomb_is_refused_from_its_headers_without_inflating():
    bomb = npz_claiming(30_000_000)  # the 2.1 MB archive of 30 M zero samples
    assert len(bomb) < 2.5e6
    raised, peak = peak_of(lambda: brdffit.read(named(bomb, "bomb.npz")))
    assert isinstance(raised, FormatError) and raised.field == "source"
    assert str(raised).startswith(
        "bomb.npz holds 30,000,000 samples (by the header of its array 'wi'), more than the "
        f"sample limit of {DEFAULT_MAX_SAMPLES:,}"
    )
    assert peak < 20e6, f"reading the bomb's headers peaked at {peak / 1e6:.0f} MB"


def test_a_header_claiming_1e11_samples_in_a_small_file_is_a_format_error():
    """The issue's 28 KB archive whose header claims 10^11 x 3 doubles (a MemoryError
    of 2.18 TiB before): refused with or without a limit, from its sizes alone."""
    forged = npz_claiming(10**11, data_bytes=24_000)
    assert len(forged) < 30_000
    for limit in (DEFAULT_MAX_SAMPLES, None):
        raised, peak = peak_of(lambda m=limit: brdffit.read(named(forged, "f.npz"), max_samples=m))
        assert isinstance(raised, FormatError), repr(raised)
        assert str(raised).startswith(
            "f.npz: the array 'wi' claims shape [100000000000, 3] of float64 "
            "(2,400,000,000,000 bytes) but its member holds 24,000 bytes of data"
        )
        assert peak < 20e6


def test_the_limit_counts_every_number_of_an_archive():
    """Few rows but many columns: the numbers, not the rows, exceed the limit's budget."""
    data = brdffit.Measurements.from_angles(
        [10.0, 20], [0.0, 0], [10.0, 20], [180.0, 180], np.ones((2, 200)), degrees=True
    )
    buffer = io.BytesIO()
    brdffit.write(buffer, data, format="npz")
    with pytest.raises(FormatError, match=r"hold [\d,]+ numbers, more than the 80 per sample"):
        brdffit.read(named(buffer.getvalue(), "wide.npz"), max_samples=4)
    assert brdffit.read(named(buffer.getvalue(), "wide.npz"), max_samples=20).n == 2


@pytest.mark.parametrize("fmt", sorted(SMALL))
def test_every_reader_takes_max_samples(fmt):
    name, raw = SMALL[fmt]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        kept = brdffit.read(named(raw, name)).n
        # RGL counts its stored pairs (2 incident angles x a 3 x 3 rgb grid in tiny_rgl),
        # before the pairs below the horizon are dropped; the others what they build.
        n = 2 * 3 * 3 if fmt == "rgl" else kept
        assert brdffit.read(named(raw, name), max_samples=n).n == kept
        with pytest.raises(
            FormatError, match=rf"^{name} holds \d[\d,]* samples .*limit of {n - 1}"
        ):
            brdffit.read(named(raw, name), max_samples=n - 1)
        assert brdffit.read(named(raw, name), max_samples=None).n == kept


@pytest.mark.parametrize("bad", [0, -3, 2.5, "10", True])
def test_max_samples_must_be_a_whole_number_or_none(bad):
    with pytest.raises(FormatError, match="max_samples=") as info:
        brdffit.read(named(SMALL["csv"][1], "a.csv"), max_samples=bad)
    assert info.value.field == "max_samples"


def test_the_service_passes_its_limit_to_the_reader():
    convert = pytest.importorskip("brdffit_service.convert", reason="the service extra is absent")
    bomb = npz_claiming(3_000_000)
    raised, peak = peak_of(lambda: convert.read_upload(bomb, "b.npz", None, limit=20_000))
    assert isinstance(raised, FormatError) and raised.field == "file"
    assert "3,000,000 samples" in str(raised) and "limit of 20,000" in str(raised)
    assert peak < 20e6
