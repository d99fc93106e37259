"""Angle units (radians in a file read as degrees) and CSV files saved by spreadsheets."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from io_helpers import named, quiet_read

import brdffit
from brdffit.errors import FormatError
from brdffit.notes import collecting

WARD = Path(__file__).resolve().parents[2] / "data_synthetic" / "ward.csv"


def ward_text() -> str:
    return WARD.read_text()


def in_radians(text: str) -> str:
    """The CSV text with its four angle columns converted to radians (no other change)."""
    out = []
    for line in text.splitlines():
        if line and line[0].isdigit():
            fields = line.split(",")
            fields[:4] = [repr(float(np.radians(float(x)))) for x in fields[:4]]
            line = ",".join(fields)
        out.append(line)
    return "\n".join(out) + "\n"


# ------------------------------------------------------------------ angle units
def test_radians_in_a_csv_read_as_degrees_are_noted_naming_the_file():
    raw = in_radians(ward_text()).encode()
    with collecting() as notes, pytest.warns(UserWarning, match="look like radians"):
        brdffit.read(named(raw, "ward_rad.csv"))
    assert len(notes) == 1
    assert notes[0].startswith("ward_rad.csv: the angles are read as degrees")
    assert "angle_unit='radians'" in notes[0] and "--angle-unit radians" in notes[0]


def test_the_file_in_degrees_is_not_noted():
    with collecting() as notes:
        quiet_read(WARD)
    assert notes == []


@pytest.mark.parametrize(
    "how",
    [
        {"angle_unit": "radians"},
        {"comment": "# angle_unit: radians"},
        {"comment": "# units: radians"},
        {"comment": "# Angles: rad"},
    ],
)
def test_the_unit_stated_by_option_or_comment_reads_the_same_directions(how):
    degrees = quiet_read(WARD)
    text = in_radians(ward_text())
    if "comment" in how:
        text = how["comment"] + "\n" + text
    with collecting() as notes:
        data = brdffit.read(named(text.encode(), "w.csv"), angle_unit=how.get("angle_unit"))
    assert notes == []
    np.testing.assert_allclose(data.wi, degrees.wi, rtol=0, atol=1e-15)
    np.testing.assert_allclose(data.wo, degrees.wo, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(data.values, degrees.values)
    assert data.units == "1/sr"


def test_degrees_stated_silence_the_note_and_the_option_wins_over_the_comment():
    raw = in_radians(ward_text()).encode()
    with collecting() as notes:
        brdffit.read(named(raw, "w.csv"), angle_unit="degrees")
    assert notes == []
    text = "# angle_unit: degrees\n" + in_radians(ward_text())
    with collecting() as notes, pytest.warns(UserWarning):
        data = brdffit.read(named(text.encode(), "w.csv"), angle_unit="radians")
    assert notes == ["w.csv: the file says its angles are in degrees; read as radians, as "
                     "angle_unit says"]  # fmt: skip
    np.testing.assert_allclose(data.wi, quiet_read(WARD).wi, atol=1e-15)


def test_an_unknown_angle_unit_is_an_error_naming_the_field_or_the_line():
    with pytest.raises(FormatError, match="angle_unit='gradians' is not known") as info:
        brdffit.read(WARD, angle_unit="gradians")
    assert info.value.field == "angle_unit"
    text = "# angle_unit: grad\n" + ward_text()
    with pytest.raises(FormatError, match=r"w.csv, line 1: the angle unit 'grad' is not known"):
        brdffit.read(named(text.encode(), "w.csv"))


@pytest.mark.parametrize("parse", ["parse_astm", "parse_pbrt"])
def test_the_radian_formats_check_angle_unit_as_the_csv_reader_does(parse):
    from brdffit.io import astm, pbrt

    function = getattr(astm if parse == "parse_astm" else pbrt, parse)
    for bad in ("gradians", None):
        with pytest.raises(FormatError, match=rf"angle_unit={bad!r} is not known") as info:
            function("", angle_unit=bad)
        assert info.value.field == "angle_unit"


def test_pbrt_and_astm_take_the_angle_unit_too():
    text = "1\n550\n10 0 20 180 0.5\n30 0 40 180 0.25\n"
    data = brdffit.read(named(text.encode(), "d.brdf"), angle_unit="degrees")
    np.testing.assert_allclose(data.angles()[0], [10, 30])


def test_from_angles_notes_radians_unless_the_unit_is_stated():
    theta = np.array([0.2, 0.5, 1.0])
    phi = np.array([0.0, 1.0, 3.1])
    with collecting() as notes, pytest.warns(UserWarning, match="look like radians"):
        brdffit.Measurements.from_angles(theta, phi, theta, phi + 3, np.ones(3), source="arr")
    assert len(notes) == 1 and notes[0].startswith("arr: ") and "degrees=False" in notes[0]
    for degrees in (True, False):
        with collecting() as notes:
            brdffit.Measurements.from_angles(theta, phi, theta, phi, np.ones(3), degrees=degrees)
        assert notes == []
    with collecting() as notes:  # degrees for real: some phi beyond 2 pi, or zero angles only
        brdffit.Measurements.from_angles(theta, phi, theta, phi + 180, np.ones(3))
        brdffit.Measurements.from_angles([0.0], [0.0], [0.0], [0.0], [1.0])
    assert notes == []


# ------------------------------------------------------------- spreadsheets
def spreadsheet_variants() -> dict:
    text = ward_text()
    semicolons = text.replace(",", ";")
    return {
        "utf8_bom": ("\ufeff" + text).encode("utf-8"),
        "semicolons": semicolons.encode(),
        "tabs_crlf": text.replace(",", "\t").replace("\n", "\r\n").encode(),
        "semicolons_decimal_commas_bom": semicolons.replace(".", ",").encode("utf-8-sig"),
        "tabs_decimal_commas_utf16": text.replace(",", "\t").replace(".", ",").encode("utf-16"),
        "quoted_header": text.replace("theta_i,phi_i", '"theta_i","phi_i"').encode(),
    }


@pytest.mark.parametrize("variant", sorted(spreadsheet_variants()))
def test_a_csv_saved_by_a_spreadsheet_reads_the_same_samples(variant):
    expected = quiet_read(WARD)
    raw = spreadsheet_variants()[variant]
    for source in (named(raw, "sheet.csv"), raw):  # by extension, and by its first bytes
        data = quiet_read(source)
        np.testing.assert_array_equal(data.values, expected.values)
        np.testing.assert_array_equal(data.sigma, expected.sigma)
        np.testing.assert_array_equal(data.wi, expected.wi)
        assert data.channels == expected.channels


def test_a_number_with_a_comma_and_a_point_in_a_semicolon_file_names_its_line():
    text = "theta_i;phi_i;theta_o;phi_o;value\n10;0;10;180;0,5\n20;0;20;180;1.000,5\n"
    with pytest.raises(FormatError) as info:
        brdffit.read(named(text.encode(), "eu.csv"))
    message = str(info.value)
    assert message.startswith("eu.csv, line 3: '1.000,5' has both a comma and a point")
    assert "semicolon-separated" in message


def test_a_header_that_is_not_split_says_which_separator_was_used():
    text = "theta_i|phi_i|theta_o|phi_o|value\n10|0|10|180|0.5\n"
    with pytest.raises(FormatError, match="no comma, semicolon or tab between column names"):
        brdffit.read(named(text.encode(), "pipes.csv"))
    text = "theta_i;phi_i;theta_out;phi_o;value\n10;0;10;180;0.5\n"
    with pytest.raises(FormatError, match=r"split on semicolons, it names 'theta_i, phi_i, th"):
        brdffit.read(named(text.encode(), "typo.csv"))
    text = "theta_i;phi_i;theta_o;phi_o;value\n10;0;10;180;0.5;7\n"
    with pytest.raises(FormatError, match=r"line 2: 6 semicolon-separated fields"):
        brdffit.read(named(text.encode(), "extra.csv"))


def test_the_command_line_warns_of_radians_and_takes_angle_unit(tmp_path, capsys):
    from brdffit.cli.main import main

    path = tmp_path / "ward_rad.csv"
    path.write_text(in_radians(ward_text()))
    assert main(["fit", str(path), "--model", "lambert", "--json"]) == 0
    err = capsys.readouterr().err
    assert "brdffit: warning: " + str(path) + ": the angles are read as degrees" in err
    assert main(["fit", str(path), "--model", "lambert", "--json", "--angle-unit", "radians"]) == 0
    assert "look like radians" not in capsys.readouterr().err


@pytest.mark.filterwarnings("ignore:.*look like radians:UserWarning")
def test_the_http_service_returns_the_note_in_data_notes(tmp_path):
    """The upload route's answer carries the reader's note; the JSON route's the
    note of Measurements.from_angles."""
    pytest.importorskip("fastapi", reason="the service extra is absent")
    from fastapi.testclient import TestClient

    from brdffit_service import Settings, create_app

    settings = Settings(store_path=tmp_path / "jobs.sqlite3", workers=1, fit_timeout=5.0)
    text = in_radians(ward_text())
    with TestClient(create_app(settings)) as client:
        files = {"file": ("ward_rad.csv", text.encode(), "text/csv")}
        answer = client.post("/fit/file", files=files, data={"model": "lambert"})
        assert answer.status_code == 200, answer.text
        notes = answer.json()["data_notes"]
        assert any(n.startswith("ward_rad.csv: the angles are read as degrees") for n in notes)
        data = quiet_read(named(text.encode(), "w.csv"), angle_unit="degrees")
        body = {"model": "lambert", "data": data.to_dict(include_data=True)}
        body["data"] = {k: body["data"][k] for k in ("theta_i", "phi_i", "theta_o", "phi_o")}
        body["data"]["values"] = data.values.tolist()
        answer = client.post("/fit", json=body)
        assert answer.status_code == 200, answer.text
        assert any("look like radians" in n for n in answer.json()["data_notes"])
