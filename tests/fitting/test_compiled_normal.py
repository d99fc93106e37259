"""The variable projection's normal equations from one compiled pass
(brdffit.kernels.normal) equal those of the stacked design matrix."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import (  # noqa: F401 (the fixture)
    NEEDS_KERNELS,
    compiled_for_every_size,
    make_data,
    rgb_data,
    solve_both,
)

from brdffit import kernels
from brdffit.fitting.problem import Problem
from brdffit.fitting.solve import compiled_normal

pytestmark = [NEEDS_KERNELS, pytest.mark.usefixtures("compiled_for_every_size")]


def _assert_the_same_solutions(problem: Problem, seed: int):
    """Compiled and stacked normal equations give the same solution at 5 random shapes."""
    rng = np.random.default_rng(seed)
    for _ in range(5):
        x = rng.uniform(problem.lower, problem.upper)
        compiled, stacked = solve_both(problem, x)
        np.testing.assert_allclose(compiled.coefs, stacked.coefs, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(compiled.loss, stacked.loss, rtol=1e-9)


@pytest.mark.parametrize(
    ("model", "weights"),
    [("ggx", None), ("cook_torrance", "samples"), ("blinn", None), ("lambert", None)],
)
def test_compiled_normal_equations_give_the_stacked_solution(model, weights):
    data = rgb_data(model, 3000, 5, 0.02)
    w = None if weights is None else np.random.default_rng(2).uniform(0.2, 3.0, data.n)
    problem = Problem(data, model, weights=w)
    _assert_the_same_solutions(problem, 9)


@pytest.mark.parametrize("model", ["ggx", "ward", "blinn"])
def test_weights_per_channel_give_the_stacked_solution(model):
    """The mixed loss weighs every value by its own sigma: (M, C) weights. Their normal
    equations are now built by the compiled pass too (they fell back to the stacked
    design, 5 ms a step on a MERL file)."""
    data = rgb_data(model, 3000, 6, 0.02)
    noise = np.random.default_rng(4).uniform(0.01, 0.2, (data.n, 3))
    problem = Problem(data, model, loss="mixed", noise_sigma=noise)
    assert problem.linearisation()[0].shape == (data.n, 3)
    with kernels.use(True):
        cols = problem.model.design(problem.geometry, problem.shape_from_x(problem.lower))
        assert compiled_normal(problem, list(cols.columns), None) is not None
    _assert_the_same_solutions(problem, 10)


def test_the_compiled_pass_is_taken_only_where_it_applies():
    data = rgb_data("ggx", 2000, 1, 0.02)
    m = data.n
    assert compiled_normal(Problem(data, "ggx"), [1.0, np.ones(m)], None) is not None
    # a non-quadratic loss, an offset, or two array columns: the stacked design
    assert compiled_normal(Problem(data, "ggx", loss="log"), [1.0, np.ones(m)], None) is None
    offset = np.zeros((m, 3))
    assert compiled_normal(Problem(data, "ggx"), [1.0, np.ones(m)], offset) is None
    assert compiled_normal(Problem(data, "ggx"), [np.ones(m)] * 2, None) is None
