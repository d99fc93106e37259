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


@pytest.mark.parametrize("fill", [0.0, -0.1])
@pytest.mark.parametrize("with_sigma", [False, True])
def test_data_without_signal_are_refused_saying_so(fill, with_sigma):
    """Failed before: all-zero data "converged" with loss 0 (ks -0, alpha left at
    its default)."""
    data = brdffit.synthesize("lambert", {"kd": 0.5}, n=200)
    sigma = np.full(data.values.shape, 0.01) if with_sigma else None
    empty = brdffit.Measurements(data.wi, data.wo, np.full(data.values.shape, fill), sigma=sigma)
    for call in (brdffit.fit, brdffit.check_fit):
        with pytest.raises(brdffit.errors.DataError, match="no signal to fit") as info:
            call(empty, "ggx")
        assert info.value.field == "values"
