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

The stratified subsample is proportional (each cell of a 32 x 32 grid over
``(theta_h, theta_d)`` in [0, pi/2]^2 keeps its share of the samples): the
subsample's loss estimates the full loss with a smaller variance than a uniform
draw of the same size (Cochran 1977, "Sampling Techniques", 3rd ed., Wiley,
sec. 5.6), so its optimum lies closer to the full one.
"""

from __future__ import annotations

import numpy as np

from .problem import Problem

__all__ = ["BINS", "FINE_FTOL", "FINE_STEP", "note", "stratified_rows", "subproblem"]

#: Cells of the stratification grid along theta_h and along theta_d.
BINS = 32
#: The initial step of the polish on all the data, as a share of each parameter's
#: range in the search space (the subsample's optimum is close: measured on MERL
#: file, steps of 0.0005 to 0.05 took the same evaluations within a few).
FINE_STEP = 0.01
#: The relative tolerance on the loss of the polish on all the data. The loss of a
#: large data set is formed from sums over all its samples (the normal equations),
#: whose round-off leaves it uncertain by about 1e-11 relative on a MERL file
#: (measured: the polish's last 18 of 49 cook_torrance evaluations moved it by 1e-11
#: to 1e-9 up and down); polishing to 1e-12 chased that noise. 1e-10 stops there:
#: blinn 15 -> 9 and cook_torrance 49 -> 31 evaluations, parameters within 2e-6
#: relative of the 1e-12 polish's (ward and ggx unchanged).
FINE_FTOL = 1e-10


def stratified_rows(geometry, size: int, seed: int) -> np.ndarray:
    """Sorted indices of ``size`` of the geometry's valid pairs (0..M-1), spread in
    proportion over the cells of a :data:`BINS` x :data:`BINS` grid over
    ``(theta_h, theta_d)``; kept on the geometry (the reweighting rounds of a fit,
    and further fits of the same data, draw the same subsample)."""
    size = min(int(size), geometry.m)
    return geometry.cached(("stratified_rows", size, seed), lambda: _draw(geometry, size, seed))


def _draw(geometry, size: int, seed: int) -> np.ndarray:
    """Systematic sampling of the pairs ordered by cell: every ``M / size``-th pair
    from a random start (Cochran 1977, sec. 8.6: on a list ordered by strata it is
    proportional stratified sampling, each cell within one sample of its share, and
    within a cell it spreads the picks over the data's own order)."""
    theta_h = np.arccos(geometry.cos_h)  # the geometry's, which the models share
    theta_d = np.arccos(geometry.cos_d)
    scale = BINS / (0.5 * np.pi)
    cell = np.minimum(theta_h * scale, BINS - 1).astype(np.int16) * BINS
    cell += np.minimum(theta_d * scale, BINS - 1).astype(np.int16)
    order = np.argsort(cell, kind="stable")  # a radix sort of small integers
    step = geometry.m / size
    start = np.random.default_rng(seed).random() * step
    picks = np.minimum((start + step * np.arange(size)).astype(np.int64), geometry.m - 1)
    return np.sort(order[picks])


def subproblem(problem: Problem, rows: np.ndarray) -> Problem:
    """The problem on the valid pairs ``rows`` only: same model, loss, fixed
    parameters, energy rows; the user's weights and the noise model's sigma subset."""
    valid = problem.geometry.valid
    index = rows if problem.geometry.all_valid else np.flatnonzero(valid)[rows]
    weights = problem.user_weights
    noise = problem.noise_sigma
    return Problem(
        problem.data.subset(index),
        problem.model,
        loss=problem.loss.name,
        weights=None if weights is None else np.asarray(weights)[index],
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
