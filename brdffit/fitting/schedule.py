"""The coarse-to-fine schedule of a fit on large data.

Above :attr:`~brdffit.fitting.options.FitOptions.coarse_above` samples (a full
MERL file has 1.1 million above the horizon) every evaluation of the objective
on all the data costs milliseconds, and a fit makes hundreds. The schedule
therefore runs the global stage and the local polishes on a seeded subsample of
:attr:`~brdffit.fitting.options.FitOptions.coarse_samples` samples, stratified over
the half and difference angles ``theta_h`` and ``theta_d`` (Rusinkiewicz 1998,
"A new change of variables for efficient BRDF representation", Eurographics
Workshop on Rendering: the coordinates in which a BRDF's features, the specular
peak about ``theta_h = 0`` and the Fresnel and masking rise at grazing
``theta_d``, are aligned), then one local polish on all the samples from the
subsample's best point. The answer is the minimum of the loss on all the data,
as without the schedule: the subsample only decides where the last polish starts.

The subsample is stratified over the cells of a 32 x 32 grid over
``(theta_h, theta_d)`` in [0, pi/2]^2, and allocated half in proportion to each
cell's samples and half by Neyman's allocation (in proportion to its samples times
the spread of its targets as the loss sees them, ``t(y)``: Cochran 1977, "Sampling
Techniques", 3rd ed., Wiley, sec. 5.5), each sample weighted by the inverse of
its probability of being drawn. The subsample's (weighted) loss is an unbiased
estimate of the full loss. Neyman's allocation minimises the variance of such an
estimate of a total of ``t(y)`` for a given size; the residuals of a fit are largest
where the targets vary most (the specular peak of a MERL file under the l2 loss,
whose cells have a hundred-fold spread), so the estimate of the loss improves there
too, the subsample's optimum lies closer to the full one, and the polish on
all the data needs fewer evaluations (measured on a MERL file, seeds 0-2, against a
proportional draw: blinn 7-9 -> 4-6, ward 17-21 -> 7-11, ggx 16-20 -> 12-25,
cook_torrance 29-42 -> 12-26; 242 -> 161 in all, with the polish's first steps of
0.01 of each range; see :data:`FINE_STEP` and benchmarks/README.md).
The half in proportion keeps every cell in the subsample
(a spread estimated as 0 does not empty a cell).
"""

from __future__ import annotations

import functools

import numpy as np

from .. import kernels
from .problem import Problem

__all__ = [
    "BINS",
    "FINE_FTOL",
    "FINE_STEP",
    "SPREAD_SAMPLES",
    "note",
    "seeded_rows",
    "stratified_rows",
    "subproblem",
]

#: Cells of the stratification grid along theta_h and along theta_d.
BINS = 32
#: The initial step of the polish on all the data, as a share of each parameter's
#: range in the search space: the subsample's optimum is close. Measured, evaluations
#: on all samples over blinn, ward, ggx and cook_torrance and seeds 0-2: on the
#: benchmark's MERL file 159 with 0.01, 168 with 0.002, 112 with 0.001, 118 with
#: 0.0005, 140 with 0.0002; on the NVIDIA car paint 183 with 0.01, 179 with 0.001;
#: the losses the same to 7e-11.
FINE_STEP = 0.001
#: The relative tolerance on the loss of the polish on all the data. The loss of a
#: large data set is formed from sums over all its samples (the normal equations),
#: whose round-off leaves it uncertain by about 1e-11 relative on a MERL file
#: (measured: the polish's last 18 of 49 cook_torrance evaluations moved it by 1e-11
#: to 1e-9 up and down); polishing to 1e-12 chased that noise. 1e-10 stops there:
#: blinn 15 -> 9 and cook_torrance 49 -> 31 evaluations, parameters within 2e-6
#: relative of the 1e-12 polish's (ward and ggx unchanged).
FINE_FTOL = 1e-10
#: The share of the subsample allocated by Neyman's rule (the rest in proportion;
#: all of it by Neyman took 171 full-data evaluations in the module's measurement).
NEYMAN = 0.5
#: The spread of the targets in each cell is estimated on every k-th pair, k the
#: valid pairs // this (at least 1): on fewer than twice this many pairs.
SPREAD_SAMPLES = 100_000
#: Pairs whose angles the compiled draw forms at a time.
ANGLE_BLOCK = 16_384


def stratified_rows(problem: Problem, size: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Sorted indices of ``size`` of the problem's valid pairs (0..M-1, about ``size``:
    the draw is systematic) and their weights (mean 1), drawn as the module says; kept
    on the geometry (the reweighting rounds of a fit, and further fits of the same
    data with the same loss, draw the same subsample)."""
    geometry = problem.geometry
    size = min(int(size), geometry.m)
    key = ("stratified_rows", size, seed, problem.loss.name)
    return geometry.cached(key, lambda: _draw(geometry, _targets(problem), size, seed))


def _targets(problem: Problem) -> np.ndarray:
    """``t(y)`` (M, C) of the valid pairs, whose spread per cell the allocation uses
    (the ``mixed`` loss's first round has unit sigma: its l2 targets)."""
    return np.asarray(problem.loss.target(problem.ctx), dtype=float)


def _cells(geometry) -> np.ndarray:
    """Each valid pair's cell of the :data:`BINS` x :data:`BINS` grid."""
    scale = BINS / (0.5 * np.pi)
    cell = np.minimum(np.arccos(geometry.cos_h) * scale, BINS - 1).astype(np.int16) * BINS
    cell += np.minimum(np.arccos(geometry.cos_d) * scale, BINS - 1).astype(np.int16)
    return cell


def _spread(cell: np.ndarray, targets) -> np.ndarray:
    """Per cell, the standard deviation of the targets (root of the sum over channels
    of their variances), estimated on a systematic sample of fewer than twice
    :data:`SPREAD_SAMPLES` pairs; 0 where fewer than two pairs of a cell are in it."""
    cells = BINS * BINS
    step = max(1, len(cell) // SPREAD_SAMPLES)
    c, t = cell[::step].astype(np.intp), targets[::step].reshape(len(cell[::step]), -1)
    t = np.where(np.isfinite(t), t, 0.0)
    n = np.bincount(c, minlength=cells).astype(float)
    variance = np.zeros(cells)
    for column in t.T:
        total = np.bincount(c, column, cells)
        mean = total / np.maximum(n, 1.0)
        squares = np.bincount(c, (column - mean[c]) ** 2, cells)
        variance += squares / np.maximum(n - 1.0, 1.0)
    return np.where(n >= 2, np.sqrt(variance), 0.0)


def _allocate(size: int, share: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """``size`` pairs shared among the cells in proportion to ``share``, none more than
    its ``counts``: a cell that would get more gets all its pairs, and what it leaves
    goes to the others in proportion (each round caps at least one more cell)."""
    allocation = size * share
    full = np.zeros(len(counts), dtype=bool)
    while np.any(allocation > counts):
        full |= allocation >= counts
        left = share[~full].sum()
        if left <= 0:
            break
        allocation = np.where(full, counts, (size - counts[full].sum()) * share / left)
    return np.minimum(allocation, counts)


def _draw(geometry, targets, size: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Systematic sampling with unequal probabilities of the pairs ordered by cell
    (Cochran 1977, sec. 8.6 and ch. 9A: every pair gets its cell's inclusion
    probability ``p_h = a_h / N_h``, at most 1; the picks are where the running sum of
    the probabilities passes a random start plus 0, 1, 2, ...): each cell gets its
    allocation ``a_h`` within one pair, spread over the data's own order within it.
    From :data:`~brdffit.kernels.MIN_PAIRS` pairs on, by the compiled loops of
    :mod:`brdffit.kernels.loops_schedule` (the same rows and weights)."""
    start = np.random.default_rng(seed).random()
    # The kernels' loops loaded now (the fit's evaluations load them next): the cells'
    # cos_h and cos_d then come from the geometry's compiled half terms (the same
    # values; numpy's took 25 ms, 19 more, of a process's first MERL fit).
    if kernels.wanted(geometry.m, modules=("loops", "loops_schedule")):
        return _draw_compiled(geometry, targets, size, start)
    cell = _cells(geometry)
    counts = np.bincount(cell, minlength=BINS * BINS).astype(float)
    probability = _probability(size, counts, _spread(cell, targets))
    order = np.argsort(cell, kind="stable")  # a radix sort of small integers
    running = np.cumsum(probability[cell[order]])
    picks = np.searchsorted(running, start + np.arange(int(running[-1] - start) + 1))
    picks = picks[picks < len(order)]
    return _weighted(order[picks], probability, cell)


def _probability(size: int, counts: np.ndarray, spread: np.ndarray) -> np.ndarray:
    """Each cell's inclusion probability (at most 1): its allocation, half in
    proportion to ``counts`` and half by Neyman's rule, over its pairs."""
    share = counts / counts.sum()
    neyman = counts * spread
    if neyman.sum() > 0:
        share = (1.0 - NEYMAN) * share + NEYMAN * neyman / neyman.sum()
    allocation = _allocate(size, share, counts)
    return np.minimum(allocation / np.maximum(counts, 1.0), 1.0)


def _weighted(rows: np.ndarray, probability: np.ndarray, cell: np.ndarray) -> tuple:
    """The picked ``rows`` (in cell order) sorted, and their weights: the inverse of
    their probabilities, over the mean."""
    weights = 1.0 / probability[cell[rows]]
    keep = np.argsort(rows)
    return rows[keep], weights[keep] / weights.mean()


def _draw_compiled(geometry, targets, size: int, start: float) -> tuple:
    """:func:`_draw` by the loops of :mod:`brdffit.kernels.loops_schedule`: the cells
    from numpy's ``arccos`` (the angles of :func:`_cells`), the spread and the walk
    of the running sum compiled."""
    from ..kernels import loops_schedule

    scale = BINS / (0.5 * np.pi)
    cell = np.empty(geometry.m, dtype=np.int16)
    counts = np.zeros(BINS * BINS, dtype=np.int64)
    theta = np.empty((2, min(ANGLE_BLOCK, geometry.m)))
    for first in range(0, geometry.m, ANGLE_BLOCK):  # the angles in the cache
        block = slice(first, first + ANGLE_BLOCK)
        theta_h, theta_d = theta[:, : len(cell[block])]
        np.arccos(geometry.cos_h[block], out=theta_h)
        np.arccos(geometry.cos_d[block], out=theta_d)
        loops_schedule.cells_and_counts(theta_h, theta_d, scale, BINS, cell[block], counts)
    t = np.ascontiguousarray(targets, dtype=float).reshape(len(cell), -1)
    spread = np.empty(BINS * BINS)
    loops_schedule.spread(cell, t, max(1, len(cell) // SPREAD_SAMPLES), spread)
    probability = _probability(size, counts.astype(float), spread)
    rows, running = loops_schedule.draw(cell, probability, counts, start)
    return _weighted(rows[: int(running - start) + 1], probability, cell)


@functools.lru_cache(maxsize=4)
def seeded_rows(m: int, keep: int, seed: int) -> np.ndarray:
    """``keep`` of the rows ``0..m-1`` drawn without replacement with ``seed``, sorted,
    read-only: they depend on the sizes and the seed alone, so further fits of data of
    the same size (every MERL file has 1,096,216 valid pairs) take them without a new
    draw (numpy's draw permutes all ``m``: 3 ms of a MERL fit's identifiability check)."""
    rows = np.sort(np.random.default_rng(seed).choice(m, keep, replace=False))
    rows.flags.writeable = False
    return rows


def subproblem(problem: Problem, rows: np.ndarray, weights=None) -> Problem:
    """The problem on the valid pairs ``rows`` only, each weighted by ``weights`` (the
    draw's, or None): same model, loss, fixed parameters, energy rows; the user's
    weights (times the draw's) and the noise model's sigma subset."""
    valid = problem.geometry.valid
    index = rows if problem.geometry.all_valid else np.flatnonzero(valid)[rows]
    if problem.user_weights is not None:
        user = np.asarray(problem.user_weights, dtype=float)[index]
        weights = user if weights is None else user * weights
    noise = problem.noise_sigma
    return Problem(
        problem.data.subset(index),
        problem.model,
        loss=problem.loss.name,
        weights=weights,
        fixed=problem.fixed,
        energy_conserving=problem.energy is not None,
        noise_sigma=None if noise is None else noise[index],
    )


def note(sub: Problem, problem: Problem, evals_sub: int, evals_all: int) -> str:
    """What a result's message says of the schedule."""
    return (
        f"coarse to fine: {evals_sub} evaluations on a stratified subsample of "
        f"{sub.geometry.m:,} of the {problem.geometry.m:,} samples, then {evals_all} on all"
    )
