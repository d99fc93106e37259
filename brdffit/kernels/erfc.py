"""A vectorisable ``erfc`` for the compiled loops: :func:`fast_erfc`.

numba's ``math.erfc`` calls libm, which stops LLVM from vectorising a loop (as
``exp`` and ``log`` do, :mod:`brdffit.kernels._compile`, :mod:`~.elementary`); the
shadowing of He et al. (:mod:`brdffit.kernels.loops_he`) takes two per pair. Below
``x = 0.5``, ``erfc = 1 - erf`` with ``erf`` by its Taylor series (14 terms); above,
``erfc(x) = exp(-x^2) erfcx(x)`` with ``erfcx`` a Chebyshev series in
``t = (x - K) / (x + K)`` (the variable of Schonfelder, Chebyshev expansions for the
error and related functions, Math. Comp. 32(144), 1978), its coefficients the
least-squares fit :func:`fit_erfcx` computes against scipy's ``erfcx``. Measured
relative error against scipy's ``erfc``: below 2e-15 from 0 to 27, where the test
holds it below 1e-14 (tests/models/test_kernels_he.py).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ._compile import FLAGS, fast_exp

__all__ = ["ERFCX_CHEBYSHEV", "ERF_TAYLOR", "fast_erfc", "fit_erfcx"]

#: ``erfcx(x) = exp(x^2) erfc(x)`` for ``x >= 0.5`` is ``(K / x) C(u)``, ``C`` a Chebyshev
#: series in ``u``, the image in [-1, 1] of ``t = (x - K) / (x + K)`` over [-0.6, 1]
#: (the variable of Schonfelder, Chebyshev expansions for the error and related
#: functions, Math. Comp. 32, 1978): :func:`fit_erfcx` computed the coefficients.
ERFCX_K, ERFCX_T0 = 2.0, -0.6
ERFCX_CHEBYSHEV = (
    0.2439956040720817, 0.05802464273277516, -0.025263981867961503, 0.006078394732245653,
    -0.0007399168994710511, -1.64448160544135e-05, 1.744647173006876e-05,
    -5.063871348756339e-07, -4.78697911957348e-07, 1.662295123182116e-08,
    1.6442453446243967e-08, 1.9349392141361064e-11, -6.325211859700279e-10,
    -4.536323211338677e-11, 2.327069296371824e-11, 4.32683232399787e-12,
    -6.098785635449861e-13, -2.8560246113254743e-13, -7.42918060908851e-15,
    1.3859680593171703e-14, 2.5609992538300906e-15, -3.2889416401064565e-16,
    -1.7735134078171591e-16, -7.246068730705806e-18, 4.5338994006305145e-17,
    3.058891004880344e-17, 4.510297631479921e-17,
)  # fmt: skip
#: The coefficients but the first, highest first, in two halves (see fast_erfc).
_CLENSHAW_HIGH = tuple(reversed(ERFCX_CHEBYSHEV[14:]))
_CLENSHAW_LOW = tuple(reversed(ERFCX_CHEBYSHEV[1:14]))
#: ``erf(x) = x sum_n c_n x^(2n)`` for ``x < 0.5``, ``c_n = 2 (-1)^n / (sqrt(pi) n! (2n+1))``,
#: highest power first; the first term left out is below 3e-19.
ERF_TAYLOR = tuple(
    2.0 * (-1.0) ** n / (math.sqrt(math.pi) * math.factorial(n) * (2 * n + 1))
    for n in range(13, -1, -1)
)


def fit_erfcx(degree: int = 26, points: int = 400) -> tuple:
    """The least-squares Chebyshev fit of ``x erfcx(x) / K`` in ``t`` on Chebyshev points
    (near the minimax fit), scipy's ``erfcx`` the reference: how
    :data:`ERFCX_CHEBYSHEV` was computed."""
    from scipy.special import erfcx

    nodes = np.cos(np.pi * (np.arange(points) + 0.5) / points)
    t = ERFCX_T0 + (1.0 - ERFCX_T0) * (nodes + 1.0) / 2.0
    x = ERFCX_K * (1.0 + t) / (1.0 - t)
    fitted = np.polynomial.Chebyshev.fit(t, erfcx(x) * x / ERFCX_K, degree, domain=[ERFCX_T0, 1.0])
    return tuple(float(c) for c in fitted.coef)


@numba.njit(inline="always", fastmath=FLAGS)
def fast_erfc(x):
    """``erfc(x)`` for ``0 <= x <= 30`` without a library call (vectorisable): ``1 - erf``
    by its Taylor series below 0.5, ``exp(-x^2) erfcx(x)`` by :data:`ERFCX_CHEBYSHEV`
    (Clenshaw's recurrence) above; relative error below 1e-14 (tested against
    scipy)."""
    z = x * x
    e = ERF_TAYLOR[0]
    for j in range(1, len(ERF_TAYLOR)):  # constant tuples: the loops are unrolled
        e = e * z + ERF_TAYLOR[j]
    small = 1.0 - x * e
    xl = max(x, 0.5)
    u = (2.0 * (xl - ERFCX_K) / (xl + ERFCX_K) - (ERFCX_T0 + 1.0)) / (1.0 - ERFCX_T0)
    u2 = 2.0 * u
    b1, b2 = 0.0, 0.0
    # Two loops of 13: LLVM unrolls each (one of 26 it leaves a loop that indexes the
    # tuple at run time, 8x slower and not vectorised).
    for j in range(len(_CLENSHAW_HIGH)):
        b1, b2 = u2 * b1 - b2 + _CLENSHAW_HIGH[j], b1
    for j in range(len(_CLENSHAW_LOW)):
        b1, b2 = u2 * b1 - b2 + _CLENSHAW_LOW[j], b1
    large = (u * b1 - b2 + ERFCX_CHEBYSHEV[0]) * (ERFCX_K / xl) * fast_exp(-xl * xl)
    return small if x < 0.5 else large
