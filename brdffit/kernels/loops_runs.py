"""The misfit test's two sample orders by counting sorts (:mod:`brdffit.fitting.runs`).

The runs test of :mod:`brdffit.fitting.misfit` orders the samples by the half and
difference angles, ties by the other, with stable sorts: on a MERL file's 274,054
samples of the test two stable sorts of complex keys took 12-15 ms of a 0.17 s fit.
A measured table's angles take few distinct values (a MERL file's cosines of
``theta_h`` 339, of ``theta_d`` 305): each key is then replaced by its rank among
its distinct values (:func:`ranks`), and both orders are counting sorts of the pairs
of ranks (:func:`order_by_ranks`; Knuth, *The Art of Computer Programming*, vol. 3,
2nd ed., sec. 5.2, "distribution counting"), which keep equal pairs in the
samples' order, as a stable sort does. Ranks preserve the keys' order and
equality exactly, so the order is the stable sort's, element for element.

The signs the test orders are those of the residuals ``f - y`` of every ``k``-th
sample: :func:`sign_codes_every` writes their codes in one pass over those rows
(numpy formed the (M / k, C) residuals from rows ``k`` apart, an inner loop of C
values each, and transposed their codes: 7 ms on a MERL file, 4 here).
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["order_by_ranks", "ranks", "sign_codes_every"]


@numba.njit(cache=True)
def ranks(keys, values, out):
    """Write the index in ``values`` (sorted, distinct, holding every key) of each of
    ``keys`` in ``out`` (int32): a binary search, skipped while the keys repeat the
    last one found (a table's samples come in runs of one angle)."""
    last, top = 0, values.shape[0] - 1
    for i in range(keys.shape[0]):
        key = keys[i]
        if values[last] != key:
            low, high = 0, top
            while low < high:
                middle = (low + high) // 2
                if values[middle] < key:
                    low = middle + 1
                else:
                    high = middle
            last = low
        out[i] = last


@numba.njit(cache=True)
def order_by_ranks(primary, secondary, n_secondary, out):
    """Write in ``out`` the indices of the samples sorted by ``(primary, secondary)``
    (ranks, ``secondary`` below ``n_secondary``), equal pairs in the samples' order: a
    counting sort over the buckets ``primary * n_secondary + secondary``."""
    top = -1  # the largest rank, by a loop: numba's np.max would make every process
    for i in range(primary.shape[0]):  # that loads this loop import numba.np.arraymath
        top = max(top, primary[i])  # and with it scipy.linalg (0.11 s of CPU)
    buckets = (top + 1) * n_secondary
    start = np.zeros(buckets + 1, dtype=np.int64)
    for i in range(primary.shape[0]):
        start[primary[i] * n_secondary + secondary[i] + 1] += 1
    for b in range(buckets):
        start[b + 1] += start[b]
    for i in range(primary.shape[0]):
        b = primary[i] * n_secondary + secondary[i]
        out[start[b]] = i
        start[b] += 1


@numba.njit(cache=True)
def sign_codes_every(f, y, step, out):
    """The codes of :func:`brdffit.fitting.runs.sign_codes` of ``f - y`` on the rows
    ``0, step, 2 step, ...`` of ``f`` and ``y`` (M, C), written in ``out`` (C, M / step)
    int8: 2 above 0, 1 below (and NaN, which ``> 0`` calls negative), 0 for an exact
    0; the same subtraction, so the same signs (no ``fastmath``: NaN compares as
    numpy's)."""
    for j in range(out.shape[1]):
        i = j * step
        for k in range(out.shape[0]):
            d = f[i, k] - y[i, k]
            out[k, j] = (1 if d > 0.0 else 0) + (1 if d != 0.0 else 0)
