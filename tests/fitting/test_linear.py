"""The bounded, linearly constrained least-squares solver of variable projection,
against scipy's BVLS and SLSQP and an exact enumeration of active sets."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.optimize import lsq_linear, minimize, nnls

from brdffit.fitting.linear import (
    MAX_ENUMERATED,
    normal_equations,
    offset_normal,
    solve_bounded,
    weighted_target,
)


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


def _brute_force(a, y, lower, upper, rows, bounds):
    """The exact optimum of a small convex QP: for every set of at most K linearly
    independent active inequalities, the KKT system of the equality-constrained
    problem; the best feasible stationary point is the global minimum."""
    k = a.shape[1]
    finite = np.isfinite(upper)
    d = np.vstack([-np.eye(k), np.eye(k)[finite], rows])
    e = np.concatenate([-lower, upper[finite], bounds])
    gram, rhs = a.T @ a, a.T @ y
    best, best_x = np.inf, None
    for size in range(k + 1):
        for active in itertools.combinations(range(len(d)), size):
            da = d[list(active)]
            if size and np.linalg.matrix_rank(da) < size:
                continue
            kkt = np.block([[gram, da.T], [da, np.zeros((size, size))]])
            try:
                x = np.linalg.solve(kkt, np.concatenate([rhs, e[list(active)]]))[:k]
            except np.linalg.LinAlgError:
                continue
            value = float(np.sum((a @ x - y) ** 2))
            if (d @ x <= e + 1e-10).all() and value < best:
                best, best_x = value, x
    return best, best_x


def _random_problem(rng, k, n_rows, m=30, c=2):
    a = np.abs(rng.normal(size=(m, k)))
    y = a @ rng.uniform(-0.5, 2.0, (k, c)) + 0.1 * rng.normal(size=(m, c))
    upper = np.where(rng.uniform(size=k) < 0.5, rng.uniform(0.3, 2.0, k), np.inf)
    rows = rng.uniform(-0.2, 1.0, (n_rows, k))
    bounds = rng.uniform(0.3, 2.0, n_rows)
    return a, y, np.zeros(k), upper, rows, bounds


@pytest.mark.parametrize("seed", range(4))
def test_constrained_solution_is_the_exact_optimum_of_small_problems(seed):
    """Random problems with 1 to 4 coefficients, up to 3 rows besides the bounds,
    some with (nearly) collinear columns: the solution obeys every bound and row,
    and its residual is the exact optimum's (enumerated in the test)."""
    rng = np.random.default_rng(seed)
    for trial in range(25):
        k = int(rng.integers(1, 5))
        a, y, lower, upper, rows, bounds = _random_problem(rng, k, int(rng.integers(0, 4)))
        if k > 1 and trial % 3 == 0:
            a[:, 1] = a[:, 0] * (1 + (trial % 2) * 1e-9 * rng.normal(size=len(a)))
        constraints = (rows, bounds) if len(rows) else None
        x, rss = solve_bounded(normal_equations(a, y, None), lower, upper, constraints)
        for ch in range(y.shape[1]):
            best, _ = _brute_force(a, y[:, ch], lower, upper, rows, bounds)
            own = float(np.sum((a @ x[ch] - y[:, ch]) ** 2))
            assert (x[ch] >= lower).all() and (x[ch] <= upper).all()
            assert (rows @ x[ch] <= bounds * (1 + 1e-9)).all(), (trial, rows @ x[ch] - bounds)
            assert own <= best * (1 + 1e-9) + 1e-12, (trial, own, best)
            np.testing.assert_allclose(rss[ch], own, rtol=1e-8, atol=1e-10)


def _multipliers(a, t, x, rows, bounds):
    """Karush-Kuhn-Tucker multipliers of ``min |a x - t|^2`` s.t. ``rows x <= bounds``,
    ``x >= 0`` at ``x``: non-negative weights of the active constraints' normals that
    cancel the gradient (non-negative least squares), the stationarity residual, and
    the constraints as ``g(z) <= 0`` functions of a point ``z``."""
    grad = 2 * a.T @ (a @ x - t)
    normals = np.vstack([rows, -np.eye(len(x))])

    def g(z):
        return np.concatenate([rows @ z - bounds, -z])

    active = g(x) >= -1e-9 * np.concatenate([bounds, np.ones(len(x))])
    mu, residual = np.zeros(len(normals)), np.linalg.norm(grad)
    if active.any():  # (scipy's nnls aborts the process on a matrix with no column)
        mu[active], residual = nnls(normals[active].T, -grad)
    return mu, residual / (np.linalg.norm(grad) + np.linalg.norm(2 * a.T @ t)), g


@pytest.mark.parametrize("k", [6, 8, 10])
def test_rows_are_honoured_with_many_coefficients(k):
    """Six or more coefficients (a sum of lobes) with 18 non-negative rows, like the
    albedo rows of an energy-conserving fit, on data that break them: every row
    holds, the solution is optimal (its KKT multipliers exist: the gradient is a
    non-negative sum of the active constraints' normals), and no SLSQP run from two
    starts does better than duality allows for its own violation of the rows,
    ``f(z) >= f(x*) - sum(mu * max(g(z), 0))``. (The enumeration solver this
    replaced ignored the rows above 5 coefficients. SLSQP ends up to 1e-8 outside
    the rows, which alone lowers its residual by 1e-9 relative.)"""
    rng = np.random.default_rng(k)
    m, c = 80, 3
    a = np.abs(rng.normal(size=(m, k)))
    y = a @ rng.uniform(0.2, 1.5, (k, c)) + 0.05 * rng.normal(size=(m, c))
    rows = rng.uniform(0.05, 0.5, (18, k))
    bounds = rng.uniform(0.6, 1.0, (c, 18))
    lower, upper = np.zeros(k), np.full(k, np.inf)
    x, rss = solve_bounded(normal_equations(a, y, None), lower, upper, (rows, bounds))
    for ch in range(c):
        assert (x[ch] >= 0).all()
        assert (rows @ x[ch] <= bounds[ch] * (1 + 1e-9)).all()
        assert (rows @ x[ch] > bounds[ch] * (1 - 1e-6)).any()  # the data pushed on a row
        mu, stationarity, g = _multipliers(a, y[:, ch], x[ch], rows, bounds[ch])
        assert stationarity < 1e-9, stationarity
        own = float(np.sum((a @ x[ch] - y[:, ch]) ** 2))
        for start in (np.zeros(k), x[ch]):
            ref = minimize(
                lambda v, t=y[:, ch]: np.sum((a @ v - t) ** 2),
                x0=start,
                jac=lambda v, t=y[:, ch]: 2 * a.T @ (a @ v - t),
                bounds=[(0, None)] * k,
                constraints=[{"type": "ineq", "fun": lambda v, b=bounds[ch]: b - rows @ v}],
                method="SLSQP",
                options={"ftol": 1e-15, "maxiter": 1000},
            )
            allowed = float(mu @ np.maximum(g(ref.x), 0))
            assert own <= ref.fun + allowed + 1e-12 * own, (own, ref.fun, allowed)
        np.testing.assert_allclose(rss[ch], own, rtol=1e-8)


def test_rows_no_coefficients_can_satisfy_are_an_error():
    """A row ``x0 + x1 <= -0.1`` with ``x >= 0`` has no solution: LinAlgError, which
    the objective turns into its "infeasible" value."""
    rng = np.random.default_rng(2)
    for k in (2, 7):
        a = np.abs(rng.normal(size=(20, k)))
        rows = np.ones((1, k))
        with pytest.raises(np.linalg.LinAlgError):
            solve_bounded(
                normal_equations(a, a @ np.ones((k, 1)), None),
                np.zeros(k),
                np.full(k, np.inf),
                (rows, np.array([-0.1])),
            )


def test_the_answer_is_deterministic():
    rng = np.random.default_rng(9)
    a, y, lower, upper, rows, bounds = _random_problem(rng, 7, 5, c=4)
    normal = normal_equations(a, y, None)
    first = solve_bounded(normal, lower, upper, (rows, bounds))
    again = solve_bounded(normal, lower, upper, (rows, bounds))
    assert all(np.array_equal(u, v) for u, v in zip(first, again))


@pytest.mark.parametrize("weighted", ["none", "per_sample"])
def test_an_offset_column_gives_the_normal_equations_of_its_target(weighted):
    """offset_normal regroups the sums of normal_equations(a, y - offset, w) without the
    target: the same Gram, A^T W (y - o) and (y - o)^T W (y - o) to their rounding."""
    rng = np.random.default_rng(len(weighted))
    m, c = 700, 31  # above the folding of the per-channel sums (2 x 128 rows)
    a, y = rng.uniform(0, 1, (m, 2)), rng.uniform(0, 1, (m, c))
    offset = rng.uniform(0, 0.5, (m, 1))
    w = None if weighted == "none" else rng.uniform(0.2, 3, m)
    want = normal_equations(a, y - offset, w)
    got = offset_normal(a, offset, w, y, weighted_target(y, w))
    np.testing.assert_array_equal(got.gram, want.gram)
    np.testing.assert_allclose(got.rhs, want.rhs, rtol=1e-13)
    np.testing.assert_allclose(got.yy, want.yy, rtol=1e-13)
    x, rss = solve_bounded(got, np.zeros(2), np.full(2, np.inf))
    x_want, rss_want = solve_bounded(want, np.zeros(2), np.full(2, np.inf))
    np.testing.assert_allclose(x, x_want, rtol=1e-12)
    np.testing.assert_allclose(rss, rss_want, rtol=1e-10)


def test_per_channel_offsets_or_weights_take_the_target():
    rng = np.random.default_rng(3)
    a, y = rng.uniform(0, 1, (300, 2)), rng.uniform(0, 1, (300, 3))
    column, per_channel = rng.uniform(0, 1, (300, 1)), rng.uniform(0, 1, (300, 3))
    for offset, w in ((per_channel, None), (column, rng.uniform(0.2, 3, (300, 3)))):
        assert offset_normal(a, offset, w, y, weighted_target(y, w)) is None
    stacked = np.repeat(a[:, :, None], 3, axis=2)  # (M, K, C) per-channel columns
    assert offset_normal(stacked, column, None, y, weighted_target(y, None)) is None


def test_feasibility_without_tolerance_is_the_slack_formula_s():
    """At tol 0 the check skips its slack arrays (0 where finite, NaN where not): the
    same answers as the formula with them, at infinities and NaN too."""
    from brdffit.fitting import linear

    def plain(x, lower, upper, rows, tol):
        slack = tol * np.maximum(1.0, np.abs(x))
        ok = ((x >= lower - slack) & (x <= upper + slack)).all(axis=-1)
        if rows is None:
            return ok
        a, b = rows
        return ok & ((x @ a.T) <= b + tol * np.maximum(1.0, np.abs(b))).all(axis=-1)

    rng = np.random.default_rng(5)
    special = [np.inf, -np.inf, np.nan, 0.0, 1.0, -1e-300, 2.0]
    x = rng.choice(special + list(rng.uniform(-0.5, 2.5, 20)), size=(9, 40, 2))
    lower, upper = np.zeros(2), np.array([2.0, np.inf])
    rows = (np.array([[1.0, 1.0], [1.0, -1.0]]), rng.choice([1.0, 3.0, np.inf, np.nan], (40, 2)))
    with np.errstate(invalid="ignore"):
        for constraints in (None, rows):
            got = linear._feasible(x, lower, upper, constraints)
            np.testing.assert_array_equal(got, plain(x, lower, upper, constraints, 0.0))


def test_the_states_objective_is_the_objective_of_each_state():
    """The enumeration's residual sums of the 3^K states by one batched matmul are
    :func:`_objective`'s of each state's coefficients, to the rounding of K products."""
    from brdffit.fitting import linear

    rng = np.random.default_rng(11)
    a, y = rng.uniform(0, 1, (200, 3)), rng.uniform(0, 1, (200, 4))
    normal = normal_equations(a, y, rng.uniform(0.2, 3, (200, 4)))
    x = rng.uniform(-1, 2, (27, 4, 3))  # (S, C, K)
    want = np.array([linear._objective(normal, state) for state in x])
    np.testing.assert_allclose(linear._state_objective(normal, x), want, rtol=1e-13, atol=1e-13)


@pytest.mark.parametrize("w", [None, "per_sample", "per_value"])
def test_column_major_targets_give_the_row_major_ones_normal_equations(w):
    """A^T W y taken as (W y)^T A for a column-major W y (a table's columns): the same
    sums as for the row-major copy of the same values, to their rounding."""
    rng = np.random.default_rng(12)
    a, y = rng.uniform(0, 1, (1439, 3)), np.asfortranarray(rng.uniform(0, 1, (1439, 31)))
    per_value = np.asfortranarray(rng.uniform(0.2, 3, y.shape))
    w = {None: None, "per_sample": rng.uniform(0.2, 3, 1439)}.get(w, per_value)
    assert weighted_target(y, w)[0].flags.f_contiguous  # the (W y)^T A side is taken
    got, want = normal_equations(a, y, w), normal_equations(a, np.ascontiguousarray(y), w)
    np.testing.assert_array_equal(got.gram, want.gram)
    np.testing.assert_allclose(got.rhs, want.rhs, rtol=1e-13)
    np.testing.assert_allclose(got.yy, want.yy, rtol=1e-13)  # summed in either layout
