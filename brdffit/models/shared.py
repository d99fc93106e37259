"""Microfacet pieces shared by every physical model: Fresnel, D, shadowing.

One implementation of each, reused by all models (as Mitsuba 3 does), so a fix
or a check applies everywhere. All functions are plain vectorised numpy
functions of cosines (or squared tangents) and parameters. They run in a fit's
inner loop on arrays of up to millions of pairs, so they work in place on the
arrays they allocate and never modify their inputs.

References
----------
- R. L. Cook and K. E. Torrance, A reflectance model for computer graphics,
  ACM TOG 1(1), 1982 (exact dielectric Fresnel, V-cavity shadowing).
- B. Walter, S. R. Marschner, H. Li and K. E. Torrance, Microfacet models for
  refraction through rough surfaces, EGSR 2007 (Beckmann and GGX D, Smith G1).
- E. Heitz, Understanding the masking-shadowing function in microfacet-based
  BRDFs, JCGT 3(2), 2014 (Smith Lambda, anisotropic D and projected roughness).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "beckmann_d",
    "beckmann_d_anisotropic",
    "fresnel_conductor",
    "fresnel_dielectric",
    "fresnel_schlick",
    "ggx_d",
    "ggx_d_anisotropic",
    "projected_alpha2",
    "schlick_weight",
    "smith_g1_beckmann",
    "smith_g1_ggx",
    "tan2_theta",
    "vcavity_g",
]

SQRT_PI = math.sqrt(math.pi)

# Cosines and denominators that vanish only in a limit (grazing c = 0, or c = 0
# with eta = 1) are kept above this, so the limit value comes out, not 0/0.
_TINY = 1e-300


def _new(*arrays) -> np.ndarray:
    """An uninitialised float array of the broadcast shape of ``arrays``.

    Used as the ``out`` of the first operation, so that 0-d inputs still give an
    array that the following in-place operations can write into.
    """
    return np.empty(np.broadcast_shapes(*(np.shape(a) for a in arrays)))


def fresnel_dielectric(c, eta: float) -> np.ndarray:
    """Unpolarised Fresnel reflectance of a dielectric of relative index ``eta``.

    MODELS.md (Cook and Torrance 1982, appendix) writes it as
    ``F = 1/2 (g-c)^2/(g+c)^2 (1 + ((c(g+c) - 1)/(c(g-c) + 1))^2)`` with
    ``g = sqrt(eta^2 - 1 + c^2)`` and ``c = V.H``. Since ``g = eta cos(theta_t)``
    (Snell), that is the mean of the s and p reflectances
    ``Rs = ((c - g)/(c + g))^2`` and ``Rp = ((eta^2 c - g)/(eta^2 c + g))^2``:
    using ``eta^2 = g^2 + 1 - c^2`` one finds ``(c - g)(c(g+c) - 1) = -(eta^2 c - g)``
    and ``(c + g)(c(g-c) + 1) = eta^2 c + g``, so ``Rp = Rs ((c(g+c)-1)/(c(g-c)+1))^2``.
    The s/p form is the one evaluated, as functions of ``x = g/c``:
    ``Rs = ((1 - x)/(1 + x))^2``, ``Rp = ((eta^2 - x)/(eta^2 + x))^2``, each computed
    as ``(2 a/(a + x) - 1)^2``, in two arrays.
    The paper prints ``g = sqrt(c^2 + tau^2) + I``: MODELS.md reads ``tau`` as
    ``eta`` and ``+ I`` as the ``-1`` inside the root.

    ``F(1) = ((eta-1)/(eta+1))^2`` and ``F(0) = 1``. For ``eta < 1`` (light leaving
    the denser medium) ``g^2 < 0`` past the critical angle: ``g`` is set to 0 there,
    which gives ``F = 1`` (total internal reflection). ``c = 0`` gives ``F = 1``.
    """
    c = np.asarray(c, dtype=float)
    if c.size and not c.min() > 0.0:
        # x = g/c needs c > 0; F is continuous in c, so a tiny c gives F(0) = 1.
        c = np.maximum(c, _TINY)
    e2 = eta * eta
    x = np.multiply(c, c, out=_new(c))
    x += e2 - 1.0
    if np.any(np.asarray(eta) < 1.0):
        np.maximum(x, 0.0, out=x)
    np.sqrt(x, out=x)
    x /= c
    rs = np.add(x, 1.0, out=_new(c))
    np.divide(2.0, rs, out=rs)
    rs -= 1.0
    rs *= rs
    x += e2
    np.divide(2.0 * e2, x, out=x)
    x -= 1.0
    x *= x
    x += rs
    x *= 0.5
    return x


def fresnel_conductor(c, eta: float, k: float) -> np.ndarray:
    """Unpolarised Fresnel reflectance of a conductor of complex index ``eta + i k``.

    The exact expression for s- and p-polarised light, averaged (Born and Wolf,
    Principles of Optics, section 14.2; in the real-arithmetic form of pbrt-v3
    ``FrConductor``): with ``s^2 = 1 - c^2``, ``t0 = eta^2 - k^2 - s^2``,
    ``a^2 + b^2 = sqrt(t0^2 + 4 eta^2 k^2)``, ``a = sqrt((a^2 + b^2 + t0)/2)``,
    ``Rs = (a^2 + b^2 + c^2 - 2ac)/(a^2 + b^2 + c^2 + 2ac)`` and
    ``Rp = Rs (c^2 (a^2 + b^2) + s^4 - 2ac s^2)/(c^2 (a^2 + b^2) + s^4 + 2ac s^2)``.
    Reduces to :func:`fresnel_dielectric` when ``k = 0`` and ``eta >= 1``.
    """
    c = np.asarray(c, dtype=float)
    c2 = c * c
    s2 = 1.0 - c2
    e2 = eta * eta
    k2 = k * k
    t0 = e2 - k2 - s2
    a2b2 = np.sqrt(t0 * t0 + 4.0 * e2 * k2)
    a = np.sqrt(np.maximum(0.5 * (a2b2 + t0), 0.0))
    t1 = a2b2 + c2
    t2 = 2.0 * c * a
    rs = (t1 - t2) / np.maximum(t1 + t2, _TINY)
    t3 = c2 * a2b2 + s2 * s2
    t4 = t2 * s2
    rp = rs * (t3 - t4) / np.maximum(t3 + t4, _TINY)
    return 0.5 * (rs + rp)


def schlick_weight(c) -> np.ndarray:
    """``(1 - c)^5``, the parameter-free part of Schlick's Fresnel approximation.

    Models cache it on the geometry: Schlick's ``F`` is then two operations.
    """
    w = np.subtract(1.0, c, out=_new(c))
    w2 = w * w
    w2 *= w2
    w *= w2
    return w


def fresnel_schlick(c, f0) -> np.ndarray:
    """Schlick's approximation ``F0 + (1 - F0)(1 - c)^5`` (Schlick 1994).

    ``F(1) = F0`` and ``F(0) = 1``.
    """
    w = schlick_weight(c)
    if np.ndim(f0) == 0:
        w *= 1.0 - f0
        w += f0
        return w
    return f0 + (1.0 - f0) * w


def vcavity_g(cos_h, cos_i, cos_o, cos_d) -> np.ndarray:
    """V-cavity shadowing-masking of Torrance-Sparrow and Cook-Torrance.

    ``G = min(1, 2 (N.H)(N.V)/(V.H), 2 (N.H)(N.L)/(V.H))`` (Cook and Torrance
    1982; Blinn 1977). Parameter-free: models cache it. ``L.H = V.H``, so the
    two shadowing terms share one denominator. ``G = 1`` at ``L = V = N``.
    """
    scale = 2.0 * cos_h / np.maximum(cos_d, _TINY)
    return np.minimum(1.0, scale * np.minimum(cos_i, cos_o))


def tan2_theta(cos_t) -> np.ndarray:
    """tan^2 of a polar angle from its cosine (cosine already clamped > 0)."""
    c2 = cos_t * cos_t
    return np.maximum(1.0 - c2, 0.0) / c2


def beckmann_d(tan2_h, cos_h, alpha2: float) -> np.ndarray:
    """Isotropic Beckmann distribution ``exp(-tan^2/alpha^2) / (pi alpha^2 cos^4)``.

    Normalised so that ``integral D(h) (N.H) dw_h = 1`` (Walter et al. 2007).
    ``alpha2`` is ``alpha^2`` (Cook-Torrance's ``m^2``). For the anisotropic
    distribution use :func:`beckmann_d_anisotropic`: its normalisation is
    ``pi alpha_u alpha_v``, not ``pi`` times an azimuth-dependent ``alpha^2``.
    """
    d = np.multiply(tan2_h, -1.0 / alpha2, out=_new(tan2_h, cos_h))
    np.exp(d, out=d)
    d /= cos_h
    d /= cos_h
    d /= cos_h
    d /= cos_h
    d *= 1.0 / (math.pi * alpha2)
    return d


def beckmann_d_anisotropic(tan2_h, cos_h, cos2_phi_h, alpha_u: float, alpha_v: float):
    """Anisotropic Beckmann distribution (Heitz 2014, section 5.4):

    ``D = exp(-tan^2 (cos^2 phi / alpha_u^2 + sin^2 phi / alpha_v^2)) /
    (pi alpha_u alpha_v cos^4)``, with ``alpha_u`` along T (phi = 0) and
    ``alpha_v`` along B. Equals :func:`beckmann_d` when ``alpha_u = alpha_v``.
    """
    inv_u2 = 1.0 / (alpha_u * alpha_u)
    inv_v2 = 1.0 / (alpha_v * alpha_v)
    e = np.multiply(cos2_phi_h, inv_u2 - inv_v2, out=_new(tan2_h, cos_h, cos2_phi_h))
    e += inv_v2
    e *= tan2_h
    np.negative(e, out=e)
    np.exp(e, out=e)
    e /= cos_h
    e /= cos_h
    e /= cos_h
    e /= cos_h
    e *= 1.0 / (math.pi * alpha_u * alpha_v)
    return e


def ggx_d(tan2_h, cos_h, alpha2) -> np.ndarray:
    """GGX (Trowbridge-Reitz) distribution
    ``1 / (pi alpha^2 cos^4 (1 + tan^2/alpha^2)^2)`` (Walter et al. 2007, eq. 33).

    Normalised so that ``integral D(h) (N.H) dw_h = 1``. For the anisotropic
    distribution use :func:`ggx_d_anisotropic`.
    """
    t = np.multiply(tan2_h, 1.0 / alpha2, out=_new(tan2_h, cos_h, alpha2))
    t += 1.0
    t *= cos_h
    t *= cos_h
    t *= t
    np.divide(1.0 / (math.pi * alpha2), t, out=t)
    return t


def ggx_d_anisotropic(tan2_h, cos_h, cos2_phi_h, alpha_u: float, alpha_v: float):
    """Anisotropic GGX distribution (Heitz 2014, section 5.4):

    ``D = 1 / (pi alpha_u alpha_v cos^4 (1 + tan^2 (cos^2 phi / alpha_u^2 +
    sin^2 phi / alpha_v^2))^2)``, ``alpha_u`` along T, ``alpha_v`` along B.
    Equals :func:`ggx_d` when ``alpha_u = alpha_v``.
    """
    inv_u2 = 1.0 / (alpha_u * alpha_u)
    inv_v2 = 1.0 / (alpha_v * alpha_v)
    t = np.multiply(cos2_phi_h, inv_u2 - inv_v2, out=_new(tan2_h, cos_h, cos2_phi_h))
    t += inv_v2
    t *= tan2_h
    t += 1.0
    t *= cos_h
    t *= cos_h
    t *= t
    np.divide(1.0 / (math.pi * alpha_u * alpha_v), t, out=t)
    return t


def projected_alpha2(cos2_phi, alpha_u, alpha_v) -> np.ndarray:
    """``alpha^2`` of an anisotropic distribution seen along a direction of azimuth
    phi: ``alpha_u^2 cos^2 phi + alpha_v^2 sin^2 phi`` (Heitz 2014, section 5.4).

    With it, the isotropic Smith ``G1`` functions give the anisotropic ``G1``. The
    roughnesses may be arrays that broadcast against ``cos2_phi`` (one row per
    walker, shape (W, 1)).
    """
    diff = alpha_u * alpha_u - alpha_v * alpha_v
    a2 = np.multiply(cos2_phi, diff, out=_new(cos2_phi, diff))
    a2 += alpha_v * alpha_v
    return a2


def smith_g1_ggx(tan2_v, alpha2) -> np.ndarray:
    """Smith masking of GGX, ``2 / (1 + sqrt(1 + alpha^2 tan^2 theta_v))`` (Walter et
    al. 2007, eq. 34). For anisotropic GGX pass :func:`projected_alpha2`."""
    t = np.multiply(tan2_v, alpha2, out=_new(tan2_v, alpha2))
    t += 1.0
    np.sqrt(t, out=t)
    t += 1.0
    np.divide(2.0, t, out=t)
    return t


def smith_g1_beckmann(tan2_v, alpha2) -> np.ndarray:
    """Exact Smith masking of Beckmann, ``G1 = 1 / (1 + Lambda(a))``.

    ``a = 1 / (alpha tan theta_v)`` and
    ``Lambda = (erf(a) - 1)/2 + exp(-a^2) / (2 a sqrt(pi))`` (Walter et al. 2007;
    Heitz 2014, section 5.1), evaluated as
    ``G1 = 2 / (1 + erf(a) + exp(-a^2) / (a sqrt(pi)))``, which avoids the
    cancellation in ``erf(a) - 1``. For ``a >= 6`` (directions within
    ``atan(1/(6 alpha))`` of the normal) ``Lambda < 3e-18``, so ``G1`` is 1 to double
    precision and ``erf`` (the costly part) is evaluated only for the others.
    For anisotropic Beckmann pass :func:`projected_alpha2` as ``alpha2``.
    """
    t = np.multiply(tan2_v, alpha2, out=_new(tan2_v, alpha2))
    masked = t > 1.0 / 36.0  # a < 6
    a = t[masked]
    np.sqrt(a, out=a)
    np.divide(1.0, a, out=a)
    g1 = np.multiply(a, a)
    np.negative(g1, out=g1)
    np.exp(g1, out=g1)
    g1 /= a
    g1 *= 1.0 / SQRT_PI
    from scipy.special import erf  # here: scipy.special takes 0.4 s to import

    g1 += erf(a)
    g1 += 1.0
    np.divide(2.0, g1, out=g1)
    t.fill(1.0)
    t[masked] = g1
    return t
