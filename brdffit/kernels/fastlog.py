"""A vectorisable natural logarithm for the compiled loops: ``fast_log``, ``fast_log1p``.

A libm ``log`` called in a loop stops LLVM from vectorising it, as ``exp`` does
(:mod:`brdffit.kernels._compile`); the lobes with a power of a parameter-dependent
base (Lafortune's, Fournier's tilted lobes) or a ``log1p`` (Ohara's) need one per
pair. The method is the classic one of Cody and Waite (Software Manual for the
Elementary Functions, 1980, chapter 5) in the arrangement of Tang (Table-driven
implementation of the logarithm function in IEEE floating-point arithmetic, ACM
TOMS 16(4), 1990, without the table):

- ``x = 2^k m`` with ``sqrt(1/2) <= m < sqrt(2)``, read from the bits of ``x``
  (subnormal ``x`` first scaled by ``2^54``);
- ``ln m = ln(1 + f)``, ``f = m - 1`` (exact), from ``s = f / (2 + f)``:
  ``ln(1 + f) = 2 atanh(s) = 2 s + s R(s^2)`` with ``R(z) = sum_j 2 z^j / (2j + 1)``,
  whose Taylor series is cut after ``j = 10``: ``|s| <= 0.1716``, ``z <= 0.0295``,
  so the first term left out is below ``6e-19`` relative;
- ``2 s = f - s f`` turns that into ``f - (f^2/2 - s (f^2/2 + R))``, where the
  rounding of ``s`` only touches a term ``f^2`` times smaller than the result;
- ``k ln 2`` in two parts (``ln 2`` to 32 bits, exact times ``|k| < 2^20``, and the
  rest), added last.

Its measured relative error is below 2.5e-16 (tests/models/test_kernels_empirical.py).
``fast_log1p`` adds the rounding error of ``u = 1 + x``, exact by Dekker's Fast2Sum
(A floating-point technique for extending the available precision, Numerische
Mathematik 18, 1971), to ``f`` before the series: ``ln(1 + x)`` to the same accuracy
for tiny ``x`` too.

Everything is arithmetic and bit operations on 64-bit integers that AVX2 has (a
logical, not arithmetic, shift; the integer ``k`` turned into a float64 by its bits,
not by a conversion AVX2 lacks), so the loops vectorise.
"""

from __future__ import annotations

import numba
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from ._compile import FLAGS

__all__ = ["LOG_ZERO", "fast_log", "fast_log1p"]

#: What :func:`fast_log` returns for ``x <= 0``: finite (the loops run without
#: infinities), and its product with any exponent of the models (at least 1) is far
#: below the smallest argument of ``fast_exp``, which then returns 0.
LOG_ZERO = -1e300

_LN2_HI = 0.6931471803691238  # ln 2 to 32 bits: k * _LN2_HI is exact for |k| < 2^20
_LN2_LO = 1.9082149292705877e-10
_SMALLEST_NORMAL = 2.2250738585072014e-308
_TWO_54 = 2.0**54
#: The bits of sqrt(1/2) subtracted from those of x and 1023 added back in the
#: exponent field: ``(bits + _SHIFT) >> 52`` is the biased k of ``x = 2^k m``.
_SHIFT = 0x3FF0000000000000 - 0x3FE6A09E667F3BCD
_K_BIAS = 2.0**52 + 1023.0  # the float of the bits 0x433 << 52 | kb is 2^52 + kb
#: ``2 / (2j + 1)`` for j = 10 down to 1: the series R(z) by Horner's scheme.
_R = tuple(2.0 / (2 * j + 1) for j in range(10, 0, -1))


@intrinsic
def _bits(typingctx, x):
    """The IEEE-754 bits of the float64 ``x`` as an int64 (a bit cast)."""
    signature = types.int64(types.float64)

    def codegen(context, builder, sig, args):
        return builder.bitcast(args[0], ir.IntType(64))

    return signature, codegen


@intrinsic
def _float(typingctx, bits):
    """The float64 whose IEEE-754 bits are the int64 ``bits`` (a bit cast)."""
    signature = types.float64(types.int64)

    def codegen(context, builder, sig, args):
        return builder.bitcast(args[0], ir.DoubleType())

    return signature, codegen


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
    r = _R[0]
    for j in range(1, len(_R)):  # the tuple is a constant: the loop is unrolled
        r = r * z + _R[j]
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
    # Fast2Sum: the rounding error of u, exactly, with the larger operand first
    error = x - (u - 1.0) if x <= 1.0 else 1.0 - (u - x)
    biased, k, m = _split(_bits(u))
    scale = _float((2046 - biased) << 52)  # 2^-k: m is u 2^-k
    return _log_of(k, (m - 1.0) + error * scale)
