"""The compiled loop of ``he`` (brdffit.kernels.loops_he) against the numpy model.

The model's reference tests (test_models_he.py) run on both paths too."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import NEEDS_KERNELS, hemisphere_pairs, random_params, stable_seed

from brdffit import kernels
from brdffit.data.geometry import Geometry
from brdffit.models.he_terms import SERIES_TOLERANCE, dd_series
from brdffit.models.wave import HE, series_arguments

pytestmark = NEEDS_KERNELS

#: fast_exp flushes results below exp(-708) to 0 (see its docstring).
FLUSH = math.exp(-708.0)
#: The paths' agreement: the series' first weight is ``exp(m ln g - g - lnGamma(m+1))``,
#: whose three terms reach 1e5 at ``g = 1e4`` (sigma0 at its bound of 5 um), where one
#: ulp (1.5e-11) of each moves the value by as much relative; ``lgamma`` (libm) and
#: ``gammaln`` (scipy) round differently. 1e-10 is the rounding allowance of the
#: model's scalar reference test (test_models_he.py); elsewhere the paths agree to
#: 1e-13 (measured).
AGREEMENT = 1e-10


def _relative(got, expected) -> float:
    big = np.abs(expected) > FLUSH * 1e3
    assert (np.abs(got[~big] - expected[~big]) <= 1e3 * FLUSH).all()
    return float(np.max(np.abs(got[big] / expected[big] - 1.0), initial=0.0))


@pytest.mark.parametrize("wavelength", [550.0, [400.0, 550.0, 700.0]])
def test_compiled_he_equals_numpy_across_the_parameter_box(wavelength):
    """Random parameters over the whole box and its corners (sigma0 to 5 um: a
    thousand terms of the series), grazing pairs included: the compiled design's
    offset and the evaluation agree with the numpy model within :data:`AGREEMENT`
    relative, and to 1e-12 where ``g`` stays below 1e3."""
    wi, wo = hemisphere_pairs(1500, seed=stable_seed("he"))
    geometry = Geometry(wi, wo)
    rng = np.random.default_rng(stable_seed("he"))
    sets = [random_params(HE, rng) for _ in range(12)]
    sets += [random_params(HE, rng, corner) for corner in ("lower", "upper")]
    for params in sets:
        params = HE.check_params({**params, "wavelength": wavelength})
        shape = {p.name: params[p.name] for p in HE.shape_params}
        with kernels.use(True):
            compiled = HE.design(geometry, shape)
            values = HE.evaluate_prepared(geometry, params)
        with kernels.use(False):
            reference = HE.design(geometry, shape)
            expected = HE.evaluate_prepared(geometry, params)
        assert compiled.offset.shape == reference.offset.shape
        assert _relative(compiled.offset, reference.offset) < AGREEMENT, params
        assert _relative(values, expected) < AGREEMENT, params
        g = series_arguments(geometry, shape)[0]
        moderate = (g < 1e3).reshape(compiled.offset.shape)
        assert _relative(compiled.offset[moderate], reference.offset[moderate]) < 1e-12


def test_the_compiled_series_sums_the_same_terms():
    """dd_series_loop sums the window of dd_series: the same number of terms per
    element (none where the series is negligible) and the same value to rounding; so
    does dd_series_blocks, the model loop's series (blocks of 512 elements in
    lockstep; 1205 elements in three blocks)."""
    from brdffit.kernels.loops_he import dd_series_blocks, dd_series_loop

    rng = np.random.default_rng(7)
    g = np.concatenate([[0.0, 1e-300, 1e-6, 4.0, 4.5], 10.0 ** rng.uniform(-4, 4, 1200)])
    a = np.concatenate([[0.0, 1.0, 3e4, 0.0, 2.0], 10.0 ** rng.uniform(-3, 5, 1200)])
    for tol in (SERIES_TOLERANCE, 1e-3, 1e-10):
        want, terms = dd_series(g, a, tol, count_terms=True)
        got = np.array([dd_series_loop(x, y, tol) for x, y in zip(g, a)])
        # g = 0 (a zero series): numpy sums one zero term, the loop none.
        np.testing.assert_array_equal(got[1:, 1], terms[1:])
        assert got[0, 0] == want[0] == 0.0
        np.testing.assert_allclose(got[:, 0], want, rtol=AGREEMENT, atol=0.0)
        moderate = g < 1e3
        np.testing.assert_allclose(got[moderate, 0], want[moderate], rtol=1e-12, atol=0.0)
        # The model's loop sums them in blocks, in lockstep: the same values.
        blocks = dd_series_blocks(g, a, tol, np.empty(g.size))
        np.testing.assert_allclose(blocks, want, rtol=AGREEMENT, atol=0.0)
        np.testing.assert_allclose(blocks[moderate], want[moderate], rtol=1e-12, atol=0.0)
        assert (terms == 0).any() and terms.max() > 100


def test_a_batch_of_shapes_goes_to_the_numpy_terms():
    """Shape parameters of shape (W, 1) (the posterior's walkers) are not numbers: the
    design falls back to the numpy terms, which broadcast them."""
    wi, wo = hemisphere_pairs(200, seed=4)
    geometry = Geometry(wi, wo)
    shape = {p.name: HE.defaults()[p.name] for p in HE.shape_params}
    with kernels.use(True):
        single = HE.design(geometry, shape).offset
    with kernels.use(False):
        expected = HE.design(geometry, shape).offset
    assert _relative(single, expected) < AGREEMENT


def test_fast_erfc_is_within_1e_14_of_scipy_and_its_fit_is_reproduced():
    """The vectorisable erfc of the shadowing against scipy from 0 to 27 (erfc of 27 is
    1e-319, below it fast_exp's flush), and the stored Chebyshev coefficients are
    those fit_erfcx computes."""
    import numba
    from scipy.special import erfc

    from brdffit.kernels import erfc as fast

    @numba.njit
    def run(x, out):
        for i in range(x.size):
            out[i] = fast.fast_erfc(x[i])

    x = np.concatenate([np.linspace(0.0, 27.0, 100_001), np.logspace(-12, 0, 500), [0.5]])
    got = np.empty_like(x)
    run(x, got)
    want = erfc(x)
    normal = want > FLUSH * 1e3
    assert np.max(np.abs(got[normal] / want[normal] - 1.0)) < 1e-14
    assert (np.abs(got[~normal]) <= 1e3 * FLUSH).all()
    stored = fast.ERFCX_CHEBYSHEV
    np.testing.assert_allclose(fast.fit_erfcx(), stored, rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("sigma0, tau", [(1e-3, 100.0), (5.0, 0.05), (0.18, 3.0), (1e-3, 0.05)])
def test_the_pair_terms_equal_numpy_from_the_normal_to_grazing(sigma0, tau):
    """sigma (the vectorised Newton iteration of z0, then the scalar one where six steps
    did not converge) and F S(L) S(V) (the vectorisable erfc, its clamp at 30 and the
    normal's S = 1, K = 0) against the numpy terms, for tau / sigma0 from 0.01 to 1e5
    (c of z0's equation from 0 to about 1e12) and cosines from 1 to MIN_COSINE: within
    1e-12 relative. Not to rounding: near the normal the loop's ``1 - c^2`` is one fused
    multiply-add (exact) where numpy rounds ``c^2`` first, which moves ``K`` by up to
    2.4e-11 relative (measured at tau / sigma0 = 0.01); sigma and S dampen it."""
    from brdffit.kernels.loops_he import pair_terms
    from brdffit.models.he_terms import effective_roughness_ratio, roughness_k, shadowing
    from brdffit.models.shared import fresnel_conductor

    cos = np.concatenate([[1.0, 1.0 - 1e-16, 1e-10], np.cos(np.linspace(0.0, 1.5707, 700))])
    cos_i, cos_o = np.meshgrid(cos, cos[::7])
    cos_i, cos_o = cos_i.ravel(), cos_o.ravel()
    cos_d = np.sqrt(0.5 * (1.0 + cos_i * cos_o))  # any V.H in (0, 1]
    ratio = tau / sigma0
    shape = np.array([sigma0, tau, 0.2, 3.5, SERIES_TOLERANCE])
    sigma, common = pair_terms(cos_i, cos_o, cos_d, shape, *np.empty((2, cos_i.size)))
    k_sum = roughness_k(cos_i, ratio) + roughness_k(cos_o, ratio)
    np.testing.assert_allclose(sigma, sigma0 * effective_roughness_ratio(k_sum), rtol=1e-12)
    want = shadowing(cos_i, ratio) * shadowing(cos_o, ratio) * fresnel_conductor(cos_d, 0.2, 3.5)
    np.testing.assert_allclose(common, want, rtol=1e-12, atol=1e3 * FLUSH)


def test_he_takes_its_loop_below_min_pairs(monkeypatch):
    """The numpy series costs milliseconds an evaluation at any size, so he uses its
    loop from one pair on when the kernels go by size (the other models from
    kernels.MIN_PAIRS); switched off, it never does."""
    from brdffit.kernels import loops_he

    calls = []
    original = loops_he.he_offset
    monkeypatch.setattr(loops_he, "he_offset", lambda *a: calls.append(1) or original(*a))
    wi, wo = hemisphere_pairs(300, seed=12)
    assert 300 < kernels.MIN_PAIRS
    with kernels.use(None):
        compiled = HE.evaluate(wi, wo, HE.defaults())
    assert calls == [1]
    with kernels.use(False):
        reference = HE.evaluate(wi, wo, HE.defaults())
    assert calls == [1]
    np.testing.assert_allclose(compiled, reference, rtol=1e-10, atol=1e-300)


def test_he_is_bound_through_the_kernels_and_adds_a_ud_in_its_loop(monkeypatch):
    """``he`` is one of kernels.COMPILED_MODELS (bound by kernels.bind as the others),
    and its prepared evaluation is one pass of the loop: ``a_ud / pi`` per wavelength is
    added there, bit for bit numpy's combination of the compiled design (before, the
    loop returned the offset and numpy added the column in a second pass); with
    ``a_ud`` per channel but one wavelength it combines the design's columns."""
    from brdffit.kernels import loops_he
    from brdffit.kernels.bind import CompiledDesign
    from brdffit.models.base import combine

    assert "he" in kernels.COMPILED_MODELS and isinstance(HE.design, CompiledDesign)
    geometry = Geometry(*hemisphere_pairs(700, seed=13))
    params = HE.check_params(
        {**HE.defaults(), "a_ud": np.array([0.1, 0.0, 0.4]), "wavelength": [450.0, 550.0, 650.0]}
    )
    shape = {p.name: params[p.name] for p in HE.shape_params}
    with kernels.use(True):
        design = HE.design(geometry, shape)
        combined = geometry.scatter(combine(design, HE.coefficient_values(params), geometry.m))
        calls = []
        original = loops_he.he_offset_loop
        monkeypatch.setattr(loops_he, "he_offset_loop", lambda *a: calls.append(a) or original(*a))
        fused = HE.evaluate_prepared(geometry, params)
        assert len(calls) == 1 and np.all(calls[0][9] == np.array([0.1, 0.0, 0.4]) / math.pi)
        np.testing.assert_array_equal(fused, combined)
        one = HE.check_params({**params, "wavelength": 550.0})
        assert HE.evaluate_prepared(geometry, one).shape == (combined.shape[0], 3)
    with kernels.use(False):
        expected = HE.evaluate_prepared(geometry, one)
    with kernels.use(True):
        assert _relative(HE.evaluate_prepared(geometry, one), expected) < AGREEMENT
