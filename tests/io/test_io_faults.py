"""A damaged file is a BrdfFitError naming it, whatever the reader meets (issue 18)."""

from __future__ import annotations

import io
import struct
import zipfile

import numpy as np
import pytest
from io_helpers import named, pack_tensor, rgb_data, tiny_rgl

import brdffit
import brdffit.io as bio
from brdffit.errors import DataError, FormatError
from brdffit.io.merl import RES_PHI_D, RES_THETA_D, RES_THETA_H, write_merl_table


def npz_of(**changes) -> bytes:
    """The NPZ of a small data set, with arrays replaced (None removes one)."""
    data = rgb_data(n=5)
    buffer = io.BytesIO()
    brdffit.write(buffer, data, format="npz")
    with np.load(io.BytesIO(buffer.getvalue())) as archive:
        arrays = {k: archive[k] for k in archive.files}
    arrays.update(changes)
    out = io.BytesIO()
    np.savez_compressed(out, **{k: v for k, v in arrays.items() if v is not None})
    return out.getvalue()


def test_an_rgl_vndf_that_integrates_to_zero_names_the_file_and_the_field():
    raw = pack_tensor(tiny_rgl(vndf=np.zeros((1, 2, 5, 4), "<f4")))
    with pytest.raises(FormatError) as info:
        brdffit.read(named(raw, "flipped.bsdf"))
    message = str(info.value)
    assert message.startswith("flipped.bsdf: the vndf table of incident node 0 (field 'vndf'")
    assert "integrates to zero" in message and info.value.field == "source"


def test_an_rgl_field_of_60000_dimensions_is_refused_from_its_header():
    ndim = 60000
    name = b"rgb"
    header = b"tensor_file\x00" + struct.pack("<BBI", 1, 0, 1)
    offset = len(header) + 2 + len(name) + 11 + 8 * ndim
    field = struct.pack("<H", len(name)) + name + struct.pack("<HBQ", ndim, 10, offset)
    raw = header + field + struct.pack(f"<{ndim}Q", *([1] * ndim)) + struct.pack("<f", 1.0)
    with pytest.raises(FormatError) as info:
        brdffit.read(named(raw, "deep.bsdf"))
    assert str(info.value).startswith(
        "deep.bsdf: field 'rgb' has 60000 dimensions (header at byte 23); a tensor has at most"
    )


def test_an_npz_member_whose_deflate_stream_is_corrupt_is_a_format_error():
    raw = bytearray(npz_of())
    with zipfile.ZipFile(io.BytesIO(bytes(raw))) as archive:
        info = archive.getinfo("values.npy")
    name_length, extra_length = struct.unpack_from("<HH", raw, info.header_offset + 26)
    start = info.header_offset + 30 + name_length + extra_length
    raw[start] = 0xFF  # final block of the reserved type 3: "invalid block type"
    with pytest.raises(FormatError) as info_:
        brdffit.read(named(bytes(raw), "corrupt.npz"))
    message = str(info_.value)
    assert message.startswith("corrupt.npz is not a readable .npz archive: error: ")
    assert "invalid block type" in message
    assert type(info_.value.__cause__).__module__ == "zlib"


@pytest.mark.parametrize(
    "version, pattern",
    [
        (np.array("one"), r"'format_version' is <U3 with shape \[\]; a brdffit .npz file stores"),
        (np.array([1, 2]), r"'format_version' has shape \[2\]; it is one value"),
        (np.array(-1), r"format_version -1 is not a whole number >= 0"),
        (np.array(9), r"has format_version 9; this brdffit reads up to 1"),
    ],
)
def test_a_bad_npz_format_version_names_the_field(version, pattern):
    with pytest.raises(FormatError, match=pattern) as info:
        brdffit.read(named(npz_of(format_version=version), "v.npz"))
    assert info.value.field == "format_version" and str(info.value).startswith("v.npz")


def test_a_merl_file_without_any_measured_cell_is_named():
    table = np.full((3, RES_THETA_H, RES_THETA_D, RES_PHI_D), -1.0)
    buffer = io.BytesIO()
    write_merl_table(buffer, table)
    with pytest.raises(FormatError) as info:
        brdffit.read(named(buffer.getvalue(), "empty.binary"))
    assert str(info.value).startswith(
        "empty.binary: no cell holds a measurement: of the 1458000 cells looked at, 1458000 "
        "are negative"
    )


def failing_reader(exc: BaseException):
    def read_broken(source, max_samples=None):
        raise exc

    return read_broken


@pytest.mark.parametrize(
    "exc", [KeyError("x"), MemoryError("Unable to allocate 2.18 TiB"), OverflowError("big")]
)
def test_any_unforeseen_exception_of_a_reader_is_a_format_error_naming_the_file(monkeypatch, exc):
    broken = bio.FORMATS["csv"]._replace(read=failing_reader(exc))
    monkeypatch.setitem(bio.FORMATS, "csv", broken)
    with pytest.raises(FormatError) as info:
        brdffit.read(named(b"theta_i,phi_i\n", "x.csv"))
    message = str(info.value)
    assert message.startswith("x.csv cannot be read as brdffit CSV")
    assert f"(the csv reader failed with {type(exc).__name__}: " in message
    if isinstance(exc, MemoryError):
        assert "too large to read in memory" in message
    assert info.value.__cause__ is exc and info.value.field == "source"


def test_a_library_error_without_the_file_name_gets_it_keeping_its_class_and_field(monkeypatch):
    inner = DataError("the data are empty; at least one sample is needed", "values")
    broken = bio.FORMATS["csv"]._replace(read=failing_reader(inner))
    monkeypatch.setitem(bio.FORMATS, "csv", broken)
    with pytest.raises(DataError) as info:
        brdffit.read(named(b"theta_i\n", "y.csv"))
    assert str(info.value) == "y.csv: the data are empty; at least one sample is needed"
    assert info.value.field == "values" and info.value.__cause__ is inner


def test_a_missing_file_is_still_the_operating_systems_error(tmp_path):
    with pytest.raises(FileNotFoundError):
        brdffit.read(tmp_path / "absent.csv")


def test_an_rgl_field_with_a_zero_and_a_huge_size_is_refused():
    """No data to read, yet numpy cannot make the shape (found by test_io_fuzz, seed 161)."""
    header = b"tensor_file\x00" + struct.pack("<BBI", 1, 0, 1)
    field = struct.pack("<H", 3) + b"rgb" + struct.pack("<HBQ2Q", 2, 10, 48, 0, 2**63 - 1)
    raw = header + field
    with pytest.raises(FormatError, match=r"^z.bsdf: field 'rgb' has the shape \[0, 922"):
        brdffit.read(named(raw, "z.bsdf"))
