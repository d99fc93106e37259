"""The posterior of an energy-conserving fit: draws whose albedo exceeds 1 dropped.

A fit made with ``energy_conserving=True`` bounds the directional albedo of
its model by 1 at the incidence angles of :mod:`brdffit.fitting.energy`; the
posterior of such a fit is the plain posterior restricted to the same set.
The sampler draws from the plain posterior (shape parameters by MCMC,
coefficients from their conditional), and this module keeps the joint draws
that satisfy the fit's albedo rows ``A(shape) c <= b``. Restricting a
distribution to a set and renormalising is what rejection does to draws of
the joint, so the kept draws follow the restricted posterior exactly; the
price is the draws thrown away, which the result reports (and counts out of
its effective sample size). When the data pull the model hard against the
bound, few draws survive and the run says so.
"""

from __future__ import annotations

import math
import time

import numpy as np

from ..errors import FitError
from ..fitting.energy import EnergyRows

__all__ = ["energy_feasible", "restrict_to_energy"]

#: Slack of the albedo rows: the fit's coefficients sit on the bound to rounding.
TOLERANCE = 1e-9


def energy_feasible(
    problem, target, theta: np.ndarray, coefs: np.ndarray, deadline: float = math.inf
) -> tuple[np.ndarray, int]:
    """Which draws (rows of ``theta`` with coefficients ``coefs`` (S, C, K)) keep
    every albedo row of the fit, a boolean (S,), and how many were checked before
    ``deadline`` (``time.perf_counter()``); the unchecked ones are not kept.

    The rows depend on the shape parameters only, so they are made once per distinct
    shape (a walker that stays put repeats its shape), in chain order: a check cut
    by the deadline keeps a prefix of the chain, not a selection by value.
    """
    rows = EnergyRows(problem)
    shapes = theta[:, : target.n_shape]
    if target.n_shape:
        _, first, which = np.unique(shapes, axis=0, return_index=True, return_inverse=True)
        which = which.reshape(-1)
    else:
        first, which = np.zeros(1, dtype=int), np.zeros(len(theta), dtype=int)
    ok = np.zeros(len(theta), dtype=bool)
    checked = len(theta)
    for u in np.argsort(first):
        if time.perf_counter() > deadline:
            checked = int(first[u])
            break
        a, b = rows.rows(problem.shape_from_x(shapes[first[u]]))
        draws = np.flatnonzero(which == u)
        albedo = coefs[draws] @ a.T  # (D, C, T)
        ok[draws] = (albedo <= b + TOLERANCE).all(axis=(1, 2))
    ok[checked:] = False
    return ok, checked


def restrict_to_energy(problem, target, theta, coefs, deadline=math.inf) -> tuple:
    """The mask of kept draws and the sentence the result's message carries."""
    keep, checked = energy_feasible(problem, target, theta, coefs, deadline)
    n, k = len(keep), int(keep.sum())
    if k == 0:
        raise FitError(
            f"energy_conserving: none of the {checked} posterior draws checked (of {n}) "
            "keeps the directional albedo <= 1; the data pull the model past the bound, "
            "so the posterior under it sits on the boundary where rejection cannot sample "
            "it (or max_seconds left too little time to check). Sample the fit without "
            "energy_conserving, or fit a model that can conserve energy here",
            "energy_conserving",
        )
    note = (
        f"energy_conserving: kept {k} of {n} draws ({100.0 * k / n:.0f} %) whose "
        "directional albedo is <= 1"
    )
    if checked < n:
        note += f" (the time limit stopped the check after {checked} draws)"
    return keep, note
