"""Microfacet pieces shared by every physical model: Fresnel, D, shadowing.

One implementation of each, reused by all models (as Mitsuba 3 does), so a fix
or a check applies everywhere. All functions are plain vectorised numpy
functions of cosines (or squared tangents) and parameters.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import erf

__all__ = [
    "fresnel_dielectric",
    "fresnel_conductor",
    "fresnel_schlick",
    "vcavity_g",
    "beckmann_d",
    "ggx_d",
    "smith_g1_ggx",
    "smith_g1_beckmann",
    "tan2_theta",
]

SQRT_PI = math.sqrt(math.pi)


def fresnel_dielectric(c: np.ndarray, eta: float) -> np.ndarray:
    """Unpolarised Fresnel reflectance of a dielectric of relative index ``eta``.

    ``F = 1/2 (g-c)^2/(g+c)^2 (1 + ((c(g+c) - 1)/(c(g-c) + 1))^2)`` with
    ``g = sqrt(eta^2 - 1 + c^2)`` and ``c = V.H`` (Cook and Torrance 1982, eq. in
    the appendix). The paper prints ``g = sqrt(c^2 + tau^2) + I``: MODELS.md reads
    ``tau`` as ``eta`` and ``+ I`` as the ``-1`` inside the root. For ``eta >= 1``
    the root is real, and ``F(1) = ((eta-1)/(eta+1))^2``.
    """
    g = np.sqrt(eta * eta - 1.0 + c * c)
    gmc = g - c
    gpc = g + c
    a = gmc / gpc
    b = (c * gpc - 1.0) / (c * gmc + 1.0)
    return 0.5 * a * a * (1.0 + b * b)


def fresnel_conductor(c: np.ndarray, eta: float, k: float) -> np.ndarray:
    """Unpolarised Fresnel reflectance of a conductor of complex index ``eta + i k``.

    The exact expression for s- and p-polarised light (e.g. Born and Wolf,
    section 14.2; the form used by pbrt-v3 ``FrConductor``), averaged. Reduces to
    :func:`fresnel_dielectric` when ``k = 0`` and ``eta >= 1``.
    """
    c2 = c * c
    s2 = 1.0 - c2
    e2 = eta * eta
    k2 = k * k
    t0 = e2 - k2 - s2
    a2b2 = np.sqrt(t0 * t0 + 4.0 * e2 * k2)
    a = np.sqrt(np.maximum(0.5 * (a2b2 + t0), 0.0))
    t1 = a2b2 + c2
    t2 = 2.0 * c * a
    rs = (t1 - t2) / (t1 + t2)
    t3 = c2 * a2b2 + s2 * s2
    t4 = t2 * s2
    rp = rs * (t3 - t4) / (t3 + t4)
    return 0.5 * (rs + rp)


def fresnel_schlick(c: np.ndarray, f0) -> np.ndarray:
    """Schlick's approximation ``F0 + (1 - F0)(1 - c)^5`` (Schlick 1994)."""
    return f0 + (1.0 - f0) * (1.0 - c) ** 5


def vcavity_g(cos_h, cos_i, cos_o, cos_d) -> np.ndarray:
    """V-cavity shadowing-masking of Torrance-Sparrow and Cook-Torrance:
    ``G = min(1, 2 (N.H)(N.V)/(V.H), 2 (N.H)(N.L)/(V.H))``. Parameter-free."""
    scale = 2.0 * cos_h / np.maximum(cos_d, 1e-300)
    return np.minimum(1.0, scale * np.minimum(cos_i, cos_o))


def tan2_theta(cos_t: np.ndarray) -> np.ndarray:
    """tan^2 of a polar angle from its cosine (cosine already clamped > 0)."""
    c2 = cos_t * cos_t
    return np.maximum(1.0 - c2, 0.0) / c2


def beckmann_d(tan2_h, cos_h, alpha2) -> np.ndarray:
    """Beckmann distribution ``exp(-tan^2/alpha^2) / (pi alpha^2 cos^4)``; alpha2 may be
    an array (anisotropic: ``1/alpha2 = cos^2 phi/alpha_u^2 + sin^2 phi/alpha_v^2``
    is folded in by the caller through ``tan2_h / alpha2``)."""
    c2 = cos_h * cos_h
    return np.exp(-tan2_h / alpha2) / (math.pi * alpha2 * c2 * c2)


def ggx_d(tan2_h, cos_h, alpha2) -> np.ndarray:
    """GGX (Trowbridge-Reitz) distribution
    ``1 / (pi alpha^2 cos^4 (1 + tan^2/alpha^2)^2)`` (Walter et al. 2007, eq. 33)."""
    c2 = cos_h * cos_h
    t = 1.0 + tan2_h / alpha2
    return 1.0 / (math.pi * alpha2 * c2 * c2 * t * t)


def smith_g1_ggx(tan2_v, alpha2) -> np.ndarray:
    """Smith masking of GGX, ``2 / (1 + sqrt(1 + alpha^2 tan^2 theta_v))`` (Walter et
    al. 2007, eq. 34). For anisotropic GGX pass the projected ``alpha^2``."""
    return 2.0 / (1.0 + np.sqrt(1.0 + alpha2 * tan2_v))


def smith_g1_beckmann(tan2_v, alpha2) -> np.ndarray:
    """Exact Smith masking of Beckmann: ``1 / (1 + Lambda(a))`` with
    ``a = 1 / (alpha tan theta_v)`` and
    ``Lambda = (erf(a) - 1)/2 + exp(-a^2) / (2 a sqrt(pi))`` (Walter et al. 2007,
    eq. 25 and Heitz 2014, eq. 72). G1 = 1 at normal incidence (a = inf)."""
    with np.errstate(divide="ignore"):
        a = 1.0 / np.sqrt(alpha2 * tan2_v)
    a = np.minimum(a, 1e150)
    lam = 0.5 * (erf(a) - 1.0) + np.exp(-a * a) / (2.0 * SQRT_PI * a)
    return 1.0 / (1.0 + np.maximum(lam, 0.0))
