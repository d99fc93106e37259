"""The posterior of a fit without sigma uses the fit's noise model (issue 12).

Data with mixed noise, ``sigma^2 = a^2 + (b f)^2``, and no sigma column: the
default fit estimates ``a`` and ``b``, and the posterior's 68 % intervals must
cover the truth 68 +/- 7 % of the time. Small datasets (300 samples) and short
fixed chains keep the 60 datasets to about 10 s. With the old default (an l2
fit, one constant absolute noise) the intervals are far too narrow where the
signal is large and too wide where it is small.
"""

from __future__ import annotations

import numpy as np
import pytest
from helpers import mirror_biased_pairs

import brdffit
from brdffit.data.measurements import Measurements

TRUTH = {"kd": 0.2, "ks": 0.4, "alpha": 0.15}
A, B = 0.003, 0.05
DATASETS = 60


def mixed_noise_data(seed: int, n: int = 300) -> Measurements:
    wi, wo = mirror_biased_pairs(n, 1000 + seed)
    f = np.asarray(brdffit.get_model("ward").evaluate(wi, wo, TRUTH)).reshape(n, -1)
    rng = np.random.default_rng(seed)
    return Measurements(wi, wo, f + np.sqrt(A**2 + (B * f) ** 2) * rng.standard_normal(f.shape))


def coverage(**fit_options) -> float:
    hits = []
    for seed in range(DATASETS):
        result = brdffit.fit(
            mixed_noise_data(seed),
            "ward",
            uncertainty=True,
            posterior_options={"walkers": 16, "steps": 200, "seed": seed},
            **fit_options,
        )
        summary = result.posterior.summary
        hits += [summary[k]["p16"] <= v <= summary[k]["p84"] for k, v in TRUTH.items()]
    return float(np.mean(hits))


def test_intervals_of_the_default_cover_the_truth_68_percent_of_the_time():
    assert abs(coverage() - 0.68) <= 0.07


def test_the_posterior_uses_the_fits_noise_model():
    result = brdffit.fit(
        mixed_noise_data(0), "ward", uncertainty=True,
        posterior_options={"walkers": 16, "steps": 200},
    )  # fmt: skip
    post = result.posterior
    assert result.loss_name == "mixed" and post.noise == "mixed"
    # The sampled noise is the multiple of the fitted model: near 1.
    assert post.summary["noise"]["median"] == pytest.approx(1.0, abs=0.15)
    assert "sigma^2 = a^2 + (b f)^2" in post.noise_meaning


def test_a_misfit_marks_the_posterior_conditional_on_the_model():
    """Data of a two-lobe material fitted with one lobe."""
    wi, wo = mirror_biased_pairs(2000, 5)
    truth = {"lambert.kd": 0.2, "ward_1.ks": 0.3, "ward_1.alpha": 0.05,
             "ward_2.ks": 0.3, "ward_2.alpha": 0.4}  # fmt: skip
    f = np.asarray(brdffit.get_model("lambert+ward+ward").evaluate(wi, wo, truth))
    y = f.reshape(len(f), -1) * (1 + 0.01 * np.random.default_rng(0).standard_normal((len(f), 1)))
    result = brdffit.fit(
        Measurements(wi, wo, y), "ward", uncertainty=True,
        posterior_options={"walkers": 16, "steps": 100},
    )  # fmt: skip
    assert result.misfit["detected"], result.misfit
    assert "MISFIT" in result.message
    assert "CONDITIONAL ON THE MODEL" in result.posterior.message
