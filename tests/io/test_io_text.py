"""Text and NPZ formats: round trips, the real Cornell files, broken files, format inference."""

from __future__ import annotations

import struct
import warnings

import numpy as np
import pytest
from helpers import shared_file
from io_helpers import pbrt_text, rgb_data

from brdffit.data.measurements import Measurements
from brdffit.errors import DataError, FormatError
from brdffit.io import FORMATS, detect_format, read, write

CORNELL = ("garnet_red.astm", "krylon_blue.astm", "acryl_blue.brdf")


def load(path, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return read(path, **kwargs)


def assert_same(a: Measurements, b: Measurements, atol=0.0):
    assert a.channels == b.channels and a.source == b.source and a.units == b.units
    np.testing.assert_array_equal(a.values, b.values)
    np.testing.assert_allclose(b.wi, a.wi, rtol=0, atol=atol)
    np.testing.assert_allclose(b.wo, a.wo, rtol=0, atol=atol)
    if a.sigma is None:
        assert b.sigma is None
    else:
        np.testing.assert_array_equal(a.sigma, b.sigma)


@pytest.mark.parametrize("extension", [".csv", ".astm", ".npz"])
def test_round_trip_keeps_values_sigma_channels_and_directions(tmp_path, extension):
    data = rgb_data()
    path = tmp_path / f"data{extension}"
    write(path, data)
    back = load(path)
    # Angles are written exactly (CSV in degrees as given; ASTM in radians, one
    # conversion away; NPZ stores the directions themselves).
    assert_same(data, back, atol=0.0 if extension != ".astm" else 1e-15)
    assert back.negative_count == 1
    again = tmp_path / f"again{extension}"
    write(again, back)
    if extension != ".npz":  # zip members carry a time stamp
        assert again.read_bytes() == path.read_bytes()


@pytest.mark.parametrize("extension", [".csv", ".astm", ".npz"])
def test_round_trip_of_data_built_from_directions(tmp_path, extension):
    data = rgb_data(from_angles=False, sigma=False)
    write(tmp_path / f"d{extension}", data)
    back = load(tmp_path / f"d{extension}")
    assert_same(data, back, atol=0.0 if extension == ".npz" else 1e-14)


def test_csv_layout_comments_text_columns_and_units(tmp_path):
    text = (
        "# a comment before the header\n"
        "# units: 1/sr\n"
        "# source: hand written\n"
        "label, theta_i, phi_i, theta_o, phi_o, value, sigma_value\n"
        "first, 10, 0, 20, 180, 0.5, 0.01\n"
        "# a comment between rows\n"
        "\n"
        "second, 30, 0, 30, 180, 1.5, 0.02\n"
    )
    path = tmp_path / "hand.csv"
    path.write_text(text)
    m = read(path)
    assert m.channels == ("value",) and m.source == "hand written" and m.units == "1/sr"
    np.testing.assert_array_equal(m.values[:, 0], [0.5, 1.5])
    np.testing.assert_array_equal(m.sigma[:, 0], [0.01, 0.02])
    np.testing.assert_array_equal(m.angles()[2], [20.0, 30.0])
    # Without a source comment, the source is the file name.
    path.write_text("theta_i,phi_i,theta_o,phi_o,r\n10,0,10,180,1\n")
    assert read(path).source == "hand.csv"


def broken_message(tmp_path, name, text, match, **options):
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(FormatError, match=match) as info:
        load(path, **options)
    assert str(path) in str(info.value)
    return str(info.value)


GOOD_CSV = "theta_i,phi_i,theta_o,phi_o,r,g\n10,0,10,180,1,2\n20,0,20,180,3,4\n30,0,30,180,5,6\n"


def test_broken_csv_files_name_the_file_and_the_line(tmp_path):
    lines = GOOD_CSV.splitlines()
    text = "\n".join([*lines[:2], "20,0,20,180,three,4", lines[3]])
    broken_message(tmp_path, "a.csv", text, r"line 3, column r: 'three' is not a number")
    text = "\n".join([*lines[:3], "30,0,30,nan,5,6"])
    broken_message(tmp_path, "b.csv", text, r"line 4, column phi_o: nan is not a finite")
    text = "\n".join([*lines[:3], "30,0,30,"])  # truncated in the middle of a row
    broken_message(tmp_path, "c.csv", text, r"line 4: 4 comma-separated fields where the header")
    text = "\n".join([*lines[:2], "20,0,200,180,3,4"])
    broken_message(tmp_path, "d.csv", text, r"line 3, column theta_o: 200.0 is outside \[0, 180\]")
    header = "theta_i,phi_i,theta_out,phi_o,r,g"
    broken_message(
        tmp_path, "e.csv", "\n".join([header, *lines[1:]]), r"line 1: bad header.*theta_o"
    )
    header = "theta_i,phi_i,theta_o,phi_o,r,r"
    broken_message(tmp_path, "f.csv", "\n".join([header, *lines[1:]]), r"line 1: .*\['r'\] appear")
    header = "theta_i,phi_i,theta_o,phi_o,r,g,sigma_r"
    rows = [row + ",0.1" for row in lines[1:]]
    broken_message(
        tmp_path, "g.csv", "\n".join([header, *rows]), r"sigma is given for r but not for g"
    )
    broken_message(tmp_path, "h.csv", lines[0] + "\n", r"header but no data rows")
    broken_message(tmp_path, "i.csv", "# only a comment\n", r"no header row")
    text = "\n".join([*lines[:2], "20,0,20,180,3,-1"]).replace("r,g", "r,g,sigma_r,sigma_g")
    text = text.replace("\n10,0,10,180,1,2", "\n10,0,10,180,1,2,0.1,0.1")
    broken_message(tmp_path, "j.csv", text, r"line 3: 6 comma-separated fields")
    path = tmp_path / "k.csv"
    path.write_bytes(b"theta_i,phi_i\n\xff\xfe")
    with pytest.raises(FormatError, match=r"k.csv is not a UTF-8 text file"):
        read(path)


def astm_text(rows: int = 3) -> str:
    values = [
        f"{0.17 * (k + 1):.6f},0.000000,{0.2 * k:.6f},3.141593,0.5,0.25" for k in range(rows)
    ]
    head = [
        "SAMPLE_NAME Test",
        "",
        f"NUM_POINTS {rows}",
        "VARS theta_i,phi_i,theta_s,phi_s,R,G",
        "",
    ]
    return "\n".join(head + values) + "\n"


def test_broken_astm_files_name_the_file_and_the_line(tmp_path):
    good = astm_text()
    (tmp_path / "ok.astm").write_text(good)
    assert load(tmp_path / "ok.astm").source == "Test"
    lines = good.splitlines()
    broken_message(
        tmp_path, "a.astm", "\n".join(lines[:-1]), r"line 3: NUM_POINTS is 3 but 2 data rows"
    )
    text = good.replace("0.340000,0.000000", "0.340000,abc")
    broken_message(tmp_path, "b.astm", text, r"line 7, column phi_i: 'abc' is not a number")
    text = good.replace("0.340000,0.000000", "0.340000,NaN")
    broken_message(tmp_path, "c.astm", text, r"line 7, column phi_i: nan is not a finite number")
    text = good.replace("VARS theta_i,", "VARS theta_x,")
    broken_message(tmp_path, "d.astm", text, r"line 4: bad header .*theta_i")
    broken_message(tmp_path, "e.astm", good.replace("VARS", "COLUMNS"), r"has no VARS line")
    text = "\n".join([*lines[:-1], lines[-1][:20]])
    broken_message(tmp_path, "f.astm", text, r"line 8: 3 comma-separated fields where the header")
    text = good.replace("0.510000,", "5.1,")
    broken_message(tmp_path, "g.astm", text, r"line 8, column theta_i: 5.1 is outside.*degrees'")
    # The same file in degrees reads with angle_unit="degrees".
    path = tmp_path / "deg.astm"
    path.write_text(text)
    assert load(path, angle_unit="degrees").angles()[0][2] == 5.1


def test_pbrt_reads_records_across_lines_and_broken_files_name_the_line(tmp_path):
    path = tmp_path / "ok.brdf"
    path.write_text(pbrt_text())
    m = read(path)
    assert m.channels == ("400nm", "550nm", "700nm")
    np.testing.assert_array_equal(m.values, [[1, 2, 3], [4, 5, 6]])
    np.testing.assert_array_equal(m.angles(degrees=False)[0], [0.1, 0.2])
    text = pbrt_text()[:-2]
    broken_message(tmp_path, "a.brdf", text, r"line 8: after the 3 wavelengths come 13 numbers")
    text = pbrt_text().replace("4 5", "4 x5")
    broken_message(tmp_path, "b.brdf", text, r"line 8: 'x5' is not a number")
    text = pbrt_text().replace("4 5", "4 nan")
    broken_message(tmp_path, "c.brdf", text, r"line 8: 'nan' is not a finite number")
    broken_message(tmp_path, "d.brdf", "2.5 400 500", r"line 1: the first number.*'2.5'")


@pytest.mark.parametrize("name", CORNELL)
def test_cornell_files_read_with_their_documented_counts_and_ranges(name):
    path = shared_file("cornell", name)
    m = read(path)
    assert m.n == 1439 and m.negative_count == 0 and m.below_horizon_count == 0
    np.testing.assert_array_equal(m.wavelengths(), np.arange(400.0, 701.0, 10.0))
    ti, pi_, to, po = m.angles(degrees=True)
    # Incidence at 8 polar angles, 10..80 degrees (the file gives radians to 6 digits).
    levels = np.unique(np.round(ti, 3))
    np.testing.assert_allclose(levels, np.arange(10.0, 81.0, 10.0), atol=1e-3)
    assert (pi_ == 0).all() and to.max() < 80
    total = m.values.sum(axis=1)
    for level in levels:
        index = np.flatnonzero(np.round(ti, 3) == level)
        peak = index[np.argmax(total[index])]
        # The peak of each incidence lies in the mirror direction phi_o = phi_i + 180,
        # at or beyond the mirror polar angle (off-specular towards grazing).
        assert abs(np.mod(po[peak] - pi_[peak] - 180.0 + 180.0, 360.0) - 180.0) < 1e-3
        assert to[peak] >= ti[peak] - 4.0
    assert np.isfinite(m.values).all() and m.values.min() >= 0
    assert 1.0 < m.values.max() < 100.0 and np.median(m.values) < 0.1


@pytest.mark.parametrize("name", CORNELL)
def test_cornell_first_record_matches_the_text(name):
    path = shared_file("cornell", name)
    m = read(path)
    text = path.read_text()
    if name.endswith(".astm"):
        first = next(line for line in text.splitlines() if line[:1].isdigit())
        numbers = [float(x) for x in first.split(",")]
    else:
        tokens = " ".join(line.split("#")[0] for line in text.splitlines()).split()
        numbers = [float(x) for x in tokens[32 : 32 + 35]]
    np.testing.assert_array_equal(np.concatenate([np.array(m.angles(degrees=False))[:, 0],
                                                  m.values[0]]), numbers)  # fmt: skip


def test_format_is_inferred_from_extension_or_first_bytes(tmp_path):
    data = rgb_data(n=5, sigma=False)
    for name, writer in (("csv", "csv"), ("astm", "astm"), ("npz", "npz")):
        path = tmp_path / f"no_extension_{name}"
        write(path, data, format=writer)
        assert detect_format(path) == name
        assert_same(data, load(path), atol=1e-15)
    pbrt = tmp_path / "pbrt_data.txt"
    pbrt.write_text(pbrt_text())
    assert detect_format(pbrt) == "pbrt"
    (tmp_path / "m.dat").write_bytes(struct.pack("<3i", 90, 90, 180) + b"\0" * 16)
    assert detect_format(tmp_path / "m.dat") == "merl"
    (tmp_path / "n.dat").write_bytes(b"NVIDIA ARC MBSDF V1\nMBSDF_DATA_REFLECTION=\n")
    assert detect_format(tmp_path / "n.dat") == "mbsdf"
    for extension, name in ((".binary", "merl"), (".mbsdf", "mbsdf"), (".BRDF", "pbrt")):
        assert detect_format(tmp_path / f"x{extension}") == name  # extension alone suffices
    (tmp_path / "junk.dat").write_bytes(b"\x00\x01 something else")
    with pytest.raises(FormatError, match=r"cannot tell the format of .*junk.dat"):
        read(tmp_path / "junk.dat")


def test_unknown_formats_options_and_read_only_formats_are_errors(tmp_path):
    data = rgb_data(n=5)
    with pytest.raises(FormatError, match=r"unknown format 'xls'; the formats are csv"):
        write(tmp_path / "a.csv", data, format="xls")
    with pytest.raises(FormatError, match=r"cannot tell which format to write .*a\.xyz"):
        write(tmp_path / "a.xyz", data)
    for name in ("pbrt", "mbsdf", "rgl"):
        with pytest.raises(FormatError, match=rf"{name} format can be read but not written"):
            write(tmp_path / "a.out", data, format=name)
    write(tmp_path / "a.csv", data)
    with pytest.raises(FormatError, match=r"csv reader does not take the option\(s\) subsample"):
        read(tmp_path / "a.csv", subsample=2)
    with pytest.raises(DataError, match="data must be Measurements"):
        write(tmp_path / "b.csv", np.zeros(3))
    assert set(FORMATS) == {"csv", "astm", "pbrt", "merl", "mbsdf", "npz", "rgl"}


def test_npz_that_is_not_brdffit_is_a_format_error(tmp_path):
    np.savez(tmp_path / "other.npz", x=np.zeros(3))
    with pytest.raises(FormatError, match=r"other.npz lacks the array\(s\) wi, wo"):
        read(tmp_path / "other.npz")
    (tmp_path / "bad.npz").write_bytes(b"PK\x03\x04 truncated")
    with pytest.raises(FormatError, match=r"bad.npz is not a readable .npz archive"):
        read(tmp_path / "bad.npz")


def test_binary_formats_are_wired_through_read_and_write(tmp_path):
    merl = pytest.importorskip("brdffit.io.merl", reason="brdffit/io/merl.py is not written yet")
    wi, wo = merl.grid_directions(step=15)
    data = Measurements(wi, wo, np.outer(np.linspace(0.1, 1.0, len(wi)), [1.0, 2.0, 3.0]),
                        ["r", "g", "b"])  # fmt: skip
    write(tmp_path / "m.binary", data)
    np.testing.assert_allclose(read(tmp_path / "m.binary").values, data.values, rtol=1e-15)
    (tmp_path / "m.binary").rename(tmp_path / "m_no_extension")
    np.testing.assert_allclose(read(tmp_path / "m_no_extension").values, data.values, rtol=1e-15)
    assert read(tmp_path / "m_no_extension", subsample=2).n < data.n


def test_mbsdf_file_reads_through_read():
    mbsdf = pytest.importorskip(
        "brdffit.io.mbsdf", reason="brdffit/io/mbsdf.py is not written yet"
    )
    path = shared_file("nvidia", "carpaint_red.mbsdf")
    data, direct = load(path), load(path, format="mbsdf")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        reference = mbsdf.read_mbsdf(path)
    np.testing.assert_array_equal(data.values, reference.values)
    np.testing.assert_array_equal(direct.wi, reference.wi)
