"""pbrt-v4's ``coateddiffuse`` in closed form: the expectation of its random walk.

pbrt-v4's CoatedDiffuseMaterial is a ``LayeredBxDF`` (src/pbrt/bxdfs.h) of a rough
``DielectricBxDF`` (Trowbridge-Reitz, i.e. GGX, widths ``alpha``; exact dielectric
Fresnel of ``eta``; height-correlated ``G = 1 / (1 + Lambda(wo) + Lambda(wi))``)
over a Lambertian ``DiffuseBxDF`` of reflectance ``R``, the two ``thickness``
apart. pbrt estimates its BSDF by a random walk (Guo, Hasan and Zhao, Position-free
Monte Carlo simulation for arbitrary layered BSDFs, ACM TOG 37(6), 2018; Pharr,
Jakob and Humphreys, Physically Based Rendering, 4th ed., section 14.3). With
``albedo = 0`` (pbrt's default: no scattering medium) each crossing of the layer
multiplies the throughput by ``Tr = exp(-thickness / |cos|)`` (``LayeredBxDF::Tr``).
After the first bounce on the Lambertian base the direction is cosine-distributed,
whatever came before, so the walk's expectation separates::

    f(wo, wi) = f_R(wo, wi) + R T(wo) T(wi) / (pi eta^2) * S_N(R r),
    S_N(x) = 1 + x + ... + x^(N-1) = (1 - x^N) / (1 - x).

``f_R = D G F(wo.h; eta) / (4 cos cos)`` is the interface's reflection.
``T(w) = integral f_t(w, w') |cos w'| Tr(w') dw'`` is the energy the interface lets
through from ``w``, attenuated on the way down: with visible normals ``m`` of ``w``
(Heitz, Sampling the GGX distribution of visible normals, JCGT 7(4), 2018; pbrt's
``Sample_wm``) it is ``E_m[(1 - F(w.m)) G(w, w_t) / G1(w) Tr(w_t)]``, ``w_t`` refracted.
``r = integral 2 mu Tr(mu) rho(mu) dmu`` is the cosine-weighted internal
reflectance, ``rho(mu) = E_m[F(w.m; 1/eta) G(w, w_r) / G1(w) Tr(w_r)]`` (total
internal reflection included): one round trip from the base back to it, attenuated
twice. The single ``1 / eta^2`` is pbrt's radiance scaling: ``DielectricBxDF``
divides a transmission by ``etap^2`` in radiance mode, ``1/eta^2`` on the way in
from ``wo`` and ``eta^2`` on the way out to ``wi``; by the symmetry
``f(a, b) / etap(a)^2 = f(b, a)`` of its rough BTDF the exit integral over the base's
cosine-distributed directions is ``T(wi) / pi``, which leaves one ``1 / eta^2``, the
radiance compression of light leaving the denser coat.

That is the layered model's BRDF, and what an unbiased walk converges to. pbrt's
estimator does not: at each bounce on the base it adds two estimates of the light
leaving towards ``wi``, one along ``wis`` (a refraction sampled from ``wi``, density
``p_a = PDF(wi -> w)``) and one along the base's cosine sample ``u`` (density
``p_b``), with power-heuristic weights; but the second weight uses
``exitPDF = PDF(-u -> wi)``, the density of the reverse refraction, in place of
``p_a``, so the two weights do not sum to one, and it skips the whole sample when
``wis`` fails (its second estimate with it). Since this exit is the same integral at
every bounce, pbrt's expectation is the formula above with ``T(wi)`` replaced by
``T'(wi) = E_m[(1 - F) G / G1 Tr(w_t) (p_a^2 / (p_a^2 + p_b^2) + P_ok p_b^2 /
(p_b^2 + p_c^2))]`` with ``p_c = PDF(w_t -> wi)`` (equal to ``p_a G1(w_t) |wi_z| /
(eta^2 G1(wi) |w_t,z|)`` through the shared microfacet) and ``P_ok`` the chance of a
valid ``wis``; it is not reciprocal. A line-by-line port of ``LayeredBxDF::f``
(tests/export/test_pbrt_layered.py) agrees with it; ``T'/T`` was 1.02 to 1.7 for
alpha 0.1 to 0.6, eta 1.5 to 2.2, light at 0 to 80 degrees (the larger for larger
eta, alpha and angle): pbrt renders the
diffuse term of a coateddiffuse that much brighter than the layered model, and the
export, fitted to what pbrt renders, writes a correspondingly darker reflectance.
:func:`coated_brdf` gives either.

``N``: pbrt's walk (``LayeredBxDF::f``) crosses the layer once per depth, down to the
base at even depths and up to the interface at odd ones, so ``maxdepth`` allows
``N = ceil(maxdepth / 2)`` bounces on the base (5 at pbrt's default 10); Russian
roulette there is unbiased. The diffuse term is therefore ``(R r)^N`` short of the
full series, which the closed form keeps.

``T`` is tabulated at 64 cosines ``mu = s^2``, ``s`` evenly spaced in [0, 1], and
interpolated by a cubic spline in ``s`` (within 1e-4 of direct quadrature, also at
grazing angles, where T is steepest), and so is ``T'``; the expectations over
visible normals use a Gauss-Legendre rule in the polar angle of the disk seen as a
hemisphere (``|p| = sin theta``) times a uniform rule in its azimuth, and ``r`` a
48-point Gauss-Legendre rule in ``mu``; ``T`` is within 1e-5 and ``r`` within
about 1e-4 of rules 24 times finer. Only
isotropic coats (``uroughness = vroughness``) are modelled.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from ..models import Design, Model, Param
from ..models.base import Classification
from ..models.params import roughness
from ..models.renderer_native import gltf_specular
from ..models.shared import fresnel_dielectric

__all__ = [
    "PBRT_COATEDDIFFUSE",
    "coated_brdf",
    "coated_tables",
    "depth_bounces",
    "reflectance_from_diffuse",
    "series",
]

#: pbrt-v4's defaults (materials.cpp, CoatedDiffuseMaterial::Create).
THICKNESS, MAXDEPTH = 0.01, 10
#: ``T`` is tabulated at ``mu = s^2`` for these ``s`` (dense where T is steep, at grazing).
ROOTS = np.linspace(0.0, 1.0, 64)
#: Disk rules (radial x angular nodes) of T and of rho; rho's integrand has the kink of
#: total internal reflection, hence the finer rule (both within 1e-4 of 384 x 768).
T_RULE, R_RULE = (16, 32), (64, 128)


@lru_cache(maxsize=4)
def _disk_rule(n_r: int, n_phi: int) -> tuple:
    """Nodes (px, py) and weights (summing to 1) of the uniform unit disk."""
    x, w = np.polynomial.legendre.leggauss(n_r)
    theta, wt = 0.25 * math.pi * (x + 1.0), 0.25 * math.pi * w
    r = np.sin(theta)  # the disk as a hemisphere: no square root at its rim
    phi = (np.arange(n_phi) + 0.5) * (2.0 * math.pi / n_phi)
    rr, pp = np.meshgrid(r, phi, indexing="ij")
    weight = (2.0 * wt * r * np.cos(theta))[:, None] * np.full(n_phi, 1.0 / n_phi)[None, :]
    return (rr * np.cos(pp)).ravel(), (rr * np.sin(pp)).ravel(), weight.ravel()


def _lambda(z, alpha: float) -> np.ndarray:
    """Smith's ``Lambda`` of GGX at direction cosine ``z`` (isotropic)."""
    z2 = np.maximum(z * z, 1e-300)
    return 0.5 * (np.sqrt(1.0 + alpha * alpha * np.maximum(1.0 - z2, 0.0) / z2) - 1.0)


def _visible_normals(mu: np.ndarray, alpha: float, rule: tuple) -> tuple:
    """pbrt's ``Sample_wm`` of ``w = (sqrt(1 - mu^2), 0, mu)`` at the disk rule's
    nodes: (m_x, m_y, m_z), each (len(mu), K), and the weights (K,)."""
    px, py, weight = _disk_rule(*rule)
    s = np.sqrt(np.maximum(1.0 - mu * mu, 0.0))
    hx, hz = alpha * s, mu
    norm = np.sqrt(hx * hx + hz * hz)
    hx, hz = (hx / norm)[:, None], (hz / norm)[:, None]
    # T1 = y, T2 = wh x T1 = (-hz, 0, hx) for wh in the xz plane.
    h = np.sqrt(1.0 - px * px)
    py = (1.0 - 0.5 * (1.0 + hz)) * h + 0.5 * (1.0 + hz) * py
    pz = np.sqrt(np.maximum(0.0, 1.0 - px * px - py * py))
    nx, ny, nz = py * -hz + pz * hx, px + 0.0 * hz, py * hx + pz * hz
    mx, my, mz = alpha * nx, alpha * ny, np.maximum(1e-6, nz)
    length = np.sqrt(mx * mx + my * my + mz * mz)
    return mx / length, my / length, mz / length, weight


def _interface(mu, alpha: float, eta: float, thickness: float, transmit: bool, mis=False):
    """``T(mu)`` (``transmit``; ``T'`` with ``mis``) or ``rho(mu)`` with ``eta`` as
    given (module docstring)."""
    mx, _, mz, weight = _visible_normals(mu, alpha, T_RULE if transmit else R_RULE)
    wx, wz = np.sqrt(np.maximum(1.0 - mu * mu, 0.0))[:, None], mu[:, None]
    c = wx * mx + wz * mz
    f = fresnel_dielectric(np.maximum(c, 1e-12), eta)
    if transmit:
        cos_t = np.sqrt(np.maximum(1.0 - (1.0 - c * c) / (eta * eta), 0.0))
        k = c / eta - cos_t  # w_t = m (c/eta - cos_t) - w/eta
        oz = mz * k - wz / eta
        value, valid, out_z = 1.0 - f, oz < 0.0, -oz
    else:
        oz = 2.0 * c * mz - wz
        value, valid, out_z = f, oz > 0.0, oz
    valid &= c > 0.0
    out_z = np.where(valid, out_z, 1.0)
    lam = _lambda(wz, alpha)
    lam_out = _lambda(out_z, alpha)
    value = value * (1.0 + lam) / (1.0 + lam + lam_out)
    value = value * np.exp(-thickness / out_z)
    if mis:
        ok = np.where(valid, 1.0, 0.0) @ weight  # pbrt skips the sample if wis fails
        geometry = (c, cos_t, mz, wz, out_z, lam, lam_out)
        value = value * _pbrt_mis(geometry, alpha, eta, ok[:, None])
    return np.where(valid, value, 0.0) @ weight


def _pbrt_mis(geometry: tuple, alpha: float, eta: float, ok) -> np.ndarray:
    """pbrt's two MIS weights at a base bounce, summed, for the exit direction ``w_t``
    refracted from ``w`` through ``m`` (module docstring); ``ok`` the chance that
    pbrt's ``wis`` sample is valid."""
    c, cos_t, mz, wz, out_z, lam, lam_out = geometry
    m2 = mz * mz
    d = 1.0 / (math.pi * alpha**2 * m2 * m2 * (1.0 + (1.0 - m2) / (m2 * alpha**2)) ** 2)
    # PDF(w -> w_t): visible normals D_w(m) times the refraction Jacobian.
    p_a = eta**2 / (1.0 + lam) / wz * d * c * cos_t / (c - eta * cos_t) ** 2
    # PDF(w_t -> w), which pbrt uses in place of p_a for its BSDF-sampled exit.
    p_c = p_a * (1.0 + lam) * wz / (eta**2 * (1.0 + lam_out) * out_z)
    p_b = out_z / math.pi  # the base's cosine sampling
    return p_a**2 / (p_a**2 + p_b**2) + ok * p_b**2 / (p_b**2 + p_c**2)


@lru_cache(maxsize=256)
def transmittance_table(alpha: float, eta: float, thickness: float, mis: bool = False):
    """``T`` (``T'`` with ``mis``) as a cubic spline in ``sqrt(mu)`` through
    :data:`ROOTS` (module docstring)."""
    from scipy.interpolate import CubicSpline  # here: an export's only need of it

    mu = np.maximum(ROOTS * ROOTS, 1e-6)
    return CubicSpline(ROOTS, _interface(mu, alpha, eta, thickness, True, mis))


@lru_cache(maxsize=64)
def internal_reflectance(alpha: float, eta: float, thickness: float) -> float:
    """``r``, the base-to-base round trip (module docstring)."""
    x, w = np.polynomial.legendre.leggauss(48)
    mu, w = 0.5 * (x + 1.0), 0.5 * w
    rho = _interface(mu, alpha, 1.0 / eta, thickness, transmit=False)
    return float(np.sum(w * 2.0 * mu * np.exp(-thickness / mu) * rho))


def coated_tables(alpha: float, eta: float, thickness: float) -> tuple:
    """(``T`` as a spline in ``sqrt(mu)``, ``r``) of a coat."""
    key = (float(alpha), float(eta), float(thickness))
    return transmittance_table(*key), internal_reflectance(*key)


def transmittance(cos_theta, alpha: float, eta: float, thickness: float, mis=False):
    """``T`` (``T'`` with ``mis``) at the given cosines, from the spline."""
    spline = transmittance_table(float(alpha), float(eta), float(thickness), bool(mis))
    return spline(np.sqrt(np.clip(cos_theta, 0.0, 1.0)))


def depth_bounces(maxdepth: int) -> int:
    """Bounces on the base that pbrt's walk of ``maxdepth`` crossings allows."""
    return (int(maxdepth) + 1) // 2


def series(x, n: int) -> np.ndarray:
    """``S_n(x) = 1 + x + ... + x^(n-1)``."""
    x = np.asarray(x, dtype=float)
    return sum(x**j for j in range(n))


def reflectance_from_diffuse(diffuse, r: float, maxdepth: int = MAXDEPTH) -> tuple:
    """pbrt's ``reflectance`` R with ``R S_N(R r) = diffuse`` (per channel), clipped
    to [0, 1]; and whether any channel was clipped at 1."""
    d = np.atleast_1d(np.asarray(diffuse, dtype=float))
    n = depth_bounces(maxdepth)
    top = float(series(r, n))
    lo, hi = np.zeros_like(d), np.ones_like(d)
    for _ in range(60):  # R S_N(R r) increases with R: bisection
        mid = 0.5 * (lo + hi)
        low = mid * series(mid * r, n) < d
        lo, hi = np.where(low, mid, lo), np.where(low, hi, mid)
    out = np.where(d >= top, 1.0, 0.5 * (lo + hi))
    return np.clip(out, 0.0, 1.0), bool(np.any(d > top * (1 + 1e-9)))


def _design(geometry, shape) -> Design:
    alpha, eta, thickness = shape["alpha"], shape["eta"], shape["thickness"]
    return Design(*_terms(geometry, alpha, eta, thickness, mis=True))


def _terms(geometry, alpha: float, eta: float, thickness: float, mis: bool) -> tuple:
    """(``(T'(wi) T(wo) / (pi eta^2),)``, ``f_R``); ``T`` for ``T'`` unless ``mis``."""
    top = gltf_specular(geometry, alpha, alpha) * fresnel_dielectric(geometry.cos_d, eta)
    column = transmittance(geometry.wi[:, 2], alpha, eta, thickness, mis)
    column = column * transmittance(geometry.wo[:, 2], alpha, eta, thickness)
    return (column / (math.pi * eta * eta),), top


def coated_brdf(geometry, q: dict, mis: bool = True) -> np.ndarray:
    """(M, 3) BRDF of a ``coateddiffuse`` of parameters ``q`` (``reflectance``,
    ``uroughness``, ``eta``, ``thickness``, ``maxdepth``): pbrt's expectation, or with
    ``mis`` false the layered model's (module docstring)."""
    alpha, eta, thickness = q["uroughness"], q["eta"], q["thickness"]
    (column,), top = _terms(geometry, alpha, eta, thickness, mis)
    r = internal_reflectance(float(alpha), float(eta), float(thickness))
    n = depth_bounces(q["maxdepth"])
    big_r = np.asarray(q["reflectance"], dtype=float)
    return top[:, None] + (big_r * series(big_r * r, n))[None, :] * column[:, None]


_DIFFUSE_DOC = "R S_N(R r): pbrt's reflectance R through the walk's series"
_ALPHA_DOC = (
    "GGX width alpha = pbrt uroughness = vroughness (remaproughness false); "
    "pbrt's remapped roughness would be alpha^2"
)
_THICKNESS_DOC = "pbrt thickness (absorption exp(-thickness/|cos|) per crossing)"

#: pbrt-v4's coateddiffuse as a model (unregistered: the pbrt export fits it).
PBRT_COATEDDIFFUSE = Model(
    name="pbrt_coateddiffuse",
    params=(
        Param("diffuse", 0.0, 10.0, 0.5, linear=True, unit="1", doc=_DIFFUSE_DOC),
        roughness("alpha", doc=_ALPHA_DOC),
        Param("eta", 1.05, 3.0, 1.5, unit="1", doc="pbrt eta of the coat"),
        Param("thickness", 0.0, 10.0, THICKNESS, unit="1", doc=_THICKNESS_DOC),
    ),
    classification=Classification("physical", "isotropic", "cosine", "material"),
    reference="pbrt-v4 (M. Pharr, W. Jakob, G. Humphreys), bxdfs.h LayeredBxDF; Guo, Hasan "
    "and Zhao, ACM TOG 37(6), 2018; Heitz, JCGT 7(4), 2018",
    design=_design,
    held=("thickness",),
    reciprocal=False,
    doc="f_R + diffuse T'(wi) T(wo) / (pi eta^2): the expectation of pbrt-v4's "
    "coateddiffuse estimator (brdffit.export.pbrt_layer).",
)
