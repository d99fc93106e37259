"""Draws of a Gaussian restricted to a box and half-spaces (posterior_truncated)."""

from __future__ import annotations

import numpy as np

from brdffit.posterior.truncnorm import draw_box_gaussian


def test_draws_obey_a_single_half_space_with_two_coefficients():
    """Ashikhmin-Shirley's triangle rd_eff + rs <= 1: one row, two coefficients
    (the start of the Gibbs sweeps once multiplied rows the wrong way round)."""
    rng = np.random.default_rng(0)
    mean = np.array([[0.9, 0.9], [2.0, -1.0], [0.2, 0.3]])  # outside, outside, inside
    cov = np.broadcast_to(np.diag([0.01, 0.02]), (3, 2, 2)).copy()
    rows, bounds = np.array([[1.0, 1.0]]), np.array([1.0])
    lower, upper = np.zeros(2), np.ones(2)
    draws = np.stack([draw_box_gaussian(mean, cov, lower, upper, rng, rows, bounds, tries=2)
                      for _ in range(200)])  # fmt: skip
    assert np.all(draws >= 0) and np.all(draws <= 1)
    assert np.all(draws.sum(axis=-1) <= 1 + 1e-12)
    # The inside mean is barely affected by the constraint: its draws centre on it.
    np.testing.assert_allclose(draws[:, 2].mean(axis=0), [0.2, 0.3], atol=0.03)
