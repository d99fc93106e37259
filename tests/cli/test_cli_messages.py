"""What the command line says (issue 17): a model name in the wrong case gets its
suggestion, counts take their plural only when they are not 1, and the table of a
fit has a heading for every column, numbers with their interval, and a compact
view of many channels."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import brdffit
from brdffit.cli.main import main
from brdffit.words import plural

ROOT = Path(__file__).resolve().parents[2]
WARD = ROOT / "data_synthetic" / "ward.csv"


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize(("given", "meant"), [("GGX", "ggx"), ("Cook_Torrance", "cook_torrance")])
def test_a_model_name_in_another_case_is_suggested(capsys, given, meant):
    code, _, err = run(capsys, "fit", WARD, "--model", given)
    assert code == 2
    assert f"unknown model {given!r} (did you mean {meant}" in err
    with pytest.raises(brdffit.errors.ModelError, match=rf"did you mean {meant}"):
        brdffit.get_model(given)


def test_counts_of_one_are_singular(capsys, tmp_path):
    one = tmp_path / "one.csv"
    one.write_text("theta_i,phi_i,theta_o,phi_o,value\n30,0,30,180,0.2\n")
    code, _, err = run(capsys, "fit", one, "--model", "lambert")
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
