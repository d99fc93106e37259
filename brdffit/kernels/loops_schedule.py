"""The coarse-to-fine schedule's stratified draw, compiled (:mod:`brdffit.fitting.schedule`).

The numpy draw forms each pair's cell of the (theta_h, theta_d) grid in a chain of
array operations, sorts the pairs by cell (a stable argsort of 1.1 million small
integers on a MERL file), gathers each pair's inclusion probability in that order,
sums them (``np.cumsum``) and finds the systematic picks by ``np.searchsorted``:
25-40 ms of a 0.2 s fit of a whole MERL file. The loops here do the same in a
few passes over the data without the sort (Cochran 1977, "Sampling Techniques",
3rd ed., Wiley, sec. 8.6, the systematic draw with unequal probabilities):

- :func:`cells_and_counts`: from numpy's ``arccos`` of ``cos_h`` and ``cos_d`` (the
  same angles as the numpy path, so the same cells), each pair's cell and the cells'
  counts;
- :func:`spread`: the cells' spread of the targets, by the sequential sums that
  ``np.bincount`` forms (the same sums in the same order, so the same values);
- :func:`draw`: the running sum of the inclusion probabilities over the pairs in
  cell order, walked cell by cell (within a cell every pair has the cell's
  probability, so the walk needs only each cell's count, not its pairs), giving
  each pick's cell and rank in its cell; then one pass over the cells in data order
  gives the rank's pair. ``np.cumsum`` adds sequentially, so the walk's sums are
  those of the numpy path bit for bit, and the picks (the first pair whose running
  sum reaches ``start + k``, as ``np.searchsorted``) are the same rows in the same
  order (the tests check the equality on the MERL geometry and random ones).

No ``fastmath``: every operation is the numpy path's, in its order.
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["cells_and_counts", "draw", "spread"]


@numba.njit(cache=True)
def cells_and_counts(theta_h, theta_d, scale, bins, cell, counts):
    """Write each pair's cell ``bins * min(theta_h scale, bins - 1) + min(theta_d
    scale, bins - 1)`` (each term truncated to an integer) in ``cell`` (M,) int16 and
    add the cells' counts to ``counts`` (bins^2,) int64; ``theta_h`` and ``theta_d``
    (M,) the angles in [0, pi/2]. A run of pairs in one cell (a MERL file's 180
    values of ``phi_d`` in a row) is counted in a register, not in memory."""
    last = float(bins - 1)
    current, run = 0, 0
    for i in range(theta_h.shape[0]):
        a = min(theta_h[i] * scale, last)
        b = min(theta_d[i] * scale, last)
        h = int(a) * bins + int(b)
        cell[i] = h
        if h != current:
            counts[current] += run
            current, run = h, 0
        run += 1
    counts[current] += run


@numba.njit(cache=True)
def spread(cell, targets, step, out):
    """Per cell, the standard deviation of the targets (root of the sum over the
    channels of their variances) on the pairs ``0, step, 2 step, ...``, non-finite
    targets taken as 0, in ``out`` (cells,): 0 where fewer than two such pairs; each
    sum formed in data order, as ``np.bincount`` (every channel's in one pass: each
    sum still takes its terms in that order). ``targets`` (M, C). Those pairs are
    copied together in the first pass, which reads the strided rows once (read
    twice, the second pass's rows came from memory again when the rows had left
    the cache: 5.1 against 3.5 ms on a MERL file after a numpy draw)."""
    cells = out.shape[0]
    m, channels = targets.shape
    size = (m + step - 1) // step
    c = np.empty(size, dtype=np.int16)
    t = np.empty((size, channels))
    n = np.zeros(cells)
    total = np.zeros((cells, channels))
    for j in range(size):
        h = cell[j * step]
        c[j] = h
        n[h] += 1.0
        for k in range(channels):
            v = targets[j * step, k]
            t[j, k] = v if np.isfinite(v) else 0.0
            total[h, k] += t[j, k]
    for h in range(cells):
        for k in range(channels):
            total[h, k] = total[h, k] / max(n[h], 1.0)  # the means
    squares = np.zeros((cells, channels))
    for j in range(size):
        h = c[j]
        for k in range(channels):
            d = t[j, k] - total[h, k]
            squares[h, k] += d * d
    for h in range(cells):
        variance = 0.0
        for k in range(channels):
            variance += squares[h, k] / max(n[h] - 1.0, 1.0)
        out[h] = np.sqrt(variance) if n[h] >= 2.0 else 0.0


@numba.njit(cache=True)
def _walk(probability, counts, start, capacity):
    """The running sum of ``probability[h]`` added ``counts[h]`` times, cells in
    order: the cell and the rank in it of the first pair at which it reaches each
    ``start + k`` (k = 0, 1, ...), and the final sum."""
    pick_cell = np.empty(capacity, dtype=np.int64)
    pick_rank = np.empty(capacity, dtype=np.int64)
    running, target, picks = 0.0, start, 0
    for h in range(probability.shape[0]):
        p = probability[h]
        for r in range(counts[h]):
            running += p
            while running >= target and picks < capacity:
                pick_cell[picks] = h
                pick_rank[picks] = r
                picks += 1
                target = start + picks
    return pick_cell[:picks], pick_rank[:picks], running


@numba.njit(cache=True)
def draw(cell, probability, counts, start):
    """The systematic draw of :mod:`brdffit.fitting.schedule` over the pairs ordered
    by cell (stably): the picked rows in that order (as ``order[picks]`` there) and
    the final running sum. ``cell`` (M,) the pairs' cells, ``probability`` and
    ``counts`` (cells,) each cell's inclusion probability (at most 1) and pairs,
    ``start`` in [0, 1). Rows whose running sum reaches ``start + k`` for ``k`` beyond
    ``int(final - start)`` are included (the caller keeps the first ``int(final -
    start) + 1``)."""
    capacity = 2 * cell.shape[0] + 2  # p <= 1: at most two targets a pair
    pick_cell, pick_rank, running = _walk(probability, counts, start, capacity)
    cells = probability.shape[0]
    first = np.zeros(cells + 1, dtype=np.int64)  # each cell's first pick
    for j in range(pick_cell.shape[0]):
        first[pick_cell[j] + 1] += 1
    for h in range(cells):
        first[h + 1] += first[h]
    at = first[:cells].copy()
    seen = np.zeros(cells, dtype=np.int64)
    rows = np.empty(pick_cell.shape[0], dtype=np.int64)
    current, r = 0, -1  # the current run's cell and the rank in it of its last pair
    for i in range(cell.shape[0]):
        h = cell[i]
        if h != current:  # a run of pairs in one cell keeps its rank in a register
            seen[current] = r + 1
            current, r = h, seen[h] - 1
        r += 1
        while at[h] < first[h + 1] and pick_rank[at[h]] == r:
            rows[at[h]] = i
            at[h] += 1
    return rows, running
