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

The loop runs in blocks of :data:`BLOCK` pairs, in passes that LLVM vectorises
(no library call, no select it cannot turn into arithmetic; eight lanes where the
processor has AVX-512, :mod:`~.wide`: the pair terms 1.35x): per pair the shadowing
and ``K`` with :func:`~.erfc.fast_erfc` (``erfc`` by its Taylor series and a Chebyshev
series of ``erfcx``) and Fresnel, then the Newton iteration of ``z0`` for the whole
block (four Halley steps with :func:`~._compile.fast_exp` and :func:`~.elementary.fast_log`,
then the scalar iteration for any pair not yet converged), then per wavelength the
window of every element and the series of all of them in lockstep (one term per
element and step; elements that have stopped keep their sum and leave the arrays
in bulk, as in the numpy model). :func:`dd_series_loop` is the same series for one
element, scalar (tested against the numpy series, term counts included). Measured
at the default parameters, 100,000 pairs, one wavelength: 86 ns a pair (35 of
shadowing, ``K``, ``z0`` and Fresnel, 41 of the series) against 0.42 us for numpy
(benchmarks/bench_he.py has the run). :mod:`brdffit.kernels.bind` binds it to the
model as the other models' loops, and ``a_ud / pi`` is added in the same pass.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..data.geometry import Geometry
from ..models import he_terms
from ._compile import FLAGS, fast_exp, jit
from .elementary import fast_log
from .erfc import fast_erfc
from .wide import prefer_wide_vectors

__all__ = [
    "dd_series_blocks",
    "dd_series_loop",
    "he_offset",
    "he_offset_loop",
    "pair_terms",
]

_SQRT_2PI = math.sqrt(2.0 * math.pi)
_INV_SQRT_PI = 1.0 / math.sqrt(math.pi)
_TINY = 1e-300  # as brdffit.models.shared.fresnel_conductor
MIN_COS_D = 1e-150  # as brdffit.models.wave.MIN_COS_D


@numba.njit(inline="always", fastmath=FLAGS)
def _shadow_and_k(cos_t, ratio):
    """``S(theta)`` (eqs. 24-25, Smith's ``G1`` of Beckmann written with ``erfc``) and
    ``K(theta) = tan(theta) erfc(a)``, ``a = tau cot(theta) / (2 sigma0)``; free of
    branches. ``a`` is clamped at 30, where ``erfc`` is 0 in float64 (with
    :func:`~._compile.fast_exp`'s flush) and ``G1`` 1: ``S = 1`` and ``K = 0`` at the normal."""
    sin_t = math.sqrt(max(1.0 - cos_t * cos_t, 0.0))
    a = min(0.5 * ratio * cos_t / max(sin_t, 1e-300), 30.0)
    erfc_a = fast_erfc(a)
    g1 = 2.0 / (2.0 - erfc_a + fast_exp(-a * a) * _INV_SQRT_PI / a)
    s = (1.0 - 0.5 * erfc_a) * (g1 if a < 6.0 else 1.0)  # as smith_g1_beckmann
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


@numba.njit(inline="always", fastmath=FLAGS)
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
    log_p = m * math.log(g) - g
    if m > 1.0:  # lgamma(2) = 0
        log_p -= math.lgamma(m + 1.0)
    p = math.exp(log_p)
    half_tol = 0.5 * tolerance
    s, q, n = 0.0, 0.0, 0
    inv_m = 1.0 / m
    while True:  # one division a term: 1/m serves t, the exponent and the next p
        n += 1
        t = p * inv_m
        q += t
        s += fast_exp(-a * inv_m) * t
        m += 1.0
        inv_m = 1.0 / m
        p *= g * inv_m
        slack = m + 1.0 - g
        if slack > 0.0 and p * (m + 1.0) <= half_tol * q * m * slack:
            return s, n


#: Pairs (or pair-wavelengths) processed together: the working arrays stay in L1.
BLOCK = 512


#: ``ln(m!)`` for ``m < LOG_FACTORIALS.size``, the numpy series' own table
#: (:func:`~brdffit.models.he_terms.log_factorial_table`): the series' first index is
#: an integer, so its weight's ``lnGamma`` is read, not computed (libm's ``lgamma``,
#: scalar, took 12 ns an element, and half the elements need it at the defaults).
LOG_FACTORIALS = he_terms.log_factorial_table()


@jit
def _series_start(g, a, tolerance, m, p):
    """Fill ``m`` (first index) and ``p`` (its Poisson weight ``g^m exp(-g) / m!``; for
    ``m`` beyond :data:`LOG_FACTORIALS`, its logarithm without ``ln(m!)``: see
    :func:`_series_block`) for the block; ``m = 0`` marks an element whose series is
    negligible or 0. Vectorisable: :func:`dd_series_loop`'s window."""
    log_two_tol = math.log(2.0 / tolerance)
    last = LOG_FACTORIALS.shape[0] - 1
    for j in range(g.shape[0]):
        gj = max(g[j], 1e-300)
        small = gj < 1e-3  # 1 - exp(-g) by its series where exp(-g) would cancel
        one_minus = gj * (1.0 - gj * (0.5 - gj * (1.0 / 6.0 - gj * (1.0 / 24.0))))
        if not small:
            one_minus = 1.0 - fast_exp(-gj)
        log_g = fast_log(gj)
        log_bound = log_two_tol - (2.0 * fast_log(one_minus) - log_g)
        root = math.sqrt(log_bound * log_bound / 9.0 + 2.0 * gj * log_bound)
        reach = gj + log_bound / 3.0 + root
        lower = max(1.0, math.floor(gj - math.sqrt(2.0 * gj * log_bound)) + 1.0)
        mj = lower if gj > 4.0 else 1.0
        log_p = mj * log_g - gj
        listed = mj <= last
        weight = fast_exp(log_p - LOG_FACTORIALS[min(int(mj), last)])
        p[j] = weight if listed else log_p
        keep = (a[j] < reach * log_two_tol) and (g[j] > 0.0)
        m[j] = mj if keep else 0.0


@jit
def _series_block(g, a, m, p, tolerance, out):
    """The series of the block's elements with ``m > 0``, in lockstep: each step adds
    one term to every element not yet stopped (a vectorisable loop); elements that
    have stopped keep their sum and leave the arrays when they are a quarter of them.
    ``p`` holds the first weight on entry, or for ``m`` beyond :data:`LOG_FACTORIALS`
    (rough surfaces, a few elements) ``m ln g - g``, whose ``lnGamma(m + 1)`` is taken here."""
    prefer_wide_vectors()
    n = 0
    idx = np.empty(g.shape[0], dtype=np.int64)
    gg, aa, mm, pp = np.empty_like(g), np.empty_like(g), np.empty_like(g), np.empty_like(g)
    for j in range(g.shape[0]):
        out[j] = 0.0
        if m[j] > 0.0:
            weight = p[j]
            if m[j] >= LOG_FACTORIALS.shape[0]:
                weight = math.exp(p[j] - math.lgamma(m[j] + 1.0))
            idx[n], gg[n], aa[n], mm[n], pp[n] = j, g[j], a[j], m[j], weight
            n += 1
    half_tol = 0.5 * tolerance
    s, q, res = np.zeros(n), np.zeros(n), np.zeros(n)
    inv = 1.0 / mm[:n]
    fin = np.zeros(n)  # 1.0 once stopped
    while n:
        finished = 0  # an integer count: a float sum would not vectorise without reassoc
        for j in range(n):  # one term for each element: vectorised, free of branches
            t = pp[j] * inv[j]
            q[j] += t
            s[j] += fast_exp(-aa[j] * inv[j]) * t
            mj = mm[j] + 1.0
            mm[j] = mj
            inv_j = 1.0 / mj
            inv[j] = inv_j
            pp[j] *= gg[j] * inv_j
            slack = mj + 1.0 - gg[j]
            stop = (slack > 0.0) & (pp[j] * (mj + 1.0) <= half_tol * q[j] * mj * slack)
            # Arithmetic, not a select (which kept LLVM from vectorising the loop):
            # res (0 until then) receives s once, at the first stop.
            was = fin[j]
            now = max(was, 1.0 if stop else 0.0)
            fin[j] = now
            res[j] += (now - was) * s[j]
            finished += now > 0.5
        if finished * 4 >= n:
            k = 0
            for j in range(n):
                if fin[j] != 0.0:
                    out[idx[j]] = res[j]
                else:
                    idx[k], gg[k], aa[k], mm[k], pp[k] = idx[j], gg[j], aa[j], mm[j], pp[j]
                    s[k], q[k], inv[k], res[k], fin[k] = s[j], q[j], inv[j], res[j], 0.0
                    k += 1
            n = k


@jit
def _pair_terms(cos_i, cos_o, cos_d, ratio, sigma0, eta, k, sigma, common):
    """``sigma`` and ``F S(L) S(V)`` of each pair of a block. The equation of
    :func:`_sigma_ratio`, ``psi(s) = s + exp(2 s)/2 - ln c = 0``, is solved vectorised
    from the same start by four steps of Halley's method (Halley 1694; cubic, one
    division a step as Newton's: ``2 psi psi' / (2 psi'^2 - psi psi'')``): the fourth
    step is below 1e-14 for every ``c`` of 2e5 log-spaced from 1e-300 to 1e300 and of
    2e5 uniform in [0, 2] and in [0, 50] (measured; Newton needs five, and its fourth
    is not below 1e-14 for 18-73 % of the pairs at tau / sigma0 from 17 to 0.1); any
    pair whose fourth step is not takes the scalar Newton iteration of
    :func:`_sigma_ratio`. (Six Newton steps before: 40 -> 35 ns a pair.)"""
    prefer_wide_vectors()
    for j in range(cos_i.shape[0]):
        s_i, k_i = _shadow_and_k(cos_i[j], ratio)
        s_o, k_o = _shadow_and_k(cos_o[j], ratio)
        sigma[j] = (k_i + k_o) / (2.0 * _SQRT_2PI)  # c of the equation, for now
        common[j] = s_i * s_o * _fresnel(max(cos_d[j], MIN_COS_D), eta, k)
    for j in range(cos_i.shape[0]):  # vectorised
        c = max(sigma[j], 1e-300)
        log_c = fast_log(c)
        s = fast_log(min(c, max(1.0, math.sqrt(2.0 * max(log_c, 0.0)))))
        step = 0.0
        for _ in range(4):
            e2 = fast_exp(2.0 * s)
            psi = s + 0.5 * e2 - log_c
            d1 = 1.0 + e2
            step = 2.0 * psi * d1 / (2.0 * d1 * d1 - 2.0 * psi * e2)
            s -= step
        u = fast_exp(s)
        ratio_j = 1.0 / math.sqrt(1.0 + u * u)
        converged = abs(step) < 1e-14
        sigma[j] = sigma0 * (ratio_j if sigma[j] > 0.0 else 1.0) if converged else -sigma[j]
    for j in range(cos_i.shape[0]):
        if sigma[j] <= 0.0 and sigma[j] != 0.0:  # not converged in four steps: none measured
            sigma[j] = sigma0 * _sigma_ratio(-sigma[j] * (2.0 * _SQRT_2PI))


@jit
def he_offset_loop(
    cos_i, cos_o, cos_d, cos_r, v_z, v_xy2, lobe, inv_sqrt, wavelength, diffuse, shape, out
):
    """``rho_s + rho_dd + diffuse`` of every pair (rows) and wavelength (columns of
    ``out``, ``diffuse[c]`` the uniform term ``a_ud / pi`` of column ``c``, 0 for the
    design's offset), in blocks of :data:`BLOCK` pairs.

    ``lobe`` is ``G / (pi (N.L)(N.V))``, ``inv_sqrt`` ``1 / sqrt((N.L)(N.V))``,
    ``wavelength`` in micrometres, ``shape`` the array ``(sigma0, tau, eta, k,
    tolerance, U)`` with ``U = 1 - cos(aperture)``: the spike's spread is
    ``max(1 - (1 - R.V) / U, 0)^3 / (sqrt((N.L)(N.V)) pi U / 2)`` as the model's
    ``_spike_spread``."""
    sigma0, tau, eta, k, tolerance = shape[0], shape[1], shape[2], shape[3], shape[4]
    big_u = shape[5]
    half_pi_u = 0.5 * math.pi * big_u
    sigma, common = np.empty(BLOCK), np.empty(BLOCK)
    work = np.empty((5, BLOCK))  # g, a, m, p and the series of a block
    g, a, m, p, series = work[0], work[1], work[2], work[3], work[4]
    for lo in range(0, cos_i.shape[0], BLOCK):
        hi = min(lo + BLOCK, cos_i.shape[0])
        b = hi - lo
        _pair_terms(cos_i[lo:hi], cos_o[lo:hi], cos_d[lo:hi], tau / sigma0, sigma0, eta, k,
                    sigma, common)  # fmt: skip
        for c in range(wavelength.shape[0]):
            lam = wavelength[c]
            scale_a = (math.pi * tau / lam) ** 2
            for j in range(b):
                g[j] = (2.0 * math.pi * sigma[j] / lam * v_z[lo + j]) ** 2
                a[j] = scale_a * v_xy2[lo + j]
            _series_start(g[:b], a[:b], tolerance, m[:b], p[:b])
            _series_block(g[:b], a[:b], m[:b], p[:b], tolerance, series[:b])
            scale_d = (0.5 * math.pi * tau / lam) ** 2
            for j in range(b):
                i = lo + j
                w = max(1.0 - (1.0 - cos_r[i]) / big_u, 0.0)
                cone = w * w * w * (inv_sqrt[i] / half_pi_u)
                d = scale_d * series[j]
                spike = common[j] * cone * fast_exp(-g[j])
                out[i, c] = (spike + common[j] * lobe[i] * d) + diffuse[c]
    return out


@jit
def dd_series_blocks(g, a, tolerance, out):
    """The series of eq. 78 of every element of ``g`` and ``a`` (flat), as the model's
    loop sums it: in blocks, in lockstep (for benchmarks/bench_he.py and the tests)."""
    m, p = np.empty(BLOCK), np.empty(BLOCK)
    for lo in range(0, g.shape[0], BLOCK):
        hi = min(lo + BLOCK, g.shape[0])
        _series_start(g[lo:hi], a[lo:hi], tolerance, m[: hi - lo], p[: hi - lo])
        _series_block(g[lo:hi], a[lo:hi], m[: hi - lo], p[: hi - lo], tolerance, out[lo:hi])
    return out


@jit
def pair_terms(cos_i, cos_o, cos_d, shape, sigma, common):
    """``sigma`` and ``F S(L) S(V)`` of every pair, in blocks (for the benchmark);
    ``shape`` as in :func:`he_offset_loop`."""
    sigma0, tau = shape[0], shape[1]
    for lo in range(0, cos_i.shape[0], BLOCK):
        hi = min(lo + BLOCK, cos_i.shape[0])
        _pair_terms(cos_i[lo:hi], cos_o[lo:hi], cos_d[lo:hi], tau / sigma0, sigma0,
                    shape[2], shape[3], sigma[lo:hi], common[lo:hi])  # fmt: skip
    return sigma, common


def he_offset(geometry: Geometry, shape, tolerance: float, diffuse=0.0) -> np.ndarray:
    """The specular plus directional-diffuse BRDF of ``he`` on the valid pairs, plus
    ``diffuse`` (``a_ud / pi``: a number, or one per wavelength), shape (M,) for one
    wavelength, (M, C) for C. Shape parameters are numbers (``wavelength`` one or one
    per channel)."""
    from ..models.wave import _inv_sqrt_cos, spike_support

    v_z, v_xy2, lobe = geometry.cached("kernels.he", lambda: _inputs(geometry))
    wavelength = np.asarray(shape["wavelength"], dtype=float) * 1e-3  # nm -> micrometres
    big_u = spike_support(math.radians(shape["aperture"]))
    values = np.array(
        [shape["sigma0"], shape["tau"], shape["eta"], shape["k"], tolerance, big_u], dtype=float
    )
    lams = np.ascontiguousarray(wavelength.reshape(-1))
    out = np.empty((geometry.m, lams.size))
    diffuse = np.array(np.broadcast_to(np.asarray(diffuse, dtype=float), lams.shape))
    args = (geometry.cos_i, geometry.cos_o, geometry.cos_d, geometry.cos_r, v_z, v_xy2, lobe)
    args = (*args, _inv_sqrt_cos(geometry))
    args = (*(np.ascontiguousarray(x, dtype=float) for x in args), lams, diffuse, values)
    he_offset_loop(*args, out)
    return out if wavelength.ndim else out[:, 0]


def _inputs(geometry: Geometry) -> tuple:
    """``v_z``, ``v_xy^2`` (of ``v = L + V``) and ``G / (pi (N.L)(N.V))``, contiguous."""
    from ..models.wave import _inv_pi_cos, _v_terms

    v_z, v_xy2, g_factor = _v_terms(geometry)
    return np.ascontiguousarray(v_z), np.ascontiguousarray(v_xy2), g_factor * _inv_pi_cos(geometry)
