"""The vectorisable logarithm of brdffit.kernels.elementary and the loops of
brdffit.kernels.loops_empirical where they must round as numpy does.

Every compiled model is also compared with its numpy design over its whole
parameter box in test_kernels.py, and its reference tests run on both paths."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import NEEDS_KERNELS, compiled_for_every_size  # noqa: F401 (the fixture)

from brdffit import kernels
from brdffit.data.geometry import Geometry, directions_from_angles
from brdffit.models import get_model

pytestmark = [NEEDS_KERNELS, pytest.mark.usefixtures("compiled_for_every_size")]


def _runner(name: str):
    """A compiled loop applying ``brdffit.kernels.elementary.<name>`` to an array."""
    import numba

    from brdffit.kernels import elementary
    from brdffit.kernels._compile import FLAGS

    function = getattr(elementary, name)

    @numba.njit(fastmath=FLAGS)
    def run(x, out):
        for i in range(x.shape[0]):
            out[i] = function(x[i])
        return out

    return lambda x: run(x, np.empty_like(x))


def test_fast_log_is_accurate_to_rounding_from_subnormal_to_huge_arguments():
    rng = np.random.default_rng(2)
    x = np.concatenate(
        [
            np.exp(rng.uniform(-745.0, 709.0, 200_000)),  # subnormal to 8e307
            rng.uniform(0.5, 2.0, 100_000),  # around the reduction's bounds
            1.0 + rng.uniform(-1e-9, 1e-9, 10_000),  # ln x near 0
            [5e-324, 2.2250738585072014e-308, math.sqrt(0.5), math.sqrt(2.0), 2.0, 1.0],
        ]
    )
    got = _runner("fast_log")(x)
    expected = np.log(x)
    nonzero = expected != 0.0
    rel = np.abs(got[nonzero] / expected[nonzero] - 1.0)
    assert rel.max() < 2.5e-16, (rel.max(), x[nonzero][rel.argmax()])
    assert (got[~nonzero] == 0.0).all()


def test_fast_log_of_zero_is_a_finite_log_zero_whose_power_is_zero():
    from brdffit.kernels.elementary import LOG_ZERO

    got = _runner("fast_log")(np.array([0.0, -0.0, -3.0]))
    np.testing.assert_array_equal(got, LOG_ZERO)
    assert math.isfinite(LOG_ZERO * 1e4) and LOG_ZERO < -708.0 * 1e250


def test_fast_log1p_is_accurate_for_tiny_and_large_arguments():
    """ln(1 + x) to rounding where ln(1 + x) ~ x (the rounding error of 1 + x, which
    a plain ln(1 + x) loses, is added back) and far from it."""
    rng = np.random.default_rng(3)
    x = np.concatenate(
        [
            np.exp(rng.uniform(-745.0, 700.0, 200_000)),
            rng.uniform(0.0, 3.0, 100_000),
            [0.0, 5e-324, 1e-300, 1e-16, 1.0, 2.0**53, 1e300],
        ]
    )
    got = _runner("fast_log1p")(x)
    expected = np.log1p(x)
    nonzero = expected != 0.0
    rel = np.abs(got[nonzero] / expected[nonzero] - 1.0)
    assert rel.max() < 2.5e-16, (rel.max(), x[nonzero][rel.argmax()])
    assert (got[~nonzero] == 0.0).all()
    tiny = x[(x > 0) & (x < 1e-17)]
    np.testing.assert_array_equal(_runner("fast_log1p")(tiny), tiny)


def test_fast_exp_short_is_accurate_to_rounding_and_flushes_below_its_minimum():
    from brdffit.kernels._compile import EXP_MIN

    x = np.concatenate(
        [np.random.default_rng(4).uniform(-720.0, 709.0, 200_000), [0.0, -1e-300, -1e304]]
    )
    got = _runner("fast_exp_short")(x)
    normal = x >= EXP_MIN
    rel = np.abs(got[normal] / np.exp(x[normal]) - 1.0)
    assert rel.max() < 3e-16, rel.max()
    assert (got[~normal] == 0.0).all() and (~normal).sum() > 1000


def test_fast_exp_7_is_within_its_stated_error_and_the_bound_is_not_slack():
    """The degree-7 exponential of the anisotropic Beckmann loop: within EXP7_ERROR
    (5e-11) of numpy's exp, the bound within 2x of the largest error found (the
    polynomial's 4.1e-11), the same flush below EXP_MIN; its polynomial is
    fit_exp_polynomial(7)'s."""
    from brdffit.kernels import elementary
    from brdffit.kernels._compile import EXP_MIN

    x = np.concatenate(
        [np.random.default_rng(5).uniform(-720.0, 709.0, 400_000), [0.0, -1e-300, -1e304]]
    )
    got = _runner("fast_exp_7")(x)
    normal = x >= EXP_MIN
    rel = np.abs(got[normal] / np.exp(x[normal]) - 1.0)
    assert elementary.EXP7_ERROR / 2 < rel.max() < elementary.EXP7_ERROR, rel.max()
    assert (got[~normal] == 0.0).all() and (~normal).sum() > 1000
    coefficients, _ = elementary.fit_exp_polynomial(7)
    np.testing.assert_allclose(coefficients, elementary.EXP_POLYNOMIAL_7, rtol=1e-12, atol=0)


def test_the_log_series_polynomial_is_the_stored_one_and_close_to_the_series():
    """fit_log_series() reproduces G, and G is within 1e-15 of the series it replaces
    (which moves ln(1 + f) by at most Z_MAX/2 of that: 1.5e-17 relative)."""
    from brdffit.kernels import elementary

    coefficients, error = elementary.fit_log_series()
    np.testing.assert_allclose(coefficients, elementary.G, rtol=1e-12, atol=0)
    z = np.linspace(0.0, elementary.Z_MAX, 100_001)
    stored = np.max(np.abs(np.polyval(elementary.G, z) - elementary.log_series(z)))
    assert error < 1e-15 and stored < 1e-15, (error, stored)


def test_the_exp_polynomial_is_the_stored_one_and_within_its_error():
    from brdffit.kernels import elementary

    coefficients, error = elementary.fit_exp_polynomial()
    np.testing.assert_allclose(coefficients, elementary.EXP_POLYNOMIAL, rtol=1e-12, atol=0)
    assert error < 4e-18, error  # far below double rounding (1.1e-16)


def _compiled_and_numpy(name: str, wi, wo, params: dict) -> tuple:
    model = get_model(name)
    geometry = Geometry(wi, wo)
    got = model.evaluate_prepared(geometry, params)
    with kernels.use(False):
        expected = model.evaluate_prepared(Geometry(wi, wo), params)
    return got, expected


def test_lafortune_rounds_its_cancelling_base_as_numpy():
    """The base ``cxy (Lx Vx + Ly Vy) + Lz Vz`` cancels where V nears the direction
    that makes it 0: there the loop's base must be numpy's product then sum (a fused
    multiply-add moves it by 2e-8 relative at these pairs)."""
    cxy, theta = -0.7, math.radians(60.0)
    # L and V in the plane phi = 0: base = cos(L) cos(V) + cxy sin(L) sin(V)
    zero = math.atan(-1.0 / (cxy * math.tan(theta)))
    offsets = np.linspace(-1e-7, 1e-7, 401)
    wi = directions_from_angles(np.full(401, theta), np.zeros(401), False)
    wo = directions_from_angles(zero + offsets, np.zeros(401), False)
    params = {"kd": 0.0, "ks": 1.0, "cxy": cxy, "n": 1.0}
    got, expected = _compiled_and_numpy("lafortune", wi, wo, params)
    assert (expected > 0).sum() > 150 and expected.max() < 1e-6
    np.testing.assert_allclose(got, expected, rtol=1e-13, atol=0)


def _pairs_about(half: np.ndarray, angle: float = 0.2) -> tuple:
    """Pairs L, V symmetric about the unit half vectors ``half`` (K, 3)."""
    side = np.stack([-half[:, 1], half[:, 0], np.zeros(len(half))], axis=1)
    side /= np.linalg.norm(side, axis=1)[:, None]
    return (
        math.cos(angle) * half + math.sin(angle) * side,
        math.cos(angle) * half - math.sin(angle) * side,
    )


def test_fournier_keeps_a_term_numpy_keeps_beside_a_tiny_sum():
    """n = 990 and H at 61 degrees, tilted towards T: one tilted lobe's power near
    1e-301, the central one below 1e-307, which numpy's sum keeps as a subnormal
    number. Before the terms were added relative to the largest, the loop flushed
    it and was 2e-9 away."""
    n, t = 990.16, 0.265
    cos_h = np.linspace(0.484, 0.489, 201)
    half_t = np.full_like(cos_h, 0.1019)
    half = np.stack([half_t, np.sqrt(1.0 - cos_h**2 - half_t**2), cos_h], axis=1)
    wi, wo = _pairs_about(half)
    inv = 1.0 / math.sqrt(1.0 + t * t)
    terms = np.stack([cos_h**n, (cos_h * inv + half_t * t * inv) ** n])
    total = terms.sum(axis=0)
    hard = (terms[0] < 1e-307) & (terms[0] > 1e-10 * total)
    assert hard.sum() > 20  # the case arises
    params = {"kd": 0.0, "ks": 1.0, "n": n, "t": t}
    got, expected = _compiled_and_numpy("fournier", wi, wo, params)
    np.testing.assert_allclose(got[hard], expected[hard], rtol=1e-11, atol=0)


def test_a_loop_that_asks_for_wide_vectors_carries_the_attribute():
    """prefer_wide_vectors() puts LLVM's prefer-vector-width attribute on the compiled
    function (an llvmlite that refused it would leave the loop as it was, silently:
    this says so)."""
    import numba

    from brdffit.kernels.wide import prefer_wide_vectors

    @numba.njit
    def wide(x):
        prefer_wide_vectors()
        return x + 1.0

    @numba.njit
    def plain(x):
        return x + 1.0

    assert wide(1.0) == 2.0 and plain(1.0) == 2.0
    assert '"prefer-vector-width"="512"' in "".join(wide.inspect_llvm().values())
    assert "prefer-vector-width" not in "".join(plain.inspect_llvm().values())


def test_an_llvmlite_that_refuses_the_wide_attribute_leaves_the_loop_compiling(monkeypatch):
    """An llvmlite whose printing of a module checks attribute names, as its ``add``
    does, would raise in the compilation of every loop given the attribute (and so
    in the model's evaluation): the attribute is tried first, and then not given.
    Before that trial, this compilation raised ValueError."""
    import numba
    from llvmlite.ir.values import FunctionAttributes

    from brdffit.kernels import wide

    printed = FunctionAttributes._to_list

    def strict(self, ret_type):
        unknown = set(self) - set(self._known)
        if unknown:
            raise ValueError(f"unknown attributes {sorted(unknown)}")
        return printed(self, ret_type)

    monkeypatch.setattr(FunctionAttributes, "_to_list", strict)
    wide._accepted.cache_clear()
    try:

        @numba.njit
        def refused(x):
            wide.prefer_wide_vectors()
            return x + 1.0

        assert refused(1.0) == 2.0
        assert "prefer-vector-width" not in "".join(refused.inspect_llvm().values())
        assert not wide._accepted()
    finally:
        monkeypatch.undo()
        wide._accepted.cache_clear()
    assert wide._accepted()  # this llvmlite: the attribute is given (test above)
