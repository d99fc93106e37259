"""read/write from and to bytes and binary file objects, for every format, as from paths."""

from __future__ import annotations

import io

import numpy as np
import pytest
from io_helpers import MAGIC as MBSDF_MAGIC
from io_helpers import (
    REFLECTION,
    pack_block,
    pack_tensor,
    pbrt_text,
    quiet_read,
    rgb_data,
    tiny_rgl,
)

from brdffit import Measurements, read, write
from brdffit.errors import FormatError
from brdffit.io import NAMELESS, detect_format
from brdffit.io.merl import grid_directions


def _merl_data():
    wi, wo = grid_directions(step=15)
    values = np.outer(np.linspace(0.1, 1.0, len(wi)), [1.0, 2.0, 3.0])
    return Measurements(wi, wo, values, ["r", "g", "b"])


def _mbsdf_bytes() -> bytes:
    values = np.random.default_rng(1).uniform(0.0, 5.0, 3 * 3 * 4 * 3).astype(np.float32)
    return MBSDF_MAGIC + REFLECTION + pack_block(1, 3, 4, values.tolist())


def _file(tmp_path, name: str):
    """A file of format ``name`` at a path with its extension."""
    extension = {"csv": ".csv", "astm": ".astm", "npz": ".npz", "merl": ".binary",
                 "pbrt": ".brdf", "mbsdf": ".mbsdf", "rgl": ".bsdf"}[name]  # fmt: skip
    path = tmp_path / f"sample{extension}"
    if name in ("csv", "astm", "npz"):
        write(path, rgb_data(n=20))
    elif name == "merl":
        write(path, _merl_data())
    elif name == "pbrt":
        path.write_text(pbrt_text())
    elif name == "mbsdf":
        path.write_bytes(_mbsdf_bytes())
    else:
        path.write_bytes(pack_tensor(tiny_rgl()))
    return path


def assert_same_data(a, b):
    assert a.channels == b.channels and a.units == b.units and a.n == b.n
    for x, y in ((a.values, b.values), (a.wi, b.wi), (a.wo, b.wo)):
        np.testing.assert_array_equal(x, y)
    assert (a.sigma is None) == (b.sigma is None)
    if a.sigma is not None:
        np.testing.assert_array_equal(a.sigma, b.sigma)


FORMAT_NAMES = ("csv", "astm", "npz", "merl", "pbrt", "mbsdf", "rgl")


@pytest.mark.parametrize("name", FORMAT_NAMES)
def test_every_format_reads_the_same_from_bytes_and_file_objects_as_from_a_path(tmp_path, name):
    path = _file(tmp_path, name)
    from_path = quiet_read(path)
    raw = path.read_bytes()
    assert detect_format(raw) == name  # the first bytes tell every format
    for make in (bytes, bytearray, memoryview, io.BytesIO):
        assert_same_data(from_path, quiet_read(make(raw)))
        assert_same_data(from_path, quiet_read(make(raw), format=name))
    with open(path, "rb") as f:
        from_file = quiet_read(f)
    assert_same_data(from_path, from_file)
    assert from_file.source == from_path.source  # a file object is named by its name


@pytest.mark.parametrize("name", ["csv", "astm", "npz", "merl"])
def test_writing_to_a_file_object_gives_the_bytes_of_the_file(tmp_path, name):
    data = _merl_data() if name == "merl" else rgb_data(n=20)
    path = _file(tmp_path, name)
    buffer = io.BytesIO()
    write(buffer, data, format=name)
    assert buffer.getvalue() == path.read_bytes()
    buffer.seek(0)
    assert_same_data(quiet_read(path), quiet_read(buffer, format=name))
    named = io.BytesIO()
    named.name = path.name  # the format is inferred from a file object's name
    write(named, data)
    assert named.getvalue() == path.read_bytes()


def test_merl_options_work_on_bytes(tmp_path):
    raw = _file(tmp_path, "merl").read_bytes()
    whole, sub = read(raw), read(raw, subsample=2)
    assert 0 < sub.n < whole.n


def test_errors_name_the_file_object_or_bytes(tmp_path):
    text = "theta_i,phi_i,theta_o,phi_o,value\n0,0,10,180,0.5\n0,0,10,oops,0.5\n"
    upload = io.BytesIO(text.encode())
    upload.name = "upload.csv"
    with pytest.raises(FormatError, match=r"^upload\.csv, line 3, column phi_o: 'oops'"):
        read(upload)
    with pytest.raises(FormatError, match=rf"^{NAMELESS}, line 3, column phi_o"):
        read(text.encode(), format="csv")
    with pytest.raises(FormatError, match=rf"^{NAMELESS}: the file has 3 bytes; a MERL"):
        read(b"abc", format="merl")


def test_a_source_that_does_not_tell_its_format_needs_format(tmp_path):
    for source in (b"\x00\x01 something", io.BytesIO(b"\x00\x01 something")):
        with pytest.raises(FormatError, match=r"cannot tell the format of <bytes> from its "
                                              r"first bytes; pass format=") as caught:  # fmt: skip
            read(source)
        assert caught.value.field == "format"
    with pytest.raises(FormatError, match="a file object without a name") as caught:
        write(io.BytesIO(), rgb_data(n=3))
    assert caught.value.field == "format"


def test_wrong_kinds_of_source_and_target_are_format_errors(tmp_path):
    path = _file(tmp_path, "csv")
    with open(path, encoding="utf-8") as f, pytest.raises(FormatError, match="binary mode") as e:
        read(f)
    assert e.value.field == "source" and str(path) in str(e.value)
    with pytest.raises(FormatError, match="cannot read from a int") as e:
        read(12, format="csv")
    assert e.value.field == "source"
    with open(tmp_path / "t.csv", "w") as f, pytest.raises(FormatError, match="binary mode"):
        write(f, rgb_data(n=3))
    with pytest.raises(FormatError, match="cannot write to a list") as e:
        write([], rgb_data(n=3), format="csv")
    assert e.value.field == "target"


@pytest.mark.parametrize("name", ["npz", "merl", "mbsdf", "rgl"])
def test_a_broken_binary_source_is_a_format_error_on_the_field_source(tmp_path, name):
    raw = _file(tmp_path, name).read_bytes()
    with pytest.raises(FormatError, match=rf"^{NAMELESS}") as caught:
        read(raw[: len(raw) // 2], format=name)
    assert caught.value.field == "source"  # the argument of read() at fault


@pytest.mark.parametrize("name", ["csv", "astm", "pbrt"])
def test_bytes_that_are_not_text_are_a_format_error_on_the_field_source(name):
    with pytest.raises(FormatError, match=r"^<bytes> is not a UTF-8 text file \(byte 1") as e:
        read(b"0\xff\xfe1,2\n", format=name)
    assert e.value.field == "source"
