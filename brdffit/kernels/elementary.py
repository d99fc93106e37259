"""Vectorisable ``log``, ``log1p`` and ``exp`` for the loops of
:mod:`brdffit.kernels.loops_empirical`, and a reciprocal without the divider
(:func:`fast_reciprocal`) for those of :mod:`brdffit.kernels.loops_renderers`.

A libm ``log`` called in a loop stops LLVM from vectorising it, as ``exp`` does
(:mod:`brdffit.kernels._compile`); the lobes with a power of a parameter-dependent
base (Lafortune's, Fournier's tilted lobes) or a ``log1p`` (Ohara's) need one per
pair. :func:`fast_log` is the classic reduction of Cody and Waite (Software Manual
for the Elementary Functions, 1980, chapter 5) in the arrangement of Tang
(Table-driven implementation of the logarithm function in IEEE floating-point
arithmetic, ACM TOMS 16(4), 1990, without the table):

- ``x = 2^k m`` with ``sqrt(1/2) <= m < sqrt(2)``, read from the bits of ``x``
  (subnormal ``x`` first scaled by ``2^54``);
- ``ln m = ln(1 + f)``, ``f = m - 1`` (exact), from ``s = f / (2 + f)``:
  ``ln(1 + f) = 2 atanh(s) = 2 s + s z G(z)``, ``z = s^2 <= 0.0295``, with
  ``G(z) = sum_j 2 z^j / (2j + 3)`` replaced by the polynomial of degree 6 closest to
  it on Chebyshev points of ``[0, 0.0295]`` (:func:`fit_log_series`; it is within
  1e-15 of ``G``, which moves ``ln m`` by under 1.2e-17 relative);
- ``2 s = f - s f`` turns that into ``f - (f^2/2 - s (f^2/2 + z G))``, where the
  rounding of ``s`` only touches a term ``f^2`` times smaller than the result;
- ``k ln 2`` in two parts (``ln 2`` to 32 bits, exact times ``|k| < 2^20``, and the
  rest), added last.

Its measured relative error is below 2.5e-16 (tests/models/test_kernels_empirical.py).
:func:`fast_log1p` adds the rounding error ``e = (1 + x) - u`` of ``u = 1 + x`` to
``f`` before the series: ``ln(1 + x)`` to the same accuracy for tiny ``x`` too. As in
Dekker's Fast2Sum (A floating-point technique for extending the available
precision, Numerische Mathematik 18, 1971), ``e = x - (u - 1)`` exactly for
``x >= 0``: below ``2^53``, ``u - 1`` is exact (1 is a multiple of the spacing of
``u``) and ``e`` is representable, so the last subtraction is exact too; above,
``e`` may be off by the spacing of ``u``, which moves ``ln(1 + x) > 36`` by under
1e-17 relative.

:func:`fast_exp_short` is :func:`~brdffit.kernels._compile.fast_exp` (the same
reduction, ``k = round(x / ln 2)`` by adding and subtracting ``1.5 * 2^52``, the same
flush below ``exp(-708)``) with ``exp(r)`` by the polynomial of degree 11 closest to
it in relative error (:func:`fit_exp_polynomial`, 3.1e-18) instead of the Taylor
polynomial of degree 13: that and the rounding (since taken over by ``fast_exp``)
each gave the Lafortune loop 12 to 15 % more pairs per second (measured beside each
other in one run). Its measured relative error is below 3e-16. Everything is
arithmetic and bit operations on 64-bit integers that AVX2 has, so the loops
vectorise.
"""

from __future__ import annotations

import math
import sys
from decimal import Decimal, localcontext

import numba
import numpy as np

# ln 2 in two parts, its inverse and the largest argument: fast_exp's (see its module)
from ._compile import _EXP_MAX, _LN2_HI, _LN2_LO, _LOG2E, EXP_MIN, FLAGS
from ._compile import _ROUNDER as _ROUND
from ._compile import _bits_of_double as _bits
from ._compile import _double_from_bits as _float

__all__ = [
    "EXP7_ERROR",
    "EXP_POLYNOMIAL",
    "EXP_POLYNOMIAL_7",
    "G",
    "LOG_ZERO",
    "Z_MAX",
    "fast_exp_7",
    "fast_exp_short",
    "fast_log",
    "fast_log1p",
    "fast_reciprocal",
    "fit_exp_polynomial",
    "fit_log_series",
    "log_series",
]

#: What :func:`fast_log` returns for ``x <= 0``: finite (the loops run without
#: infinities), and its product with any exponent of the models (at least 1) is far
#: below the smallest argument of ``fast_exp``, which then returns 0.
LOG_ZERO = -1e300

_SMALLEST_NORMAL = sys.float_info.min
_TWO_54 = 2.0**54
#: The bits of sqrt(1/2) subtracted from those of x and 1023 added back in the
#: exponent field: ``(bits + _SHIFT) >> 52`` is the biased k of ``x = 2^k m``.
_SHIFT = 0x3FF0000000000000 - int(np.float64(math.sqrt(0.5)).view(np.int64))
_K_BIAS = 2.0**52 + 1023.0  # the float of the bits 0x433 << 52 | kb is 2^52 + kb
#: The largest ``z = s^2``: ``s = (sqrt 2 - 1)/(sqrt 2 + 1)``.
Z_MAX = ((math.sqrt(2.0) - 1.0) / (math.sqrt(2.0) + 1.0)) ** 2
#: The polynomial in place of ``G(z)``, highest power first (:func:`fit_log_series`).
G = (
    0.1462710929566226,
    0.1533085642758008,
    0.18182915017875054,
    0.22222210788014152,
    0.28571428627942674,
    0.3999999999989616,
    0.6666666666666671,
)
#: The polynomial of degree 11 in place of ``exp(r)`` on ``|r| <= ln(2)/2``, highest
#: power first (:func:`fit_exp_polynomial`; relative error 3.1e-18).
EXP_POLYNOMIAL = (
    2.4989491355772434e-08,
    2.763226447373137e-07,
    2.7557638344026344e-06,
    2.480148660775664e-05,
    0.00019841269413815112,
    0.0013888888951133485,
    0.008333333333569098,
    0.04166666666649316,
    0.16666666666666147,
    0.5000000000000018,
    1.0,
    1.0,
)

#: The polynomial of degree 7 in place of ``exp(r)`` (:func:`fit_exp_polynomial` with
#: ``degree=7``), highest power first: relative error 4.1e-11 on ``|r| <= ln(2)/2``.
EXP_POLYNOMIAL_7 = (
    0.0001976691897555816,
    0.0013948134043156074,
    0.008333578289957027,
    0.041666226310524,
    0.1666666502416243,
    0.5000000104139771,
    1.000000000258079,
    0.9999999999619436,
)
#: The stated bound on the relative error of :func:`fast_exp_7` (tested).
EXP7_ERROR = 5e-11


def log_series(z: np.ndarray) -> np.ndarray:
    """``G(z) = sum_j 2 z^j / (2j + 3)`` to rounding for ``0 <= z <= Z_MAX`` (40 terms:
    the first left out is below ``Z_MAX^40 < 1e-61``)."""
    return sum(2.0 * z**j / (2 * j + 3) for j in range(40))


def fit_log_series(points: int = 200) -> tuple:
    """The degree-6 least-squares fit of :func:`log_series` on Chebyshev points of
    ``[0, Z_MAX]`` (near the minimax polynomial), highest power first: how :data:`G`
    was computed. Returns ``(coefficients, max |fit - G|)`` on a dense grid."""
    nodes = (np.cos(np.pi * (np.arange(points) + 0.5) / points) + 1.0) * (Z_MAX / 2.0)
    fitted = np.polynomial.Chebyshev.fit(nodes, log_series(nodes), 6, domain=[0.0, Z_MAX])
    coefficients = tuple(float(c) for c in fitted.convert(kind=np.polynomial.Polynomial).coef)
    grid = np.linspace(0.0, Z_MAX, 100_001)
    error = np.max(np.abs(np.polyval(coefficients[::-1], grid) - log_series(grid)))
    return coefficients[::-1], float(error)


def fit_exp_polynomial(degree: int = 11, points: int = 100) -> tuple:
    """The polynomial of ``degree`` closest to ``exp(r)`` in relative error, by least
    squares on Chebyshev points of ``[-ln(2)/2, ln(2)/2]`` (near the minimax one), in
    60-digit decimal arithmetic (float64 normal equations would lose the last digits
    that matter): how :data:`EXP_POLYNOMIAL` was computed. Returns ``(coefficients,
    max relative error)``, the coefficients highest power first, the error on 2001
    points, before the coefficients are rounded to float64."""
    half = math.log(2.0) / 2.0
    size = degree + 1
    with localcontext() as context:
        context.prec = 60
        rows = []
        for i in range(points):
            r = Decimal(half * math.cos(math.pi * (i + 0.5) / points))
            weight = 1 / r.exp()  # relative error: rows and targets divided by exp(r)
            rows.append([weight * r**j if j else weight for j in range(size)])
        normal = [[sum(row[i] * row[j] for row in rows) for j in range(size)] for i in range(size)]
        rhs = [sum(row[i] for row in rows) for i in range(size)]
        for col in range(size):  # Gaussian elimination (the matrix is positive definite)
            for k in range(col + 1, size):
                factor = normal[k][col] / normal[col][col]
                normal[k] = [a - factor * b for a, b in zip(normal[k], normal[col])]
                rhs[k] -= factor * rhs[col]
        c = [Decimal(0)] * size
        for i in reversed(range(size)):
            c[i] = (rhs[i] - sum(normal[i][j] * c[j] for j in range(i + 1, size))) / normal[i][i]

        def relative_error(r: Decimal) -> Decimal:
            value = Decimal(0)
            for coefficient in reversed(c):
                value = value * r + coefficient
            return abs(value / r.exp() - 1)

        grid = (Decimal(half * (2 * k / 2000 - 1)) for k in range(2001))
        error = max(relative_error(r) for r in grid)
    return tuple(float(x) for x in reversed(c)), float(error)


@numba.njit(inline="always", fastmath=FLAGS)
def _split(bits):
    """``(k + 1023, k, m)`` of ``x = 2^k m``, ``sqrt(1/2) <= m < sqrt(2)``, from the
    bits of a positive normal ``x``; ``k`` as a float64."""
    biased = (bits + _SHIFT) >> 52  # >= 0: logical and arithmetic shifts agree
    m = _float(bits - ((biased - 1023) << 52))
    k = _float(biased | 0x4330000000000000) - _K_BIAS
    return biased, k, m


@numba.njit(inline="always", fastmath=FLAGS)
def _log_of(k, f):
    """``k ln 2 + ln(1 + f)`` for ``sqrt(1/2) - 1 <= f < sqrt(2) - 1`` (see the module)."""
    s = f / (2.0 + f)
    z = s * s
    r = G[0]
    for j in range(1, len(G)):  # the tuple is a constant: the loop is unrolled
        r = r * z + G[j]
    r *= z
    half_f2 = 0.5 * f * f
    return k * _LN2_HI + (f - (half_f2 - (s * (half_f2 + r) + k * _LN2_LO)))


@numba.njit(inline="always", fastmath=FLAGS)
def fast_log(x):
    """``ln(x)`` for finite ``x > 0`` (subnormal too), :data:`LOG_ZERO` for ``x <= 0``."""
    tiny = x < _SMALLEST_NORMAL
    scaled = x * _TWO_54 if tiny else x
    _, k, m = _split(_bits(scaled))
    if tiny:
        k -= 54.0
    value = _log_of(k, m - 1.0)
    return value if x > 0.0 else LOG_ZERO


@numba.njit(inline="always", fastmath=FLAGS)
def fast_log1p(x):
    """``ln(1 + x)`` for finite ``x >= 0``, accurate for tiny ``x`` as well."""
    u = 1.0 + x
    error = x - (u - 1.0)  # (1 + x) - u exactly (see the module)
    biased, k, m = _split(_bits(u))
    scale = _float((2046 - biased) << 52)  # 2^-k: m is u 2^-k
    return _log_of(k, (m - 1.0) + error * scale)


@numba.njit(inline="always", fastmath=FLAGS)
def _exp_by(x, polynomial):
    """``exp(x)`` for ``x <= 709`` with ``2^r``'s ``polynomial`` (0 below ``EXP_MIN``).
    ``t = y / ln 2 + _ROUND`` (``_ROUND = 1.5 * 2^52``) is ``_ROUND + k`` exactly, ``k =
    round(y / ln 2)``, ``|k| < 2^51``, and its low bits are ``k``: the bits of ``2^k``
    are ``(bits(t) + 1023) << 52`` (the shift drops the bits of ``_ROUND``)."""
    y = min(max(x, EXP_MIN), _EXP_MAX)
    t = y * _LOG2E + _ROUND
    k = t - _ROUND
    r = y - k * _LN2_HI - k * _LN2_LO
    p = polynomial[0]
    for j in range(1, len(polynomial)):
        p = p * r + polynomial[j]
    scaled = p * _float((_bits(t) + 1023) << 52)
    return scaled if x >= EXP_MIN else 0.0


@numba.njit(inline="always", fastmath=FLAGS)
def fast_exp_short(x):
    """``exp(x)`` for ``x <= 709`` as :func:`~brdffit.kernels._compile.fast_exp` (0 below
    ``EXP_MIN``), by :data:`EXP_POLYNOMIAL` (:func:`_exp_by`)."""
    return _exp_by(x, EXP_POLYNOMIAL)


@numba.njit(inline="always", fastmath=FLAGS)
def fast_exp_7(x):
    """:func:`fast_exp_short` with :data:`EXP_POLYNOMIAL_7`: four multiply-adds fewer,
    within :data:`EXP7_ERROR` relative. For the anisotropic Beckmann loop, whose float32
    inputs already cost it up to 1.2e-7 (its exponent error adds 5e-11 to that)."""
    return _exp_by(x, EXP_POLYNOMIAL_7)


_MANTISSA = (1 << 52) - 1
_EXPONENT_ONE = 1023 << 52


@numba.njit(inline="always", fastmath=FLAGS)
def fast_reciprocal(x):
    """``1 / x`` for positive normal ``x`` below ``2^1022`` without the divider.

    ``x = 2^k m``, ``1 <= m < 2``, read from its bits; ``1/m`` in float32 (the
    vector float32 division or estimate: at least 12 correct bits) times ``2^-k``
    (bits again), then two Newton steps ``r <- r (2 - x r)`` in float64, each of
    which squares the relative error (Markstein, IA-64 and elementary functions,
    2000, chapter 8): within an ulp or two of ``1/x`` (tests/models/
    test_kernels_renderers.py). A division of a vector of float64 takes the divider
    about two cycles a value on the machine of ``benchmarks/``; this is about twelve
    instructions for four values, with no range restriction as the float32
    estimate of the division alone would have."""
    bits = _bits(x)
    m = _float((bits & _MANTISSA) | _EXPONENT_ONE)
    r = np.float64(np.float32(1.0) / np.float32(m)) * _float((2046 - (bits >> 52)) << 52)
    r = r * (2.0 - x * r)
    return r * (2.0 - x * r)
