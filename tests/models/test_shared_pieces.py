"""The shared microfacet pieces (brdffit.models.shared) against independent references.

Every reference here is written in the test from physics or from the primary
source: Fresnel from Snell's law and the s/p amplitude coefficients in complex
arithmetic (cmath), distributions from their slope-space definitions, Smith G1
from its defining integral (Smith 1967; Heitz 2014, eq. for Lambda).
"""

from __future__ import annotations

import cmath
import math

import numpy as np
import pytest
from helpers import hemisphere_pairs
from scipy import integrate

from brdffit.models import shared

ANGLES_DEG = (0.0, 10.0, 30.0, 45.0, 56.31, 60.0, 75.0, 85.0, 89.0, 89.99)


def fresnel_snell(cos_i: float, n: complex) -> float:
    """Unpolarised reflectance from the s and p amplitude coefficients.

    ``n cos_t = sqrt(n^2 - sin^2 theta_i)`` (Snell), on the branch with a
    non-negative imaginary part (the transmitted wave decays into an absorbing
    medium, and past the critical angle the wave is evanescent).
    """
    sin2 = 1.0 - cos_i * cos_i
    n = complex(n)
    w = cmath.sqrt(n * n - sin2)
    if w.imag < 0:
        w = -w
    rs = (cos_i - w) / (cos_i + w)
    rp = (n * n * cos_i - w) / (n * n * cos_i + w)
    return 0.5 * (abs(rs) ** 2 + abs(rp) ** 2)


# ------------------------------------------------------------------- Fresnel
@pytest.mark.parametrize("eta", [1.001, 1.1, 1.33, 1.5, 2.0, 3.0, 0.75])
def test_fresnel_dielectric_matches_snell_and_the_s_p_coefficients(eta):
    cos = np.cos(np.radians(ANGLES_DEG))
    expected = [fresnel_snell(c, eta) for c in cos]
    got = shared.fresnel_dielectric(cos, eta)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-16)


def test_fresnel_dielectric_at_normal_incidence_and_grazing():
    for eta in (1.0, 1.2, 1.5, 2.4, 3.0):
        assert shared.fresnel_dielectric(np.array([1.0]), eta)[0] == pytest.approx(
            ((eta - 1) / (eta + 1)) ** 2, rel=1e-13, abs=1e-17
        )
        if eta > 1.0:
            assert shared.fresnel_dielectric(np.array([0.0]), eta)[0] == 1.0
    # A scalar input gives a 0-d result, not an error.
    assert float(shared.fresnel_dielectric(0.5, 1.5)) == pytest.approx(
        fresnel_snell(0.5, 1.5), rel=1e-12
    )


def test_fresnel_dielectric_is_total_below_the_critical_angle_for_eta_below_one():
    eta = 0.7
    critical = math.sqrt(1.0 - eta * eta)  # cos of the critical angle
    cos = np.array([0.0, 0.3 * critical, 0.99 * critical])
    np.testing.assert_array_equal(shared.fresnel_dielectric(cos, eta), 1.0)
    assert shared.fresnel_dielectric(np.array([1.0]), eta)[0] < 0.05


@pytest.mark.parametrize("eta", [1.1, 1.5, 2.5])
def test_fresnel_conductor_without_absorption_is_the_dielectric(eta):
    cos = np.cos(np.radians(ANGLES_DEG))
    np.testing.assert_allclose(
        shared.fresnel_conductor(cos, eta, 0.0),
        shared.fresnel_dielectric(cos, eta),
        rtol=1e-12,
        atol=1e-16,
    )


# Complex indices of metals near 550 nm (gold, silver, copper, aluminium) and a
# strongly absorbing index below 1.
@pytest.mark.parametrize(
    "eta, k", [(0.43, 2.45), (0.06, 3.6), (1.1, 2.58), (0.96, 6.69), (2.0, 0.5)]
)
def test_fresnel_conductor_matches_the_complex_index_computation(eta, k):
    cos = np.cos(np.radians(ANGLES_DEG))
    expected = [fresnel_snell(c, complex(eta, k)) for c in cos]
    np.testing.assert_allclose(shared.fresnel_conductor(cos, eta, k), expected, rtol=1e-11)
    normal = ((eta - 1) ** 2 + k * k) / ((eta + 1) ** 2 + k * k)
    assert shared.fresnel_conductor(np.array([1.0]), eta, k)[0] == pytest.approx(normal, rel=1e-12)


@pytest.mark.parametrize("f0", [0.0, 0.04, 0.5, 0.95, 1.0])
def test_schlick_end_points_and_formula(f0):
    cos = np.array([1.0, 0.0, 0.3, 0.7])
    got = shared.fresnel_schlick(cos, f0)
    assert got[0] == f0
    assert got[1] == 1.0
    for c, value in zip(cos[2:], got[2:]):
        assert value == pytest.approx(f0 + (1 - f0) * (1 - c) ** 5, rel=1e-14)
    np.testing.assert_allclose(shared.schlick_weight(cos), (1 - cos) ** 5, rtol=1e-14)


# ------------------------------------------------------------------ V-cavity
def test_vcavity_g_is_in_unit_interval_symmetric_and_one_at_normal_incidence():
    wi, wo = hemisphere_pairs(4000, seed=11)
    h = wi + wo
    h /= np.linalg.norm(h, axis=1)[:, None]
    cos_h, cos_i, cos_o = h[:, 2], wi[:, 2], wo[:, 2]
    cos_d = np.einsum("ij,ij->i", wo, h)
    g = shared.vcavity_g(cos_h, cos_i, cos_o, cos_d)
    assert (g >= 0).all() and (g <= 1).all()
    assert (g < 0.5).any(), "grazing pairs must be shadowed"
    np.testing.assert_array_equal(g, shared.vcavity_g(cos_h, cos_o, cos_i, cos_d))
    for k in range(0, 4000, 397):
        expected = min(1.0, 2 * cos_h[k] * cos_o[k] / cos_d[k], 2 * cos_h[k] * cos_i[k] / cos_d[k])
        assert g[k] == pytest.approx(expected, rel=1e-14)
    one = np.array([1.0])
    assert shared.vcavity_g(one, one, one, one)[0] == 1.0


# ------------------------------------------------------------- distributions
def _gauss_legendre_01(n: int):
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (x + 1.0), 0.5 * w


def projected_integral(d_of, alpha_u: float, alpha_v: float, n_s: int, n_phi: int) -> float:
    """``integral D(h) cos(theta_h) dw_h`` over the hemisphere, by quadrature.

    With ``t = tan(theta_h)``, ``cos sin dtheta = t dt / (1 + t^2)^2``. For each
    azimuth, ``t = a_phi s`` with ``a_phi`` the width of D along phi (any positive
    scale is a valid substitution; this one puts the nodes where D lives), and
    ``s = x/(1 - x)`` maps ``x in (0, 1)`` onto ``(0, inf)``: Gauss-Legendre in x.
    The azimuth is integrated by the trapezoid rule, spectrally accurate for a
    periodic integrand.
    """
    x, w = _gauss_legendre_01(n_s)
    phi = np.arange(n_phi) * (2 * np.pi / n_phi)
    cos2_phi = np.cos(phi) ** 2
    a_phi = 1.0 / np.sqrt(cos2_phi / alpha_u**2 + (1 - cos2_phi) / alpha_v**2)
    s = x / (1 - x)
    t = a_phi[:, None] * s[None, :]
    dt = a_phi[:, None] * (w / (1 - x) ** 2)[None, :]
    tan2 = t * t
    cos_h = 1.0 / np.sqrt(1.0 + tan2)
    d = d_of(tan2.ravel(), cos_h.ravel(), np.repeat(cos2_phi, n_s)).reshape(t.shape)
    return float(np.sum(d * t / (1 + tan2) ** 2 * dt) * (2 * np.pi / n_phi))


ISO_ALPHAS = (0.001, 0.003, 0.02, 0.1, 0.5, 1.0)


@pytest.mark.parametrize("alpha", ISO_ALPHAS)
@pytest.mark.parametrize("name", ["beckmann_d", "ggx_d"])
def test_isotropic_distributions_integrate_to_one_projected(name, alpha):
    """Quadrature accuracy: the result changes by < 1e-13 from 200 to 400 nodes
    (checked here), so a deviation from 1 above 1e-11 is the distribution's."""
    fn = getattr(shared, name)

    def d_of(tan2, cos_h, _cos2_phi):
        return fn(tan2, cos_h, alpha * alpha)

    coarse = projected_integral(d_of, alpha, alpha, 200, 4)
    fine = projected_integral(d_of, alpha, alpha, 400, 4)
    assert abs(fine - coarse) < 1e-13
    assert fine == pytest.approx(1.0, abs=1e-11)


ANISO_ALPHAS = ((0.001, 0.01), (0.01, 0.001), (0.02, 0.3), (0.3, 0.05), (0.5, 1.0))


@pytest.mark.parametrize("alpha_u, alpha_v", ANISO_ALPHAS)
@pytest.mark.parametrize("name", ["beckmann_d_anisotropic", "ggx_d_anisotropic"])
def test_anisotropic_distributions_integrate_to_one_projected(name, alpha_u, alpha_v):
    """Quadrature accuracy: < 1e-12 change when both node counts double (checked);
    alpha ratios up to 15 need ~1e3 azimuths for the trapezoid rule."""
    fn = getattr(shared, name)

    def d_of(tan2, cos_h, cos2_phi):
        return fn(tan2, cos_h, cos2_phi, alpha_u, alpha_v)

    coarse = projected_integral(d_of, alpha_u, alpha_v, 120, 1024)
    fine = projected_integral(d_of, alpha_u, alpha_v, 240, 2048)
    assert abs(fine - coarse) < 1e-12
    assert fine == pytest.approx(1.0, abs=1e-10)


def test_anisotropic_distributions_match_the_slope_space_form():
    """Mitsuba's form ``1/(pi au av ((hx/au)^2 + (hy/av)^2 + hz^2)^2)`` (GGX) and
    ``exp(-((hx/au)^2 + (hy/av)^2)/hz^2)/(pi au av hz^4)`` (Beckmann), at unit h."""
    rng = np.random.default_rng(3)
    for _ in range(40):
        theta, phi = rng.uniform(0, 1.4), rng.uniform(0, 2 * math.pi)
        au, av = np.exp(rng.uniform(np.log(0.01), 0, 2))
        hx, hy, hz = (
            math.sin(theta) * math.cos(phi),
            math.sin(theta) * math.sin(phi),
            math.cos(theta),
        )
        q = (hx / au) ** 2 + (hy / av) ** 2
        ggx = 1 / (math.pi * au * av * (q + hz * hz) ** 2)
        beck = math.exp(-q / (hz * hz)) / (math.pi * au * av * hz**4)
        args = (np.array([math.tan(theta) ** 2]), np.array([hz]), np.array([math.cos(phi) ** 2]))
        assert shared.ggx_d_anisotropic(*args, au, av)[0] == pytest.approx(ggx, rel=1e-12)
        if beck > 1e-250:
            assert shared.beckmann_d_anisotropic(*args, au, av)[0] == pytest.approx(
                beck, rel=1e-10
            )


# ------------------------------------------------------------------- Smith G1
def _smith_lambda_integral(p2, cot: float) -> float:
    """Smith's ``Lambda(mu) = (1/mu) integral_mu^inf (q - mu) P2(q) dq``, mu = cot(theta)."""
    value, _ = integrate.quad(lambda q: (q - cot) * p2(q), cot, np.inf, epsabs=0, epsrel=1e-13)
    return value / cot


def _p2_beckmann(alpha):
    return lambda q: math.exp(-((q / alpha) ** 2)) / (alpha * math.sqrt(math.pi))


def _p2_ggx(alpha):
    # Marginal of the GGX slope density 1/(pi a^2 (1 + (x^2+y^2)/a^2)^2) over y.
    return lambda q: 1.0 / (2 * alpha * (1 + (q / alpha) ** 2) ** 1.5)


THETAS_DEG = (5.0, 30.0, 60.0, 80.0, 88.0)


@pytest.mark.parametrize("alpha", [0.05, 0.3, 1.0])
@pytest.mark.parametrize(
    "name, p2", [("smith_g1_beckmann", _p2_beckmann), ("smith_g1_ggx", _p2_ggx)]
)
def test_smith_g1_equals_smiths_integral_definition(name, p2, alpha):
    fn = getattr(shared, name)
    for theta in THETAS_DEG:
        cot = 1.0 / math.tan(math.radians(theta))
        expected = 1.0 / (1.0 + _smith_lambda_integral(p2(alpha), cot))
        got = fn(np.array([math.tan(math.radians(theta)) ** 2]), alpha * alpha)[0]
        assert got == pytest.approx(expected, rel=1e-9), theta


def test_smith_g1_closed_forms_and_limits():
    """Closed forms (Walter et al. 2007, Heitz 2014): GGX ``Lambda = (sqrt(1 + 1/a^2) - 1)/2``,
    Beckmann ``Lambda = (erf(a) - 1)/2 + exp(-a^2)/(2 a sqrt(pi))``, ``a = 1/(alpha tan)``."""
    theta = np.radians(np.linspace(0.0, 89.999, 400))
    tan2 = np.tan(theta) ** 2
    for alpha in (0.001, 0.01, 0.2, 1.0):
        ggx = shared.smith_g1_ggx(tan2, alpha * alpha)
        beck = shared.smith_g1_beckmann(tan2, alpha * alpha)
        for g1 in (ggx, beck):
            assert g1[0] == 1.0
            assert (np.diff(g1) <= 0).all(), "G1 must not increase towards grazing"
            assert (g1 > 0).all() and (g1 <= 1).all()
        for k in range(1, len(theta), 37):
            a = 1.0 / (alpha * math.tan(theta[k]))
            lam_ggx = (math.sqrt(1 + 1 / (a * a)) - 1) / 2
            lam_beck = (math.erf(a) - 1) / 2 + math.exp(-a * a) / (2 * a * math.sqrt(math.pi))
            assert ggx[k] == pytest.approx(1 / (1 + lam_ggx), rel=1e-13)
            assert beck[k] == pytest.approx(1 / (1 + lam_beck), rel=1e-13, abs=1e-15)
    # Grazing: G1 falls to zero like 2 a sqrt(pi) (Beckmann) and 2 a (GGX).
    tiny = np.array([1e16])
    assert shared.smith_g1_ggx(tiny, 1.0)[0] == pytest.approx(2e-8, rel=1e-6)
    assert shared.smith_g1_beckmann(tiny, 1.0)[0] == pytest.approx(
        2e-8 * math.sqrt(math.pi), rel=1e-6
    )


def _half_line(n: int, scale: float):
    """Gauss-Legendre nodes and weights on (0, inf) through ``t = scale x/(1 - x)``."""
    x, w = _gauss_legendre_01(n)
    return scale * x / (1 - x), scale * w / (1 - x) ** 2


def _anisotropic_lambda(d_fn, au, av, phi, cot, n):
    """Smith's Lambda along azimuth phi, ``(1/mu) integral (q - mu)+ P22 dq dr``, with
    the slope density ``P22 = D cos^4`` of the library's anisotropic D; q is the
    slope along phi, r across it. Gauss-Legendre on mapped half-lines; across,
    the scale grows with q, as the width of GGX's heavy tail does."""
    u, wu = _half_line(n, av)
    q = cot + u
    s, ws = _half_line(n, 1.0)
    s = np.concatenate([-s[::-1], s])
    ws = np.concatenate([ws[::-1], ws])
    width = np.sqrt(av * av + q * q)[:, None]
    qq, rr = q[:, None] * np.ones_like(s), width * s
    wr = width * ws
    x = qq * math.cos(phi) - rr * math.sin(phi)
    y = qq * math.sin(phi) + rr * math.cos(phi)
    tan2 = x * x + y * y
    cos2 = 1 / (1 + tan2)
    d = d_fn(tan2.ravel(), np.sqrt(cos2).ravel(), (x * x / tan2).ravel(), au, av)
    p22 = d.reshape(tan2.shape) * cos2 * cos2
    return float(np.einsum("i,ij,ij->", wu, (qq - cot) * p22, wr)) / cot


@pytest.mark.parametrize("distribution", ["beckmann", "ggx"])
def test_projected_alpha_gives_the_smith_lambda_of_the_anisotropic_distribution(distribution):
    """Lambda of an anisotropic D along azimuth phi, from Smith's definition with the
    slope density taken from the library's anisotropic D, equals the isotropic G1
    at the projected alpha. Quadrature accuracy: < 1e-12 change from 100 to 200
    nodes per axis (checked; about 1e-14 in practice)."""
    au, av = 0.15, 0.5
    d_fn = getattr(shared, f"{distribution}_d_anisotropic")
    g1_fn = getattr(shared, f"smith_g1_{distribution}")
    for phi_deg, theta_deg in ((0.0, 70.0), (90.0, 70.0), (35.0, 80.0), (120.0, 60.0)):
        phi, cot = math.radians(phi_deg), 1 / math.tan(math.radians(theta_deg))
        coarse = _anisotropic_lambda(d_fn, au, av, phi, cot, 100)
        fine = _anisotropic_lambda(d_fn, au, av, phi, cot, 200)
        assert abs(fine - coarse) < 1e-12 * (1 + fine)
        c2 = math.cos(phi) ** 2
        alpha2 = shared.projected_alpha2(np.array([c2]), au, av)
        assert alpha2[0] == pytest.approx(au * au * c2 + av * av * (1 - c2), rel=1e-14)
        got = g1_fn(np.array([1 / cot**2]), alpha2)[0]
        assert got == pytest.approx(1 / (1 + fine), rel=1e-11), (phi_deg, theta_deg)


def test_tan2_theta_from_cosine():
    for theta in (0.0, 0.1, 0.7, 1.2, 1.5):
        got = shared.tan2_theta(np.array([math.cos(theta)]))[0]
        assert got == pytest.approx(math.tan(theta) ** 2, rel=1e-12, abs=1e-30)
