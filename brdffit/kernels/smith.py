"""Beckmann's Smith masking as one rational function, for vectorised loops.

The exact masking of the Beckmann distribution (Walter et al., EGSR 2007; Heitz,
JCGT 3(2), 2014, section 5.1) is, with ``a = 1 / (alpha tan theta)``,

    G1 = 1 / (1 + Lambda(a)),  Lambda(a) = (exp(-a^2) / (a sqrt(pi)) - erfc(a)) / 2.

It needs ``erfc``, which numba evaluates by a library call: in a loop that stops
LLVM from vectorising it (measured: 30 M pairs/s for a Beckmann loop calling
``erf``), and a table of polynomials over intervals of ``a`` makes the loop gather
its coefficients (63 M pairs/s, measured). Here ``G1`` is one rational function of
``a`` with fixed coefficients, evaluated by two Horner schemes and one division
shared by the pair (no table, no branch):

    G1(a) ~ a Q(x) / (a Q(x) + P(x)),  x = 2 a / A_MAX - 1,  0 <= a <= A_MAX,

``P/Q`` a rational approximation of degree (6, 6) of ``a Lambda(a) = (exp(-a^2) /
sqrt(pi) - a erfc(a)) / 2``, an entire function, fitted to minimise the relative
error of ``G1`` (its error is weighted by ``1 / (a + a Lambda)``) on Chebyshev points
of ``[0, A_MAX]`` by linearised least squares (Sanathanan and Koerner, IEEE Trans.
Autom. Control 8(1), 1963) with Lawson's reweighting towards the minimax error
(C. L. Lawson, 1961; see L. N. Trefethen, Approximation Theory and Approximation
Practice, SIAM 2013, on rational approximation and linearised least squares). For ``a > A_MAX``
(directions within ``atan(1 / (A_MAX alpha))`` of the normal) ``G1`` is taken at
``A_MAX``: ``Lambda(3.7) = 2.9e-9``. The relative error of ``G1`` on the whole of
``a > 0`` is below :data:`MAX_ERROR` (measured against scipy's ``erfc`` on a dense
grid: tests/models/test_kernels.py). ``python -m brdffit.kernels.smith`` refits the
coefficients.

The degree is a trade of speed against exactness (issue 13; one core, the compiled
Beckmann loop): (11, 11) on ``[0, 5]`` is within 4.2e-13 of the exact ``G1`` but
leaves the loop at 0.6-0.7x of Mitsuba 3's LLVM Beckmann, (6, 6) on ``[0, 3.7]``
is within 1.5e-8 and 1.3-1.4x faster (benchmarks/README.md). An error of 1.5e-8 is far
below that of any measurement a fit sees, and below the issue's bound of 1e-6, so
the Beckmann models use this function in their numpy form too
(:mod:`brdffit.models.renderers`): both paths evaluate the same ``G1`` (the
compiled loop's float32 inputs add at most 2e-7, :mod:`brdffit.kernels.inputs`),
within ``2 MAX_ERROR`` of the exact Smith ``G1(L) G1(V)`` (the models' docs and
reference tests say so).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.polynomial import chebyshev

__all__ = ["A_MAX", "MAX_ERROR", "P", "Q", "a_lambda", "fit", "g1", "g1_exact", "smith_g1"]

A_MAX = 3.7
#: The stated bound on the relative error of :func:`g1` for every ``a > 0``.
MAX_ERROR = 2e-8
#: Coefficients of P and Q in powers of x, highest power first (Horner's order).
P = (
    0.0010374517408812077,
    -0.004636674039062708,
    0.008950538590942343,
    -0.009654098809983564,
    0.006178542260331334,
    -0.0022293796538826495,
    0.0003537999473950861,
)
Q = (
    0.016674925763879866,
    0.12004675214836416,
    0.4010829221031325,
    0.7653515426141249,
    0.9686707535652498,
    0.7439524485466358,
    0.360047613127488,
)


def a_lambda(a) -> np.ndarray:
    """``a Lambda(a) = (exp(-a^2)/sqrt(pi) - a erfc(a)) / 2`` from scipy's ``erfc``
    (the reference of the fit and its tests: scipy.special is imported here only)."""
    from scipy.special import erfc

    a = np.asarray(a, dtype=float)
    with np.errstate(over="ignore"):  # a^2 overflows for a > 1e154: exp(-inf) = 0
        return 0.5 * (np.exp(-a * a) / math.sqrt(math.pi) - a * erfc(a))


def g1_exact(a) -> np.ndarray:
    """Beckmann's Smith ``G1 = a / (a + a Lambda(a))`` from scipy's ``erfc``."""
    a = np.asarray(a, dtype=float)
    return a / (a + a_lambda(a))


def g1(a, p=P, q=Q) -> np.ndarray:
    """``G1`` as the loops compute it, ``a Q / (a Q + P)`` at ``min(a, A_MAX)``
    (Horner's scheme in place: the numpy models' evaluation, without temporaries)."""
    a = np.minimum(np.asarray(a, dtype=float), A_MAX)
    x = a * (2.0 / A_MAX)
    x -= 1.0
    n, d = np.multiply(x, q[0]), np.multiply(x, p[0])  # Horner's first step: c0 x + c1
    if not isinstance(n, np.ndarray):  # one value: a 0-d array, written in place below
        n, d = np.array(n), np.array(d)
    n += q[1]
    d += p[1]
    for c in q[2:]:
        n *= x
        n += c
    for c in p[2:]:
        d *= x
        d += c
    n *= a
    d += n
    return np.divide(n, d, out=n)


def smith_g1(tan2_v, alpha2) -> np.ndarray:
    """Beckmann's Smith ``G1`` of a direction as the Beckmann models compute it:
    :func:`g1` at ``a = 1 / sqrt(alpha^2 tan^2 theta_v)`` (``A_MAX`` at the normal),
    within :data:`MAX_ERROR` of the exact ``G1``. Broadcasts like numpy (``alpha2``
    may be :func:`~brdffit.models.shared.projected_alpha2`, or an array of walkers)."""
    a = np.multiply(tan2_v, alpha2)
    np.sqrt(a, out=a)
    with np.errstate(divide="ignore"):
        np.divide(1.0, a, out=a)
    return g1(a)


def fit(m: int = 6, n: int = 6, points: int = 8000, iterations: int = 60):
    """Fit ``P`` (degree m) and ``Q`` (degree n, ``Q``'s Chebyshev constant term 1):
    the coefficients in powers of x, highest first, and the largest relative error of
    ``G1`` on the fitting points (see the module docstring for the method)."""
    x = np.cos(np.pi * (np.arange(points) + 0.5) / points)
    a = (x + 1.0) * (0.5 * A_MAX)
    f = a_lambda(a)
    scale = a + f  # the error of P/Q relative to a + a Lambda is that of G1
    vm, vn = chebyshev.chebvander(x, m), chebyshev.chebvander(x, n)
    system = np.hstack([vm, -f[:, None] * vn[:, 1:]])
    weights, denominator, best = np.ones(points), np.ones(points), None
    for _ in range(iterations):
        row = np.sqrt(weights) / (np.abs(denominator) * scale)
        solution = np.linalg.lstsq(system * row[:, None], f * row, rcond=None)[0]
        p, q = solution[: m + 1], np.concatenate([[1.0], solution[m + 1 :]])
        denominator = chebyshev.chebval(x, q)
        error = (chebyshev.chebval(x, p) / denominator - f) / scale
        worst = float(np.max(np.abs(error)))
        if best is None or worst < best[2]:
            best = (p, q, worst)
        weights = np.maximum(weights * np.abs(error), 1e-300)
        weights /= weights.sum()
    p, q, worst = best
    in_powers = [tuple(float(c) for c in chebyshev.cheb2poly(c)[::-1]) for c in (p, q)]
    return in_powers[0], in_powers[1], worst


if __name__ == "__main__":
    p, q, worst = fit()
    print(f"# largest relative error of G1 on the fitting points: {worst:.3e}")
    print(f"P = {p!r}\nQ = {q!r}")
