"""One compiled pass of the ``log`` loss's Gauss-Newton step over all samples.

The ``log`` loss (Löw, Kronander, Ynnerman and Unger 2012, "BRDF models for accurate
and efficient rendering of glossy surfaces", ACM TOG 31(1), error E2) compares
``t(f) = ln(1 + f cos(theta_i))`` of model and data. Its transform is not linear in
``f``, so :func:`brdffit.fitting.solve.solve_linear` solves the coefficients by
Gauss-Newton passes: at the prediction ``f`` of the last coefficients it linearises
``t`` (weights ``w = u t'(f)^2``, ``u`` the user's sample weight, targets
``z = f - (t(f) - t(y)) / t'(f)``) and solves the weighted least squares again (the
Gauss-Newton method: Nocedal and Wright, Numerical Optimization, 2nd ed., 2006,
section 10.3). In numpy each pass forms the prediction, ``t``, ``t'``, ``w`` and
``z`` as arrays over all values and then the normal equations from them (measured on
a whole MERL file: about 0.2 s a pass, 0.7 s an evaluation of the objective).

For the designs of :mod:`brdffit.kernels.normal` (one array column ``l``, the other
columns constants) the prediction of channel ``c`` is ``f = b_c + a_c l`` and the
normal equations need seven sums, taken here in one pass over the samples without
any array of their size::

    S0 = sum w,  S1 = sum w l,  S2 = sum w l^2,  T0 = sum w z,  T1 = sum w z l,
    YY = sum w z^2,  LOSS = sum u (t(f) - t(y))^2

(the last is the loss at ``f``: the pass that solves no more gives the loss).
``w z = u t' (t' f - r)`` and ``w z^2 = u (t' f - r)^2`` with ``r = t(f) - t(y)``:
equal to the numpy forms, without the division by ``t'``. The logarithm is
:func:`~brdffit.kernels.elementary.fast_log` (within 2.5e-16 of libm's), so the
loop over a block of samples vectorises; the sums are then taken over the block in
a second loop with reassociation allowed (a vectorised reduction), both with eight
lanes on AVX-512 (:mod:`brdffit.kernels.wide`; measured beside the four-lane loops
in one run: 13.5 -> 10.1 ms a pass over a MERL file's 3.3 M values). The sums differ
from numpy's pairwise sums by rounding (relative 1e-16 times the square root of
the number of samples at worst).
"""

from __future__ import annotations

import numba
import numpy as np

from ._compile import jit
from .elementary import fast_log
from .wide import prefer_wide_vectors

__all__ = ["BLOCK", "SUMS", "log_sums"]

#: Samples per block: the block's four terms (32 kB) stay in the first-level cache.
BLOCK = 1024
#: The sums of a pass, in the order of :func:`log_sums`'s rows.
SUMS = ("S0", "S1", "S2", "T0", "T1", "YY", "LOSS")


@jit
def _terms(lobe, cos_i, ty, u, start, stop, b, a, buf):
    """The four per-sample terms ``w``, ``w z``, ``w z^2`` and ``u r^2`` of samples
    ``start`` to ``stop`` into ``buf`` (4, BLOCK)."""
    prefer_wide_vectors()
    for j in range(stop - start):
        i = start + j
        f = b + a * lobe[i]
        c = cos_i[i]
        arg = max(1.0 + f * c, 1e-12)
        r = fast_log(arg) - ty[i]
        dt = c / arg
        g = dt * f - r
        ui = u[i]
        buf[0, j] = ui * dt * dt
        buf[1, j] = ui * dt * g
        buf[2, j] = ui * g * g
        buf[3, j] = ui * r * r


@numba.njit(cache=True, fastmath=True, error_model="numpy")
def _reduce(lobe, start, stop, buf, acc):
    """Add the block's terms and their products with the lobe to the seven sums."""
    prefer_wide_vectors()
    s0 = s1 = s2 = t0 = t1 = yy = loss = 0.0
    for j in range(stop - start):
        li = lobe[start + j]
        w, wz = buf[0, j], buf[1, j]
        s0 += w
        s1 += w * li
        s2 += w * li * li
        t0 += wz
        t1 += wz * li
        yy += buf[2, j]
        loss += buf[3, j]
    acc[0] += s0
    acc[1] += s1
    acc[2] += s2
    acc[3] += t0
    acc[4] += t1
    acc[5] += yy
    acc[6] += loss


@jit
def log_sums(lobe, cos_i, ty_t, u, b, a):
    """The seven sums of the module (rows, :data:`SUMS`) per channel (columns), for
    the prediction ``b_c + a_c lobe``: ``lobe``, ``cos_i`` and ``u`` (M,), ``ty_t``
    the transformed data (C, M), ``b`` and ``a`` (C,). Returns (7, C)."""
    c, m = ty_t.shape
    out = np.zeros((7, c))
    buf = np.empty((4, BLOCK))
    acc = np.empty(7)
    for k in range(c):
        acc[:] = 0.0
        for start in range(0, m, BLOCK):
            stop = min(start + BLOCK, m)
            _terms(lobe, cos_i, ty_t[k], u, start, stop, b[k], a[k], buf)
            _reduce(lobe, start, stop, buf, acc)
        out[:, k] = acc
    return out
