"""The compiler of the kernels: numba, imported on first use, and a fast ``exp``.

Every kernel is compiled by :func:`jit`: numba's ``njit`` with ``cache=True`` (the
machine code is stored beside the module, or in numba's per-user cache directory
when the package folder is not writable, so only the first run of a fresh install
compiles) and ``fastmath`` (which lets LLVM vectorise the loops; the tests check
every kernel against the float64 references at the references' tolerances).

numba has no vectorised ``exp`` without Intel's SVML, and a libm call in a loop
stops LLVM from vectorising it (measured: 0.23 G exp/s scalar against 1.1 G/s for
:func:`fast_exp` on one core). :func:`fast_exp` is the classic range reduction
``exp(x) = 2^k exp(r)``, ``k = round(x / ln 2)``, ``|r| <= ln(2)/2`` with ``ln 2``
split in two parts (Cody and Waite, Software Manual for the Elementary Functions,
1980), and ``exp(r)`` by its Taylor polynomial of degree 13, whose truncation error
``|r|^14 / 14! < 4e-18`` is below double rounding; ``2^k`` is built from its bits.
``k`` is rounded by adding and subtracting ``1.5 * 2^52`` (whose sum keeps ``k`` in
its low bits), not by ``floor`` and two conversions between float64 and int64
(measured beside the old rounding in one process: a loop of ``exp`` 1.2x faster,
the Beckmann loop 1.04x; without ``reassoc`` in :data:`FLAGS` LLVM keeps the two
operations).
Its measured relative error is below 3e-16 (tests/models/test_kernels.py).
"""

from __future__ import annotations

import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

__all__ = ["jit", "fast_exp"]

_LOG2E = 1.4426950408889634
_LN2_HI = 0.6931471803691238  # ln 2 to 32 bits: k * _LN2_HI is exact for |k| < 2^20
_LN2_LO = 1.9082149292705877e-10
#: Below this (exp(x) < 3.3e-308, near the smallest normal double 2.2e-308) fast_exp
#: returns 0: see fast_exp.
EXP_MIN = -708.0
_EXP_MAX = 709.0  # the kernels take exp of arguments <= 0 only

#: LLVM's fast-math flags but ``reassoc``: reassociation would fold the two-part
#: ``k ln 2`` of :func:`fast_exp` into one product and lose its accuracy (measured:
#: relative errors of 1e-13 near x = -700 with it, 2e-16 without).
FLAGS = {"nnan", "ninf", "nsz", "arcp", "contract", "afn"}


def jit(function):
    """Compile ``function`` with numba: cached on disk, vectorisable float maths."""
    return numba.njit(cache=True, fastmath=FLAGS, error_model="numpy")(function)


@intrinsic
def _double_from_bits(typingctx, bits):
    """The float64 whose IEEE-754 bits are the int64 ``bits`` (a bit cast)."""
    signature = types.float64(types.int64)

    def codegen(context, builder, sig, args):
        return builder.bitcast(args[0], ir.DoubleType())

    return signature, codegen


@intrinsic
def _bits_of_double(typingctx, x):
    """The IEEE-754 bits of the float64 ``x`` as an int64 (a bit cast)."""
    signature = types.int64(types.float64)

    def codegen(context, builder, sig, args):
        return builder.bitcast(args[0], ir.IntType(64))

    return signature, codegen


#: ``1.5 * 2^52``: adding it to ``|t| < 2^51`` rounds ``t`` to an integer ``k`` (the
#: sum's unit in the last place is 1) and leaves ``k`` in the sum's low bits.
_ROUNDER = 1.5 * 2.0**52
_EXPONENT_BIAS = 1023 - int(np.float64(_ROUNDER).view(np.int64))


@numba.njit(inline="always", fastmath=FLAGS)
def fast_exp(x):
    """``exp(x)`` in float64 for ``x <= 709``, vectorisable; 0 for ``x <`` :data:`EXP_MIN`.

    Results under 3.3e-308 are flushed to 0 instead of underflowing gradually into
    subnormal numbers as libm's ``exp`` does: arithmetic on subnormal numbers takes a
    microcode assist of the order of a hundred cycles on x86 (measured: the Ward loop
    at 520 instead of 800 M pairs/s with gradual underflow). A BRDF value below
    1e-307 is 0 to every use brdffit makes of it; the tests compare the compiled and
    the numpy models with an absolute tolerance of the smallest normal double."""
    y = min(max(x, EXP_MIN), _EXP_MAX)
    rounded = y * _LOG2E + _ROUNDER  # k = rounded - _ROUNDER, also in its low bits
    k = rounded - _ROUNDER
    r = y - k * _LN2_HI - k * _LN2_LO
    p = 1.0 / 6227020800.0
    p = p * r + 1.0 / 479001600.0
    p = p * r + 1.0 / 39916800.0
    p = p * r + 1.0 / 3628800.0
    p = p * r + 1.0 / 362880.0
    p = p * r + 1.0 / 40320.0
    p = p * r + 1.0 / 5040.0
    p = p * r + 1.0 / 720.0
    p = p * r + 1.0 / 120.0
    p = p * r + 1.0 / 24.0
    p = p * r + 1.0 / 6.0
    p = p * r + 0.5
    p = p * r + 1.0
    p = p * r + 1.0
    scaled = p * _double_from_bits((_bits_of_double(rounded) + _EXPONENT_BIAS) << 52)
    return scaled if x >= EXP_MIN else 0.0
