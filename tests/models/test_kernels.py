"""The compiled kernels (brdffit.kernels): their pieces against libm and scipy, and
every compiled model against its numpy design over its whole parameter box.

The models' reference tests (test_models_*.py, test_model_invariants.py) also run
on both paths (the ``evaluation_path`` fixture of conftest.py)."""

from __future__ import annotations

import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import (  # noqa: F401 (the fixture)
    NEEDS_KERNELS,
    compiled_for_every_size,
    hemisphere_pairs,
    pairs_at_height,
    random_params,
    stable_seed,
    with_f32,
)
from scipy.special import erf

from brdffit import kernels
from brdffit.data.geometry import Geometry
from brdffit.models import get_model

pytestmark = [NEEDS_KERNELS, pytest.mark.usefixtures("compiled_for_every_size")]


#: fast_exp flushes results below exp(-708) to 0 (see its docstring).
FLUSH = math.exp(-708.0)


def test_fast_exp_is_accurate_to_rounding_and_flushes_below_its_minimum():
    import numba

    from brdffit.kernels._compile import EXP_MIN, FLAGS, fast_exp

    @numba.njit(fastmath=FLAGS)
    def run(x, out):
        for i in range(x.shape[0]):
            out[i] = fast_exp(x[i])
        return out

    x = np.concatenate([np.random.default_rng(1).uniform(-720.0, 0.0, 200_000), [0.0, -1e-300]])
    got = run(x, np.empty_like(x))
    normal = x >= EXP_MIN
    rel = np.abs(got[normal] / np.exp(x[normal]) - 1.0)
    assert rel.max() < 3e-16, rel.max()
    assert (got[~normal] == 0.0).all() and (~normal).sum() > 1000


def test_the_rational_smith_masking_of_beckmann_matches_erf():
    """smith.g1 (what the loops compute) against the exact G1 from scipy's erf on a
    dense grid of a = 1/(alpha tan) from 1e-300 to far past A_MAX: within the stated
    bound, which is of the order of the fit's own error (not a loose one)."""
    from brdffit.kernels import smith

    a = np.concatenate(
        [np.geomspace(1e-300, 1e-3, 2001), np.linspace(1e-3, 8.0, 400_001), [50.0, 1e10]]
    )
    expected = 2.0 / (1.0 + erf(a) + np.exp(-a * a) / (a * math.sqrt(math.pi)))
    error = np.max(np.abs(smith.g1(a) / expected - 1.0))
    assert error < smith.MAX_ERROR, error
    assert error > smith.MAX_ERROR / 4, "MAX_ERROR overstates the error: tighten it"
    x = np.linspace(-1.0, 1.0, 10_001)
    a = (x + 1.0) * (smith.A_MAX / 2)
    assert np.all(np.polyval(smith.Q, x) > 0.0)  # no pole of P/Q on [0, A_MAX]
    # the denominators: positive, and their products within the range of the loops'
    # float32-seeded reciprocal (loops_microfacet._reciprocal)
    d = a * np.polyval(smith.Q, x) + np.polyval(smith.P, x)
    assert 0.03 < d.min() and d.max() < 13.0, (d.min(), d.max())


def test_refitting_the_smith_masking_gives_the_stored_coefficients():
    from brdffit.kernels import smith

    p, q, worst = smith.fit()
    np.testing.assert_allclose(p, smith.P, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(q, smith.Q, rtol=1e-9, atol=1e-15)
    assert worst < smith.MAX_ERROR


def test_the_compiled_beckmann_loop_computes_the_rational_smith_masking():
    """The loop's G1(L) G1(V) (D's factor and exponent zeroed, V at the normal) equals
    smith.g1's at a = cot/alpha, from a -> 0 to past A_MAX."""
    from brdffit.kernels import loops_microfacet, smith
    from brdffit.kernels.inputs import COT_MAX

    alpha = 0.3
    cot = np.geomspace(1e-9, 1e3, 5001)
    zeros = np.zeros_like(cot)
    got = loops_microfacet.beckmann(
        zeros,
        cot,
        np.full_like(cot, COT_MAX),
        np.full_like(cot, math.log(math.pi * alpha**2)),  # cancels D's 1/(pi alpha^2)
        zeros,
        alpha**2,
        1.0,
        1.0,
        0.0,
        np.empty_like(cot),
    )
    expected = smith.g1(cot / alpha) * smith.g1(COT_MAX / alpha)
    np.testing.assert_allclose(got, expected, rtol=1e-14, atol=0)


def test_one_newton_step_roots_are_within_their_bound():
    """loops_microfacet.rsqrt and sqrt_short (a float32 estimate, one Newton step in
    float64) within SHORT_NEWTON_ERROR (2e-13) of 1/sqrt(x) and sqrt(x) over
    [RSQRT_MIN, RSQRT_MAX], compiled as the loops are (eight lanes on AVX-512, whose
    float32 estimates are the least accurate)."""
    import numba

    from brdffit.kernels._compile import FLAGS
    from brdffit.kernels.loops_microfacet import (
        RSQRT_MAX,
        RSQRT_MIN,
        SHORT_NEWTON_ERROR,
        rsqrt,
        sqrt_short,
        wide,
    )

    @wide
    @numba.njit(fastmath=FLAGS, error_model="numpy")
    def run(x, roots, direct):
        for i in range(x.shape[0]):
            roots[i] = rsqrt(x[i])
            direct[i] = sqrt_short(x[i])

    rng = np.random.default_rng(8)
    x = np.concatenate(
        [
            np.geomspace(RSQRT_MIN, RSQRT_MAX, 500_001),
            np.exp(rng.uniform(math.log(RSQRT_MIN), math.log(RSQRT_MAX), 500_000)),
            [1.0, 2.0, 1e20],
        ]
    )
    roots, direct = np.empty_like(x), np.empty_like(x)
    run(x, roots, direct)
    assert np.abs(roots * np.sqrt(x) - 1.0).max() < SHORT_NEWTON_ERROR
    assert np.abs(direct / np.sqrt(x) - 1.0).max() < SHORT_NEWTON_ERROR


def test_wide_compiles_eight_lanes_and_sets_the_vectoriser_back():
    """On AVX-512, the first call of a ``wide`` loop with each kind of arguments
    compiles it with 512-bit vectors (zmm registers), and a loop compiled after it
    gets LLVM's default width again; without AVX-512, ``wide`` leaves the function
    as it is."""
    import llvmlite.binding as llvm
    import numba

    from brdffit.kernels._compile import FLAGS
    from brdffit.kernels.loops_microfacet import wide

    def scale(x, out):
        for i in range(x.shape[0]):
            out[i] = 3.0 * x[i]
        return out

    def compiled():
        return numba.njit(fastmath=FLAGS, error_model="numpy")(scale)

    x = np.arange(64.0)
    function = wide(compiled())
    if not llvm.get_host_cpu_features().get("avx512f", False):
        assert isinstance(function, numba.core.registry.CPUDispatcher)
        return
    np.testing.assert_array_equal(function(x, np.empty(64)), 3.0 * x)
    # a second kind of arguments (float32 input): its own compilation, also wide
    np.testing.assert_array_equal(function(x.astype(np.float32), np.empty(64)), 3.0 * x)
    dispatcher = function.__wrapped__
    assert len(dispatcher.signatures) == 2
    for signature in dispatcher.signatures:
        assert "zmm" in dispatcher.inspect_asm(signature)
    after = compiled()
    after(x, np.empty(64))
    assert "zmm" not in after.inspect_asm(after.signatures[0])


def test_the_named_models_are_those_with_a_kernel():
    """COMPILED_MODELS is written out (brdffit.kernels imports its bind module only in
    install()); it names exactly the models that install() binds."""
    from brdffit.kernels.bind import SPECS

    assert sorted(kernels.COMPILED_MODELS) == sorted(SPECS)


@pytest.mark.parametrize("name", kernels.COMPILED_MODELS)
def test_every_named_model_is_bound_to_its_kernel(name):
    from brdffit.kernels.bind import MODULES, CompiledDesign

    design = get_model(name).design
    assert isinstance(design, CompiledDesign)
    assert not isinstance(design.reference, CompiledDesign)
    # the loop modules it imports on first use (kernels.wanted) exist and hold its loop
    assert design.modules == MODULES[name] and design.modules
    for module in design.modules:
        assert kernels.wanted(10**6, modules=(module,))
    loop = getattr(design.compiled, "loop", None)
    if loop:  # principled's "": its inputs choose one of two loops per geometry
        assert hasattr(sys.modules[f"brdffit.kernels.{design.modules[0]}"], loop)


def _relative(got, expected) -> float:
    got, expected = np.broadcast_arrays(np.asarray(got, float), np.asarray(expected, float))
    big = np.abs(expected) > FLUSH * 1e3
    assert (np.abs(got[~big] - expected[~big]) <= 1e3 * FLUSH).all()
    return float(np.max(np.abs(got[big] / expected[big] - 1.0), initial=0.0))


@pytest.mark.parametrize("name", kernels.COMPILED_MODELS)
def test_compiled_design_and_evaluation_equal_numpy_across_the_parameter_box(name):
    """Random parameters over the whole box (log-uniform where searched so) and its
    corners, on pairs including grazing ones: columns, offset and values agree with
    the numpy design to 1e-11 relative (exponents reach several hundred; one ulp of
    an exponent of 700 is a relative 1e-13 in the value), or within the stated error
    of float32 inputs (helpers.with_f32)."""
    model = get_model(name)
    tolerance = with_f32(1e-11, name)
    wi, wo = hemisphere_pairs(2000, seed=stable_seed(name))
    geometry = Geometry(wi, wo)
    rng = np.random.default_rng(stable_seed(name))
    sets = [random_params(model, rng) for _ in range(20)]
    sets += [random_params(model, rng, corner) for corner in ("lower", "upper")]
    for params in sets:
        params = model.check_params(params)
        shape = {p.name: params[p.name] for p in model.shape_params}
        compiled = model.design(geometry, shape)
        with kernels.use(False):
            reference = model.design(geometry, shape)
            expected = model.evaluate_prepared(geometry, params)
        for got, want in zip(compiled.columns, reference.columns):
            assert _relative(got, want) < tolerance, params
        if reference.offset is not None:
            assert _relative(compiled.offset, reference.offset) < tolerance, params
        assert _relative(model.evaluate_prepared(geometry, params), expected) < tolerance, params


def _f32_models() -> list:
    from brdffit.kernels import inputs

    return sorted(inputs.F32_ERROR)


@pytest.mark.parametrize("name", _f32_models())
def test_float32_inputs_cost_what_their_bound_states(name):
    """The loops that read float32 inputs stay within the stated bound of the float64
    numpy model, and the bound is not slack: the largest error over random
    parameters is within a factor 10 of it (float32 rounding, not a 1e-11 path); the
    model's doc states a bound at least as large."""
    model = get_model(name)
    geometry = Geometry(*hemisphere_pairs(20_000, seed=5))
    rng = np.random.default_rng(stable_seed(name))
    worst = 0.0
    for _ in range(10):
        params = model.check_params(random_params(model, rng))
        got = model.evaluate_prepared(geometry, params)
        with kernels.use(False):
            worst = max(worst, _relative(got, model.evaluate_prepared(geometry, params)))
    bound = with_f32(0.0, name)
    assert bound / 10 < worst < bound, worst
    # the model's doc states a bound that holds
    stated = re.search(r"float32: within ([0-9.e-]+) relative", model.doc)
    assert stated and float(stated.group(1)) >= bound, model.doc


@pytest.mark.parametrize("name", ["beckmann", "ggx_anisotropic", "beckmann_anisotropic"])
@pytest.mark.parametrize("z", [1e-12, 1e-40, 1e-100])
def test_float32_loops_agree_with_numpy_just_above_the_horizon(name, z):
    """L and V at height ``z`` (opposite, equal, orthogonal and in between), where N.L,
    N.V and N.H are clamped at 1e-10: the loops that read float32 inputs stay finite and
    within their bound. (Anisotropic GGX read ``1 / (4 (N.L)(N.V)(N.H)^4)`` in float32,
    2.5e59 at L = V there: infinite in float32, and its value ``inf`` where numpy's is
    0.16; it now reads ``1 / (4 (N.L)(N.V))``.)"""
    model = get_model(name)
    wi, wo = pairs_at_height(z)
    geometry = Geometry(wi, wo)
    params = model.defaults()
    got = model.evaluate_prepared(geometry, params)
    with kernels.use(False):
        expected = model.evaluate_prepared(geometry, params)
    assert np.all(np.isfinite(got)) and np.all(expected > 0.0)
    assert _relative(got, expected) < with_f32(1e-11, name)


@pytest.mark.parametrize("name", kernels.COMPILED_MODELS)
def test_per_channel_coefficients_give_numpys_values(name):
    """Every linear parameter given per channel: the compiled evaluation (fused where
    the model's compiled form takes channels, else the compiled columns combined)
    agrees with the numpy model as the single-channel values do."""
    model = get_model(name)
    wi, wo = hemisphere_pairs(500, seed=3)
    params = model.defaults()
    for j, p in enumerate(model.linear_params):
        params[p.name] = p.default * np.array([0.25, 0.5, 1.0])[[j % 3, (j + 1) % 3, 2]]
    got = model.evaluate(wi, wo, params)
    with kernels.use(False):
        expected = model.evaluate(wi, wo, params)
    assert got.shape == (wi.shape[0], 3)
    assert _relative(got, expected) < with_f32(1e-11, name)


@pytest.mark.parametrize("name", ["blinn", "ggx", "ward_anisotropic"])
def test_the_fused_per_channel_evaluation_is_the_combined_compiled_design(name):
    """``kd / pi + ks lobe`` per channel in one compiled pass: bit for bit the numpy
    combination of the compiled design's columns (the same operations, no fused
    multiply-adds)."""
    from brdffit.models.base import combine

    model = get_model(name)
    geometry = Geometry(*hemisphere_pairs(3000, seed=4))
    params = model.check_params({**model.defaults(), "kd": np.array([0.1, 0.0, 0.3]),
                                 "ks": np.array([0.7, 1.5, 0.2])})  # fmt: skip
    shape = {p.name: params[p.name] for p in model.shape_params}
    assert model.design.compiled.by_channel
    combined = combine(model.design(geometry, shape), model.coefficient_values(params), 3000)
    np.testing.assert_array_equal(model.evaluate_prepared(geometry, params), combined)


def test_the_environment_switches_the_kernels_off():
    root = Path(__file__).resolve().parents[2]
    code = "from brdffit import kernels; print(kernels.enabled())"
    env = {**os.environ, "PYTHONPATH": str(root), "BRDFFIT_KERNELS": "0"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert out.stdout.strip() == "False", out.stderr
    with kernels.use(False):
        assert not kernels.enabled() and not kernels.wanted(10**6)
    with kernels.use(None):
        assert kernels.enabled() and kernels.wanted(kernels.MIN_PAIRS)
        assert not kernels.wanted(kernels.MIN_PAIRS - 1)


@pytest.mark.parametrize(("name", "module"), [("ggx", "loops"), ("gltf_pbr", "loops_renderers")])
def test_a_loop_module_that_fails_to_import_leaves_the_numpy_formulas(monkeypatch, name, module):
    """A broken numba (one that does not support the installed numpy, say) warns once
    and the models whose loops the module holds evaluate as without it, even with the
    kernels switched on for every size. (Before, kernels.wanted() did not try
    loops_renderers: the kernels stayed on and the first evaluation raised.)"""
    model = get_model(name)
    wi, wo = hemisphere_pairs(200, seed=4)
    with kernels.use(False):
        expected = model.evaluate(wi, wo, model.defaults())
    monkeypatch.delitem(kernels._state, "loaded", raising=False)
    monkeypatch.delattr(kernels, module, raising=False)
    monkeypatch.setitem(sys.modules, f"brdffit.kernels.{module}", None)  # import fails
    with pytest.warns(RuntimeWarning, match="compiled kernels are off"):
        assert not kernels.wanted(10**6, modules=(module,))
    assert not kernels.wanted(10**6, modules=(module,))  # once: no second warning
    np.testing.assert_array_equal(model.evaluate(wi, wo, model.defaults()), expected)
    with kernels.use(True):
        np.testing.assert_array_equal(model.evaluate(wi, wo, model.defaults()), expected)


def _batch_of_shapes(name: str, pairs: int, seed: int, walkers: int):
    """A model, a geometry, ``walkers`` random shape parameter rows and those rows as
    a batch of shape (walkers, 1) per parameter."""
    model = get_model(name)
    geometry = Geometry(*hemisphere_pairs(pairs, seed=seed))
    rng = np.random.default_rng(stable_seed(name))
    rows = [random_params(model, rng) for _ in range(walkers)]
    names = [p.name for p in model.shape_params]
    return model, geometry, rows, {k: np.array([[r[k]] for r in rows]) for k in names}


def _assert_rows_are_designs(model, geometry, rows, design, tolerance: float) -> None:
    """Row w of each column of ``design`` (or the column, when it is the same for every
    row) is the design of ``rows[w]`` alone."""
    names = [p.name for p in model.shape_params]
    for w, row in enumerate(rows):
        expected = model.design(geometry, {k: row[k] for k in names})
        for got, want in zip(design.columns, expected.columns):
            got = got[w] if np.ndim(got) == 2 else got
            assert _relative(got, want) < tolerance


@pytest.mark.parametrize("name", kernels.COMPILED_MODELS)
def test_a_batch_of_shapes_gives_each_rows_design(name):
    """The posterior sampler asks for the designs of all walkers at once, shape
    parameters of shape (W, 1): row w of each column is the design at row w."""
    model, geometry, rows, batch = _batch_of_shapes(name, 300, 6, 4)
    design = model.design(geometry, batch)
    with kernels.use(False):
        _assert_rows_are_designs(model, geometry, rows, design, with_f32(1e-11, name))


@pytest.mark.parametrize("name", ["ggx_anisotropic", "beckmann_anisotropic"])
def test_the_anisotropic_numpy_designs_take_a_batch_of_shapes(name):
    """The anisotropic GGX and Beckmann numpy designs (kernels off, under
    MIN_PAIRS) take shape parameters of shape (W, 1), so the posterior evaluates
    all walkers in one call (posterior/design.py; models that cannot are looped):
    row w is the design at row w. Before, ``projected_alpha2`` wrote a (W, M)
    product into an (M,) array and the sampler fell back to the loop."""
    model, geometry, rows, batch = _batch_of_shapes(name, 200, 7, 3)
    with kernels.use(False):
        design = model.design(geometry, batch)
        _assert_rows_are_designs(model, geometry, rows, design, 1e-12)
