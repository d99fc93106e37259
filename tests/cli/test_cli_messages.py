"""What the command line says (issue 17): a model name in the wrong case gets its
suggestion, counts take their plural only when they are not 1, and the table of a
fit has a heading for every column, numbers with their interval, and a compact
view of many channels."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from helpers import run_cli

import brdffit
from brdffit.words import plural

ROOT = Path(__file__).resolve().parents[2]
WARD = ROOT / "data_synthetic" / "ward.csv"


@pytest.mark.parametrize(("given", "meant"), [("GGX", "ggx"), ("Cook_Torrance", "cook_torrance")])
def test_a_model_name_in_another_case_is_suggested(capsys, given, meant):
    code, _, err = run_cli(capsys, "fit", WARD, "--model", given)
    assert code == 2
    assert f"unknown model {given!r} (did you mean {meant}" in err
    with pytest.raises(brdffit.errors.ModelError, match=rf"did you mean {meant}"):
        brdffit.get_model(given)


def test_counts_of_one_are_singular(capsys, tmp_path):
    one = tmp_path / "one.csv"
    one.write_text("theta_i,phi_i,theta_o,phi_o,value\n30,0,30,180,0.2\n")
    code, _, err = run_cli(capsys, "fit", one, "--model", "lambert")
    assert code == 2
    assert "the data have 1 sample above the horizon but lambert has 1 free parameter " in err
    assert (plural(1, "sample"), plural(2, "sample"), plural(" 1", "step")) == (
        "1 sample", "2 samples", " 1 step",
    )  # fmt: skip


def test_counts_above_one_keep_their_plural():
    data = brdffit.synthesize("lambert", {"kd": 0.4}, n=2, geometry="hemisphere", seed=1)
    message = "2 samples above the horizon but ward has 3 free parameters per channel"
    with pytest.raises(brdffit.errors.FitError, match=message):
        brdffit.fit(data, "ward")
    assert data.subset(np.array([0])).summary().startswith("1 sample from ")


# -------------------------------------------------------------- the fit table
def _table(out: str) -> list[list[str]]:
    """The rows of the first table in ``out`` (cells two or more spaces apart)."""
    import re

    lines = out.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("parameter"))
    rows = []
    for line in lines[start:]:
        if not line.strip():
            break
        rows.append(re.split(r"\s{2,}", line.strip()))
    return rows


def test_every_column_has_a_heading(capsys):
    code, out, err = run_cli(capsys, "fit", WARD, "--model", "ward", "--fixed", "kd=0.1")
    assert code == 0, err
    assert _table(out)[0] == ["parameter", "r", "g", "b", "note"]
    lines = out.splitlines()
    head = next(line for line in lines if line.startswith("parameter"))
    kd = next(line for line in lines if line.startswith("kd "))
    assert kd.endswith("fixed") and kd.index("fixed") == head.index("note")


@pytest.mark.parametrize(
    ("value", "expected"),
    [
        ({"median": 2027.3, "p16": 2015.0, "p84": 2041.3}, "2027 +14 -12"),
        ({"median": 11141.0, "p16": 10860.0, "p84": 11441.0}, "11140 +300 -280"),
        ({"median": 0.050025, "p16": 0.049948, "p84": 0.050104}, "0.050025 +0.000079 -0.000077"),
    ],
)
def test_numbers_print_without_a_trailing_point_or_exponent(value, expected):
    from brdffit.cli.fittable import pm

    assert pm(value) == expected


def test_a_remapped_coefficient_prints_with_its_interval(capsys):
    path = ROOT / "data_synthetic" / "ashikhmin_shirley.csv"
    argv = ("fit", path, "--model", "ashikhmin_shirley", "--uncertainty", "--max-seconds", 5)
    code, out, err = run_cli(capsys, *argv)
    assert code == 0, err
    _, _, *rows = _table(out)
    rd = next(r for r in rows if r[0] == "rd")
    assert len(rd) == 4 and all(" +" in cell and " -" in cell for cell in rd[1:4])
    # the same posterior, mapped back by hand: rd = rd_eff / (1 - rs) of each sample
    post = brdffit.fit(
        brdffit.read(path), "ashikhmin_shirley", uncertainty=True,
        posterior_options={"max_seconds": 5},
    ).posterior  # fmt: skip
    s = post.samples
    for k, c in enumerate(post.channels):
        rd_c = s[:, post.index(f"rd_eff[{c}]")] / (1 - s[:, post.index(f"rs[{c}]")])
        median = float(rd[1 + k].split()[0])
        spread = np.percentile(rd_c, 84) - np.percentile(rd_c, 16)
        assert median == pytest.approx(np.median(rd_c), abs=0.1 * spread)


def _spectral(tmp_path, kd):
    bands = [f"{w}nm" for w in range(400, 701, 10)]
    data = brdffit.synthesize("lambert", {"kd": kd}, n=200, geometry="hemisphere",
                              channels=bands, seed=3)  # fmt: skip
    path = tmp_path / "spectral.csv"
    brdffit.write(path, data)
    return path, bands


def test_many_channels_get_one_summary_row_per_parameter(capsys, tmp_path):
    kd = np.linspace(0.1, 0.7, 31)
    path, bands = _spectral(tmp_path, kd)
    code, out, err = run_cli(capsys, "fit", path, "--model", "lambert")
    assert code == 0, err
    header, _, *rows = _table(out)
    assert header == ["parameter", "value", "note"] and len(rows) == 1
    assert rows[0][1] == "31 channels: min 0.1 (400nm), max 0.7 (700nm), median 0.4"
    assert "--every-channel prints one row per channel" in out
    code, out, _ = run_cli(capsys, "fit", path, "--model", "lambert", "--every-channel")
    assert [r[0] for r in _table(out)[2:]] == [f"kd[{b}]" for b in bands]


def test_rgb_fits_linear_srgb_in_the_same_units(capsys, tmp_path):
    path, _ = _spectral(tmp_path, np.full(31, 0.5))  # a grey: r = g = b = its albedo
    code, out, err = run_cli(capsys, "fit", path, "--model", "lambert", "--rgb", "--json")
    assert code == 0, err
    import json

    got = json.loads(out)
    assert got["channels"] == ["r", "g", "b"]
    assert got["params"]["kd"] == pytest.approx([0.5, 0.5, 0.5], rel=1e-3)
    code, _, err = run_cli(capsys, "fit", WARD, "--model", "ward", "--rgb")
    assert code == 2 and "--rgb needs spectral channels" in err
