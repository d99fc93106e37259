"""The posterior of an energy-conserving fit: draws whose albedo exceeds 1 dropped.

A fit made with ``energy_conserving=True`` bounds the directional albedo of
its model by 1 at the incidence angles of :mod:`brdffit.energy`; the
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

from .energy import EnergyRows
from .errors import FitError

__all__ = ["energy_feasible", "restrict_to_energy"]

#: Slack of the albedo rows: the fit's coefficients sit on the bound to rounding.
TOLERANCE = 1e-9


def energy_feasible(
    problem, target, theta: np.ndarray, coefs: np.ndarray, deadline: float = math.inf
) -> tuple[np.ndarray, int]:
    """Which draws (rows of ``theta`` with coefficients ``coefs`` (S, C, K)) keep
    every albedo row of the fit, a boolean (S,), and how many were checked before
    ``deadline`` (``time.perf_counter()``); the unchecked ones are not kept."""
    rows = EnergyRows(problem)
    ok = np.zeros(len(theta), dtype=bool)
    for s, x in enumerate(theta[:, : target.d]):
        if time.perf_counter() > deadline:
            return ok, s
        a, b = rows.rows(problem.shape_from_x(x))
        albedo = coefs[s] @ a.T  # (C, T)
        ok[s] = bool((albedo <= b + TOLERANCE).all())
    return ok, len(theta)


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
