"""The sums of squares behind a fit's metrics, compiled (:mod:`brdffit.fitting.sums`).

The losses linear in the prediction ``f`` (l2, cosine, relative, chi2, mixed) and
the residual sum of squares are summed in one compiled pass over the residual
``d = f - y`` (:func:`sums_and_project`); numpy forms the same from (M, 3) arrays with
broadcasts over three channels, whose inner loops of three elements run at a
fraction of the speed (a dozen such passes took 65 ms on a whole MERL file's 3.3 M
values). The two others (log and cbrt) need ``ln`` and ``cbrt``, which numpy's
SIMD functions take at about 1 ns a value on the machine measured, against 4 ns for
the vectorised :func:`~brdffit.kernels.elementary.fast_log` in a loop here (and 20
ns for a cube root from it): the same pass writes, block by block, ``f cos(theta_i)``
and ``y cos(theta_i)`` and the ratio whose logarithm is the log loss's difference,
which numpy then takes while they are in the cache. The pass reads the samples' rows
in memory order, RGB's three channels unrolled (a pass per channel over rows of
three, and a second to lay the values out channel by channel, took 16.5 ms on a
MERL file's values; this one 10), and the ratio needs one ``ln`` a value, not two
(a blinn fit's metrics 41 -> 30 ms).
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
def sums_and_project(f, y, cos, w, scale, sigma, noise, start, fc, yc, ratio, out):
    """Add the sums of :data:`NAMES` (rss and the losses linear in ``f``) of the samples
    ``start`` to ``start + B`` to ``out``, and write those samples' ``f cos`` and ``y
    cos`` in ``fc`` and ``yc`` (B, C) for numpy's vectorised ``cbrt``, and the log
    loss's ratio ``max(1 + f cos, 1e-12) / max(1 + y cos, 1e-12)`` in ``ratio`` (B, C),
    whose logarithm is the difference of the two logarithms (one ``ln`` a value, not
    two). ``f`` and ``y`` (M, C) predictions and targets, ``cos`` (M,) the cosine of
    ``theta_i`` (at least 0), ``w`` (M,) the weights, ``scale`` (C,) the relative
    loss's floor (``1e-3 max|y|``), ``sigma`` and ``noise`` (M, C) the data's and the
    noise model's standard deviations; ``w``, ``sigma`` and ``noise`` empty when
    absent. One pass over the samples' rows (each read once, in memory order), summed
    by blocks of :data:`BLOCK` samples whose sums are then added (the rounding of a
    sum of a million terms in one accumulator reached 2e-12); ``start`` a multiple of
    :data:`BLOCK`, so that the blocks are the same whatever ``B``. Reassociation is
    allowed (``fastmath=True``): it changes the sums' rounding only."""
    size, c = fc.shape
    weighted, chi2, mixed = w.shape[0] > 0, sigma.shape[0] > 0, noise.shape[0] > 0
    for first in range(0, size, BLOCK):
        rss = l2 = cosine = relative = chi = mix = 0.0
        for j in range(first, min(first + BLOCK, size)):
            i = start + j
            ci = cos[i]
            wi = w[i] if weighted else 1.0
            if c == 3:  # RGB: the channels unrolled (a MERL file's values 12 -> 9.5 ms)
                t0 = _value(f, y, ci, wi, scale, i, j, 0, fc, yc, ratio)
                t1 = _value(f, y, ci, wi, scale, i, j, 1, fc, yc, ratio)
                t2 = _value(f, y, ci, wi, scale, i, j, 2, fc, yc, ratio)
                rss += t0[0] + t1[0] + t2[0]
                l2 += t0[1] + t1[1] + t2[1]
                cosine += t0[2] + t1[2] + t2[2]
                relative += t0[3] + t1[3] + t2[3]
            else:
                for k in range(c):
                    t = _value(f, y, ci, wi, scale, i, j, k, fc, yc, ratio)
                    rss += t[0]
                    l2 += t[1]
                    cosine += t[2]
                    relative += t[3]
            for k in range(c if chi2 or mixed else 0):
                d = f[i, k] - y[i, k]
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


@numba.njit(cache=True, fastmath=True, error_model="numpy", inline="always")
def _value(f, y, ci, wi, scale, i, j, k, fc, yc, ratio):
    """The terms of value ``(i, k)`` of :func:`sums_and_project`'s rss, l2, cosine and
    relative sums, with its ``f cos``, ``y cos`` and ratio written at ``(j, k)``."""
    fv, yv = f[i, k], y[i, k]
    d = fv - yv
    d2 = d * d
    dc = d * ci
    dr = d / max(abs(yv), scale[k])
    a, b = fv * ci, yv * ci
    fc[j, k], yc[j, k] = a, b
    ratio[j, k] = max(1.0 + a, 1e-12) / max(1.0 + b, 1e-12)
    return d2, wi * d2, wi * dc * dc, wi * dr * dr
