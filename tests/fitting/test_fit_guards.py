"""Fits that used to answer without a word (issues 17 and 18): linear parameters at a
bound, data without signal, values at scales LAPACK cannot take."""

from __future__ import annotations

import numpy as np
import pytest

import brdffit


@pytest.mark.parametrize(
    ("truth", "at_zero"),
    [({"kd": 0.5, "ks": 0.0, "n": 40.0}, "ks"), ({"kd": 0.0, "ks": 1.0, "n": 40.0}, "kd")],
)
def test_a_linear_parameter_at_zero_is_flagged(truth, at_zero):
    """Failed before: only shape parameters (f0 = 1) were checked against their bounds."""
    data = brdffit.synthesize("blinn", truth)
    result = brdffit.fit(data, "blinn", loss="l2")
    assert float(result.params[at_zero]) == pytest.approx(0.0, abs=1e-9)
    assert at_zero in result.at_bounds
    assert f"at a bound of its range: {at_zero}" in result.message
    other = "kd" if at_zero == "ks" else "ks"
    assert other not in result.at_bounds


def test_a_linear_parameter_at_zero_in_one_channel_is_flagged():
    data = brdffit.synthesize("blinn", {"kd": [0.5, 0.4], "ks": [0.0, 0.8], "n": 40.0})
    result = brdffit.fit(data, "blinn", loss="l2")
    assert np.asarray(result.params["ks"])[0] == pytest.approx(0.0, abs=1e-9)
    assert "ks" in result.at_bounds and "kd" not in result.at_bounds
