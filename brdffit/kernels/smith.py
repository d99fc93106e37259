"""Beckmann's exact Smith masking as a table of polynomials, for vectorised loops.

``G1 = 2 / (1 + erf(a) + exp(-a^2) / (a sqrt(pi)))`` with ``a = 1 / (alpha tan
theta)`` (Walter et al., EGSR 2007; Heitz, JCGT 3(2), 2014, section 5.1) needs
``erf``, which numba evaluates by a library call: in a loop that stops LLVM from
vectorising it (measured: 30 M pairs/s for a Beckmann loop calling ``erf`` against
several hundred without). ``G1 = 1`` to double precision for ``a >= 6``, and on
``0 < a < 6``

    q(a) = G1(a) / a = 2 sqrt(pi) / (2 a sqrt(pi) + exp(-a^2) - a sqrt(pi) erfc(a))

is analytic (no pole at ``a = 0``, where ``G1`` vanishes like ``2 sqrt(pi) a``). It
is interpolated at Chebyshev points on each of :data:`PIECES` intervals of width
:data:`WIDTH` by a polynomial of degree :data:`DEGREE`; the interpolants of an
analytic function converge geometrically (L. N. Trefethen, Approximation Theory and
Approximation Practice, SIAM 2013, ch. 8). The table is built from scipy's ``erfc``
when the loops are first imported; the measured relative error of ``G1`` is below
3e-15 on ``(0, 6)`` (tests/models/test_kernels.py).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.polynomial import chebyshev
from scipy.special import erfc

__all__ = ["DEGREE", "PIECES", "WIDTH", "A_MAX", "g1_over_a", "table"]

A_MAX = 6.0
WIDTH = 0.25
PIECES = 24  # A_MAX / WIDTH
DEGREE = 10  # loops.beckmann_g1 writes its Horner scheme out for this degree
_SQRT_PI = math.sqrt(math.pi)


def g1_over_a(a: np.ndarray) -> np.ndarray:
    """``q(a) = G1(a) / a`` from scipy's ``erfc`` (the function the table holds)."""
    a = np.asarray(a, dtype=float)
    return 2.0 * _SQRT_PI / (2.0 * a * _SQRT_PI + np.exp(-a * a) - a * _SQRT_PI * erfc(a))


def table() -> np.ndarray:
    """Power-basis coefficients, shape (PIECES, DEGREE + 1), lowest power first, of
    ``q`` on interval ``j`` as a polynomial of ``x = (a - j WIDTH) 2/WIDTH - 1``."""
    rows = []
    for j in range(PIECES):
        low = j * WIDTH

        def piece(x, low=low):
            return g1_over_a(low + (x + 1.0) * (0.5 * WIDTH))

        rows.append(chebyshev.cheb2poly(chebyshev.chebinterpolate(piece, DEGREE)))
    return np.ascontiguousarray(rows, dtype=float)
