"""The base-2 pieces of brdffit.kernels.base2 against numpy, and the Fournier loop
built on them (brdffit.kernels.loops_empirical.fournier) where its pieces leave
something for it to bound."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import NEEDS_KERNELS, hemisphere_pairs, random_params, stable_seed

from brdffit import kernels
from brdffit.data.geometry import Geometry
from brdffit.models import get_model

pytestmark = NEEDS_KERNELS

#: What the tests of the compiled models hold small values to, absolutely.
FLUSH = math.exp(-708.0)


def _run_log2_pair(x1, x2):
    import numba

    from brdffit.kernels._compile import FLAGS
    from brdffit.kernels.base2 import log2_pair

    @numba.njit(fastmath=FLAGS)
    def run(x1, x2, out1, out2):
        for i in range(x1.shape[0]):
            out1[i], out2[i] = log2_pair(x1[i], x2[i])

    out1, out2 = np.empty_like(x1), np.empty_like(x2)
    run(x1, x2, out1, out2)
    return out1, out2


def _run_exp2(y):
    import numba

    from brdffit.kernels._compile import FLAGS
    from brdffit.kernels.base2 import fast_exp2

    @numba.njit(fastmath=FLAGS)
    def run(y, out):
        for i in range(y.shape[0]):
            out[i] = fast_exp2(y[i])
        return out

    return run(y, np.empty_like(y))


def test_log2_pair_is_accurate_for_both_arguments_of_any_normal_size():
    """Each of the two logarithms sharing one division is within LOG2_ERROR (4 units
    in the last place) of numpy's log2, whatever the other argument (the pairs are
    shuffled), and the bound is not slack."""
    from brdffit.kernels.base2 import LOG2_ERROR

    rng = np.random.default_rng(11)
    x = np.concatenate(
        [
            2.0 ** rng.uniform(-1022.0, 1023.0, 200_000),
            rng.uniform(0.5, 2.0, 200_000),  # around the reduction's bounds
            1.0 + rng.uniform(-1e-9, 1e-9, 10_000),  # log2 x near 0
            [2.2250738585072014e-308, math.sqrt(0.5), math.sqrt(2.0), 2.0, 1.0],
        ]
    )
    other = rng.permutation(x)
    worst = 0.0
    for got, arg in zip(_run_log2_pair(x, other), (x, other)):
        expected = np.log2(arg)
        nonzero = expected != 0.0
        rel = np.abs(got[nonzero] / expected[nonzero] - 1.0)
        assert rel.max() < LOG2_ERROR, (rel.max(), arg[nonzero][rel.argmax()])
        assert (got[~nonzero] == 0.0).all()
        worst = max(worst, rel.max())
    assert worst > LOG2_ERROR / 2  # the bound is not slack


def test_the_log2_series_is_the_stored_one_and_close_to_the_series():
    from brdffit.kernels import base2

    coefficients, error = base2.fit_log2_series()
    np.testing.assert_allclose(coefficients, base2.LOG2_SERIES, rtol=1e-12, atol=0)
    assert error < 5e-16, error


def test_log2_pair_reads_zero_negative_and_subnormal_arguments_as_the_floor():
    from brdffit.kernels.base2 import LOG2_FLOOR

    x = np.array([0.0, -0.0, -3.0, 5e-324, 1e-310])
    got = _run_log2_pair(x, np.full_like(x, 0.75))
    np.testing.assert_array_equal(got[0], math.log2(LOG2_FLOOR))
    assert math.log2(LOG2_FLOOR) == -1022.0
    np.testing.assert_allclose(got[1], math.log2(0.75), rtol=1e-15)


def test_fast_exp2_is_within_its_stated_error_and_the_bound_is_not_slack():
    from brdffit.kernels.base2 import EXP2_ERROR, EXP2_FLOOR

    y = np.concatenate([np.random.default_rng(12).uniform(EXP2_FLOOR, 1000.0, 400_000), [0.0]])
    rel = np.abs(_run_exp2(y) / np.exp2(y) - 1.0)
    assert EXP2_ERROR / 2 < rel.max() < EXP2_ERROR, rel.max()
    below = np.array([EXP2_FLOOR - 1e-9, -1100.0, -1e300])
    np.testing.assert_allclose(_run_exp2(below), 2.0**EXP2_FLOOR, rtol=EXP2_ERROR, atol=0)


def test_the_exp2_polynomial_is_the_scaled_exp_fit():
    """EXP2_POLYNOMIAL is fit_exp2_polynomial(9): fit_exp_polynomial(9)'s coefficients
    of u = r ln 2 times (ln 2)^j, within 1.4e-14 of 2^r."""
    from brdffit.kernels import base2

    coefficients, error = base2.fit_exp2_polynomial(9)
    np.testing.assert_allclose(coefficients, base2.EXP2_POLYNOMIAL, rtol=1e-12, atol=0)
    assert error < 1.4e-14, error
    r = np.linspace(-0.5, 0.5, 10_001)
    assert np.max(np.abs(np.polyval(base2.EXP2_POLYNOMIAL, r) / np.exp2(r) - 1.0)) < 1.4e-14


def _fournier_both(geometry, params: dict) -> tuple:
    model = get_model("fournier")
    with kernels.use(True):
        got = model.evaluate_prepared(geometry, params)
    with kernels.use(False):
        expected = model.evaluate_prepared(geometry, params)
    return got, expected


def _relative(got, expected) -> float:
    big = np.abs(expected) > FLUSH * 1e3
    assert (np.abs(got[~big] - expected[~big]) <= 1e3 * FLUSH).all()
    return float(np.max(np.abs(got[big] / expected[big] - 1.0), initial=0.0))


def test_the_fournier_loop_is_within_its_stated_error_of_numpy():
    """Random parameters over the box and its corners: within the 2e-12 its docstring
    states. The largest errors are at H near a tilted normal with n in the thousands
    (1.4e-12 at n = 6254, t = 0.59); the loop before base 2 was 1.39e-12 there."""
    from brdffit.kernels.loops_empirical import fournier

    model = get_model("fournier")
    geometry = Geometry(*hemisphere_pairs(20_000, seed=5))
    rng = np.random.default_rng(stable_seed("fournier"))
    sets = [random_params(model, rng) for _ in range(40)]
    sets += [random_params(model, rng, corner) for corner in ("lower", "upper")]
    worst = max(_relative(*_fournier_both(geometry, model.check_params(p))) for p in sets)
    assert 2e-13 < worst < 2e-12, worst
    assert "within 2e-12 of the numpy model" in " ".join(fournier.__doc__.split())


@pytest.mark.parametrize("scale", [1e-300, 1e-3, 1e4, 1e290])
def test_the_fournier_loop_scales_its_sum_for_any_coefficient(scale):
    """The sum is scaled by 2^64 unless ks is huge (2^shift keeps every power below
    2^1000): the loop's value is ks times its lobe column, at ks far outside the box
    too."""
    from brdffit.kernels.inputs_empirical import fournier_inputs
    from brdffit.kernels.loops_empirical import fournier

    geometry = Geometry(*hemisphere_pairs(3000, seed=8))
    inputs = fournier_inputs(geometry)
    lobe = fournier(*inputs, 30.0, 0.4, 1.0, 0.0, np.empty(len(inputs[0])))
    scaled = fournier(*inputs, 30.0, 0.4, scale, 0.0, np.empty(len(inputs[0])))
    np.testing.assert_allclose(scaled, scale * lobe, rtol=1e-13, atol=1e3 * FLUSH)


def test_a_tilted_cosine_below_zero_adds_nothing_numpy_does_not():
    """n = 1 and t = 1 on pairs whose H leans far towards +-T: one tilted cosine is at
    or below 0 (numpy's power of it is 0, the loop's that of the smallest normal
    number), and the values agree to rounding."""
    cos_h = np.linspace(0.05, 0.6, 400)
    half = np.stack([np.sqrt(1.0 - cos_h**2), np.zeros_like(cos_h), cos_h], axis=1)
    half = np.concatenate([half, half * [-1.0, 1.0, 1.0]])
    side = np.stack([np.zeros(len(half)), np.ones(len(half)), np.zeros(len(half))], axis=1)
    wi, wo = (
        math.cos(0.1) * half + math.sin(0.1) * side,
        math.cos(0.1) * half - math.sin(0.1) * side,
    )
    geometry = Geometry(wi, wo)
    assert (np.abs(geometry.half[:, 0]) > geometry.cos_h).all()  # one tilted cosine < 0
    got, expected = _fournier_both(geometry, {"kd": 0.0, "ks": 1.0, "n": 1.0, "t": 1.0})
    from brdffit.kernels.base2 import EXP2_ERROR

    assert _relative(got, expected) < 2 * EXP2_ERROR  # the exponentials' error only
