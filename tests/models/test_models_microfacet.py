"""Ward, Torrance-Sparrow, Cook-Torrance and the GGX/Beckmann family against scalar
references written here with the math module from MODELS.md and the primary
sources (Ward 1992; Torrance-Sparrow 1967; Cook-Torrance 1982; Walter et al.
2007; Heitz 2014; Mitsuba 3's roughconductor for the perfect-conductor limit).

The references work on unit vectors component by component, in the forms the
sources print (e.g. Mitsuba's slope-space form of D and the Cook-Torrance form
of the Fresnel factor), not in the library's tan^2/azimuth form.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import hemisphere_pairs, random_params

from brdffit.data.geometry import MIN_COSINE, Geometry, directions_from_angles
from brdffit.kernels import inputs, smith
from brdffit.models import REGISTRY, microfacet, renderers

# Every test here runs on the compiled kernels and on the numpy formulas.
pytestmark = pytest.mark.usefixtures("evaluation_path")

MODELS = {m.name: m for m in (*microfacet.MODELS, *renderers.MODELS)}


# ------------------------------------------------------------ scalar helpers
def direction(theta_deg: float, phi_deg: float) -> tuple:
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return (math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t))


def dot(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def half(L, V) -> tuple:
    s = (L[0] + V[0], L[1] + V[1], L[2] + V[2])
    n = math.sqrt(dot(s, s))
    return (s[0] / n, s[1] / n, s[2] / n)


def fresnel_cook_torrance(c: float, eta: float) -> float:
    """MODELS.md's exact dielectric Fresnel, as Cook and Torrance print it."""
    g = math.sqrt(eta * eta - 1 + c * c)
    return 0.5 * (g - c) ** 2 / (g + c) ** 2 * (1 + ((c * (g + c) - 1) / (c * (g - c) + 1)) ** 2)


def schlick(c: float, f0: float) -> float:
    return f0 + (1 - f0) * (1 - c) ** 5


def vcavity(L, V, H) -> float:
    nh, vh = H[2], dot(V, H)
    return min(1.0, 2 * nh * V[2] / vh, 2 * nh * L[2] / dot(L, H))


def ward_ref(L, V, p) -> float:
    H = half(L, V)
    tan2 = (H[0] ** 2 + H[1] ** 2) / H[2] ** 2
    a2 = p["alpha"] ** 2
    lobe = math.exp(-tan2 / a2) / (4 * math.pi * a2 * math.sqrt(L[2] * V[2]))
    return p["kd"] / math.pi + p["ks"] * lobe


def torrance_sparrow_ref(L, V, p) -> float:
    H = half(L, V)
    theta_h = math.atan2(math.hypot(H[0], H[1]), H[2])
    d = math.exp(-((theta_h / p["m"]) ** 2))
    f = fresnel_cook_torrance(dot(V, H), p["eta"])
    return p["kd"] / math.pi + p["ks"] * f * d * vcavity(L, V, H) / (4 * L[2] * V[2])


def cook_torrance_ref(L, V, p) -> float:
    H = half(L, V)
    m2 = p["m"] ** 2
    tan2 = (H[0] ** 2 + H[1] ** 2) / H[2] ** 2
    d = math.exp(-tan2 / m2) / (math.pi * m2 * H[2] ** 4)
    c = dot(V, H)
    f = fresnel_cook_torrance(c, p["eta"]) if "eta" in p else schlick(c, p["f0"])
    return p["kd"] / math.pi + p["ks"] * f * d * vcavity(L, V, H) / (4 * L[2] * V[2])


def slope_d(H, au: float, av: float, distribution: str) -> float:
    """Mitsuba 3's MicrofacetDistribution::eval, slope-space form."""
    q = (H[0] / au) ** 2 + (H[1] / av) ** 2
    if distribution == "ggx":
        return 1 / (math.pi * au * av * (q + H[2] ** 2) ** 2)
    return math.exp(-q / H[2] ** 2) / (math.pi * au * av * H[2] ** 4)


def smith_g1(v, H, au: float, av: float, distribution: str) -> float:
    """Exact Smith G1 with the roughness projected on v's azimuth (Heitz 2014)."""
    if dot(v, H) * v[2] <= 0:
        return 0.0
    xy = (au * v[0]) ** 2 + (av * v[1]) ** 2
    if xy == 0:
        return 1.0
    if distribution == "ggx":
        return 2 / (1 + math.sqrt(1 + xy / v[2] ** 2))
    a = v[2] / math.sqrt(xy)
    lam = (math.erf(a) - 1) / 2 + math.exp(-a * a) / (2 * a * math.sqrt(math.pi))
    return 1 / (1 + lam)


def renderer_ref(distribution: str):
    def ref(L, V, p) -> float:
        au = p.get("alpha_u", p.get("alpha"))
        av = p.get("alpha_v", p.get("alpha"))
        H = half(L, V)
        d = slope_d(H, au, av, distribution)
        g = smith_g1(L, H, au, av, distribution) * smith_g1(V, H, au, av, distribution)
        f = schlick(dot(V, H), p["f0"])
        return p["kd"] / math.pi + p["ks"] * f * d * g / (4 * L[2] * V[2])

    return ref


REFERENCES = {
    "ward": ward_ref,
    "torrance_sparrow": torrance_sparrow_ref,
    "cook_torrance": cook_torrance_ref,
    "cook_torrance_schlick": cook_torrance_ref,
    "ggx": renderer_ref("ggx"),
    "beckmann": renderer_ref("beckmann"),
    "ggx_anisotropic": renderer_ref("ggx"),
    "beckmann_anisotropic": renderer_ref("beckmann"),
}

# (theta_i, phi_i, theta_o, phi_o) in degrees: H = N, H = N at grazing, L = V,
# grazing light with the viewer elsewhere, and generic pairs in other azimuths
# (so that anisotropic models see T and B differently).
PAIRS = (
    (40.0, 0.0, 40.0, 180.0),
    (89.9, 30.0, 89.9, 210.0),
    (35.0, 45.0, 35.0, 45.0),
    (89.5, 10.0, 30.0, 200.0),
    (20.0, 30.0, 50.0, 250.0),
    (60.0, 90.0, 10.0, 300.0),
    (25.0, 0.0, 30.0, 175.0),
    (15.0, 95.0, 18.0, 272.0),
)

SHAPES = {
    "ward": ({"alpha": 0.05}, {"alpha": 0.4}),
    "torrance_sparrow": ({"m": 0.1, "eta": 1.5}, {"m": 0.6, "eta": 2.7}),
    "cook_torrance": ({"m": 0.08, "eta": 1.33}, {"m": 0.5, "eta": 2.2}),
    "cook_torrance_schlick": ({"m": 0.08, "f0": 0.04}, {"m": 0.5, "f0": 0.9}),
    "ggx": ({"alpha": 0.05, "f0": 0.04}, {"alpha": 0.6, "f0": 0.9}),
    "beckmann": ({"alpha": 0.05, "f0": 0.04}, {"alpha": 0.6, "f0": 0.9}),
    "ggx_anisotropic": (
        {"alpha_u": 0.05, "alpha_v": 0.3, "f0": 0.04},
        {"alpha_u": 0.7, "alpha_v": 0.1, "f0": 0.9},
    ),
    "beckmann_anisotropic": (
        {"alpha_u": 0.05, "alpha_v": 0.3, "f0": 0.04},
        {"alpha_u": 0.7, "alpha_v": 0.1, "f0": 0.9},
    ),
}


#: The Beckmann models evaluate Smith's G1 as a rational function within
#: smith.MAX_ERROR (2e-8) of the exact one (brdffit.kernels.smith says why), so
#: G1(L) G1(V) is within twice that of the references' erf form.
TOLERANCE = {
    "beckmann": 2 * smith.MAX_ERROR + 1e-11,
    "beckmann_anisotropic": 2 * smith.MAX_ERROR + 1e-11,
}


def float32_error(name: str, path: str) -> float:
    """What float32 inputs add to ``name`` on the evaluation path ``path``: some
    compiled loops read some inputs in float32 (brdffit.kernels.inputs says which
    and why)."""
    return inputs.F32_ERROR.get(name, 0.0) if path == "compiled" else 0.0


@pytest.mark.parametrize("name", sorted(MODELS))
def test_model_matches_its_scalar_reference(name, evaluation_path):
    """Relative tolerance 1e-11: the exponents reach a few hundred, and one ulp of
    an exponent of 300 is a relative 7e-14 in the value; other factors add a few
    ulps. The Beckmann models and float32 inputs: see TOLERANCE, float32_error."""
    model = MODELS[name]
    rtol = TOLERANCE.get(name, 1e-11) + float32_error(name, evaluation_path)
    wi = np.array([direction(t, p) for t, p, _, _ in PAIRS])
    wo = np.array([direction(t, p) for _, _, t, p in PAIRS])
    geometry = Geometry(wi, wo)
    for shape in SHAPES[name]:
        for kd, ks in ((0.0, 1.0), (0.3, 2.5)):
            params = {"kd": kd, "ks": ks, **shape}
            got = model.evaluate_prepared(geometry, params)
            expected = [REFERENCES[name](tuple(L), tuple(V), params) for L, V in zip(wi, wo)]
            np.testing.assert_allclose(got, expected, rtol=rtol, atol=0)
    # The specular part is really exercised: the two H = N pairs carry the peak.
    lobe = model.evaluate_prepared(geometry, {"kd": 0.0, "ks": 1.0, **SHAPES[name][0]})
    assert set(np.argsort(lobe)[-2:]) == {0, 1}, lobe


def test_anisotropic_models_reduce_to_their_isotropic_forms(evaluation_path):
    wi, wo = hemisphere_pairs(2000, seed=21)
    geometry = Geometry(wi, wo)
    for distribution in ("ggx", "beckmann"):
        iso, aniso = MODELS[distribution], MODELS[f"{distribution}_anisotropic"]
        rtol = 1e-12 + float32_error(iso.name, evaluation_path)
        rtol += float32_error(aniso.name, evaluation_path)
        for alpha in (0.001, 0.02, 0.3, 1.0):
            for f0 in (0.0, 0.5):
                common = {"kd": 0.2, "ks": 1.5, "f0": f0}
                a = iso.evaluate_prepared(geometry, {**common, "alpha": alpha})
                b = aniso.evaluate_prepared(
                    geometry, {**common, "alpha_u": alpha, "alpha_v": alpha}
                )
                np.testing.assert_allclose(b, a, rtol=rtol, atol=0)


def test_alpha_u_acts_along_the_tangent():
    """A highlight tilted along T is wide when alpha_u is large, not when alpha_v is."""
    tilt = math.radians(20.0)
    for distribution in ("ggx_anisotropic", "beckmann_anisotropic"):
        model = MODELS[distribution]
        values = []
        for azimuth in (0.0, 90.0):  # H tilted towards T, then towards B
            p = math.radians(azimuth)
            h = np.array(
                [math.sin(tilt) * math.cos(p), math.sin(tilt) * math.sin(p), math.cos(tilt)]
            )
            wi = np.array([direction(30.0, azimuth + 180.0)])
            wo = 2 * np.dot(wi[0], h) * h - wi[0]
            params = {"kd": 0.0, "ks": 1.0, "alpha_u": 0.5, "alpha_v": 0.05, "f0": 1.0}
            values.append(model.evaluate(wi, wo[None, :], params)[0])
        assert values[0] > 100 * values[1], distribution


def roughconductor_eval(wi, wo, alpha_u: float, alpha_v: float) -> float:
    """Mitsuba 3 ``roughconductor.eval`` for GGX and a perfect conductor (F = 1):
    ``D(H) G1(wi, H) G1(wo, H) / (4 cos(theta_i))``, cosine-weighted."""
    if wi[2] <= 0 or wo[2] <= 0:
        return 0.0
    H = half(wi, wo)
    d = slope_d(H, alpha_u, alpha_v, "ggx")
    g = smith_g1(wi, H, alpha_u, alpha_v, "ggx") * smith_g1(wo, H, alpha_u, alpha_v, "ggx")
    return d * g / (4 * wi[2])


def test_ggx_with_unit_f0_is_mitsubas_perfect_rough_conductor(evaluation_path):
    wi, wo = hemisphere_pairs(300, seed=22)
    # Below MIN_COSINE the geometry clamps the cosines (a documented convention),
    # which Mitsuba does not: compare above it.
    above = (wi[:, 2] > MIN_COSINE) & (wo[:, 2] > MIN_COSINE)
    wi, wo = wi[above], wo[above]
    assert (np.minimum(wi[:, 2], wo[:, 2]) < 1e-4).sum() >= 2, "the 89.999 deg pairs are kept"
    for alpha in (0.01, 0.2, 0.8):
        got = MODELS["ggx"].evaluate(wi, wo, {"kd": 0.0, "ks": 1.0, "alpha": alpha, "f0": 1.0})
        expected = [roughconductor_eval(a, b, alpha, alpha) / b[2] for a, b in zip(wi, wo)]
        np.testing.assert_allclose(got, expected, rtol=1e-11, atol=0)
    au, av = 0.05, 0.4
    got = MODELS["ggx_anisotropic"].evaluate(
        wi, wo, {"kd": 0.0, "ks": 1.0, "alpha_u": au, "alpha_v": av, "f0": 1.0}
    )
    expected = [roughconductor_eval(a, b, au, av) / b[2] for a, b in zip(wi, wo)]
    rtol = 1e-11 + float32_error("ggx_anisotropic", evaluation_path)
    np.testing.assert_allclose(got, expected, rtol=rtol, atol=0)


def test_parameter_names_bounds_and_scales_follow_models_md():
    expected = {
        "ward": ("kd", "ks", "alpha"),
        "torrance_sparrow": ("kd", "ks", "m", "eta"),
        "cook_torrance": ("kd", "ks", "m", "eta"),
        "cook_torrance_schlick": ("kd", "ks", "m", "f0"),
        "ggx": ("kd", "ks", "alpha", "f0"),
        "beckmann": ("kd", "ks", "alpha", "f0"),
        "ggx_anisotropic": ("kd", "ks", "alpha_u", "alpha_v", "f0"),
        "beckmann_anisotropic": ("kd", "ks", "alpha_u", "alpha_v", "f0"),
    }
    assert set(MODELS) == set(expected)
    for name, names in expected.items():
        model = MODELS[name]
        assert model.param_names == names, name
        assert [p.name for p in model.linear_params] == ["kd", "ks"]
        for p in model.shape_params:
            if p.name in ("alpha", "alpha_u", "alpha_v", "m"):
                assert (p.lower, p.upper, p.log_scale) == (1e-3, 1.0, True), (name, p)
            elif p.name == "eta":
                assert (p.lower, p.upper, p.log_scale) == (1.0, 3.0, False)
            else:
                assert (p.lower, p.upper, p.log_scale) == (0.0, 1.0, False)
        # Normalised lobes keep ks an albedo scale; the unnormalised
        # Torrance-Sparrow D needs ks up to 1/(pi m^2) at the smallest m.
        ks = model.param("ks")
        if name == "torrance_sparrow":
            assert ks.upper >= 1 / (math.pi * model.param("m").lower ** 2)
        else:
            assert ks.upper == 10.0


def test_highlight_colour_follows_the_fresnel_factor():
    """``material`` exactly for the models with a Fresnel parameter (eta or f0)."""
    for model in MODELS.values():
        has_fresnel = bool({"eta", "f0"} & set(model.param_names))
        assert (model.classification.highlight == "material") == has_fresnel, model.name
        assert model.classification.origin == "physical", model.name
        assert model.reciprocal
    assert MODELS["torrance_sparrow"].classification.operand == "angle"


def test_every_model_is_registered():
    """brdffit.models.__init__ must import renderers next to microfacet."""
    missing = sorted(set(MODELS) - set(REGISTRY))
    assert not missing, f"not in the registry: {missing}"


def directional_albedo(model, params, theta_i: float, n_theta: int, n_phi: int) -> float:
    """``integral f(L, V) cos(theta_o) dw_o``: Gauss-Legendre in theta_o, trapezoid
    (spectrally accurate for a periodic integrand) in phi_o."""
    x, w = np.polynomial.legendre.leggauss(n_theta)
    theta = (x + 1) * (np.pi / 4)
    phi = np.arange(n_phi) * (2 * np.pi / n_phi)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    wo = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1).reshape(-1, 3)
    wi = np.repeat(np.array([direction(theta_i, 0.0)]), len(wo), axis=0)
    f = model.evaluate(wi, wo, params).reshape(t.shape)
    weights = (w * (np.pi / 4) * np.cos(theta) * np.sin(theta))[:, None] * (2 * np.pi / n_phi)
    return float(np.sum(f * weights))


def test_ggx_albedo_at_normal_incidence_and_unit_roughness_is_one_minus_ln2():
    """At alpha = 1, GGX's D is 1/pi. At normal incidence G1(L) = 1, theta_o =
    2 theta_h and dw_o = 4 (V.H) dw_h, so the albedo (F = 1) is
    ``2 integral_0^{pi/4} G1(V) cos sin dtheta_h`` with ``G1 = 2u/(1 + u)``,
    ``u = cos(2 theta_h)``: ``integral_0^1 u/(1 + u) du = 1 - ln 2``."""
    params = {"kd": 0.0, "ks": 1.0, "alpha": 1.0, "f0": 1.0}
    coarse = directional_albedo(MODELS["ggx"], params, 0.0, 200, 8)
    fine = directional_albedo(MODELS["ggx"], params, 0.0, 400, 8)
    assert abs(fine - coarse) < 1e-12
    assert fine == pytest.approx(1 - math.log(2), abs=1e-10)


@pytest.mark.parametrize("name", ["ggx", "beckmann", "ggx_anisotropic", "beckmann_anisotropic"])
def test_normalised_lobes_keep_directional_albedo_below_one(name):
    """With ks = 1 and F = 1 a microfacet lobe reflects at most all the light (single
    scattering loses some). The quadrature error is bounded by the change between
    two resolutions, and added before comparing."""
    model = MODELS[name]
    for alpha in (0.2, 0.5, 1.0):
        rough = (
            {"alpha": alpha}
            if "alpha" in model.param_names
            else {"alpha_u": alpha, "alpha_v": max(0.2, alpha / 2)}
        )
        params = {"kd": 0.0, "ks": 1.0, "f0": 1.0, **rough}
        for theta_i in (0.0, 45.0, 75.0):
            coarse = directional_albedo(model, params, theta_i, 150, 96)
            fine = directional_albedo(model, params, theta_i, 300, 192)
            assert abs(fine - coarse) < 1e-3, (name, alpha, theta_i, coarse, fine)
            assert fine + abs(fine - coarse) <= 1.0, (name, alpha, theta_i, fine)
            assert fine > 0.2, (name, alpha, theta_i, fine)


def test_values_stay_finite_at_extreme_parameters_and_directions():
    wi, wo = hemisphere_pairs(500, seed=24)
    geometry = Geometry(wi, wo)
    rng = np.random.default_rng(25)
    for model in MODELS.values():
        for corner in ("lower", "upper", None):
            params = random_params(model, rng, corner)
            f = model.evaluate_prepared(geometry, params)
            assert np.isfinite(f).all() and (f >= 0).all(), (model.name, params)
    # Exactly grazing-adjacent mirror pair at the smallest roughness.
    wi = directions_from_angles([90 - 1e-7], [0.0])
    wo = directions_from_angles([90 - 1e-7], [180.0])
    for model in MODELS.values():
        params = random_params(model, rng, "lower")
        params["ks"] = model.param("ks").upper
        assert np.isfinite(model.evaluate(wi, wo, params)).all(), model.name


@pytest.mark.parametrize("distribution", ["ggx", "beckmann"])
def test_shadowing_of_both_directions_at_once_is_each_direction_s(distribution):
    """One roughness for every sample: G1 of L and V in one call on the stacked
    tan^2 and projected alpha^2 (issue 13's speed); the walkers' path (roughness
    arrays) takes each direction alone. The same operations on the same numbers:
    the same values, bit for bit."""
    wi, wo = hemisphere_pairs(600, seed=11)
    geometry = Geometry(wi, wo)
    for alpha_u, alpha_v, f0 in ((0.1, 0.3, 0.04), (0.02, 0.02, 1.0), (0.7, 0.05, 0.5)):
        stacked = renderers.anisotropic_lobe(geometry, distribution, alpha_u, alpha_v, f0)
        alone = renderers.anisotropic_lobe(
            geometry, distribution, np.array([[alpha_u]]), np.array([[alpha_v]]), f0
        )
        np.testing.assert_array_equal(stacked, alone[0])
        # the isotropic lobes' one number for both directions (D aside: ones)
        g1, a2, m = renderers._DISTRIBUTIONS[distribution][2], alpha_u**2, geometry.m
        stacked = renderers._finish(geometry, np.ones(m), g1, a2, a2, f0)
        a2 = np.array([[a2]])
        alone = renderers._finish(geometry, np.ones((1, m)), g1, a2, a2, f0)
        np.testing.assert_array_equal(stacked, alone[0])
