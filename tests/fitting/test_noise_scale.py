"""Data in a unit far from a BRDF's (values scaled by 1e10 .. 1e99, which the data
checks accept): the noise model's estimate neither overflows nor turns NaN, and a fit
whose model cannot reach the data says so in words (review of the default loss).

Before: at 1e20 the estimate overflowed (noise.py, RuntimeWarnings) and kd came out
0 with no word; at 1e60 the fit raised "the noise model's sigma must be finite and
positive". The estimate alone, given residuals and predictions of 1e160 (whose squares
are inf) or 1e-160, returned a noise model of 0 or off by orders of magnitude; given
a prediction of 0 under a residual of 1e5, it overflowed."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from helpers import shared_file

import brdffit
from brdffit.data.measurements import Measurements
from brdffit.errors import FitError
from brdffit.fitting.noise import NoiseModel, estimate
from brdffit.fitting.problem import Problem
from brdffit.fitting.result import FAR

WARD = Path(__file__).resolve().parents[2] / "data_synthetic" / "ward.csv"


def mixed_residuals(seed: int = 3, n: int = 4000):
    """Predictions and residuals drawn from sigma^2 = a^2 + (b f)^2, a = 0.002, b = 0.05."""
    rng = np.random.default_rng(seed)
    f = np.exp(rng.uniform(np.log(1e-3), np.log(50.0), (n, 1)))
    r = rng.standard_normal((n, 1)) * NoiseModel(0.002, 0.05).sigma(f)
    return r, f


@pytest.mark.parametrize("scale", [1e10, 1e20, 1e60, 1e99, 1e-20, 1e160, 1e-160])
def test_the_estimate_scales_with_the_data_without_overflow(scale):
    r, f = mixed_residuals()
    base = estimate(r, f)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # an overflow or a NaN in numpy raises here
        scaled = estimate(r * scale, f * scale)
    # a is in the data's unit, b a fraction: the same noise model in the new unit
    # (1e10 .. 1e99: the values a user's file can hold; 1e160: squares that overflow).
    assert scaled.a == pytest.approx(base.a * scale, rel=1e-3)
    assert scaled.b == pytest.approx(base.b, rel=1e-3)


def test_a_zero_prediction_under_a_large_residual_does_not_overflow():
    r, f = mixed_residuals()
    f[::50] = 0.0  # the model predicts 0 there (a lobe that underflows, kd = 0)
    r = r * 1e5
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        noise = estimate(r, f)
    assert np.isfinite(noise.a) and noise.a > 0 and np.isfinite(noise.b)
    sigma = noise.sigma(f)
    assert np.isfinite(sigma).all() and (sigma > 0).all()


def scaled_ward(scale: float) -> Measurements:
    m = brdffit.read(WARD)
    return Measurements(m.wi, m.wo, m.values * scale, channels=m.channels)


@pytest.mark.parametrize("scale", [100.0, 1e4, 1e10, 1e20, 1e60, 1e99])
def test_data_far_beyond_the_model_are_said_in_words(scale):
    data = scaled_ward(scale)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = brdffit.fit(data, "ward")
    # (percent data are refitted with the log loss on their misfit: no a, b then)
    assert all(result.noise[k] is None or np.isfinite(result.noise[k]) for k in "ab")
    for name, value in result.params.items():
        assert np.isfinite(value).all(), name
    top = float(np.max(data.values))
    message = result.message
    assert "far beyond what ward can reach" in message, message
    assert f"{top:.3g}" in message and "kd <= 1" in message and "ks <= 10" in message
    assert "rescale" in message and "percent" in message
    assert {"kd", "ks"} & set(result.at_bounds)
    assert result.to_dict()["message"] == message


def test_ordinary_data_get_no_such_note():
    data = scaled_ward(1.0)
    result = brdffit.fit(data, "ward")
    assert "far beyond" not in result.message
    # and data 3 times larger, still within the model's bounds (kd <= 1 of 0.3):
    result = brdffit.fit(scaled_ward(3.0), "ward")
    assert "far beyond" not in result.message, result.message


def test_a_coefficient_at_its_lower_bound_is_not_beyond_reach():
    # Cornell's garnet_red: ward puts kd at 0 and its median 3.1 times under the data.
    data = brdffit.read(shared_file("cornell", "garnet_red.astm"))
    result = brdffit.fit(data, "ward")
    assert "kd" in result.at_bounds
    assert "far beyond" not in result.message, result.message


def test_the_note_needs_the_data_far_above_the_prediction():
    data = scaled_ward(1e10)
    result = brdffit.fit(data, "ward", loss="l2")
    assert "far beyond" in result.message  # l2 too: the bound reached, the data far above
    model = brdffit.get_model("ward")
    from brdffit.fitting.result import beyond_reach

    pred = np.full(data.values.shape, float(np.max(data.values)) / FAR * 1.01)
    assert beyond_reach(model, result.params, ("kd", "ks"), data.values, pred) == ""
    assert beyond_reach(model, result.params, (), data.values, pred / 10) == ""
    assert beyond_reach(model, result.params, ("ks",), data.values, pred / 10)
    # kd and ks at 0 (their lower bounds) under the same data: only a prediction of 0
    # everywhere is beyond reach then.
    low = {**result.params, "kd": 0 * result.params["kd"], "ks": 0 * result.params["ks"]}
    assert beyond_reach(model, low, ("kd", "ks"), data.values, pred / 10) == ""
    assert beyond_reach(model, low, ("kd", "ks"), data.values, 0 * pred)


def test_a_bad_noise_sigma_says_what_to_do():
    data = scaled_ward(1.0)
    problem = Problem(data, "ward", loss="mixed")
    with pytest.raises(FitError) as info:
        problem.reweighted(np.full(data.values.shape, np.inf))
    text = str(info.value)
    assert "ward" in text and "rescale" in text and "loss='l2'" in text
    assert f"{float(np.max(data.values)):.3g}" in text
