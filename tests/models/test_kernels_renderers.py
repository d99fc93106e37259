"""The compiled kernels of the renderer-native models (brdffit.kernels.bind_renderers)
where they differ in kind from the others: the one-slot cache of the dielectric
Fresnel factor, per-channel colours, and Mitsuba's perfect conductor. Their values
over the whole parameter box are checked with every compiled model in
test_kernels.py; their reference and Mitsuba tests run on both paths in
test_models_renderer_native.py."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import NEEDS_KERNELS, hemisphere_pairs, pairs_at_height, with_f32

from brdffit import kernels
from brdffit.data.geometry import Geometry
from brdffit.models import get_model

pytestmark = NEEDS_KERNELS

#: fast_exp's flush (test_kernels.py): no exponential here, so values agree to rounding.
TOLERANCE = 1e-12


#: Every renderer-native model with a compiled form (brdffit.kernels.bind_renderers).
RENDERER_MODELS = [
    "gltf_pbr", "gltf_pbr_anisotropic", "mitsuba_roughconductor",
    "mitsuba_roughconductor_anisotropic", "mitsuba_principled",
    "mitsuba_principled_anisotropic", "mitsuba_roughplastic",
]  # fmt: skip


def _both(model, geometry, params) -> tuple:
    with kernels.use(True):
        compiled = model.evaluate_prepared(geometry, params)
    with kernels.use(False):
        reference = model.evaluate_prepared(geometry, params)
    return compiled, reference


def test_the_fresnel_slot_follows_the_index_and_holds_one():
    """Principled at one ``specular``, another, the first again, then roughplastic on
    the same geometry: every value is the numpy model's, and the geometry keeps one
    Fresnel array per dtype, that of the last index asked (principled's loop of unit
    directions reads the float32 one, roughplastic the float64 one)."""
    from brdffit.kernels.bind_renderers import dielectric_fresnel
    from brdffit.models.mitsuba_principled import principled_eta

    geometry = Geometry(*hemisphere_pairs(1500, seed=31))
    principled = get_model("mitsuba_principled")
    for specular in (0.5, 0.1, 0.5):
        params = {**principled.defaults(), "specular": specular, "metallic": 0.3}
        compiled, reference = _both(principled, geometry, params)
        rtol = with_f32(TOLERANCE, principled.name)
        np.testing.assert_allclose(compiled, reference, rtol=rtol, atol=0)
    single = geometry.cached("kernels.dielectric_slot_float32", dict)
    assert list(single) == ["last"] and single["last"][0] == principled_eta(0.5)
    plastic = get_model("mitsuba_roughplastic")
    params = {**plastic.defaults(), "eta": 2.0}
    compiled, reference = _both(plastic, geometry, params)
    np.testing.assert_allclose(compiled, reference, rtol=TOLERANCE, atol=0)
    slot = geometry.cached("kernels.dielectric_slot", dict)
    assert list(slot) == ["last"] and slot["last"][0] == 2.0
    assert dielectric_fresnel(geometry, 2.0) is slot["last"][1]  # a hit: the same array
    dielectric_fresnel(geometry, principled_eta(0.5))  # a miss replaces the slot
    assert list(slot) == ["last"] and slot["last"][0] == principled_eta(0.5)


@pytest.mark.parametrize(
    "name",
    ["gltf_pbr", "gltf_pbr_anisotropic", "mitsuba_roughconductor", "mitsuba_principled",
     "mitsuba_roughplastic"],
)  # fmt: skip
def test_per_channel_colours_combine_the_compiled_columns(name):
    """A colour given per channel makes the compiled evaluation decline (None) and
    the model combine the compiled design's columns: the numpy values."""
    model = get_model(name)
    wi, wo = hemisphere_pairs(400, seed=32)
    params = {**model.defaults(), model.linear_params[0].name: np.array([0.1, 0.45, 0.8])}
    with kernels.use(True):
        got = model.evaluate(wi, wo, params)
    with kernels.use(False):
        expected = model.evaluate(wi, wo, params)
    assert got.shape == (wi.shape[0], 3)
    np.testing.assert_allclose(got, expected, rtol=with_f32(TOLERANCE, name), atol=0)


@pytest.mark.parametrize(
    "eta, k", [(0.0, 1.0), (0.0, 1e-50), (0.0, 4.0), (0.0, 1e-100), (0.0, 0.0), (0.2, 3.0)]
)
@pytest.mark.parametrize("name", ["mitsuba_roughconductor", "mitsuba_roughconductor_anisotropic"])
def test_the_perfect_conductor_skips_only_a_fresnel_factor_of_exactly_one(name, eta, k):
    """``eta = 0`` with ``k > 0`` is Mitsuba's material "none", where the numpy conductor
    Fresnel is exactly 1 and the loop skips it; ``eta = k = 0`` is not (numpy's form
    gives F = 1/2 at V.H = 1, the pair L = V = N included here): both agree."""
    model = get_model(name)
    wi, wo = hemisphere_pairs(800, seed=33)
    params = {**model.defaults(), "eta": eta, "k": k}
    compiled, reference = _both(model, Geometry(wi, wo), params)
    np.testing.assert_allclose(compiled, reference, rtol=with_f32(TOLERANCE, name), atol=0)
    if (eta, k) == (0.0, 0.0):  # at L = V = N, half of the perfect conductor's value
        at_normal = (wi[:, 2] == 1.0) & (wo[:, 2] == 1.0)
        perfect, _ = _both(model, Geometry(wi, wo), {**params, "k": 1.0})
        assert at_normal.sum() == 1
        assert compiled[at_normal] == pytest.approx(0.5 * perfect[at_normal], rel=1e-15)


def test_roughplastic_without_diffuse_skips_its_table_and_equals_numpy():
    from brdffit.kernels.plastic_table import transmittance_table

    model = get_model("mitsuba_roughplastic")
    geometry = Geometry(*hemisphere_pairs(600, seed=34))
    params = {**model.defaults(), "diffuse": 0.0, "alpha": 0.37}
    asked = transmittance_table.cache_info()
    compiled, reference = _both(model, geometry, params)
    calls = transmittance_table.cache_info()
    assert (calls.hits, calls.misses) == (asked.hits, asked.misses)  # the table: not asked
    np.testing.assert_allclose(compiled, reference, rtol=TOLERANCE, atol=0)
    assert np.all(compiled > 0.0) and math.isfinite(compiled.max())
    with kernels.use(True):
        model.evaluate_prepared(geometry, {**params, "diffuse": 0.2})
    after = transmittance_table.cache_info()
    assert after.hits + after.misses > calls.hits + calls.misses  # with a diffuse term it is


def test_the_compiled_transmittance_table_is_the_numpy_models():
    """Over roughplastic's box of alpha and eta (bounds included), the compiled table
    equals the numpy integral to rounding: 1024 terms summed in another order."""
    from brdffit.kernels.plastic_table import transmittance_table as compiled
    from brdffit.models.mitsuba_plastic import transmittance_table as reference

    model = get_model("mitsuba_roughplastic")
    alpha, eta = model.param("alpha"), model.param("eta")
    for a in (alpha.lower, 0.004, 0.05, 0.3, alpha.upper):
        for e in (eta.lower, 1.5, eta.upper):
            np.testing.assert_allclose(compiled(a, e), reference(a, e), rtol=1e-13, atol=0)


@pytest.mark.parametrize("k", [1e-70, 1e-30, 0.5, 1.0, 10.0])
def test_the_conductor_fresnel_factor_is_exactly_one_where_the_models_skip_it(k):
    """perfect_conductor(0, k): the numpy and the compiled models skip F; it is exactly
    1 at every V.H in [0, 1], grazing and normal included. Not at k = 1e-100 (1/2 at
    V.H = 1, where t0^2 underflows), which perfect_conductor refuses."""
    from brdffit.models.renderer_native import perfect_conductor
    from brdffit.models.shared import fresnel_conductor

    c = np.concatenate([np.linspace(0.0, 1.0, 200_001), np.geomspace(1e-300, 1e-3, 500)])
    assert perfect_conductor(0.0, k)
    assert np.all(fresnel_conductor(c, 0.0, k) == 1.0)
    assert not perfect_conductor(0.0, 1e-100) and not perfect_conductor(1e-9, 1.0)
    assert fresnel_conductor(np.array([1.0]), 0.0, 1e-100)[0] == 0.5


def test_the_roughplastic_loops_refuse_a_table_of_another_size():
    """The loops copy the table to a stack array of TABLE_SIZE values (so that their
    look-ups vectorise): a table of another size is refused, not read or written past
    its end."""
    from brdffit.kernels import loops_renderers as loops
    from brdffit.kernels.plastic_table import TABLE_SIZE, transmittance_table

    z = np.linspace(0.01, 1.0, 50)
    table = transmittance_table(0.2, 1.5)
    good = loops.plastic_diffuse(z, z, table, 1.5, np.empty(50))
    assert table.shape == (TABLE_SIZE,) and np.all(good > 0.0)
    for size in (TABLE_SIZE - 1, TABLE_SIZE + 1):
        with pytest.raises(ValueError, match=f"TABLE_SIZE = {TABLE_SIZE} values"):
            loops.plastic_diffuse(z, z, np.ones(size), 1.5, np.empty(50))
        with pytest.raises(ValueError, match=f"TABLE_SIZE = {TABLE_SIZE} values"):
            loops.plastic_evaluate(z, z, z, z, z, z, z, np.ones(size), 1.5, 0.04, 0.5, 1.0,
                                   np.empty(50))  # fmt: skip


def test_fast_reciprocal_is_accurate_to_rounding_over_the_normal_range():
    """elementary.fast_reciprocal (float32 division of the mantissa, exponent from the
    bits, two Newton steps) within 4 ulps of 1/x from the smallest normal double to
    2^1021, far beyond float32's range, where a float32 estimate of x alone fails."""
    import sys

    import numba

    from brdffit.kernels._compile import FLAGS
    from brdffit.kernels.elementary import fast_reciprocal

    @numba.njit(fastmath=FLAGS, error_model="numpy")
    def run(x, out):
        for i in range(x.shape[0]):
            out[i] = fast_reciprocal(x[i])
        return out

    tiny = sys.float_info.min
    x = np.concatenate([np.geomspace(tiny, 2.0**1021, 400_001), [1.0, 2.0, 3.0, 1e-40, 1e40]])
    rel = np.abs(run(x, np.empty_like(x)) * x - 1.0)
    assert rel.max() < 4 * np.finfo(float).eps, rel.max()


@pytest.mark.parametrize("name", RENDERER_MODELS)
def test_directions_off_unit_length_give_the_numpy_values(name):
    """Directions are accepted within 1e-6 of unit length and not normalised; the
    anisotropic loops compute H and the cosines from the components of L and V, so
    they must not assume unit length: compiled and numpy agree there too (with
    eta != 0 so that the conductor's Fresnel factor, from V.H, is computed)."""
    model = get_model(name)
    wi, wo = hemisphere_pairs(1500, seed=36)
    rng = np.random.default_rng(36)
    wi = wi * (1.0 + rng.uniform(-9e-7, 9e-7, (wi.shape[0], 1)))
    wo = wo * (1.0 + rng.uniform(-9e-7, 9e-7, (wo.shape[0], 1)))
    params = {**model.defaults(), **({"eta": 0.3, "k": 2.0} if "conductor" in name else {})}
    geometry = Geometry(wi, wo)
    # principled's loop for directions off unit length reads float64 only
    tolerance = TOLERANCE if name == "mitsuba_principled" else with_f32(TOLERANCE, name)
    compiled, reference = _both(model, geometry, params)
    np.testing.assert_allclose(compiled, reference, rtol=tolerance, atol=0)
    shape = {p.name: params[p.name] for p in model.shape_params}
    with kernels.use(True):
        design = model.design(geometry, shape)
    with kernels.use(False):
        expected = model.design(geometry, shape)
    for got, want in zip((*design.columns, design.offset), (*expected.columns, expected.offset)):
        if want is not None:
            np.testing.assert_allclose(got, want, rtol=tolerance, atol=0)


@pytest.mark.parametrize("name", RENDERER_MODELS)
@pytest.mark.parametrize("z", [1e-12, 1e-40, 1e-100])
def test_directions_just_above_the_horizon_give_the_numpy_values(name, z):
    """L and V at height ``z`` above the horizon (valid pairs: z > 0), opposite,
    equal, orthogonal and in between, where N.H, N.L and N.V are clamped and ``|L +
    V|`` can be as small as ``2 z``: compiled and numpy agree, with no overflow."""
    model = get_model(name)
    wi, wo = pairs_at_height(z)
    params = {**model.defaults(), **({"eta": 0.3, "k": 2.0} if "conductor" in name else {})}
    compiled, reference = _both(model, Geometry(wi, wo), params)
    assert np.all(np.isfinite(reference))
    np.testing.assert_allclose(compiled, reference, rtol=with_f32(TOLERANCE, name), atol=0)


@pytest.mark.parametrize("z", [1e-160, 1e-200, 1e-250, 1e-295])
def test_gltf_anisotropic_with_l_and_v_exactly_opposite_but_for_their_height(z):
    """L and V opposite to the last bit but for their height ``z`` (``L + V = (0, 0,
    2z)``): below the clamps the BRDF is that at ``z = 1e-100`` (H = N, N.L and N.V
    clamped, Schlick's weight 1), and the compiled loop gives it; its ``|L + V|^2``
    underflowed to 0 for ``z < 1e-162`` (NaN; now for ``z < 4e-298`` only). The numpy
    model is off there too (its H divides by at least 1e-300, and its ``|L + V|`` is
    a subnormal number's root), so the reference is the loop's own value at 1e-100,
    which the test above holds to numpy's."""
    model = get_model("gltf_pbr_anisotropic")
    params = {**model.defaults(), "anisotropy_strength": 0.7, "anisotropy_rotation": 0.4}
    angles = np.radians([0.0, 20.0, 90.0, 137.0])
    values = []
    for height in (1e-100, z):
        r = math.sqrt(1.0 - height * height)
        wi = np.stack([r * np.cos(angles), r * np.sin(angles), np.full(4, height)], axis=1)
        wo = wi * np.array([-1.0, -1.0, 1.0])
        with kernels.use(True):
            values.append(model.evaluate_prepared(Geometry(wi, wo), params))
    assert np.all(np.isfinite(values[1]))
    np.testing.assert_allclose(values[1], values[0], rtol=TOLERANCE, atol=0)


def test_unit_directions_decides_which_principled_loop_runs():
    """The five-array principled loop (G1 from the cosines, exact for unit L and V)
    runs only where every squared length is within UNIT_ERROR of 1."""
    from brdffit.kernels.inputs_renderers import UNIT_ERROR, principled_inputs, unit_directions

    wi, wo = hemisphere_pairs(300, seed=37)
    assert unit_directions(Geometry(wi, wo))
    assert principled_inputs(Geometry(wi, wo))[0] == "principled_unit"
    for scale, unit in ((1.0 + 0.1 * UNIT_ERROR, True), (1.0 + 10.0 * UNIT_ERROR, False)):
        geometry = Geometry(wi, wo * scale)
        assert unit_directions(geometry) is unit
        assert principled_inputs(geometry)[0] == ("principled_unit" if unit else "principled")


def test_the_principled_diffuse_sensitivity_bounds_the_diffuse_and_is_reached():
    """inputs_renderers.principled_diffuse_sensitivity bounds ``|d ln diffuse / d ln
    c|`` of Burley's diffuse (central differences over random cosines and
    retro-reflection weights R in [0, 2]; the largest found is about 0.44, the bound
    1.50: pessimistic, not wrong by more than 4x), and is under 2, so that the colour
    column's diffuse stays within the ``4u`` of its specular part (the premise of
    PRINCIPLED_F32_ERROR's ``5u``)."""
    from brdffit.kernels.inputs_renderers import principled_diffuse_sensitivity

    bound = principled_diffuse_sensitivity()
    rng = np.random.default_rng(41)
    c, other, r = rng.uniform(0.0, 1.0, (3, 200_000))
    r = 2.0 * r

    def log_diffuse(cos):
        w, wv = (1.0 - cos) ** 5, (1.0 - other) ** 5
        return np.log((1 - 0.5 * w) * (1 - 0.5 * wv) + r * (w + wv + w * wv * (r - 1.0)))

    h = 1e-6
    sensitivity = np.abs(log_diffuse(c * (1 + h)) - log_diffuse(c * (1 - h))) / (2 * h)
    assert bound / 4 < sensitivity.max() <= bound * (1 + 1e-6)
    assert bound < 2.0


def test_principleds_fresnel_factor_is_zero_or_a_normal_float32_number():
    """The unit loop reads F in float32, whose rounding is within 2^-24 relative
    (PRINCIPLED_F32_ERROR's premise) only for 0 and float32's normal numbers: over
    specular from 1e-40 to 1 (the index is exactly 1 below about 1e-32, then at least
    1 + 4.4e-16) and V.H over [0, 1], every F is 0 or above float32's smallest normal
    number, and the float32 slot holds the float64 factor rounded."""
    from brdffit.kernels.bind_renderers import dielectric_fresnel, dielectric_fresnel32
    from brdffit.kernels.loops_renderers import dielectric
    from brdffit.models.mitsuba_principled import principled_eta

    cos_d = np.concatenate([np.linspace(0.0, 1.0, 200_001), np.geomspace(1e-300, 1.0, 2000)])
    tiny = np.finfo(np.float32).tiny
    etas = sorted({principled_eta(s) for s in np.geomspace(1e-40, 1.0, 400)})
    assert etas[0] == 1.0 and etas[1] - 1.0 < 1e-15  # the smallest indices are reached
    for eta in etas:
        f = dielectric(cos_d, eta, np.empty(cos_d.size))
        assert np.all((f == 0.0) | (f > tiny)), eta
    geometry = Geometry(*hemisphere_pairs(1500, seed=42))
    single = dielectric_fresnel32(geometry, etas[1])
    assert single.dtype == np.float32
    np.testing.assert_array_equal(single, dielectric_fresnel(geometry, etas[1]).astype(np.float32))


def test_roughplastics_unit_loop_gives_the_seven_array_loops_values(monkeypatch):
    """For directions of unit length roughplastic's values come from four arrays (the
    cosines from the table's z, G1 from the cosines), within rounding of those of the
    seven-array loop that runs off unit length; each runs where it should."""
    from brdffit.kernels import bind_renderers, inputs_renderers
    from brdffit.kernels import loops_renderers as loops
    from brdffit.kernels.bind_renderers import dielectric_fresnel
    from brdffit.kernels.inputs_renderers import UNIT_ERROR
    from brdffit.kernels.plastic_table import transmittance_table

    wi, wo = hemisphere_pairs(3000, seed=43)
    heights = [pairs_at_height(z) for z in (1e-12, 1e-40)]
    wi = np.concatenate([wi, *(h[0] for h in heights)])
    wo = np.concatenate([wo, *(h[1] for h in heights)])
    geometry = Geometry(wi, wo)
    for alpha, eta in ((0.001, 1.05), (0.1, 1.5), (1.0, 3.0)):
        table, fresnel = transmittance_table(alpha, eta), dielectric_fresnel(geometry, eta)
        z = inputs_renderers.plastic_z(geometry)
        arrays = (*inputs_renderers.plastic_inputs(geometry), fresnel)
        terms = (table, eta, alpha * alpha, 0.7, 1.3, np.empty(geometry.m))
        seven = loops.plastic_evaluate(*z, *arrays, *terms)
        four = loops.plastic_unit(*z, geometry.tan2_h, fresnel, *terms)
        np.testing.assert_allclose(four, seven, rtol=1e-13, atol=0)
    ran = []
    real = bind_renderers._loop
    monkeypatch.setattr(bind_renderers, "_loop", lambda name: ran.append(name) or real(name))
    model = get_model("mitsuba_roughplastic")
    for scale in (1.0, 1.0 + 10.0 * UNIT_ERROR):
        with kernels.use(True):
            model.evaluate_prepared(Geometry(wi, wo * scale), model.defaults())
    assert [name for name in ran if name.startswith("plastic")] == [
        "plastic_unit",
        "plastic_evaluate",
    ]
