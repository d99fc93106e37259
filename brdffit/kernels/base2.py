"""Base-2 logarithms of two numbers with one division (:func:`log2_pair`) and a short
``2^y`` (:func:`fast_exp2`): the pieces of the Fournier loop of
:mod:`brdffit.kernels.loops_empirical`.

Fournier's lobe is three powers ``x^n`` a pair, two of them of bases that depend on
the shape parameter ``t``: two logarithms and three exponentials a pair, whose
vector instructions bound its loop (two 512-bit ports). Working in base 2 drops a
multiply-add from each of them:

- :func:`log2_pair` is :func:`~brdffit.kernels.elementary.fast_log`'s reduction
  (Cody and Waite, Software Manual for the Elementary Functions, 1980, chapter 5):
  ``x = 2^k m``, ``sqrt(1/2) <= m < sqrt(2)``, ``s = (m - 1) / (m + 1)``,
  ``log2 x = k + s Q(s^2)`` with ``Q(z) = (2 / ln 2) sum_j z^j / (2j + 1)``
  (``2 atanh(s) / ln 2``) replaced by :data:`LOG2_SERIES`, the polynomial of degree 6
  closest to it on ``[0, Z_MAX]`` (:func:`fit_log2_series`). ``k`` is added as it is
  (no two-part ``k ln 2``); ``m`` is the low bits of ``bits(x) + SHIFT`` plus those of
  ``sqrt(1/2)`` (an and and an add). The two quotients share one division,
  ``1 / ((m_1 + 1)(m_2 + 1))``: a division of eight float64 lanes holds the divider
  about 16 cycles, and two of them a pair bound the loop. Without Tang's arrangement
  of :func:`~brdffit.kernels.elementary.fast_log` (three more instructions a
  logarithm), the roundings of ``s`` reach the result: within :data:`LOG2_ERROR`
  (4 units in the last place) instead of 1. Arguments at or below 0 (and subnormal
  ones) are read as the smallest normal number, whose base-2 logarithm is
  ``-1022``: finite, so the loop needs no select; what that leaves is the caller's
  to bound (Fournier's: see its loop).
- :func:`fast_exp2` is ``2^k 2^r``, ``k = round(y)`` by adding and subtracting
  ``1.5 * 2^52`` (as :func:`~brdffit.kernels._compile.fast_exp`), ``r = y - k``
  exactly (no two-part ``ln 2``), ``2^r`` by :data:`EXP2_POLYNOMIAL`, degree 9
  (:func:`fit_exp2_polynomial`, 1.4e-14 relative), and ``2^k`` added to the bits
  of the result's exponent (an integer add in place of a multiply). Below ``-1020``
  it returns ``2^-1020`` (to its error), not 0 (no select either): the caller's to
  bound again.

Their measured relative errors (tests/models/test_kernels_base2.py): below
:data:`LOG2_ERROR` and :data:`EXP2_ERROR`. Everything is arithmetic and 64-bit
integer operations, so the loops vectorise.
"""

from __future__ import annotations

import math
import sys

import numba
import numpy as np

from ._compile import _LOG2E, FLAGS
from ._compile import _ROUNDER as _ROUND
from ._compile import _bits_of_double as _bits
from ._compile import _double_from_bits as _float
from .elementary import _SHIFT, Z_MAX, fit_exp_polynomial, log_series

__all__ = [
    "EXP2_ERROR",
    "EXP2_FLOOR",
    "EXP2_POLYNOMIAL",
    "LOG2_ERROR",
    "LOG2_FLOOR",
    "LOG2_SERIES",
    "fast_exp2",
    "fit_exp2_polynomial",
    "fit_log2_series",
    "log2_pair",
]

#: ``2^r`` on ``|r| <= 1/2``, highest power first: ``fit_exp2_polynomial(9)``.
EXP2_POLYNOMIAL = (
    1.0147564615099417e-07,
    1.3259381682060455e-06,
    1.5253000328423049e-05,
    0.00015403435067411336,
    0.0013333557588818576,
    0.009618129191881425,
    0.055504108668883015,
    0.24022650695650577,
    0.6931471805598673,
    1.0000000000000127,
)
#: The stated bound on the relative error of :func:`fast_exp2` (tested, not slack).
EXP2_ERROR = 2e-14
#: ``Q(z) = (2 / ln 2) sum_j z^j / (2j + 1)`` on ``[0, Z_MAX]``, highest power first
#: (:func:`fit_log2_series`).
LOG2_SERIES = (
    0.2431529590230131,
    0.261423661098497,
    0.32061705677424407,
    0.4121983921192441,
    0.5770780173119042,
    0.961796693924178,
    2.8853900817779277,
)
#: The stated bound on the relative error of :func:`log2_pair` for normal arguments.
LOG2_ERROR = 1e-15
#: What :func:`fast_exp2` returns below it: ``2^EXP2_FLOOR`` (to its error).
EXP2_FLOOR = -1020.0
#: What :func:`log2_pair` reads in place of an argument below it (``log2`` is -1022).
LOG2_FLOOR = sys.float_info.min

_MANTISSA = (1 << 52) - 1
_SQRT_HALF_BITS = 0x3FF0000000000000 - _SHIFT  # the bits of sqrt(1/2)
_K_BIAS = 2.0**52 + 1023.0  # the float of the bits 0x433 << 52 | kb is 2^52 + kb


def fit_exp2_polynomial(degree: int = 9) -> tuple:
    """The polynomial of ``degree`` closest to ``2^r`` on ``|r| <= 1/2`` in relative
    error: :func:`~brdffit.kernels.elementary.fit_exp_polynomial`'s ``exp(u)``,
    ``u = r ln 2``, its coefficient of ``u^j`` times ``(ln 2)^j``. Returns
    ``(coefficients, max relative error)``, highest power first."""
    coefficients, error = fit_exp_polynomial(degree)
    ln2 = math.log(2.0)
    return tuple(c * ln2 ** (degree - j) for j, c in enumerate(coefficients)), error


def fit_log2_series(degree: int = 6, points: int = 200) -> tuple:
    """The least-squares fit of ``Q(z) = log2(e) (2 + z G(z))`` (``G``:
    :func:`~brdffit.kernels.elementary.log_series`) of ``degree`` on Chebyshev points
    of ``[0, Z_MAX]`` (near the minimax polynomial), highest power first: how
    :data:`LOG2_SERIES` was computed. Returns ``(coefficients, max relative error)``
    on a dense grid."""

    def series(z):
        return _LOG2E * (2.0 + z * log_series(z))

    nodes = (np.cos(np.pi * (np.arange(points) + 0.5) / points) + 1.0) * (Z_MAX / 2.0)
    fitted = np.polynomial.Chebyshev.fit(nodes, series(nodes), degree, domain=[0.0, Z_MAX])
    coefficients = tuple(float(c) for c in fitted.convert(kind=np.polynomial.Polynomial).coef)
    grid = np.linspace(0.0, Z_MAX, 100_001)
    error = np.max(np.abs(np.polyval(coefficients[::-1], grid) / series(grid) - 1.0))
    return coefficients[::-1], float(error)


@numba.njit(inline="always", fastmath=FLAGS)
def _reduce(x):
    """``(k, m)`` of ``max(x, LOG2_FLOOR) = 2^k m``, ``sqrt(1/2) <= m < sqrt(2)``; ``k``
    as a float64 (see the module)."""
    shifted = _bits(max(x, LOG2_FLOOR)) + _SHIFT
    m = _float((shifted & _MANTISSA) + _SQRT_HALF_BITS)
    k = _float((shifted >> 52) | 0x4330000000000000) - _K_BIAS
    return k, m


@numba.njit(inline="always", fastmath=FLAGS)
def _series(s):
    """``s Q(s^2)``: ``log2((1 + s) / (1 - s))``."""
    z = s * s
    q = LOG2_SERIES[0]
    for j in range(1, len(LOG2_SERIES)):  # the tuple is a constant: the loop is unrolled
        q = q * z + LOG2_SERIES[j]
    return s * q


@numba.njit(inline="always", fastmath=FLAGS)
def log2_pair(x1, x2):
    """``(log2 x1, log2 x2)`` with one division; :data:`LOG2_FLOOR` in place of an
    argument below it (see the module)."""
    k1, m1 = _reduce(x1)
    k2, m2 = _reduce(x2)
    p1 = m1 + 1.0
    p2 = m2 + 1.0
    inv = 1.0 / (p1 * p2)
    return k1 + _series((m1 - 1.0) * (p2 * inv)), k2 + _series((m2 - 1.0) * (p1 * inv))


@numba.njit(inline="always", fastmath=FLAGS)
def fast_exp2(y):
    """``2^y`` for ``EXP2_FLOOR <= y <= 1000``; ``2^EXP2_FLOOR`` below, both within
    :data:`EXP2_ERROR` (see the module). ``t = y + 1.5 * 2^52`` holds ``k = round(y)``
    in its low bits, and ``bits(t) << 52`` is ``k`` in the exponent field (the shift
    drops the rest)."""
    y = max(y, EXP2_FLOOR)
    t = y + _ROUND
    r = y - (t - _ROUND)
    p = EXP2_POLYNOMIAL[0]
    for j in range(1, len(EXP2_POLYNOMIAL)):
        p = p * r + EXP2_POLYNOMIAL[j]
    return _float(_bits(p) + (_bits(t) << 52))
