"""The terms of the He-Torrance-Sillion-Greenberg model, as plain vectorised functions.

He, Torrance, Sillion and Greenberg, "A comprehensive physical model for light
reflection", SIGGRAPH 1991 (Computer Graphics 25(4)); equation numbers are the
paper's, as the bbm library's he.h cites them. Every function here is a numpy
function of cosines and parameters, with no knowledge of
:class:`~brdffit.data.geometry.Geometry`, so the tests can check each one on its own
against scalar code. The model that assembles them, and the notes on what was
checked against which source, are in :mod:`brdffit.models.wave`.

Lengths (``sigma0``, ``tau``, ``wavelength``) only enter through ratios, so any
one unit will do here; the model passes micrometres.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .shared import smith_g1_beckmann

__all__ = [
    "SERIES_TOLERANCE",
    "shadowing",
    "roughness_k",
    "effective_roughness_ratio",
    "z0_ratio",
    "dd_series",
    "series_lower_start",
    "series_negligible",
]

#: Default bound on the truncation error of the series over m, relative to the
#: series' value with every ``exp(-a/m)`` set to 1 (its peak; see dd_series).
SERIES_TOLERANCE = 1e-6

_SQRT_2PI = math.sqrt(2.0 * math.pi)


def _cot_scaled(cos_t: np.ndarray, tau_over_sigma0: float) -> np.ndarray:
    """``tau cot(theta) / (2 sigma0)``, inf at normal incidence."""
    sin_t = np.sqrt(np.maximum(1.0 - cos_t * cos_t, 0.0))
    with np.errstate(divide="ignore"):
        return (0.5 * tau_over_sigma0) * cos_t / sin_t


def shadowing(cos_t: np.ndarray, tau_over_sigma0: float) -> np.ndarray:
    """Smith's shadowing of one direction, He et al. eqs. 24-25 with the errata.

    ``S(theta) = (1 - erfc(a)/2) / (Lambda(a) + 1)``, ``a = tau cot(theta) / (2 sigma0)``,
    ``Lambda(a) = (exp(-a^2) / (a sqrt(pi)) - erfc(a)) / 2``.

    The paper prints eq. 25 without the ``exp(-a^2)``; its errata, Westin's
    reference code, Radiance's ``He.cal`` and Holzschuch and Pacanowski all
    include it, and with it ``Lambda`` is Smith's function of a Gaussian surface
    of rms slope ``m = 2 sigma0 / tau``, so ``1 / (Lambda + 1)`` is
    :func:`~brdffit.models.shared.smith_g1_beckmann` with ``alpha = m``, reused
    here. ``S = 1`` at normal incidence and tends to 0 at the horizon.
    """
    from scipy.special import erfc  # here: scipy.special takes 0.4 s to import

    a = _cot_scaled(cos_t, tau_over_sigma0)
    tan2 = np.maximum(1.0 - cos_t * cos_t, 0.0) / (cos_t * cos_t)
    slope2 = 4.0 / (tau_over_sigma0 * tau_over_sigma0)
    return (1.0 - 0.5 * erfc(a)) * smith_g1_beckmann(tan2, slope2)


def roughness_k(cos_t: np.ndarray, tau_over_sigma0: float) -> np.ndarray:
    """``K(theta) = tan(theta) erfc(tau cot(theta) / (2 sigma0))`` (eqs. 82-83); 0 at
    normal incidence."""
    from scipy.special import erfc

    sin_t = np.sqrt(np.maximum(1.0 - cos_t * cos_t, 0.0))
    return (sin_t / cos_t) * erfc(_cot_scaled(cos_t, tau_over_sigma0))


def z0_ratio(k_sum: np.ndarray, max_steps: int = 60) -> np.ndarray:
    """``u = z0 / sigma0``, the root of the paper's implicit equation for z0.

    The equation, ``sqrt(pi/2) z0 = (sigma0/4)(K_i + K_r) exp(-z0^2 / (2 sigma0^2))``, reads
    ``u exp(u^2/2) = c`` with ``c = (K_i + K_r) / (2 sqrt(2 pi))``; its left side
    increases from 0, so the root ``u >= 0`` is unique. Newton's method is applied
    to ``psi(s) = s + exp(2 s)/2 - ln c`` in ``s = ln u``: ``psi`` is increasing and
    convex, so from any start with ``psi >= 0`` the iterates decrease
    monotonically to the root, with no overshoot, for every ``c > 0``. The start
    ``u = min(c, max(1, sqrt(2 ln c)))`` bounds the root from above (``u <= c``
    always; ``u <= sqrt(2 ln c)`` when ``u >= 1``), so no bracketing is needed and
    the steps shrink quadratically at once: 5 iterations reach a step below
    1e-14 for every ``c`` from 1e-300 to 1e300 (measured on 1e5 values).
    ``c = 0`` (normal incidence both ways) gives 0.
    """
    k_sum = np.asarray(k_sum, dtype=float)
    u = np.zeros_like(k_sum)
    c = k_sum / (2.0 * _SQRT_2PI)
    positive = c > 0.0
    if positive.any():
        cp = c[positive]
        log_c = np.log(cp)
        start = np.minimum(cp, np.maximum(1.0, np.sqrt(2.0 * np.maximum(log_c, 0.0))))
        s = np.log(start)
        for _ in range(max_steps):
            e2 = np.exp(2.0 * s)
            step = (s + 0.5 * e2 - log_c) / (1.0 + e2)
            s -= step
            if np.max(np.abs(step)) < 1e-14:
                break
        u[positive] = np.exp(s)
    return u


def effective_roughness_ratio(k_sum: np.ndarray) -> np.ndarray:
    """``sigma / sigma0 = (1 + z0^2/sigma0^2)^(-1/2)`` (eq. 80), ``z0`` from :func:`z0_ratio`."""
    u = z0_ratio(k_sum)
    return 1.0 / np.sqrt(1.0 + u * u)


def _log_bound(g: np.ndarray, tolerance: float) -> np.ndarray:
    """``L = ln(2 / (tolerance q))`` with ``q = (1 - exp(-g))^2 / g``, a lower bound of the
    peak ``Q(g) = sum_m P(X = m)/m`` (Jensen: ``E[1/X | X >= 1] >= 1 / E[X | X >= 1]``);
    a Poisson tail below ``exp(-L)`` then weighs at most ``tolerance/2 * Q(g)``."""
    with np.errstate(divide="ignore", invalid="ignore"):
        log_q = 2.0 * np.log(-np.expm1(-g)) - np.log(g)
    return math.log(2.0 / tolerance) - log_q


def series_lower_start(g: np.ndarray, tolerance: float) -> np.ndarray:
    """First index m of the summed window: the terms below it hold at most
    ``tolerance / 2`` of the series' peak (see :func:`dd_series`).

    With ``X`` Poisson of mean ``g``, the skipped terms weigh at most
    ``P(X <= m_lo - 1)``, which Chernoff's bound and ``1 - x + x ln x >= (1-x)^2/2``
    keep below ``exp(-t^2 / (2 g))`` at ``m_lo - 1 = g - t``; ``t = sqrt(2 g L)``
    (:func:`_log_bound`) suffices.
    """
    g = np.asarray(g, dtype=float)
    m_lo = np.ones_like(g)
    big = g > 4.0
    if big.any():
        gb = g[big]
        t = np.sqrt(2.0 * gb * _log_bound(gb, tolerance))
        m_lo[big] = np.maximum(1.0, np.floor(gb - t) + 1.0)
    return m_lo


def series_negligible(g: np.ndarray, a: np.ndarray, tolerance: float) -> np.ndarray:
    """Elements whose whole series is below ``tolerance`` times its peak: they are 0.

    Bernstein's inequality ``P(X >= g + t) <= exp(-t^2 / (2 (g + t/3)))`` puts the
    Poisson mass above ``M = g + L/3 + sqrt(L^2/9 + 2 g L)`` below ``tolerance/2 * Q``;
    below ``M`` every ``exp(-a/m) <= exp(-a/M)``, at most ``tolerance / 2`` when
    ``a >= M ln(2 / tolerance)``. Far from the specular direction of a narrow lobe
    this holds, and no term need be summed.
    """
    log_bound = _log_bound(g, tolerance)
    reach = g + log_bound / 3.0 + np.sqrt(log_bound * log_bound / 9.0 + 2.0 * g * log_bound)
    return a >= reach * math.log(2.0 / tolerance)


def dd_series(g, a, tolerance: float = SERIES_TOLERANCE, count_terms: bool = False):
    """The series of eq. 78, ``sum_{m>=1} exp(-g) g^m / (m! m) exp(-a/m)``.

    Parameters
    ----------
    g : array_like
        ``g = (2 pi sigma (cos_i + cos_r) / lambda)^2`` (eq. 79), >= 0.
    a : array_like
        ``v_xy^2 tau^2 / 4`` with ``v_xy`` in wavenumber units (``2 pi / lambda``
        times the unit-vector difference), >= 0; broadcast with ``g``.
    tolerance : float
        Bound on the truncation error relative to the peak ``Q(g)``.
    count_terms : bool
        Also return the number of terms summed per element (for benchmarks).

    Returns
    -------
    ndarray (and ndarray of int)
        The sum, of the broadcast shape.

    Notes
    -----
    With ``p_m = exp(-g) g^m / m!`` (Poisson weights) and ``w_m = exp(-a/m)/m <= 1/m``,
    the error of summing ``m = m_lo .. M`` is at most ``tolerance * Q(g)`` where
    ``Q(g) = sum_m p_m / m`` is the series at ``a = 0`` (the lobe's value in the
    specular direction at the same ``g``, its largest): half from the terms below
    ``m_lo`` (:func:`series_lower_start`), half from those above ``M``. Summation
    stops, per element, at the first ``M > g - 2`` with
    ``p_{M+1} / ((M+1)(1 - g/(M+2))) <= tolerance/2 * sum_{m<=M} p_m/m``; the left
    side bounds the rest because ``p_{j+1}/p_j = g/(j+1)`` is below ``g/(M+2)`` for
    every later ``j`` (a geometric tail). About ``2 sqrt(2 g ln(2 g / tolerance))``
    terms are summed when ``g`` is large, a few when it is small, none where
    :func:`series_negligible` shows the whole series to be below the bound. Each element's
    result depends on its own ``g`` and ``a`` only, not on the others it is
    computed with; elements are processed in chunks that fit in cache, and those
    that have converged leave the working set.
    """
    g, a = np.broadcast_arrays(np.asarray(g, dtype=float), np.asarray(a, dtype=float))
    shape = g.shape
    g, a = g.ravel(), a.ravel()
    total = np.zeros(g.size)
    counts = np.zeros(g.size, dtype=np.int64)
    todo = np.flatnonzero(~series_negligible(g, a, tolerance))
    for start in range(0, todo.size, _CHUNK):
        part = todo[start : start + _CHUNK]
        total[part], counts[part] = _series_chunk(g[part], a[part], tolerance)
    if count_terms:
        return total.reshape(shape), counts.reshape(shape)
    return total.reshape(shape)


#: Elements summed together: large enough to amortise numpy's overhead per call,
#: small enough for the working arrays to stay in cache. On 3e5 elements with g up
#: to 30, chunks of 2^13 to 2^17 ran equally fast, 2^11 and 2^19 1.5 to 2 times slower.
_CHUNK = 1 << 15


def log_factorials(n: int) -> np.ndarray:
    """``ln(m!)`` for ``m < n``, within an ulp: the sum of ``ln k`` in double-double
    (Knuth's two-sum; Knuth, TAOCP vol. 2, 4.2.2). The series' first weight
    ``exp(m ln g - g - ln(m!))`` cancels terms of several thousand at ``g`` of 1e3,
    where one ulp of ``ln(m!)`` is 1e-12 of the weight; scipy's ``gammaln`` is an ulp
    off there, CPython's ``math.lgamma`` up to three (measured against 50 digits)."""
    hi, lo, out = 0.0, 0.0, [0.0]
    for k in range(1, n):
        x = math.log(k)
        s = hi + x
        b = s - hi
        lo += (hi - (s - b)) + (x - b)
        hi = s
        out.append(hi + lo)
    return np.array(out)


@functools.cache
def log_factorial_table() -> np.ndarray:
    """``ln(m!)`` for ``m < 2048``, the first indices of most series (beyond,
    ``gammaln``); computed on first use (0.7 ms), not when brdffit is imported."""
    return log_factorials(2048)


def _series_chunk(g: np.ndarray, a: np.ndarray, tolerance: float):
    """:func:`dd_series` on a flat chunk; returns the sums and the term counts."""
    from scipy.special import gammaln  # here: scipy.special takes 0.4 s to import

    total = np.zeros(g.size)
    counts = np.zeros(g.size, dtype=np.int64)
    m = series_lower_start(g, tolerance)
    table = log_factorial_table()
    listed = m < table.size
    log_factorial = table[np.where(listed, m, 0.0).astype(np.int64)]
    if not listed.all():
        log_factorial[~listed] = gammaln(m[~listed] + 1.0)
    with np.errstate(divide="ignore"):
        p = np.exp(m * np.log(g) - g - log_factorial)
    neg_a = -a
    idx = np.arange(g.size)
    s, q = np.zeros(g.size), np.zeros(g.size)
    live = np.ones(g.size, dtype=bool)
    half_tol = 0.5 * tolerance
    n_live, n = g.size, 0
    t, e = np.empty(g.size), np.empty(g.size)
    while n_live:
        n += 1
        np.divide(p, m, out=t)
        q += t
        np.divide(neg_a, m, out=e)
        np.exp(e, out=e)
        e *= t
        s += e
        m += 1.0
        np.divide(g, m, out=e)
        p *= e  # p is now p_{m}, m the next index
        # The bound p_{M+1} / ((M+1)(1 - g/(M+2))), with M + 1 = m, free of divisions.
        slack = m + 1.0 - g
        done = (slack > 0.0) & (p * (m + 1.0) <= half_tol * q * m * slack) & live
        n_done = np.count_nonzero(done)
        if n_done:
            total[idx[done]] = s[done]
            counts[idx[done]] = n
            live &= ~done
            n_live -= n_done
            # Converged elements are dropped in bulk: copying every array at every
            # step costs more than carrying a few finished ones along.
            if n_live and n_live < 0.75 * idx.size:
                idx, g, neg_a, p, m, s, q, live = (
                    x[live] for x in (idx, g, neg_a, p, m, s, q, live)
                )
                t, e = np.empty(idx.size), np.empty(idx.size)
    return total, counts
