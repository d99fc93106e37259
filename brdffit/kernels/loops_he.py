"""The compiled loop of the He-Torrance-Sillion-Greenberg model (``he``).

One pass over the valid pairs computes, per pair, what the numpy model
(:mod:`brdffit.models.wave`, terms in :mod:`brdffit.models.he_terms`) computes with
arrays: the shadowing ``S`` of L and V (He et al. 1991, eqs. 24-25 with the errata's
``exp(-a^2)``), ``K`` of eqs. 82-83, the effective roughness of eqs. 80-81 (the same
Newton iteration in ``ln z0``), the exact conductor Fresnel factor, then per
wavelength the spike ``F S exp(-g) w / (Omega sqrt((N.L)(N.V)))`` and the
directional-diffuse series of eq. 78, summed over the same window and stopped by
the same bound as :func:`brdffit.models.he_terms.dd_series` (the recursion
``p_{m+1} = p_m g / (m + 1)``, the Chernoff start, the Bernstein test of a negligible
series, the geometric-tail stop), so the two agree to rounding (tested at 1e-11
relative, tests/models/test_kernels_he.py).

The numpy model loops over the terms of the series in Python, one array operation
per step over the elements not yet converged; here each element's series is a
scalar loop of a multiplication, a division and one :func:`~._compile.fast_exp` per
term, and everything that depends on the pair only (``erfc`` twice, ``erf``
twice, the Newton iteration, Fresnel) is computed once for all wavelengths.
"""

from __future__ import annotations

import math

import numpy as np

from ..data.geometry import Geometry
from ._compile import fast_exp, jit

__all__ = ["he_offset", "he_offset_loop", "dd_series_loop"]

_SQRT_2PI = math.sqrt(2.0 * math.pi)
_INV_SQRT_PI = 1.0 / math.sqrt(math.pi)
_TINY = 1e-300  # as brdffit.models.shared.fresnel_conductor
MIN_COS_D = 1e-150  # as brdffit.models.wave.MIN_COS_D


@jit
def _shadow_and_k(cos_t, ratio):
    """``S(theta)`` (eqs. 24-25, Smith's ``G1`` of Beckmann written with ``erfc``) and
    ``K(theta) = tan(theta) erfc(a)``, ``a = tau cot(theta) / (2 sigma0)``."""
    sin2 = max(1.0 - cos_t * cos_t, 0.0)
    if sin2 == 0.0:
        return 1.0, 0.0
    sin_t = math.sqrt(sin2)
    a = 0.5 * ratio * cos_t / sin_t
    erfc_a = math.erfc(a)
    s = 1.0 - 0.5 * erfc_a
    if a < 6.0:  # as smith_g1_beckmann: G1 = 1 to double precision beyond
        s *= 2.0 / (2.0 - erfc_a + math.exp(-a * a) * _INV_SQRT_PI / a)
    return s, sin_t / cos_t * erfc_a


@jit
def _sigma_ratio(k_sum):
    """``sigma / sigma0 = (1 + u^2)^(-1/2)``, ``u exp(u^2/2) = k_sum / (2 sqrt(2 pi))``,
    by the Newton iteration of :func:`brdffit.models.he_terms.z0_ratio`."""
    c = k_sum / (2.0 * _SQRT_2PI)
    if c <= 0.0:
        return 1.0
    log_c = math.log(c)
    s = math.log(min(c, max(1.0, math.sqrt(2.0 * max(log_c, 0.0)))))
    for _ in range(60):
        e2 = math.exp(2.0 * s)
        step = (s + 0.5 * e2 - log_c) / (1.0 + e2)
        s -= step
        if abs(step) < 1e-14:
            break
    u = math.exp(s)
    return 1.0 / math.sqrt(1.0 + u * u)


@jit
def _fresnel(c, eta, k):
    """Unpolarised conductor Fresnel, :func:`brdffit.models.shared.fresnel_conductor`."""
    c2 = c * c
    s2 = 1.0 - c2
    e2, k2 = eta * eta, k * k
    t0 = e2 - k2 - s2
    a2b2 = math.sqrt(t0 * t0 + 4.0 * e2 * k2)
    a = math.sqrt(max(0.5 * (a2b2 + t0), 0.0))
    t1 = a2b2 + c2
    t2 = 2.0 * c * a
    rs = (t1 - t2) / max(t1 + t2, _TINY)
    t3 = c2 * a2b2 + s2 * s2
    t4 = t2 * s2
    rp = rs * (t3 - t4) / max(t3 + t4, _TINY)
    return 0.5 * (rs + rp)


@jit
def dd_series_loop(g, a, tolerance):
    """The series of eq. 78 for one element, as :func:`~brdffit.models.he_terms.dd_series`
    sums it (window, stop and negligible test the same); returns ``(sum, terms)``."""
    if not g > 0.0:
        return 0.0, 0
    log_two_tol = math.log(2.0 / tolerance)
    log_bound = log_two_tol - (2.0 * math.log(-math.expm1(-g)) - math.log(g))
    reach = g + log_bound / 3.0 + math.sqrt(log_bound * log_bound / 9.0 + 2.0 * g * log_bound)
    if a >= reach * log_two_tol:
        return 0.0, 0
    m = 1.0
    if g > 4.0:
        m = max(1.0, math.floor(g - math.sqrt(2.0 * g * log_bound)) + 1.0)
    p = math.exp(m * math.log(g) - g - math.lgamma(m + 1.0))
    half_tol = 0.5 * tolerance
    s, q, n = 0.0, 0.0, 0
    while True:
        n += 1
        t = p / m
        q += t
        s += fast_exp(-a / m) * t
        m += 1.0
        p *= g / m
        slack = m + 1.0 - g
        if slack > 0.0 and p * (m + 1.0) <= half_tol * q * m * slack:
            return s, n


@jit
def he_offset_loop(cos_i, cos_o, cos_d, v_z, v_xy2, lobe, cone, wavelength, shape, out):
    """``rho_s + rho_dd`` of every pair (rows) and wavelength (columns of ``out``).

    ``lobe`` is ``G / (pi (N.L)(N.V))``, ``cone`` the spike's spread
    ``w / (Omega sqrt((N.L)(N.V)))``, ``wavelength`` in micrometres, ``shape`` the
    array ``(sigma0, tau, eta, k, tolerance)``."""
    sigma0, tau, eta, k, tolerance = shape[0], shape[1], shape[2], shape[3], shape[4]
    ratio = tau / sigma0
    for i in range(cos_i.shape[0]):
        s_i, k_i = _shadow_and_k(cos_i[i], ratio)
        s_o, k_o = _shadow_and_k(cos_o[i], ratio)
        sigma = sigma0 * _sigma_ratio(k_i + k_o)
        common = s_i * s_o * _fresnel(max(cos_d[i], MIN_COS_D), eta, k)
        for c in range(wavelength.shape[0]):
            lam = wavelength[c]
            g = (2.0 * math.pi * sigma / lam * v_z[i]) ** 2
            a = (math.pi * tau / lam) ** 2 * v_xy2[i]
            series, _ = dd_series_loop(g, a, tolerance)
            d = (0.5 * math.pi * tau / lam) ** 2 * series
            out[i, c] = common * cone[i] * fast_exp(-g) + common * lobe[i] * d
    return out


def he_offset(geometry: Geometry, shape, cone: np.ndarray, tolerance: float) -> np.ndarray:
    """The specular plus directional-diffuse BRDF of ``he`` on the valid pairs, shape
    (M,) for one wavelength, (M, C) for C; ``cone`` from the model's ``_spike_spread``.
    Shape parameters are numbers (``wavelength`` one or one per channel)."""
    v_z, v_xy2, lobe = geometry.cached("kernels.he", lambda: _inputs(geometry))
    wavelength = np.asarray(shape["wavelength"], dtype=float) * 1e-3  # nm -> micrometres
    values = np.array(
        [shape["sigma0"], shape["tau"], shape["eta"], shape["k"], tolerance], dtype=float
    )
    lams = np.ascontiguousarray(wavelength.reshape(-1))
    out = np.empty((geometry.m, lams.size))
    args = (geometry.cos_i, geometry.cos_o, geometry.cos_d, v_z, v_xy2, lobe, cone)
    he_offset_loop(*(np.ascontiguousarray(x, dtype=float) for x in args), lams, values, out)
    return out if wavelength.ndim else out[:, 0]


def _inputs(geometry: Geometry) -> tuple:
    """``v_z``, ``v_xy^2`` (of ``v = L + V``) and ``G / (pi (N.L)(N.V))``, contiguous."""
    from ..models.wave import _inv_pi_cos, _v_terms

    v_z, v_xy2, g_factor = _v_terms(geometry)
    return np.ascontiguousarray(v_z), np.ascontiguousarray(v_xy2), g_factor * _inv_pi_cos(geometry)
