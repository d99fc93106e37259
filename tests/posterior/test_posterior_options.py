"""The posterior's ``max_seconds`` and the fit's ``timeout`` take the same values.

Both are a positive number of seconds, with ``inf`` (and None) meaning no limit.
Before, ``max_seconds=inf`` was refused while ``timeout=inf`` was taken, so
``fit(..., timeout=inf, uncertainty=True, posterior_options={"max_seconds": None})``
failed: the fit hands the posterior what its timeout leaves, here ``inf``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdffit import FitError, fit, sample_posterior, synthesize

POSTERIOR = {"steps": 40, "walkers": 16, "seed": 2}


@pytest.fixture(scope="module")
def fitted():
    data = synthesize("blinn", {"kd": 0.2, "ks": 0.5, "n": 30}, noise=0.02, seed=1)
    return data, fit(data, "blinn", seed=1)


def test_infinite_max_seconds_is_no_limit(fitted):
    data, result = fitted
    unlimited = sample_posterior(data, result, max_seconds=math.inf, **POSTERIOR)
    none = sample_posterior(data, result, max_seconds=None, **POSTERIOR)
    np.testing.assert_array_equal(unlimited.samples, none.samples)
    assert "time limit" not in unlimited.message


def test_a_fit_without_a_time_limit_samples_its_posterior(fitted):
    data, _ = fitted
    options = POSTERIOR | {"max_seconds": None}
    result = fit(data, "blinn", seed=1, timeout=math.inf, uncertainty=True,
                 posterior_options=options)  # fmt: skip
    assert result.posterior is not None and result.posterior.samples.shape[1] >= 3


@pytest.mark.parametrize("value", [0, -1.0, math.nan, -math.inf, "10", True])
def test_bad_time_limits_are_refused_alike(fitted, value):
    data, result = fitted
    with pytest.raises(
        FitError, match=f"timeout={value!r} must be a positive number"
    ) as fit_error:
        fit(data, "blinn", timeout=value)
    assert fit_error.value.field == "timeout"
    with pytest.raises(FitError, match="must be a positive number of seconds") as post_error:
        sample_posterior(data, result, max_seconds=value, **POSTERIOR)
    assert post_error.value.field == "max_seconds"
    assert f"max_seconds={value!r}" in str(post_error.value)
