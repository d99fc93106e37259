"""The variable-projection objective (brdffit.fitting.problem.Problem): finite
everywhere, safe to share between threads, and bounded by what the models declare."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest
from helpers import make_data, random_params

import brdffit.fitting.solve as solve_module
from brdffit import get_model, synthesize
from brdffit.fitting.problem import BAD_LOSS, Problem
from brdffit.models import REGISTRY


@pytest.mark.parametrize("name", sorted(REGISTRY))
def test_objective_is_finite_everywhere_in_the_search_box(name):
    """nlopt must never see NaN: the objective at the corners and random points of
    the box is finite for every registered model."""
    model = get_model(name)
    rng = np.random.default_rng(11)
    data = make_data(name, random_params(model, rng), n=200, noise=0.01)
    problem = Problem(data, model)
    points = [problem.lower, problem.upper, problem.x_from_params(model.defaults())]
    points += [rng.uniform(problem.lower, problem.upper) for _ in range(20)]
    for x in points:
        loss = problem.solve(x).loss
        assert np.isfinite(loss) and loss >= 0, (name, x)


def bright_phong_problem() -> Problem:
    """An energy-conserving phong problem on data brighter than albedo 1: its
    albedo rows bind, and differ with the exponent."""
    truth = {"kd": [0.8, 0.6, 0.5], "ks": [3.0, 1.0, 2.0], "n": 5.0}
    data = synthesize("phong", truth, geometry="hemisphere", n=300, seed=4, channels=list("rgb"))
    return Problem(data, "phong", energy_conserving=True)


def test_a_problem_shared_by_two_threads_gives_the_single_threaded_answers(monkeypatch):
    """Two threads solve the same Problem at different shapes (so with different
    albedo rows) while a slow step in the middle of each solve lets the other thread
    run. Every answer equals the one-thread answer at that shape. (A Problem that
    kept the rows of a call on itself, for a later method to read, solved one
    thread's shape under the other's rows.)"""
    problem = bright_phong_problem()
    points = [problem.x_from_params({"n": 2.0}), problem.x_from_params({"n": 40.0})]
    expected = [problem.solve(x) for x in points]
    assert not np.allclose(expected[0].coefs, expected[1].coefs)
    rows = [problem.energy.rows(problem.shape_from_x(x)) for x in points]
    assert not np.allclose(rows[0][0], rows[1][0])  # the two calls' constraints differ
    real = solve_module.normal_equations

    def slow(*args, **kwargs):
        time.sleep(0.002)  # releases the GIL: the other thread runs here
        return real(*args, **kwargs)

    monkeypatch.setattr(solve_module, "normal_equations", slow)
    found: list[list] = [[], []]

    def work(i: int):
        for _ in range(15):
            found[i].append(problem.solve(points[i]))

    threads = [threading.Thread(target=work, args=(i,)) for i in (0, 1)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for i in (0, 1):
        assert len(found[i]) == 15
        for sol in found[i]:
            assert sol.loss == expected[i].loss
            assert np.array_equal(sol.coefs, expected[i].coefs)


def test_sums_of_lobes_keep_their_components_coefficient_bounds_and_rows():
    """lambert + ashikhmin_shirley: the sum declares the bounds [0, 1] of
    ashikhmin_shirley's rd_eff and rs and its row rd_eff + rs <= 1 (through the
    public Model.coefficient_ranges / coefficient_constraints), and the solved
    coefficients of data brighter than that obey them."""
    name = "lambert+ashikhmin_shirley"
    model = get_model(name)
    part = get_model("ashikhmin_shirley")
    assert model.coefficient_ranges[1:] == part.coefficient_ranges
    assert model.coefficient_ranges[0] == get_model("lambert").coefficient_ranges[0]
    ((row, bound),) = model.coefficient_constraints
    assert row == (0.0, *part.coefficient_constraints[0][0]) and bound == 1.0
    truth = {"lambert.kd": 0.1, "ashikhmin_shirley.rd": 0.7, "ashikhmin_shirley.rs": 0.3}
    truth |= {"ashikhmin_shirley.nu": 40.0, "ashikhmin_shirley.nv": 40.0}
    data = synthesize(name, truth, geometry="hemisphere", n=400, seed=5)
    data = type(data)(data.wi, data.wo, 2.5 * data.values, channels=data.channels)
    problem = Problem(data, name)
    np.testing.assert_array_equal(problem.coef_upper, [1.0, 1.0, 1.0])
    sol = problem.solve(problem.x_from_params(truth))
    kd, rd_eff, rs = sol.coefs[0]
    assert sol.loss < BAD_LOSS and 0 <= kd <= 1 and 0 <= rs <= 1
    assert rd_eff + rs <= 1 + 1e-12
    assert rd_eff + rs > 1 - 1e-6  # the bright data hold them on the row


@pytest.mark.parametrize("weights", [None, "uniform", "varying"])
def test_the_l2_targets_are_those_of_its_linearisation(weights):
    """The l2 loss's weights and targets, taken as they are (t(f) = f), equal those
    of the generic Gauss-Newton linearisation."""
    from brdffit.fitting.solve import compact_weights

    ward_data = make_data("ward", {"kd": 0.1, "ks": 0.3, "alpha": 0.12}, n=800, seed=1)
    u = {None: None, "uniform": np.full(ward_data.n, 2.0),
         "varying": np.linspace(0.5, 2.0, ward_data.n)}[weights]  # fmt: skip
    problem = Problem(ward_data, "ward", loss="l2", weights=u)
    w, z = compact_weights(*problem.loss.linearised(problem.y, problem.ctx))
    assert (problem.linearisation()[0] is None) == (w is None) == (weights != "varying")
    if w is not None:
        np.testing.assert_array_equal(problem.linearisation()[0], w)
    np.testing.assert_array_equal(problem.linearisation()[1], z)


def test_a_problem_makes_its_first_pass_once_and_lets_it_go_after_the_search():
    """The compiled normal equations' inputs are made once per problem (a fit solves
    the same targets thousands of times), without keeping the linearisation's own
    arrays, and go with :meth:`Problem.let_go` (a later solve makes them again)."""
    data = synthesize("blinn", {"kd": 0.2, "ks": 0.5, "n": 40.0}, noise=0.01, seed=1)
    problem = Problem(data, "blinn", loss="cosine")
    first = solve_module.first_pass(problem)
    assert solve_module.first_pass(problem) is first
    assert problem._linearised is None  # the (M, C) linearisation itself is not kept
    problem.let_go()
    again = solve_module.first_pass(problem)
    assert again is not first
    for a, b in zip(first[0] + (first[1],), again[0] + (again[1],)):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("name", ["log", "cbrt", "cosine", "mixed"])
@pytest.mark.parametrize("weighted", [False, True])
def test_the_linearisation_in_place_equals_its_formula(name, weighted):
    """The Gauss-Newton weights and targets, formed in the transform's own arrays,
    are bit for bit ``dt^2 u`` and ``ref - (t(ref) - t(y)) / dt``; the prediction,
    the data and the cached t(y) are left as they were; at the data the target is
    the data."""
    from brdffit.fitting.losses import LossContext, get_loss

    rng = np.random.default_rng(3)
    y = rng.uniform(0.0, 2.0, (500, 3))
    ctx = LossContext(
        cos_i=rng.uniform(0.05, 1.0, 500),
        y=y,
        sigma=None,
        weights=rng.uniform(0.5, 2.0, 500) if weighted else None,
        noise_sigma=rng.uniform(0.1, 1.0, (500, 3)),
    )
    loss = get_loss(name)
    ref = y * rng.uniform(0.8, 1.2, y.shape)
    before, y_before, target = ref.copy(), y.copy(), loss.target(ctx).copy()
    w, z = loss.linearised(ref, ctx)
    dt = np.broadcast_to(loss.derivative(ref, ctx), y.shape)
    u = 1.0 if ctx.weights is None else ctx.weights[:, None]
    np.testing.assert_array_equal(w, dt * dt * u)
    if not loss.linear:
        np.testing.assert_array_equal(z, ref - (loss.transform(ref, ctx) - target) / dt)
    np.testing.assert_array_equal(ref, before)
    np.testing.assert_array_equal(y, y_before)
    np.testing.assert_array_equal(loss.target(ctx), target)
    w, z = loss.linearised(ctx.y, ctx)
    assert z is ctx.y
    dt = np.broadcast_to(loss.derivative(y, ctx), y.shape)
    np.testing.assert_array_equal(w, dt * dt * u)
