"""The log loss's Gauss-Newton passes compiled (brdffit.kernels.loss_log, through
brdffit.fitting.solve.solve_log) give the numpy passes' coefficients and loss."""

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

import brdffit
from brdffit import kernels
from brdffit.fitting import solve
from brdffit.fitting.problem import Problem
from brdffit.models import get_model

pytestmark = [NEEDS_KERNELS, pytest.mark.usefixtures("compiled_for_every_size")]


@pytest.mark.parametrize(
    ("model", "weights", "grey"),
    [
        ("ggx", None, False),
        ("cook_torrance", "samples", False),
        ("blinn", None, True),
        ("ward", "samples", True),
    ],
)
def test_compiled_log_passes_give_the_numpy_solution(model, weights, grey):
    """Same coefficients and loss at 6 random shapes, with and without sample weights,
    with weights per channel (colour) and the same in every channel (grey data)."""
    data = rgb_data(model, 3000, 5, 0.05, grey)
    w = None if weights is None else np.random.default_rng(2).uniform(0.2, 3.0, data.n)
    problem = Problem(data, model, loss="log", weights=w)
    assert problem.linearisation()[0].ndim == (1 if grey else 2)
    rng = np.random.default_rng(9)
    for _ in range(6):
        x = rng.uniform(problem.lower, problem.upper)
        compiled, numpy = solve_both(problem, x)
        np.testing.assert_allclose(compiled.coefs, numpy.coefs, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(compiled.loss, numpy.loss, rtol=1e-11)
        # the loss is the exact loss of the coefficients found (formed residuals)
        params = problem.params_of(compiled)
        np.testing.assert_allclose(compiled.loss, problem.exact_loss(params), rtol=1e-11)


def test_compiled_log_passes_keep_the_energy_rows():
    """In an energy-conserving fit the albedo rows bind the coefficients (bright data):
    the compiled passes solve under them as the numpy passes do."""
    params = get_model("ggx").defaults()
    for p in get_model("ggx").linear_params:
        params[p.name] = params[p.name] * np.array([1.8, 1.3, 0.7])
    data = make_data("ggx", params, n=3000, noise=0.05, seed=3, channels=["r", "g", "b"])
    problem = Problem(data, "ggx", loss="log", energy_conserving=True)
    free = Problem(data, "ggx", loss="log")
    rng = np.random.default_rng(1)
    bound = 0
    for _ in range(4):
        x = rng.uniform(problem.lower, problem.upper)
        compiled, numpy = solve_both(problem, x)
        np.testing.assert_allclose(compiled.coefs, numpy.coefs, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(compiled.loss, numpy.loss, rtol=1e-11)
        bound += compiled.loss > free.solve(x).loss * (1 + 1e-6)  # the rows bind
    assert bound


def test_the_compiled_passes_are_taken_only_where_they_apply():
    data = rgb_data("ggx", 2000, 1, 0.05)
    problem = Problem(data, "ggx", loss="log")
    m = len(problem.y)
    cols = [1.0 / np.pi, np.linspace(0.0, 2.0, m)]
    assert solve.solve_log(problem, {}, cols, None, None) is not None
    # an offset (a held coefficient), two array columns, another loss, kernels off
    assert solve.solve_log(problem, {}, cols, np.zeros((m, 3)), None) is None
    assert solve.solve_log(problem, {}, [cols[1], cols[1] ** 2], None, None) is None
    assert solve.solve_log(Problem(data, "ggx", loss="cbrt"), {}, cols, None, None) is None
    with kernels.use(False):
        assert solve.solve_log(problem, {}, cols, None, None) is None


def test_log_sums_are_the_sums_of_the_formed_terms():
    """The seven sums against numpy's formed arrays, with a prediction that reaches
    the clamp of the logarithm's argument (1e-12), a sample at cos = 0 and weights."""
    from brdffit.kernels.loss_log import log_sums

    rng = np.random.default_rng(3)
    m = 5000  # not a multiple of the block
    lobe = rng.uniform(0.0, 4.0, m)
    cos_i = rng.uniform(0.0, 1.0, m)
    cos_i[7] = 0.0
    y = rng.uniform(0.0, 3.0, (m, 2))
    u = rng.uniform(0.5, 2.0, m)
    ty = np.log(1.0 + y * cos_i[:, None])
    b, a = np.array([0.1, -5.0]), np.array([0.5, 0.2])  # channel 1: 1 + f cos < 0
    f = b + a * lobe[:, None]
    arg = np.maximum(1.0 + f * cos_i[:, None], 1e-12)
    assert (arg == 1e-12).any()
    r = np.log(arg) - ty
    dt = cos_i[:, None] / arg
    w = u[:, None] * dt**2
    wz = u[:, None] * dt * (dt * f - r)
    expected = [w, w * lobe[:, None], w * lobe[:, None] ** 2, wz, wz * lobe[:, None],
                u[:, None] * (dt * f - r) ** 2, u[:, None] * r**2]  # fmt: skip
    sums = log_sums(lobe, cos_i, np.ascontiguousarray(ty.T), u, b, a)
    assert sums.shape == (7, 2)
    np.testing.assert_allclose(sums, [e.sum(axis=0) for e in expected], rtol=1e-12)
    # where dt > 0, w z is the numpy form w (f - r / dt)
    k = cos_i > 0
    np.testing.assert_allclose(
        (wz * lobe[:, None])[k].sum(axis=0),
        (w[k] * (f[k] - r[k] / dt[k]) * lobe[k, None]).sum(axis=0),
        rtol=1e-10,
    )


def test_a_log_fit_is_the_numpy_fit():
    """A whole fit with the log loss, compiled and numpy: the same parameters."""
    data = rgb_data("ggx", 4000, 8, 0.05)
    with kernels.use(True):
        compiled = brdffit.fit(data, "ggx", loss="log")
    with kernels.use(False):
        numpy = brdffit.fit(data, "ggx", loss="log")
    assert compiled.loss <= numpy.loss * (1 + 1e-10)
    for name, value in numpy.params.items():
        np.testing.assert_allclose(compiled.params[name], value, rtol=1e-6, atol=1e-12)


@pytest.mark.parametrize("bad", [np.inf, np.nan, 1e300])
def test_a_design_that_is_not_finite_is_refused_as_by_the_numpy_passes(bad):
    """The loops assume finite values (fast-math): a lobe that is not finite, or whose
    square is not, must not give a finite loss; it is refused by the bounded solve, as
    in the numpy passes (Problem.solve turns that into BAD_LOSS)."""
    problem = Problem(rgb_data("ggx", 2000, 1, 0.05), "ggx", loss="log")
    lobe = np.linspace(0.0, 2.0, len(problem.y))
    lobe[5] = bad
    with pytest.raises(np.linalg.LinAlgError, match="not finite"), np.errstate(all="ignore"):
        solve.solve_log(problem, {}, [1.0 / np.pi, lobe], None, None)
    with pytest.raises(np.linalg.LinAlgError, match="not finite"), np.errstate(all="ignore"):
        solve.solve_linear(problem, {}, np.stack([np.full(len(lobe), 0.3), lobe], 1), None, None)


def test_the_log_transform_in_one_array_is_the_expression_as_written():
    """The log loss's transform and derivative, formed in place, give exactly the
    values of ``ln(max(1 + f cos, 1e-12))`` and ``cos / max(1 + f cos, 1e-12)``."""
    from brdffit.fitting.losses import LOSSES, LossContext

    rng = np.random.default_rng(4)
    cos_i = rng.uniform(0.0, 1.0, 4000)
    f = rng.uniform(-3.0, 3.0, (4000, 3))  # 1 + f cos < 1e-12 too
    f.setflags(write=False)  # a prediction is read-only
    ctx = LossContext(cos_i=cos_i, y=np.abs(f), sigma=None, weights=None)
    arg = np.maximum(1.0 + f * cos_i[:, None], 1e-12)
    assert (arg == 1e-12).any()
    log = LOSSES["log"]
    assert np.array_equal(log.transform(f, ctx), np.log(arg))
    assert np.array_equal(log.derivative(f, ctx), cos_i[:, None] / arg)
    t, dt = log.both(f, ctx)
    assert np.array_equal(t, np.log(arg)) and np.array_equal(dt, cos_i[:, None] / arg)
