"""Tests of the He-Torrance-Sillion-Greenberg model (brdffit.models.wave, he_terms).

Reference values come from code written here, scalar, with the math and cmath
modules, from the paper's equations (with the errata of eq. 25) and the
structure of Radiance's He.cal: the full polarisation form of G (eq. 76), z0 by
bisection, the series summed term by term to convergence, Fresnel from complex
arithmetic. The paper's figures could not be read numerically from the copies
available, so its values are checked through its stated limits and trends.
"""

from __future__ import annotations

import cmath
import math

import numpy as np
import pytest
import test_model_invariants as invariants
from helpers import hemisphere_pairs
from scipy.optimize import least_squares

from brdffit.data.geometry import MIN_COSINE, Geometry, directions_from_angles
from brdffit.errors import ParameterError
from brdffit.fitting.problem import Problem
from brdffit.models import REGISTRY
from brdffit.models.base import Design, Model
from brdffit.models.he_terms import (
    SERIES_TOLERANCE,
    dd_series,
    effective_roughness_ratio,
    roughness_k,
    shadowing,
    z0_ratio,
)
from brdffit.models.properties import albedo
from brdffit.models.wave import HE, MODELS, _v_terms, he_components
from brdffit.synth import synthesize

#: Every test runs with the compiled loop (brdffit.kernels.loops_he) on, then off.
pytestmark = pytest.mark.usefixtures("evaluation_path")

PARAMS = dict(a_ud=0.0, sigma0=0.18, tau=3.0, eta=1.5, k=0.0, aperture=1.0, wavelength=550.0)
METAL = {**PARAMS, "sigma0": 0.3, "tau": 2.0, "eta": 0.2, "k": 3.5, "wavelength": 633.0}


# ------------------------------------------------------------ scalar reference
def ref_fresnel(c, eta, k):
    """Unpolarised Fresnel reflectance of the complex index eta + i k, from r_s and r_p."""
    n2 = complex(eta, k) ** 2
    root = cmath.sqrt(n2 - (1.0 - c * c))
    rs = (c - root) / (c + root)
    rp = (n2 * c - root) / (n2 * c + root)
    return 0.5 * (abs(rs) ** 2 + abs(rp) ** 2)


def ref_shadowing(c, tau, sigma0):
    """Eqs. 24-25 of the paper with the errata's exp(-a^2)."""
    if c >= 1.0:
        return 1.0
    a = tau * c / (2.0 * sigma0 * math.sqrt(1.0 - c * c))
    lam = 0.5 * (math.exp(-a * a) / (a * math.sqrt(math.pi)) - math.erfc(a))
    return (1.0 - 0.5 * math.erfc(a)) / (lam + 1.0)


def ref_sigma(ci, co, tau, sigma0):
    """Effective roughness: the implicit equation for z0 by bisection, then eq. 80."""

    def k_of(c):
        if c >= 1.0:
            return 0.0
        s = math.sqrt(1.0 - c * c)
        return s / c * math.erfc(tau * c / (2.0 * sigma0 * s))

    kk = k_of(ci) + k_of(co)
    lo, hi = 0.0, kk / 4.0 / math.sqrt(math.pi / 2.0) + 1.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if math.sqrt(math.pi / 2.0) * mid < kk / 4.0 * math.exp(-0.5 * mid * mid):
            lo = mid
        else:
            hi = mid
    return sigma0 / math.sqrt(1.0 + (0.5 * (lo + hi)) ** 2)


def ref_g_factor(wi, wo):
    """Eq. 76 with its polarisation vectors s, p (k_i = -L is the incident propagation)."""
    n = np.array([0.0, 0.0, 1.0])
    ki, kr = -np.asarray(wi), np.asarray(wo)
    v = kr - ki
    si = np.cross(ki, n) / np.linalg.norm(np.cross(ki, n))
    sr = np.cross(kr, n) / np.linalg.norm(np.cross(kr, n))
    pi_, pr = np.cross(si, ki), np.cross(sr, kr)
    cross4 = np.linalg.norm(np.cross(kr, ki)) ** 4
    pol = (sr @ ki) ** 2 + (pr @ ki) ** 2
    pol *= (si @ kr) ** 2 + (pi_ @ kr) ** 2
    return (v @ v / v[2]) ** 2 * pol / cross4


def ref_series(g, a):
    """Eq. 78's sum, term by term from m = 1 well past the Poisson bulk."""
    top = int(g + 40.0 * math.sqrt(g) + 60)
    return math.fsum(
        math.exp(-g + m * math.log(g) - math.lgamma(m + 1) - a / m) / m for m in range(1, top)
    )


def ref_he(wi, wo, p):
    """rho_s + rho_dd (1/sr) for one pair, and the bound on the series' truncation.

    Cosines are clamped at MIN_COSINE as brdffit.data.geometry does for every model."""
    ci, co = max(wi[2], MIN_COSINE), max(wo[2], MIN_COSINE)
    lam = p["wavelength"] * 1e-3
    sigma = ref_sigma(ci, co, p["tau"], p["sigma0"])
    s = ref_shadowing(ci, p["tau"], p["sigma0"]) * ref_shadowing(co, p["tau"], p["sigma0"])
    v = np.asarray(wi) + np.asarray(wo)
    f = ref_fresnel(math.sqrt(v @ v) / 2.0, p["eta"], p["k"])
    g = (2.0 * math.pi * sigma * (ci + co) / lam) ** 2
    a = (math.pi * p["tau"] / lam) ** 2 * (v[0] ** 2 + v[1] ** 2)
    # Eq. 76 reduced to (v.v / v_z)^2, which the full form is checked to equal where it is
    # defined (it is 0/0 at normal incidence and for k_r parallel to k_i).
    v_z = ci + co
    g_factor = ((v[0] ** 2 + v[1] ** 2 + v_z**2) / v_z) ** 2
    scale = f * s * g_factor * (math.pi * p["tau"] / (2 * lam)) ** 2 / (math.pi * ci * co)
    dd = scale * ref_series(g, a)
    # The spike spread by the response w = (1 - psi^2/beta^2)^3 in the angle psi from the
    # mirror direction (as 1 - cos psi over 1 - cos beta), normalised over solid angle.
    beta = math.radians(p["aperture"])
    mirror = np.array([-wi[0], -wi[1], wi[2]])
    psi = math.acos(min(1.0, float(mirror @ wo)))
    w = max(0.0, 1.0 - (1.0 - math.cos(psi)) / (1.0 - math.cos(beta))) ** 3
    spec = f * math.exp(-g) * s * w / (spike_solid_angle(beta) * math.sqrt(ci * co))
    return spec + dd, scale * ref_series(g, 0.0)


def spike_solid_angle(beta):
    """Integral of the response over solid angle: 2 pi (1 - cos beta) / 4."""
    return 0.5 * math.pi * (1.0 - math.cos(beta))


# -------------------------------------------------------------------- helpers
def component_model(which: int) -> Model:
    """The specular (0) or directional-diffuse (1) term alone, as a model."""

    def design(geometry, shape):
        return Design((), offset=he_components(geometry, shape)[which])

    return Model(
        name=f"he_part{which}",
        params=HE.params[1:],
        classification=HE.classification,
        reference=HE.reference,
        design=design,
        doc="one term of he",
    )


def mirror_pairs(theta_i_deg, phi_i_deg=20.0):
    wi = directions_from_angles([theta_i_deg], [phi_i_deg])
    return wi, wi * np.array([-1.0, -1.0, 1.0])


def cone_energy(params, theta_i_deg, n_psi=24, n_chi=96):
    """Integral of rho_s cos(theta_o) over the acceptance cone about the mirror direction
    (Gauss-Legendre in the angle from it, trapezoid in azimuth; rho_s is smooth there)."""
    t = math.radians(theta_i_deg)
    beta = math.radians(params["aperture"])
    x, w = np.polynomial.legendre.leggauss(n_psi)
    psi, w_psi = 0.5 * beta * (x + 1.0), 0.5 * beta * w
    chi = 2 * math.pi * np.arange(n_chi) / n_chi
    r = np.array([-math.sin(t), 0.0, math.cos(t)])
    e1 = np.array([math.cos(t), 0.0, math.sin(t)])
    e2 = np.array([0.0, 1.0, 0.0])
    pp, cc = np.meshgrid(psi, chi, indexing="ij")
    wo = (
        np.cos(pp)[..., None] * r
        + np.sin(pp)[..., None] * (np.cos(cc)[..., None] * e1 + np.sin(cc)[..., None] * e2)
    ).reshape(-1, 3)
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    wi = np.tile([math.sin(t), 0.0, math.cos(t)], (len(wo), 1))
    spec = component_model(0).evaluate(wi, wo, {k: v for k, v in params.items() if k != "a_ud"})
    weight = (w_psi[:, None] * np.sin(pp) * (2 * math.pi / n_chi)).ravel()
    # Directions of the cone below the horizon (at grazing incidence) get 0 from the model.
    return float(np.sum(spec * wo[:, 2] * weight))


# ---------------------------------------------------------------------- terms
def test_series_is_within_its_bound_of_the_full_sum():
    """Against every term from m = 1 (math.fsum of terms each good to ~1e-12), the
    windowed, truncated sum is within tolerance * peak, the documented bound."""

    def full(g, a):
        top = int(g + 40.0 * math.sqrt(g) + 60)
        return math.fsum(
            math.exp(-g + m * math.log(g) - math.lgamma(m + 1) - a / m) / m for m in range(1, top)
        )

    for g in (1e-6, 0.3, 4.0, 60.0, 2500.0):
        a = np.array([0.0, 2.0, 50.0, 3e4])
        want = np.array([full(g, x) for x in a])
        for tol in (SERIES_TOLERANCE, 1e-3):
            got = dd_series(np.full(a.size, g), a, tol)
            assert (np.abs(got - want) <= tol * want[0]).all(), (g, tol, got - want)
    # A looser tolerance sums fewer terms; a large g sums a window, not g terms.
    _, n_tight = dd_series(np.array([2500.0]), np.array([0.0]), 1e-9, count_terms=True)
    _, n_loose = dd_series(np.array([2500.0]), np.array([0.0]), 1e-3, count_terms=True)
    assert n_loose[0] < n_tight[0] < 2500 / 3


def test_the_log_factorials_are_within_an_ulp():
    """ln(m!) of the series' first weight, against its 40-digit sum: within one ulp for
    every m it lists (scipy's gammaln is an ulp off at m = 758, math.lgamma up to three:
    at g = 960 the weight cancels terms of 5000, so an ulp there is 1e-12 of it)."""
    from decimal import Decimal, localcontext

    from brdffit.models.he_terms import log_factorial_table

    table = log_factorial_table()
    with localcontext() as context:
        context.prec = 40
        exact, total = [0.0], Decimal(0)
        for k in range(1, table.size):
            total += Decimal(k).ln()
            exact.append(float(total))
    exact = np.array(exact)
    assert table.size == 2048 and table[:2].tolist() == [0.0, 0.0]
    assert np.all(np.abs(table - exact)[2:] <= np.spacing(exact[2:]))


def test_effective_roughness_solves_eq81_and_falls_towards_grazing():
    k_sum = np.concatenate([[0.0], np.logspace(-12, 12, 60)])
    u = z0_ratio(k_sum)
    # sqrt(pi/2) u = K/4 exp(-u^2/2), checked in its own form.
    lhs, rhs = math.sqrt(math.pi / 2) * u, k_sum / 4 * np.exp(-u * u / 2)
    np.testing.assert_allclose(lhs, rhs, rtol=1e-13, atol=1e-300)
    ratio = effective_roughness_ratio(k_sum)
    assert ratio[0] == 1.0 and (np.diff(ratio) <= 0).all() and ratio[-1] < 0.2
    # Same sigma as the scalar bisection along a sweep of incidence angles.
    for theta in (0.0, 30.0, 60.0, 80.0, 89.0, 89.99):
        c = math.cos(math.radians(theta))
        got = 0.2 * effective_roughness_ratio(2 * roughness_k(np.array([c]), 1.0 / 0.2))[0]
        assert got == pytest.approx(ref_sigma(c, c, 1.0, 0.2), rel=1e-12)


def test_shadowing_is_smith_with_the_errata_of_eq25():
    cos = np.cos(np.radians([0.0, 10.0, 45.0, 70.0, 85.0, 89.9, 90 - 1e-9]))
    for tau, sigma0 in ((3.0, 0.18), (0.05, 5.0), (100.0, 0.001)):
        got = shadowing(cos, tau / sigma0)
        want = [ref_shadowing(c, tau, sigma0) for c in cos]
        np.testing.assert_allclose(got, want, rtol=1e-12)
    assert shadowing(np.array([1.0]), 10.0)[0] == 1.0
    assert shadowing(np.array([1e-10]), 10.0)[0] < 1e-8


def test_geometric_factor_is_eq76_with_its_polarisation_terms():
    wi, wo = hemisphere_pairs(300, seed=11, grazing=False)
    geometry = Geometry(wi, wo)
    _, _, g_factor = _v_terms(geometry)
    want = [ref_g_factor(a, b) for a, b in zip(wi, wo)]
    np.testing.assert_allclose(g_factor, want, rtol=1e-9)


# --------------------------------------------------------------------- model
@pytest.mark.parametrize(
    "params",
    [PARAMS, METAL, {**PARAMS, "sigma0": 0.05, "tau": 0.3, "wavelength": 400.0, "aperture": 5.0}],
)
def test_model_matches_the_scalar_implementation(params):
    wi, wo = hemisphere_pairs(60, seed=12)
    near_i, near_o = mirror_pairs(40.0)
    tilt = directions_from_angles([40.3], [200.0])  # inside a 1-degree cone
    wi = np.vstack([wi, near_i, near_i])
    wo = np.vstack([wo, near_o, tilt])
    got = HE.evaluate(wi, wo, params)
    for f, a, b in zip(got, wi, wo):
        if a[2] <= 0 or b[2] <= 0:
            continue
        want, peak = ref_he(a, b, params)
        # The series may differ by its documented bound; the rest agrees to rounding.
        assert abs(f - want) <= SERIES_TOLERANCE * peak + 1e-10 * want, (a, b, f, want)


def test_wavelength_channels_give_one_column_each():
    wi, wo = hemisphere_pairs(200, seed=13)
    wavelengths = [400.0, 550.0, 700.0, 1500.0]
    params = {**PARAMS, "a_ud": [0.1, 0.2, 0.3, 0.4], "wavelength": wavelengths}
    f = HE.evaluate(wi, wo, params)
    assert f.shape == (len(wi), 4)
    for c, wl in enumerate(wavelengths):
        one = HE.evaluate(wi, wo, {**PARAMS, "a_ud": params["a_ud"][c], "wavelength": wl})
        np.testing.assert_allclose(f[:, c], one, rtol=1e-13)
    with pytest.raises(ParameterError, match="wavelength"):
        HE.evaluate(wi, wo, {**PARAMS, "wavelength": 50.0})
    with pytest.raises(ParameterError, match="same length"):
        HE.evaluate(wi, wo, {**params, "wavelength": wavelengths[:3]})


def test_reciprocity_inside_and_outside_the_spike():
    wi, wo = hemisphere_pairs(400, seed=14, grazing=False)
    near = wi * np.array([-1.0, -1.0, 1.0]) + 0.01 * np.random.default_rng(0).normal(size=wi.shape)
    near /= np.linalg.norm(near, axis=1, keepdims=True)
    wi, wo = np.vstack([wi, wi]), np.vstack([wo, near])
    for params in (PARAMS, {**METAL, "aperture": 2.0, "wavelength": [450.0, 650.0]}):
        a, b = HE.evaluate(wi, wo, params), HE.evaluate(wo, wi, params)
        assert np.count_nonzero(he_components(Geometry(wi, wo), params)[0]) > 50
        assert np.max(np.abs(a - b)) <= 1e-12 * np.max(a)


# -------------------------------------------------------------------- limits
def test_smooth_limit_is_a_fresnel_mirror():
    """sigma0/lambda -> 0: the directional diffuse term vanishes and the spike's
    reflectance tends to F(theta_i) (pointwise at the mirror pair and as energy)."""
    theta = 35.0
    c = math.cos(math.radians(theta))
    previous_spec = previous_dd = None
    for sigma0, wavelength in ((0.1, 1000.0), (0.01, 1000.0), (0.001, 1000.0), (0.001, 1e4)):
        params = {**METAL, "sigma0": sigma0, "tau": 3.0, "aperture": 0.1, "wavelength": wavelength}
        shape = {k: v for k, v in params.items() if k != "a_ud"}
        fresnel = ref_fresnel(c, params["eta"], params["k"])
        wi, wo = mirror_pairs(theta)
        spec, _ = he_components(Geometry(wi, wo), shape)
        omega = spike_solid_angle(math.radians(params["aperture"]))
        spec_gap = abs(spec[0] * omega * c / fresnel - 1.0)
        dd = albedo(component_model(1), shape, theta, rtol=1e-4).value / fresnel
        if previous_spec is not None:  # both fall like (sigma0 / lambda)^2
            assert spec_gap < previous_spec / 50 and dd < previous_dd / 50
        energy = cone_energy(params, theta)
        assert abs(energy / fresnel - 1.0) < spec_gap + 1e-6
        previous_spec, previous_dd = spec_gap, dd
    assert previous_spec < 1e-5 and previous_dd < 1e-5


def test_rough_limit_is_cook_torrance_with_beckmann_and_smith():
    """g >> 1: rho_dd -> F S D_beckmann(m = 2 sigma / tau) / (4 cos_i cos_o). The
    leading correction of E[w(X)] around w(g) is (t^2 - 4t + 2)/(2g) with
    t = tan^2(theta_h)/m^2, at most 1/g inside the lobe (t <= 4)."""
    p = {**METAL, "sigma0": 2.0, "tau": 20.0, "wavelength": 400.0}
    rng = np.random.default_rng(15)
    theta_i = rng.uniform(0, 60, 80)
    wi = directions_from_angles(theta_i, np.zeros(80))
    wo = directions_from_angles(theta_i + rng.normal(0, 8, 80), rng.normal(180, 10, 80))
    keep = wo[:, 2] > 0.05
    wi, wo = wi[keep], wo[keep]
    _, dd = he_components(Geometry(wi, wo), p)
    checked = 0
    for f, a, b in zip(dd, wi, wo):
        ci, co = a[2], b[2]
        sigma = ref_sigma(ci, co, p["tau"], p["sigma0"])
        m2 = (2 * sigma / p["tau"]) ** 2
        h = (a + b) / np.linalg.norm(a + b)
        tan2 = (h[0] ** 2 + h[1] ** 2) / h[2] ** 2
        if tan2 / m2 > 4:
            continue
        beckmann = math.exp(-tan2 / m2) / (math.pi * m2 * h[2] ** 4)
        s = ref_shadowing(ci, p["tau"], p["sigma0"]) * ref_shadowing(co, p["tau"], p["sigma0"])
        want = ref_fresnel(float(h @ b), p["eta"], p["k"]) * s * beckmann / (4 * ci * co)
        g = (2 * math.pi * sigma * (ci + co) / (p["wavelength"] * 1e-3)) ** 2
        assert abs(f / want - 1.0) <= 2.0 / g + SERIES_TOLERANCE
        checked += 1
    assert checked > 30


def test_transition_from_diffuse_like_to_specular():
    """The paper's abstract: the reflection turns from diffuse-like to specular as the
    wavelength and the incidence angle increase or the roughness decreases. The
    spike's share of the Fresnel reflectance, exp(-g) S^2, measures it."""

    def share(theta, wavelength, sigma0):
        params = {**PARAMS, "sigma0": sigma0, "wavelength": wavelength}
        params.pop("a_ud")
        wi, wo = mirror_pairs(theta)
        spec, _ = he_components(Geometry(wi, wo), params)
        c = math.cos(math.radians(theta))
        omega = spike_solid_angle(math.radians(params["aperture"]))
        return spec[0] * omega * c / ref_fresnel(c, params["eta"], params["k"])

    by_wavelength = [share(30, wl, 0.18) for wl in (300, 450, 600, 900, 1500, 3000, 20000)]
    by_angle = [share(t, 550, 0.18) for t in (0, 20, 40, 60, 75, 85)]
    by_roughness = [share(30, 550, s) for s in (0.01, 0.05, 0.1, 0.2, 0.4)]
    assert (np.diff(by_wavelength) > 0).all() and by_wavelength[0] < 0.01 < 0.9 < by_wavelength[-1]
    assert (np.diff(by_angle) > 0).all()
    assert (np.diff(by_roughness) < 0).all()


ALBEDO_GRID = [  # (sigma0/lambda, tau/lambda) from smooth to rough, narrow to broad lobes
    (0.003, 20.0),
    (0.03, 0.5),
    (0.03, 1.0),
    (0.1, 2.0),
    (1.0, 5.0),
]


def albedo_shape(s_l, t_l, eta, k, wavelength=500.0):
    """Shape parameters at sigma0/lambda = s_l, tau/lambda = t_l."""
    lam = wavelength * 1e-3
    return dict(sigma0=s_l * lam, tau=t_l * lam, eta=eta, k=k, aperture=1.0, wavelength=wavelength)


def total_albedo(shape, thetas):
    """Spike (integrated over its cone) plus directional diffuse, with a_ud = 0, and the
    error estimate of the directional-diffuse quadrature."""
    dd = albedo(component_model(1), shape, thetas, rtol=1e-4, max_level=5)
    spike = np.array([cone_energy({**shape, "a_ud": 0.0}, t) for t in thetas])
    return spike + dd.value, dd.error


@pytest.mark.parametrize("eta, k", [(1.5, 0.0), (10.0, 0.0), (10.0, 20.0), (0.4, 2.4), (1.0, 6.7)])
def test_directional_albedo_at_most_one_unless_the_conductor_is_nearly_perfect(eta, k):
    """Dielectrics (up to eta = 10) and conductors with F(0) up to 0.92 (eta = 10, k = 20;
    gold's visible index 0.4 + 2.4i; aluminium's 1.0 + 6.7i), 0 to 89 degrees of incidence,
    smooth to rough surfaces."""
    thetas = [0.0, 60.0, 85.0, 89.0]
    for s_l, t_l in ALBEDO_GRID:
        shape = albedo_shape(s_l, t_l, eta, k)
        total, error = total_albedo(shape, thetas)
        assert (total <= 1.0 + error).all(), (shape, total)


def test_nearly_perfect_conductors_exceed_one_at_oblique_incidence():
    """A measured property of the model, not of the code: with F -> 1 (eta = 0.01,
    k = 20, F(0) = 0.9999) the directional-diffuse term, a Kirchhoff approximation, returns
    more than the spike loses (its 1/cos(theta_o) grows towards the horizon), so the
    albedo exceeds 1: by about 1e-4 at normal incidence and about 2.5 % at 75 degrees for
    sigma0/lambda = 0.03, tau/lambda = 0.5. At least it stays within 3 %."""
    thetas = [0.0, 45.0, 75.0]
    worst_normal, worst = 0.0, 0.0
    for s_l, t_l in ALBEDO_GRID:
        shape = albedo_shape(s_l, t_l, 0.01, 20.0)
        total, error = total_albedo(shape, thetas)
        worst_normal = max(worst_normal, total[0] + error[0])
        worst = max(worst, float(np.max(total - error)))
    assert 1.02 < worst < 1.03
    assert worst_normal < 1.001


# ------------------------------------------------------------------ fitting
def test_sigma0_and_tau_are_identifiable_from_31_wavelengths():
    """Synthetic spectra, 400..700 nm every 10 nm, 1 % noise, sampled densely around the
    specular lobe; a_ud per channel by linear least squares, (sigma0, tau) by scipy's
    least_squares from two distant starts, one on each side of the truth."""
    wavelengths = np.arange(400.0, 701.0, 10.0)

    def in_plane(theta_o):  # positive: forward, on the side of the mirror direction
        return directions_from_angles(np.abs(theta_o), np.where(theta_o > 0, 180.0, 0.0))

    wi_list, wo_list = [], []
    for theta_i in (15.0, 45.0, 70.0):
        wo = np.vstack(
            [
                in_plane(np.arange(theta_i - 24.0, min(theta_i + 25.0, 88.0), 2.0)),
                in_plane(np.arange(-80.0, 81.0, 10.0)),
                directions_from_angles(
                    np.full(8, theta_i), 180.0 + np.array([-12, -6, -3, -1, 1, 3, 6, 12])
                ),
            ]
        )
        wo_list.append(wo)
        wi_list.append(directions_from_angles(np.full(len(wo), theta_i), np.zeros(len(wo))))
    geometry = Geometry(np.vstack(wi_list), np.vstack(wo_list))
    truth = dict(sigma0=0.12, tau=1.5, eta=1.5, k=0.0, aperture=1.0, wavelength=wavelengths)
    a_ud = 0.2 + 0.3 * (wavelengths - 400.0) / 300.0
    clean = HE.evaluate_prepared(geometry, {**truth, "a_ud": a_ud})
    data = clean * (1.0 + 0.01 * np.random.default_rng(16).normal(size=clean.shape))
    weight = 1.0 / (0.01 * clean)

    def residuals(x):
        shape = {**truth, "sigma0": math.exp(x[0]), "tau": math.exp(x[1])}
        offset = HE.design(geometry, shape).offset
        w2 = weight**2
        a = np.maximum(np.pi * np.sum(w2 * (data - offset), 0) / np.sum(w2, 0), 0.0)
        return ((offset + a / np.pi - data) * weight).ravel()

    dof = data.size - 2 - wavelengths.size
    for start in ([0.4, 0.8], [0.04, 5.0]):
        fit = least_squares(residuals, np.log(start))
        assert fit.success
        chi2 = 2 * fit.cost / dof
        se = np.sqrt(np.diag(np.linalg.inv(fit.jac.T @ fit.jac) * chi2))  # of ln sigma0, ln tau
        assert 0.9 < chi2 < 1.1 and (se < 0.01).all(), (chi2, se)
        assert abs(fit.x[0] - math.log(truth["sigma0"])) < 4 * se[0], np.exp(fit.x)
        assert abs(fit.x[1] - math.log(truth["tau"])) < 4 * se[1], np.exp(fit.x)


def test_fit_objective_is_finite_over_the_search_box():
    """What tests/fitting/test_problem.py checks for every model, with the wavelength
    channels he needs: the engine's objective at the corners and random points of the box."""
    channels = ["450nm", "550nm", "650nm"]
    params = {**HE.defaults(), "a_ud": [0.1, 0.2, 0.3], "wavelength": [450.0, 550.0, 650.0]}
    data = synthesize(
        HE, params, geometry="hemisphere", n=200, noise=0.01, seed=3, channels=channels
    )
    problem = Problem(data, HE)
    rng = np.random.default_rng(11)
    points = [problem.lower, problem.upper, problem.x_from_params(HE.defaults())]
    points += [rng.uniform(problem.lower, problem.upper) for _ in range(20)]
    for x in points:
        loss = problem.solve(x).loss
        assert np.isfinite(loss) and loss >= 0, x


# --------------------------------------------------------------- the registry
@pytest.mark.parametrize(
    "invariant",
    [
        invariants.test_finite_and_non_negative_everywhere,
        invariants.test_zero_below_the_horizon,
        invariants.test_prepared_equals_unprepared_and_channels_broadcast,
        invariants.test_isotropic_models_are_invariant_under_rotation_about_the_normal,
        invariants.test_reciprocity_where_the_model_is_reciprocal,
        invariants.test_bad_params_are_named,
    ],
)
def test_registry_invariants_hold_for_he(invariant, monkeypatch):
    monkeypatch.setitem(REGISTRY, "he", HE)
    invariant("he")


def test_module_exports_the_model():
    assert MODELS == (HE,)
    assert HE.classification.wave_optics and HE.reciprocal
    wl = HE.param("wavelength")
    assert wl.per_channel and not wl.linear and (wl.lower, wl.upper) == (100.0, 20000.0)
    assert [p.name for p in HE.linear_params] == ["a_ud"]
