"""The sums of squares behind a fit's metrics, compiled (:mod:`brdffit.fitting.sums`).

The losses linear in the prediction ``f`` (l2, cosine, relative, chi2, mixed) and
the residual sum of squares are summed in one compiled pass over the residual
``d = f - y`` (:func:`sums_and_project`); numpy forms the same from (M, 3) arrays with
broadcasts over three channels, whose inner loops of three elements run at a
fraction of the speed (a dozen such passes took 65 ms on a whole MERL file's 3.3 M
values). The two others (log and cbrt) need ``ln`` and ``cbrt``, which numpy's
SIMD functions take at about 1 ns a value on the machine measured, against 4 ns for
the vectorised :func:`~brdffit.kernels.elementary.fast_log` in a loop here (and 20
ns for a cube root from it): the same pass lays ``f cos(theta_i)`` and ``y
cos(theta_i)`` out channel by channel for numpy, block by block, each block of a
channel right after it is summed, while it is in the cache (one pass over a MERL
file's values, not one to sum and one to lay out: 43 -> 39 ms of metrics).
Sums in another order than numpy's: they differ by rounding (the tests hold every
sum to the numpy formula's to 1e-12 relative).
"""

from __future__ import annotations

import numba

__all__ = ["BLOCK", "NAMES", "sums_and_project"]

#: The sums :func:`sums_and_project` adds to, in this order.
NAMES = ("rss", "l2", "cosine", "relative", "chi2", "mixed")
#: Samples per partial sum.
BLOCK = 4096


@numba.njit(cache=True, fastmath=True, error_model="numpy")
def _linear_block(f, y, cos, w, scale, sigma, noise, k, start, stop, out):
    """Add channel ``k``'s sums over samples ``start:stop`` of the losses linear in
    ``f`` to ``out``; ``w``, ``sigma`` and ``noise`` empty when absent (unit weights,
    no chi2, no mixed)."""
    weighted, chi2, mixed = w.shape[0] > 0, sigma.shape[0] > 0, noise.shape[0] > 0
    s = scale[k]
    rss = l2 = cosine = relative = chi = mix = 0.0
    for i in range(start, stop):
        d = f[i, k] - y[i, k]
        wi = w[i] if weighted else 1.0
        d2 = d * d
        rss += d2
        l2 += wi * d2
        dc = d * cos[i]
        cosine += wi * dc * dc
        dr = d / max(abs(y[i, k]), s)
        relative += wi * dr * dr
        if chi2:
            ds = d / sigma[i, k]
            chi += wi * ds * ds
        if mixed:
            dn = d / noise[i, k]
            mix += wi * dn * dn
    out[0] += rss
    out[1] += l2
    out[2] += cosine
    out[3] += relative
    out[4] += chi
    out[5] += mix


@numba.njit(cache=True, error_model="numpy")
def sums_and_project(f, y, cos, w, scale, sigma, noise, start, fc, yc, f_log, y_log, out):
    """Add the sums of the first six :data:`NAMES` (rss and the losses linear in ``f``)
    of the samples ``start`` to ``start + B`` to ``out``, and lay out those samples'
    ``f cos`` and ``y cos`` channel by channel: rows of ``fc`` and ``yc`` (C, B),
    contiguous for numpy's vectorised ``cbrt``, and the arguments of the log loss's
    logarithms, ``max(1 + f cos, 1e-12)`` and likewise for ``y``, in ``f_log`` and
    ``y_log``. ``f`` and ``y`` (M, C) predictions and targets, ``cos`` (M,) the cosine
    of ``theta_i`` (at least 0), ``w`` (M,) the weights, ``scale`` (C,) the relative
    loss's floor (``1e-3 max|y|``), ``sigma`` and ``noise`` (M, C) the data's and the
    noise model's standard deviations; ``w``, ``sigma`` and ``noise`` empty when
    absent. Summed by blocks of :data:`BLOCK` samples, whose sums are then added (the
    rounding of a sum of a million terms in one accumulator reached 2e-12); ``start``
    a multiple of :data:`BLOCK`, so that the blocks are the same whatever ``B``."""
    c, size = fc.shape
    for k in range(c):
        for first in range(0, size, BLOCK):
            stop = min(first + BLOCK, size)
            _linear_block(f, y, cos, w, scale, sigma, noise, k, start + first, start + stop, out)
            for j in range(first, stop):
                a = f[start + j, k] * cos[start + j]
                b = y[start + j, k] * cos[start + j]
                fc[k, j], yc[k, j] = a, b
                f_log[k, j] = max(1.0 + a, 1e-12)
                y_log[k, j] = max(1.0 + b, 1e-12)
