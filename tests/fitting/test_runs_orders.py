"""The misfit test's two sample orders by counting sorts (brdffit.fitting.runs.orders,
brdffit.kernels.loops_runs) are the stable lexsorts' orders, element for element, and
its residuals' signs by one compiled pass are numpy's (issue 13); keys and sizes they
do not take go the plain way."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import NEEDS_KERNELS, calls_of

import brdffit
from brdffit import kernels
from brdffit.fitting import misfit, runs

pytestmark = NEEDS_KERNELS


@pytest.fixture
def counted(monkeypatch):
    """The calls of the counting sort (to tell which path ran)."""
    from brdffit.kernels import loops_runs

    return calls_of(monkeypatch, loops_runs, "order_by_ranks")


def _assert_orders(a, b, calls, counting):
    """Counting: numpy's lexsorts; else the complex-key sort that ran before (which
    orders NaNs its own way)."""
    got = runs.orders(a, b)
    if counting:
        want = np.lexsort((b, a)), np.lexsort((a, b))
    else:
        want = runs.lexsort(a, b), runs.lexsort(b, a)
    assert len(calls) == (2 if counting else 0)
    for g, w in zip(got, want):
        assert g.shape == w.shape and np.array_equal(g, w)


def test_a_merl_file_s_orders_are_the_lexsorts(counted):
    """The keys of a MERL grid (every second step: 137,027 pairs of a few hundred
    angles, ties everywhere), as the misfit test forms them."""
    data = brdffit.synthesize("blinn", geometry="merl", step=2)
    key_h, key_d = misfit._keys(data)
    _assert_orders(key_h, key_d, counted, counting=True)
    # misfit's own orders (32-bit) are the same
    by_h, by_d = misfit._sort_orders(data)
    assert by_h.dtype == np.int32 and np.array_equal(by_h, np.lexsort((key_d, key_h)))
    assert np.array_equal(by_d, np.lexsort((key_h, key_d)))


def test_few_values_of_every_sign_with_both_zeros_and_runs(counted):
    rng = np.random.default_rng(3)
    n = kernels.MIN_PAIRS + 517
    levels = np.array([-2.5, -1.0, -0.0, 0.0, 1e-300, 0.25, 3.0, np.inf, -np.inf])
    a = levels[rng.integers(0, len(levels), n)]
    a[100:400] = 0.25  # a long run
    b = rng.integers(-40, 40, n) * 0.125
    b[rng.random(n) < 0.3] = -0.0
    _assert_orders(a, b, counted, counting=True)
    assert np.any(np.signbit(a) & (a == 0)) and np.any(~np.signbit(a) & (a == 0))


@pytest.mark.parametrize("case", ["nan", "many values", "small", "kernels off"])
def test_keys_the_counting_sort_does_not_take_go_to_the_lexsort(case, counted):
    rng = np.random.default_rng(5)
    n = 400 if case == "small" else kernels.MIN_PAIRS + 3
    a = rng.integers(0, 50, n) * 0.5 if case != "many values" else rng.random(n)
    b = rng.integers(0, 30, n) * 1.5
    if case == "nan":
        b[[7, 70, 700]] = np.nan
    with kernels.use(False if case == "kernels off" else None):
        _assert_orders(a, b, counted, counting=False)


@pytest.mark.parametrize("step", [1, 4, 7])
def test_the_compiled_residual_signs_are_the_codes_of_the_residuals(step, monkeypatch):
    """Every step-th sample's signs of pred - values by the compiled pass: the codes of
    numpy's residuals (exact zeros, NaN, infinities, ties at the largest doubles)."""
    from brdffit.kernels import loops_runs

    calls = calls_of(monkeypatch, loops_runs, "sign_codes_every")
    rng = np.random.default_rng(step)
    n = kernels.MIN_PAIRS * step + 5
    pred = rng.standard_normal((n, 3))
    values = pred + rng.choice([-1e-300, 0.0, 1e-300, 0.5], (n, 3))
    pred[::13, 1], values[::17, 2], pred[::19, 0] = np.nan, np.inf, np.inf
    values[::23], pred[::23] = 1.7e308, -1.7e308  # an overflowing difference: -inf
    with np.errstate(over="ignore"):  # the overflow, as the plain way meets it
        want = runs.sign_codes(np.subtract(pred[::step], values[::step]))
        got = runs.residual_signs(pred, values, step)
        assert calls == [1] and got.dtype == np.int8 and np.array_equal(got, want)
        assert set(np.unique(want)) == {0, 1, 2}
        small = pred[: kernels.MIN_PAIRS * step - step], values[: kernels.MIN_PAIRS * step - step]
        with kernels.use(False):
            assert np.array_equal(runs.residual_signs(pred, values, step), want)
        assert np.array_equal(runs.residual_signs(*small, step), want[:, : kernels.MIN_PAIRS - 1])
    assert calls == [1]  # neither with the kernels off nor below MIN_PAIRS rows
