"""The misfit check's residuals and log-likelihood formed by blocks of samples equal
the whole-array formulas (brdffit.fitting.misfit.BLOCK)."""

import numpy as np
import pytest
from helpers import make_data

from brdffit.fitting import misfit
from brdffit.fitting.noise import NoiseModel
from brdffit.fitting.problem import Problem


@pytest.mark.parametrize("weighted", [False, True])
def test_blocks_give_the_whole_arrays_values(monkeypatch, weighted):
    data = make_data("ward", {"kd": 0.1, "ks": 0.3, "alpha": 0.12}, n=1000, seed=3)
    weights = np.linspace(0.5, 2.0, data.n) if weighted else None
    problem = Problem(data, "ward", loss="mixed", weights=weights)
    params = {"kd": 0.11, "ks": 0.28, "alpha": 0.13}
    noise = NoiseModel(a=0.002, b=0.03)
    pred = problem.predict(params)
    y = np.asarray(data.values, dtype=float)
    sigma = np.sqrt(noise.a**2 + (noise.b * pred) ** 2)
    want_z = (pred - y) / sigma
    want = np.log(2 * np.pi * sigma**2) + want_z**2
    if weighted:
        want = want * problem.user_weights[:, None]
    monkeypatch.setattr(misfit, "BLOCK", 64)  # 16 blocks, the last one short
    z, keep = misfit.standardised(problem, params, noise)
    np.testing.assert_allclose(z, want_z, rtol=1e-14)
    assert keep.all()
    got = misfit._minus_two_log_likelihood(problem, params, noise, z, 0.0)
    assert got == pytest.approx(float(want.sum()), rel=1e-13)
