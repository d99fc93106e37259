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
    assert float(result.params[at_zero]) == pytest.approx(0.0, abs=1e-6)
    assert at_zero in result.at_bounds
    assert f"at a bound of its range: {at_zero}" in result.message
    other = "kd" if at_zero == "ks" else "ks"
    assert other not in result.at_bounds


def test_a_zero_diffuse_is_flagged_whatever_the_lobe():
    """Failed before on 10 of these 18 (tolerance 1e-9 of kd's range): the polish stops
    at 1e-7 in n, and kd comes out at 1e-9 to 7e-8 instead of 0."""
    missed = []
    for n in (10.0, 20.0, 40.0, 80.0, 160.0, 300.0):
        for ks in (0.5, 1.0, 2.0):
            data = brdffit.synthesize("blinn", {"kd": 0.0, "ks": ks, "n": n})
            result = brdffit.fit(data, "blinn", loss="l2")
            if "kd" not in result.at_bounds:
                missed.append((n, ks, float(result.params["kd"])))
    assert missed == []
    # A small diffuse part that the data show is not at the bound.
    data = brdffit.synthesize("blinn", {"kd": 1e-4, "ks": 1.0, "n": 40.0})
    assert "kd" not in brdffit.fit(data, "blinn", loss="l2").at_bounds


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


def _ggx_data(scale=1.0, sigma=None):
    data = brdffit.synthesize("ggx", {"kd": 0.3, "ks": 0.5, "alpha": 0.2}, n=300)
    values = np.asarray(data.values) * scale
    sig = None if sigma is None else np.full(values.shape, sigma)
    return brdffit.Measurements(data.wi, data.wo, values, sigma=sig)


@pytest.mark.parametrize(
    ("scale", "sigma", "field", "words"),
    [
        (1e300, None, "values", "rescale the values"),
        (1e-300, None, "values", "rescale the values"),
        (1.0, 1e-300, "sigma", "would overflow"),
        (1.0, 1e300, "sigma", "would underflow"),
    ],
)
def test_scales_a_double_cannot_carry_are_refused_quietly(capfd, scale, sigma, field, words):
    """Issue 18: 1e300 values or sigma 1e-300 printed LAPACK DLASCL lines on stderr;
    failed before: the fit ran (its coefficients at 0, or at their bounds) instead
    of saying why it cannot."""
    data = _ggx_data(scale, sigma)
    for call in (brdffit.fit, brdffit.check_fit):
        with pytest.raises(brdffit.errors.DataError, match=words) as info:
            call(data, "ggx")
        assert info.value.field == field
    assert capfd.readouterr().err == ""


def test_ordinary_scales_still_fit():
    result = brdffit.fit(_ggx_data(1e-6, 1e-9), "ggx")
    assert result.params["alpha"] == pytest.approx(0.2, rel=1e-3)
    # sigma 1e-40 of the values (a relative sigma where a narrow lobe is 1e-38 of its
    # peak) is small, not a scale to refuse.
    brdffit.check_fit(_ggx_data(1.0, 1e-40), "ggx")
