"""Albedo quadrature, reciprocity measure and model properties (brdffit.models.properties).

Reference values are closed forms or an independent integration written here:
scalar ``math`` code integrated over the half-vector domain with scipy's
adaptive ``quad``. Every albedo is checked twice: against the truth, and the
truth against the returned error estimate (an honest estimate bounds the error).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy import integrate

from brdffit import DataError, ModelError, ParameterError, get_model, list_models
from brdffit.models import REGISTRY
from brdffit.models.base import Classification, Param, diffuse_plus_lobe
from brdffit.models.properties import albedo, model_properties, reciprocity_error

ISOTROPIC = Classification("empirical", "isotropic", "cosine", "light")
PHYSICAL = Classification("physical", "isotropic", "angle", "material")
F0 = 0.04  # Schlick reflectance of the Cook-Torrance-like test lobe


def adhoc(name, lobe, shape=(), classification=ISOTROPIC, reciprocal=True):
    """A test model ``kd/pi + ks lobe`` built on the public helper."""
    return diffuse_plus_lobe(
        name, lobe, shape, classification, "test", "test lobe", reciprocal=reciprocal
    )


def exponent():
    return Param("n", 1.0, 1e4, 50.0, log_scale=True, doc="exponent")


def roughness():
    return Param("m", 1e-3, 1.0, 0.1, log_scale=True, doc="roughness")


# Lobes from the formulas of MODELS.md, on the geometry's cached cosines.
PHONG = adhoc("test_phong", lambda g, n: np.maximum(g.cos_r, 0.0) ** n, (exponent(),))
NON_RECIPROCAL = adhoc(
    "test_phong_shading", lambda g, n: g.cos_h**n / g.cos_i, (exponent(),), reciprocal=False
)


def _beckmann(g, m):
    return np.exp(-g.tan2_h / m**2) / (math.pi * m**2 * g.cos_h**4)


BECKMANN = adhoc(
    "test_beckmann",
    lambda g, m: _beckmann(g, m) / (4 * g.cos_i * g.cos_o),
    (roughness(),),
    PHYSICAL,
)


def _cook_torrance_like(g, m):
    shadowing = np.minimum(1.0, 2 * g.cos_h * np.minimum(g.cos_i, g.cos_o) / g.cos_d)
    fresnel = F0 + (1 - F0) * (1 - g.cos_d) ** 5
    return _beckmann(g, m) * shadowing * fresnel / (4 * g.cos_i * g.cos_o)


COOK_TORRANCE_LIKE = adhoc("test_ct", _cook_torrance_like, (roughness(),), PHYSICAL)
WARD = adhoc(
    "test_ward",
    lambda g, m: np.exp(-g.tan2_h / m**2) / (4 * math.pi * m**2 * np.sqrt(g.cos_i * g.cos_o)),
    (roughness(),),
    PHYSICAL,
)


def assert_accurate(result, truth, rel=1e-6):
    """The albedo is within ``rel`` of the truth and the estimate bounds the error."""
    error = np.abs(result.value - truth)
    assert np.all(error <= rel * np.abs(truth)), (result.value, truth)
    assert np.all(error <= result.error), (error, result.error)


# ----------------------------------------------------------- closed forms
def test_lambert_albedo_is_kd_at_every_incidence():
    theta = [0, 10, 20, 30, 40, 50, 60, 70, 80, 85, 89, 89.9]
    result = albedo("lambert", {"kd": 0.7}, theta, 37.0)
    assert result.converged
    assert_accurate(result, 0.7)
    per_channel = albedo("lambert", {"kd": [0.1, 0.4, 0.9]}, [0.0, 60.0, 88.0])
    assert per_channel.value.shape == (3, 3)
    assert_accurate(per_channel, np.array([0.1, 0.4, 0.9]))


@pytest.mark.parametrize("n", [1.0, 10.0, 1e3, 1e4])
def test_normalised_phong_lobe_has_unit_albedo_at_normal_incidence(n):
    """integral cos^n(alpha) cos(theta_o) dw = 2 pi / (n + 2) when R = N."""
    result = albedo(PHONG, {"kd": 0.0, "ks": (n + 2) / (2 * math.pi), "n": n}, 0.0)
    assert result.converged
    assert_accurate(result, 1.0)
    if "phong" in REGISTRY:  # the registered lobe is the same max(0, R.V)^n
        registered = albedo("phong", {"kd": 0.0, "ks": 1.0, "n": n}, 0.0)
        assert_accurate(registered, 2 * math.pi / (n + 2))


@pytest.mark.parametrize("n", [1e3, 1e4])
def test_sharp_phong_lobe_at_oblique_incidence(n):
    """Over the whole cap R.V > 0 the integral of (R.V)^n V.z is cos(theta_i) 2 pi/(n+2);
    the part of the cap below the horizon, where R.V <= sin(theta_i), is at most
    2 pi sin(theta_i)^n, negligible here."""
    theta = np.array([30.0, 60.0])
    cut = (n + 2) * np.sin(np.radians(theta)) ** n
    assert cut.max() < 1e-12
    result = albedo(PHONG, {"kd": 0.0, "ks": (n + 2) / (2 * math.pi), "n": n}, theta, 20.0)
    assert_accurate(result, np.cos(np.radians(theta)))


@pytest.mark.parametrize("n", [1.0, 10.0, 1e3, 1e4])
def test_blinn_albedo_at_normal_incidence_matches_its_closed_form(n):
    """At L = N: theta_o = 2 theta_h, V.H = u = cos(theta_h), dw_o = 4 u dw_h, so
    a = 8 pi integral_{1/sqrt 2}^1 u^(n+1) (2u^2 - 1) du
      = 8 pi [2 (1 - r^(n+4))/(n+4) - (1 - r^(n+2))/(n+2)], r = 1/sqrt(2)."""
    r = 1 / math.sqrt(2)
    truth = 8 * math.pi * (2 * (1 - r ** (n + 4)) / (n + 4) - (1 - r ** (n + 2)) / (n + 2))
    result = albedo("blinn", {"kd": 0.0, "ks": 1.0, "n": n}, 0.0)
    assert_accurate(result, truth)


@pytest.mark.parametrize("m", [1e-3, 3e-3, 1e-2, 3e-2])
def test_normalised_beckmann_lobe_has_unit_albedo(m):
    """D/(4 N.L N.V) with dw_o = 4 (V.H) dw_h gives integral D (L.H)/cos(theta_i) dw_h;
    integral D H dw_h = N for a normalised isotropic D, so the albedo is 1 minus the
    part of D whose reflection leaves the hemisphere: theta_h > t = (90 - theta_i)/2,
    bounded by exp(-T/m^2)(sqrt(1+T) + m^2/2)/cos(theta_i), T = tan^2(t)."""
    theta = np.array([0.0, 30.0, 60.0] + ([85.0] if m <= 3e-3 else []))
    tan2 = np.tan(np.radians((90 - theta) / 2)) ** 2
    cut = np.exp(-tan2 / m**2) * (np.sqrt(1 + tan2) + m**2 / 2) / np.cos(np.radians(theta))
    assert cut.max() < 1e-12
    result = albedo(BECKMANN, {"kd": 0.0, "ks": 1.0, "m": m}, theta, 45.0)
    assert result.converged
    assert_accurate(result, 1.0)


# --------------------------------------------- half-vector reference integration
def _cook_torrance_like_integrand(c, cos_h, tan2_h, cos_i, m):
    """f cos(theta_o) 4 (V.H) for f = F D G / (4 N.L N.V), with c = V.H = L.H."""
    cos_o = 2 * c * cos_h - cos_i
    d = math.exp(-tan2_h / m**2) / (math.pi * m**2 * cos_h**4)
    g = min(1.0, 2 * cos_h * min(cos_i, cos_o) / c)
    return (F0 + (1 - F0) * (1 - c) ** 5) * d * g * c / cos_i


def _ward_integrand(c, cos_h, tan2_h, cos_i, m):
    cos_o = 2 * c * cos_h - cos_i
    return math.exp(-tan2_h / m**2) / (math.pi * m**2) * math.sqrt(cos_o / cos_i) * c


def half_vector_albedo(integrand, theta_i, m):
    """integral over H (theta_h, phi_h) of f(L, V) cos(theta_o) 4 (V.H) sin(theta_h),
    V = 2 (L.H) H - L, for L at azimuth 0 (the integrand is even in phi_h). theta_h
    stops at atan(9 m), past which the Beckmann factor is below exp(-81). The inner
    integral breaks where the integrand has kinks: at the horizon, c = N.L / (2 N.H),
    and where the V-cavity G switches branch, c = 2 (N.H)(N.L) and
    c = 2 (N.H)(N.L) / (4 (N.H)^2 - 1)."""
    cos_i, sin_i = math.cos(theta_i), math.sin(theta_i)

    def over_phi(theta_h):
        cos_h, sin_h = math.cos(theta_h), math.sin(theta_h)
        tan2_h = math.tan(theta_h) ** 2

        def f(phi_h):
            c = sin_i * sin_h * math.cos(phi_h) + cos_i * cos_h
            if c <= 0 or 2 * c * cos_h <= cos_i:  # L.H <= 0 or V below the horizon
                return 0.0
            return integrand(c, cos_h, tan2_h, cos_i, m) * sin_h

        kinks = [cos_i / (2 * cos_h), 2 * cos_h * cos_i]
        if 4 * cos_h**2 != 1:
            kinks.append(2 * cos_h * cos_i / (4 * cos_h**2 - 1))
        cosines = [(c - cos_i * cos_h) / (sin_i * sin_h) for c in kinks if sin_i * sin_h > 0]
        points = sorted(math.acos(x) for x in cosines if -1 < x < 1) or None
        inner = integrate.quad(f, 0, math.pi, points=points, epsabs=1e-15, epsrel=1e-13, limit=400)
        return 2 * inner[0]

    top = math.atan(9 * m)
    points = [k * m for k in (0.5, 1, 2, 4) if k * m < top]
    return integrate.quad(over_phi, 0, top, points=points, epsabs=1e-14, epsrel=1e-12, limit=400)[
        0
    ]


@pytest.mark.parametrize("m", [1e-3, 1e-2, 0.1, 0.3])
def test_ward_lobe_matches_half_vector_integration(m):
    theta = np.array([0.0, 45.0, 75.0])
    truth = [half_vector_albedo(_ward_integrand, math.radians(t), m) for t in theta]
    assert_accurate(albedo(WARD, {"kd": 0.0, "ks": 1.0, "m": m}, theta), np.array(truth))


@pytest.mark.parametrize("m", [1e-3, 1e-2, 0.1, 0.3])
def test_cook_torrance_like_lobe_matches_half_vector_integration(m):
    """The kinks of the V-cavity G slow convergence: at m = 0.3 the rule stops at its
    finest level, about 1e-5 from the truth, and says so."""
    theta = np.array([0.0, 45.0, 75.0])
    truth = [half_vector_albedo(_cook_torrance_like_integrand, math.radians(t), m) for t in theta]
    result = albedo(COOK_TORRANCE_LIKE, {"kd": 0.0, "ks": 1.0, "m": m}, theta)
    assert_accurate(result, np.array(truth), rel=1e-6 if m < 0.3 else 1e-4)
    if m < 0.1:
        assert result.converged


@pytest.mark.parametrize("name", [m.name for m in list_models(symmetry="anisotropic")])
def test_anisotropic_albedo_at_normal_incidence_is_the_same_for_every_phi_i(name):
    """At L = N the azimuth of incidence only rotates the quadrature grid."""
    result = albedo(name, None, 0.0, [0.0, 30.0, 90.0, 200.0], rtol=1e-5)
    spread = np.abs(result.value - result.value[0])
    assert np.all(spread <= result.error + result.error[0])


def test_albedo_shapes_and_read_only_results():
    scalar = albedo("blinn", None, 30.0)
    assert scalar.value.shape == () and scalar.error.shape == ()
    grid = albedo("blinn", {"kd": [0.1, 0.2], "ks": 0.5}, [[0, 30, 60], [10, 20, 80]], 45.0)
    assert grid.value.shape == (2, 3, 2) and grid.phi_i.shape == (2, 3)
    assert np.all(grid.value[..., 1] > grid.value[..., 0])
    with pytest.raises(ValueError):
        grid.value[0, 0, 0] = 1.0


# ------------------------------------------------------------------ reciprocity
def test_reciprocity_error_is_zero_for_blinn_and_large_without_the_cosine():
    blinn = reciprocity_error("blinn", {"n": 200.0}, n_pairs=5000, seed=3)
    assert blinn.max < 1e-12 and blinn.is_reciprocal
    shading = reciprocity_error(NON_RECIPROCAL, {"n": 20.0}, n_pairs=5000, seed=3)
    assert shading.max > 0.1 and shading.rms > 1e-4 and not shading.is_reciprocal
    assert 4500 <= shading.n_pairs <= 5000  # only pairs pushed below the horizon drop out
    again = reciprocity_error(NON_RECIPROCAL, {"n": 20.0}, n_pairs=5000, seed=3)
    assert again == shading
    assert reciprocity_error(NON_RECIPROCAL, {"n": 20.0}, n_pairs=5000, seed=4) != shading


# ------------------------------------------------------------- model properties
@pytest.mark.parametrize("name", sorted(REGISTRY))
def test_model_properties_of_every_registered_model(name):
    model = get_model(name)
    props = json.loads(json.dumps(model_properties(model)))
    assert props["params"] == pytest.approx(model.defaults())
    assert props["reciprocal"] == model.reciprocal
    error = props["albedo_error"]
    assert 0 <= error <= 1e-3 * props["max_albedo"]
    listed = props["albedo"]
    assert set(listed) == {"0", "30", "60", "85"}
    assert all(v >= 0 for v in listed.values())
    assert props["max_albedo"] >= max(listed.values()) - error
    assert props["energy_conserving"] == (props["max_albedo"] <= 1 + error)
    at_60 = albedo(model, None, 60.0, rtol=1e-5)
    assert abs(listed["60"] - float(at_60.value)) <= error + float(at_60.error)


def test_model_properties_measure_energy_and_channels():
    lambert = model_properties("lambert", {"kd": [0.2, 0.9]})
    within = {"abs": lambert["albedo_error"], "rel": 0}
    assert lambert["max_albedo"] == pytest.approx([0.2, 0.9], **within)
    assert lambert["albedo"]["85"] == pytest.approx([0.2, 0.9], **within)
    assert lambert["energy_conserving"] and lambert["albedo_error"] < 1e-3
    bright = model_properties(PHONG, {"kd": 0.5, "ks": 1.5 / math.pi, "n": 100.0})
    # kd + ks 2 pi/(n + 2) at normal incidence, where the lobe is whole
    assert bright["max_albedo"] == pytest.approx(0.5 + 3 / 102, rel=1e-3)
    assert bright["max_albedo_theta_i"] == 0.0
    assert not model_properties(PHONG, {"kd": 1.0, "ks": 1.0, "n": 100.0})["energy_conserving"]


# --------------------------------------------------------------------- errors
def test_bad_input_is_named():
    with pytest.raises(DataError, match="theta_i=90"):
        albedo("lambert", None, [10.0, 90.0])
    with pytest.raises(DataError, match="phi_i contains NaN"):
        albedo("lambert", None, 10.0, float("nan"))
    with pytest.raises(DataError, match="theta_i is empty"):
        albedo("lambert", None, [])
    with pytest.raises(DataError, match="broadcast"):
        albedo("lambert", None, [1.0, 2.0, 3.0], [0.0, 1.0])
    with pytest.raises(ParameterError, match="bogus"):
        albedo("lambert", {"bogus": 1.0}, 0.0)
    with pytest.raises(ParameterError, match="params must be a mapping"):
        albedo("lambert", [0.5], 0.0)
    with pytest.raises(ParameterError, match="rtol=0"):
        albedo("lambert", None, 0.0, rtol=0)
    with pytest.raises(ParameterError, match="max_level=9"):
        albedo("lambert", None, 0.0, max_level=9)
    with pytest.raises(ParameterError, match="n_pairs=1"):
        reciprocity_error("lambert", n_pairs=1)
    with pytest.raises(ModelError, match="did you mean blinn"):
        model_properties("blin")
