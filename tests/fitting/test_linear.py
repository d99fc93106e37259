"""The bounded least-squares solver of variable projection, against scipy's BVLS."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import lsq_linear

from brdffit.fitting.linear import MAX_ENUMERATED, normal_equations, solve_bounded


@pytest.mark.parametrize("k", [1, 2, 3, 4, MAX_ENUMERATED + 1])
@pytest.mark.parametrize("weighted", ["none", "per_sample", "per_channel"])
def test_solution_matches_scipy_bvls(k, weighted):
    rng = np.random.default_rng(k * 10 + len(weighted))
    for _ in range(20):
        m, c = 40, 3
        a = rng.normal(size=(m, k))
        y = rng.normal(size=(m, c))
        w = {
            "none": None,
            "per_sample": rng.uniform(0.2, 3, m),
            "per_channel": rng.uniform(0.2, 3, (m, c)),
        }[weighted]
        lower = np.zeros(k)
        upper = np.where(rng.uniform(size=k) < 0.5, rng.uniform(0.05, 1.0, k), np.inf)
        x, rss = solve_bounded(normal_equations(a, y, w), lower, upper)
        for ch in range(c):
            sw = np.ones(m) if w is None else np.sqrt(w if w.ndim == 1 else w[:, ch])
            ref = lsq_linear(a * sw[:, None], y[:, ch] * sw, bounds=(lower, upper), method="bvls")
            ref_rss = float(np.sum(((a @ ref.x - y[:, ch]) * sw) ** 2))
            own_rss = float(np.sum(((a @ x[ch] - y[:, ch]) * sw) ** 2))
            assert (x[ch] >= lower).all() and (x[ch] <= upper).all()
            assert own_rss <= ref_rss * (1 + 1e-9) + 1e-12
            np.testing.assert_allclose(rss[ch], own_rss, rtol=1e-8, atol=1e-10)


def test_per_channel_columns():
    """Columns that differ per channel (wavelength-dependent models) give each channel
    its own least-squares problem."""
    rng = np.random.default_rng(3)
    m, k, c = 30, 2, 4
    a = np.abs(rng.normal(size=(m, k, c)))
    truth = rng.uniform(0.1, 1.0, (c, k))
    y = np.einsum("mkc,ck->mc", a, truth)
    x, rss = solve_bounded(normal_equations(a, y, None), np.zeros(k), np.full(k, np.inf))
    np.testing.assert_allclose(x, truth, rtol=1e-9)
    # The RSS comes from the normal equations (x'Gx - 2x'b + y'y): its absolute
    # error is round-off of y'y, documented in brdffit.fitting.linear.
    assert (rss <= 1e-13 * np.sum(y * y, axis=0)).all()


def test_collinear_columns_do_not_fail():
    a = np.ones((10, 2))
    y = np.full((10, 1), 2.0)
    x, rss = solve_bounded(normal_equations(a, y, None), np.zeros(2), np.full(2, np.inf))
    assert np.isfinite(x).all() and x.sum() == pytest.approx(2.0, rel=1e-6)
    assert rss[0] == pytest.approx(0.0, abs=1e-9)


def test_general_inequality_constraints_match_a_qp_solver():
    """With a row ``x0 + x1 <= 1`` (Ashikhmin-Shirley's triangle) the solution is the
    constrained optimum, checked against scipy's SLSQP on the same quadratic."""
    from scipy.optimize import minimize

    rng = np.random.default_rng(5)
    constraints = (np.array([[1.0, 1.0]]), np.array([1.0]))
    lower, upper = np.zeros(2), np.ones(2)
    for _ in range(30):
        a = np.abs(rng.normal(size=(25, 2)))
        y = a @ rng.uniform(0.2, 1.2, (2, 2)) + 0.05 * rng.normal(size=(25, 2))
        x, rss = solve_bounded(normal_equations(a, y, None), lower, upper, constraints)
        for ch in range(2):
            assert x[ch].sum() <= 1 + 1e-9 and (x[ch] >= 0).all() and (x[ch] <= 1).all()
            ref = minimize(
                lambda v, a=a, t=y[:, ch]: np.sum((a @ v - t) ** 2),
                x0=[0.3, 0.3],
                bounds=[(0, 1), (0, 1)],
                constraints=[{"type": "ineq", "fun": lambda v: 1 - v.sum()}],
                method="SLSQP",
                options={"ftol": 1e-14, "maxiter": 500},
            )
            assert rss[ch] <= ref.fun * (1 + 1e-7) + 1e-12
