"""A linear coefficient fixed per channel (one value a channel) in the posterior's
designs (brdffit.posterior.design.assemble): each channel as if fitted alone."""

from __future__ import annotations

import numpy as np
import pytest

from brdffit import Measurements, get_model, kernels
from brdffit.fitting.problem import Problem
from brdffit.posterior.target import Target


def ward_data(channels: int, seed: int = 4, n: int = 400) -> Measurements:
    rng = np.random.default_rng(seed)
    theta = np.degrees(np.arccos(rng.uniform(0.1, 1.0, (2, n))))
    phi = rng.uniform(0.0, 360.0, (2, n))
    probe = Measurements.from_angles(theta[0], phi[0], theta[1], phi[1], np.zeros(n))
    f = get_model("ward").evaluate(probe.wi, probe.wo, {"kd": 0.2, "ks": 0.5, "alpha": 0.2})
    values = f[:, None] * np.linspace(0.6, 1.0, channels) + 0.01 * rng.normal(size=(n, channels))
    sigma = np.full((n, channels), 0.01)
    return Measurements.from_angles(theta[0], phi[0], theta[1], phi[1], values, sigma=sigma)


def target_of(data, kd) -> Target:
    problem = Problem(data, get_model("ward"), loss="chi2", fixed={"kd": kd})
    return Target(problem, "given", problem.x_from_params({"ks": 0.5, "alpha": 0.2}))


@pytest.mark.parametrize("compiled", [False, True])
def test_a_coefficient_fixed_per_channel_is_each_channels_own(compiled):
    """kd fixed per channel: with the noise given, the log-density is the sum of the
    channels' own, each with its kd fixed to one number, and the least-squares ks the
    channel's own. The constant column times (C,) values made a (C,) offset, read as
    (M,): a ValueError from broadcasting before, in every posterior of such a fit."""
    if compiled and not kernels.available():
        pytest.skip("numba is not installed")
    data, kd = ward_data(3), [0.12, 0.2, 0.25]
    points = np.log10([[0.15], [0.2], [0.3]])
    with kernels.use(compiled):
        target = target_of(data, kd)
        total = target.log_prob(points)
        beta_all = target._stats(target.shape_values(points))[2]
        draws = target.draw_coefficients(points, np.random.default_rng(3))
        parts = []
        for c, name in enumerate(data.channels):
            alone = target_of(data.select_channels([name]), kd[c])
            parts.append(alone.log_prob(points))
            beta = alone._stats(alone.shape_values(points))[2]
            np.testing.assert_allclose(beta_all[:, c], beta[:, 0], rtol=1e-12)
    np.testing.assert_allclose(total, np.sum(parts, axis=0), rtol=1e-12)
    assert draws.shape == (3, 3, 1) and np.isfinite(draws).all()
