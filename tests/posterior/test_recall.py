"""The run's points kept for the coefficient draws (brdffit.posterior.recall): found
bitwise, within the budget, and draws from them equal to draws recomputed."""

from __future__ import annotations

import numpy as np

from brdffit import Measurements, fit, get_model
from brdffit.fitting.problem import Problem
from brdffit.posterior.recall import Recall
from brdffit.posterior.target import Target


def test_find_returns_each_kept_row_and_marks_the_others():
    rng = np.random.default_rng(0)
    recall = Recall()
    points = [rng.normal(size=(5, 3)) for _ in range(3)]
    for i, p in enumerate(points):
        recall.add(p, np.full((5, 2, 2), float(i)), np.full((5, 2, 2, 2), 10.0 + i))
    query = np.vstack([points[2][1], rng.normal(size=3), points[0][4], points[1][0] + 1e-16])
    found, beta, inv = recall.find(query)
    assert found.tolist() == [True, False, True, False]
    assert (beta[0] == 2).all() and (inv[0] == 12).all()
    assert (beta[2] == 0).all() and (inv[2] == 10).all()


def test_nothing_is_kept_past_the_budget():
    recall = Recall(budget=100)
    recall.add(np.zeros((4, 2)), np.zeros((4, 1, 2)), np.zeros((4, 1, 2, 2)))  # 32 numbers
    recall.add(np.ones((4, 2)), np.zeros((4, 1, 2)), np.zeros((4, 1, 2, 2)))  # 64
    recall.add(np.full((4, 2), 2.0), np.zeros((4, 1, 2)), np.zeros((4, 1, 2, 2)))  # 96
    recall.add(np.full((1, 2), 3.0), np.zeros((1, 1, 2)), np.zeros((1, 1, 2, 2)))  # past 100
    assert recall.size == 96
    found, _, _ = recall.find(np.array([[1.0, 1.0], [3.0, 3.0]]))
    assert found.tolist() == [True, False]


def test_draws_from_the_recall_are_the_draws_recomputed():
    rng = np.random.default_rng(2)
    n = 400
    theta = np.degrees(np.arccos(rng.uniform(0.1, 1.0, (2, n))))
    phi = rng.uniform(0.0, 360.0, (2, n))
    probe = Measurements.from_angles(theta[0], phi[0], theta[1], phi[1], np.zeros(n))
    f = get_model("ward").evaluate(probe.wi, probe.wo, {"kd": 0.2, "ks": 0.5, "alpha": 0.2})
    data = Measurements.from_angles(
        theta[0], phi[0], theta[1], phi[1], f + 0.01 * rng.normal(size=n), sigma=np.full(n, 0.01)
    )
    result = fit(data, "ward", loss="chi2")
    problem = Problem(data, result.model, loss="chi2")
    target = Target(problem, "given", problem.x_from_params(result.params))
    points = problem.x_from_params(result.params) + rng.normal(0, 0.02, (100, 1))
    target.recall = Recall()
    target.log_prob(points[:70])  # evaluated: 70 of the 100 kept, 30 not
    recalled = target.draw_coefficients(points, np.random.default_rng(9))
    target.recall = None
    computed = target.draw_coefficients(points, np.random.default_rng(9))
    np.testing.assert_allclose(recalled, computed, rtol=1e-12, atol=1e-15)
