"""The prepared geometry's half-vector terms (brdffit.data.geometry.Geometry)."""

import importlib

import numpy as np
import pytest
from helpers import gonio_pairs, hemisphere_pairs

from brdffit import kernels, synthesize
from brdffit.data.geometry import MIN_COSINE, Geometry


@pytest.mark.parametrize("pairs", [lambda: hemisphere_pairs(5000, seed=1),
                                   lambda: gonio_pairs(3000, seed=2)])  # fmt: skip
def test_the_isotropic_terms_equal_the_half_vectors_and_do_not_form_it(pairs):
    """cos_h and sin2_h come from the half vector's components without the (M, 3) half
    vector kept (a MERL file's is 26 MB): bit for bit the values from it, which are
    checked here against the definition."""
    wi, wo = pairs()
    lazy, eager = Geometry(wi, wo), Geometry(wi, wo)
    h = (wi + wo) / np.linalg.norm(wi + wo, axis=1, keepdims=True)
    np.testing.assert_allclose(eager.half, h, rtol=0, atol=1e-15)
    for name in ("cos_h", "sin2_h", "tan2_h", "log_cos_h", "theta_h"):
        np.testing.assert_array_equal(getattr(lazy, name), getattr(eager, name), err_msg=name)
    assert "half" not in lazy.__dict__
    np.testing.assert_allclose(lazy.cos_h, np.clip(h[:, 2], MIN_COSINE, 1.0), rtol=1e-15)
    np.testing.assert_allclose(lazy.sin2_h, h[:, 0] ** 2 + h[:, 1] ** 2, atol=1e-15)


def _merl_pairs():
    """The directions of a MERL file's grid (every fourth step)."""
    data = synthesize("blinn", geometry="merl", step=4)
    return np.array(data.wi), np.array(data.wo)


@pytest.mark.skipif(not kernels.available(), reason="numba is not installed")
@pytest.mark.parametrize("pairs", [lambda: hemisphere_pairs(20_000, seed=3),
                                   lambda: gonio_pairs(12_000, seed=4),
                                   _merl_pairs])  # fmt: skip
def test_the_compiled_half_terms_are_numpys_bit_for_bit(pairs):
    """|L + V|, cos_h and cos_d formed in one compiled pass are numpy's values bit for
    bit, and so is every term formed from them."""
    importlib.import_module("brdffit.kernels.loops")  # loaded: the geometry may use them
    wi, wo = pairs()
    wi[:7, :] = [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.6, 0.0, 0.8],
                 [-1.0, 0.0, 1e-12], [1.0, 0.0, 1e-300], [0.0, -1.0, 0.0]]  # fmt: skip
    wo[:7, :] = [[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [-0.6, 0.0, 0.8],
                 [1.0, 0.0, 1e-12], [-1.0, 0.0, 1e-300], [1.0, 0.0, 0.0]]  # fmt: skip
    with kernels.use(True):
        compiled = Geometry(wi, wo, check=False)
        assert compiled._half_terms() is True  # the compiled pass ran
        names = ("cos_h", "cos_d", "_half_norm", "sin2_h", "tan2_h", "theta_h")
        formed = {name: getattr(compiled, name) for name in names}
    assert "half" not in compiled.__dict__
    with kernels.use(False):
        plain = Geometry(wi, wo, check=False)
        for name in names:
            np.testing.assert_array_equal(formed[name], getattr(plain, name), err_msg=name)
    assert formed["cos_h"].min() >= MIN_COSINE and formed["cos_d"].max() <= 1.0


def test_the_half_terms_are_not_compiled_for_a_small_geometry_or_with_the_kernels_off():
    """Below the kernels' size, and with them switched off, the numpy formulas run
    (the compiled pass would not pay for itself, or must not run)."""
    wi, wo = hemisphere_pairs(500, seed=5)
    small = Geometry(wi, wo)
    assert small._half_terms() is False and "_half_norm" not in small.__dict__
    wi, wo = hemisphere_pairs(kernels.MIN_PAIRS, seed=6)
    with kernels.use(False):
        assert Geometry(wi, wo)._half_terms() is False


def _edge_pairs(pairs):
    """``pairs()`` with L = V = N, grazing and horizon pairs first."""
    wi, wo = pairs()
    wi[:4, :] = [[0.0, 0.0, 1.0], [1.0, 0.0, 1e-12], [0.6, 0.0, 0.8], [0.0, 1.0, 1e-300]]
    wo[:4, :] = [[0.0, 0.0, 1.0], [-1.0, 0.0, 1e-12], [-0.6, 0.0, 0.8], [0.0, -1.0, 1e-300]]
    return wi, wo


_PAIRS = [lambda: hemisphere_pairs(20_000, seed=7), lambda: gonio_pairs(12_000, seed=8),
          _merl_pairs]  # fmt: skip


@pytest.mark.skipif(not kernels.available(), reason="numba is not installed")
@pytest.mark.parametrize("pairs", _PAIRS)
@pytest.mark.parametrize("formed", [(), ("sin2_h",), ("cos_h", "tan2_h")])
def test_the_compiled_microfacet_inputs_are_numpys_bit_for_bit(pairs, formed, monkeypatch):
    """GGX's inputs and the geometry's sin2_h and tan2_h formed in one compiled pass
    (brdffit.kernels.loops_geometry) are numpy's values bit for bit, whichever of the
    geometry's terms were formed before (by numpy or by the compiled half terms)."""
    from brdffit.kernels import inputs, loops_geometry

    importlib.import_module("brdffit.kernels.loops")
    calls, loop = [], loops_geometry.microfacet_terms
    spy = lambda *a: calls.append(a[7]) or loop(*a)  # noqa: E731
    monkeypatch.setattr(loops_geometry, "microfacet_terms", spy)
    wi, wo = _edge_pairs(pairs)
    with kernels.use(True):
        compiled = Geometry(wi, wo, check=False)
        for name in formed:
            getattr(compiled, name)
        got = inputs.microfacet_inputs(compiled)
        assert calls == [formed == ()]  # the loop ran, forming sin2_h unless formed
        terms = (compiled.sin2_h, compiled.tan2_h, compiled.theta_h)
    with kernels.use(False):
        plain = Geometry(wi, wo, check=False)
        want = inputs.microfacet_inputs(plain)
        for a, b in zip((*got, *terms), (*want, plain.sin2_h, plain.tan2_h, plain.theta_h)):
            np.testing.assert_array_equal(a, b)
    assert len(got) == len(want) == 5


@pytest.mark.skipif(not kernels.available(), reason="numba is not installed")
@pytest.mark.parametrize("pairs", _PAIRS)
@pytest.mark.parametrize("model", ["ward", "cook_torrance", "ward_anisotropic"])
def test_the_compiled_ward_and_cook_torrance_inputs_are_numpys_bit_for_bit(pairs, model):
    """Ward's and Cook-Torrance's inputs, and the geometry's sin2_h and tan2_h, by the
    loops of brdffit.kernels.loops_geometry (numpy's log of their factors) are numpy's
    values bit for bit."""
    from brdffit.kernels import inputs, loops_geometry

    importlib.import_module("brdffit.kernels.loops")
    wi, wo = _edge_pairs(pairs)
    inputs_of = getattr(inputs, f"{model}_inputs")
    with kernels.use(True):
        compiled = Geometry(wi, wo, check=False)
        got = inputs_of(compiled)
        assert ("tan2_h" in compiled.__dict__) == (model != "ward_anisotropic")
        terms = (compiled.sin2_h, compiled.tan2_h)
        fresh = Geometry(wi, wo, check=False)
        assert loops_geometry and fresh._half_sines() is True  # the compiled pass runs
    with kernels.use(False):
        plain = Geometry(wi, wo, check=False)
        want = inputs_of(plain)
        for a, b in zip((*got, *terms), (*want, plain.sin2_h, plain.tan2_h)):
            np.testing.assert_array_equal(a, b)
