"""Energy conservation in fits: directional albedo <= 1 at every incidence angle.

The directional albedo ``a(L) = integral f(L, V) cos(theta_o) dw_o`` is linear
in a model's coefficients: with the design ``f = offset + sum_j c_j column_j``,

    a(theta_i) = a_offset(theta_i) + sum_j c_j a_j(theta_i),

where ``a_j`` is the albedo of column j alone. So for each shape the fitting
engine tries, the bound ``a(theta_i) <= 1`` on a grid of incidence angles is a
set of linear inequality rows on the coefficients, and the bounded least-squares
solve of :mod:`brdffit.fitting.linear` enforces it exactly, channel by channel. The
optimiser over the shape parameters needs no constraint of its own: every
point it evaluates already carries the best coefficients that conserve energy,
and a shape for which no coefficients can (its offset alone reflects more than
it receives) gets the objective's "infeasible" value, a barrier nlopt stays
away from.

The albedos of the columns come from the quadrature of
:mod:`brdffit.models.properties` (graded about the mirror direction) at one fixed,
moderate resolution (``ROW_AZIMUTHS`` x ``ROW_INTERVALS``): its nodes are
prepared once per fit as a :class:`~brdffit.data.geometry.Geometry`, so each step
evaluates the model's design there and takes weighted sums. Anisotropic models
get the incidence azimuths 0, 45 and 90 degrees as well.

The promise is albedo <= 1 at every incidence angle from 0 to 89 degrees. The
rows hold it on :data:`INCIDENCE_GRID` (0 to 85 degrees by 5, 87.5 and 89).
Between those angles, and by the fixed rule's own error (up to 1e-3 at grazing
incidence), the albedo can still pass 1; so the fit checks its result with the
adaptive full-accuracy quadrature (``rtol = 1e-6``) on :data:`CHECK_GRID`
(every 2.5 degrees and 89) and, wherever the check finds albedo above
``1 + ABOVE_TOL``, adds those angles as rows computed with a finer rule
(:data:`FINE_RULE`) and polishes the fit again from its best point, up to
:data:`MAX_ROUNDS` times: the exchange method of semi-infinite programming
(R. Hettich and K. O. Kortanek, Semi-infinite programming: theory, methods and
applications, SIAM Review 35 (1993) 380-429, section 7). The message says
what the last check found, and whether the bound is met.
"""

from __future__ import annotations

import copy
import time
from dataclasses import dataclass, replace

import numpy as np

from ..data.geometry import Geometry
from ..errors import FitError
from ..models.properties import ANISOTROPIC_PHI_I, albedo
from ..models.quadrature import quadrature_nodes

__all__ = [
    "ABOVE_TOL",
    "CHECK_GRID",
    "GRAZING_GRID",
    "INCIDENCE_GRID",
    "EnergyCheck",
    "EnergyRows",
    "enforce_energy",
]

#: Incidence angles (degrees) where the fit enforces albedo <= 1 from the start, by
#: the fixed rule, and (GRAZING_GRID) by the finer rule, which grazing incidence needs.
INCIDENCE_GRID = np.arange(0.0, 86.0, 5.0)
GRAZING_GRID = (87.5, 89.0)
#: Incidence angles (degrees) where the result is checked.
CHECK_GRID = np.concatenate([np.arange(0.0, 88.0, 2.5), [89.0]])
#: Resolution of the fixed rule used inside the fit (azimuths, radial intervals):
#: 32 azimuths erred by 5 % on ward_anisotropic at 85 degrees, 64 by 3e-4, but by
#: 1.3e-3 at 89 degrees, where FINE_RULE is used (tests/fitting/test_energy.py checks
#: 1e-3 against the adaptive quadrature).
ROW_AZIMUTHS, ROW_INTERVALS = 64, 8
#: The rule of the grazing rows and of those added where the check found albedo
#: above 1. Measured at 87.5 and 89 degrees against the adaptive quadrature, largest
#: relative error of a column (64x8 / 128x16 / 256x16): ward_anisotropic (0.05, 0.3)
#: 1.4e-3 / 3e-8 / 2e-8; ggx_anisotropic (0.02, 0.4) 2.5e-2 / 8.8e-4 / 3.8e-4;
#: cook_torrance (m 0.03) 1.1e-4 / 2.3e-5 / 2.3e-5, at 40 % of 256x16's cost.
FINE_RULE = (2 * ROW_AZIMUTHS, 2 * ROW_INTERVALS)
#: Albedo above 1 + ABOVE_TOL (by the full-accuracy check) breaks the bound.
ABOVE_TOL = 1e-5
#: Rounds of adding the angles where the check found albedo above 1.
MAX_ROUNDS = 3
#: Seconds the check may take past the fit's deadline (to report something).
CHECK_GRACE = 0.5


class EnergyRows:
    """Albedo rows ``A c <= 1 - a_offset`` of a problem's free coefficients."""

    def __init__(self, problem, grid=INCIDENCE_GRID, extra=GRAZING_GRID):
        model = problem.model
        if any(p.per_channel for p in model.params):
            raise FitError(
                f"energy_conserving is not supported for {model.name}: its columns differ "
                "per channel (wavelength)",
                "energy_conserving",
            )
        self.problem, self.grid, self.extra = problem, tuple(grid), tuple(sorted(set(extra)))
        self.blocks = [_block(model, self.grid, (ROW_AZIMUTHS, ROW_INTERVALS))]
        if self.extra:
            self.blocks.append(_block(model, self.extra, FINE_RULE))

    def with_angles(self, angles) -> EnergyRows:
        """These rows plus rows at ``angles`` (degrees) by the finer rule."""
        return EnergyRows(self.problem, self.grid, set(self.extra) | set(angles))

    def rows(self, shape: dict) -> tuple[np.ndarray, np.ndarray]:
        """(A, b): A of shape (T, K_free), b of shape (T,) or (C, T), for ``shape``."""
        p = self.problem
        columns, bound = [], []
        for geometry, weights in self.blocks:
            a, b = _integrated_design(p.model, shape, geometry, weights)
            columns.append(a)
            bound.append(b)
        columns, bound = np.concatenate(columns), np.concatenate(bound)
        names = list(p.model.coefficients)
        for name in p.fixed_coefs:
            value = np.asarray(p.fixed[name], dtype=float)
            bound = bound - np.multiply.outer(value, columns[:, names.index(name)])
        return columns[:, p.coef_index], bound


def _incidences(model, grid) -> tuple[np.ndarray, np.ndarray]:
    """Every pair (theta_i, phi_i) in degrees, flat, of the incidence angles ``grid`` and,
    for an anisotropic model, the azimuths :data:`ANISOTROPIC_PHI_I` (else phi_i 0)."""
    phi = np.zeros(1)
    if model.classification.symmetry == "anisotropic":
        phi = np.asarray(ANISOTROPIC_PHI_I, dtype=float)
    theta, phi = np.meshgrid(np.asarray(grid, dtype=float), phi, indexing="ij")
    return theta.ravel(), phi.ravel()


def _block(model, grid, rule) -> tuple:
    """The quadrature nodes of incidence angles ``grid`` (and the anisotropic
    azimuths) as a Geometry, with their weights (T, nodes)."""
    theta, phi = _incidences(model, grid)
    wi, wo, weights, _, _ = quadrature_nodes(np.radians(theta), np.radians(phi), *rule)
    return Geometry(wi, wo, check=False), weights


def _integrated_design(model, shape, geometry, weights) -> tuple:
    """The albedo of every design column (T, K) and ``1 -`` the offset's albedo (T,)."""
    design = model.design(geometry, shape)
    n_angles = weights.shape[0]

    def integrate(values):
        full = geometry.scatter(np.broadcast_to(values, (geometry.m,)).copy())
        return (weights * full.reshape(n_angles, -1)).sum(axis=1)

    columns = np.stack([integrate(c) for c in design.columns], axis=1)
    bound = np.ones(n_angles)
    if design.offset is not None:
        bound = bound - integrate(design.offset)
    return columns, bound


@dataclass(frozen=True)
class EnergyCheck:
    """What the full-accuracy check of an energy-conserving fit found.

    ``top`` (its ``error``) at ``angle`` degrees is the largest albedo; ``above``
    the checked angles where it passed ``1 + ABOVE_TOL``; ``enforced`` every angle
    held by rows in the last search; ``rounds`` the polishes that added angles;
    ``complete`` False when the fit's deadline cut the check short."""

    top: float
    error: float
    angle: float
    above: tuple
    enforced: tuple
    rounds: int = 0
    complete: bool = True

    def note(self) -> str:
        """The check in words, for the fit's message."""
        text = (
            f"; energy: max directional albedo {self.top:.6f} (+-{self.error:.1e}) at "
            f"{self.angle:g} deg (enforced at 0 to 89 deg"
            + (f", {self.rounds} round(s) adding checked angles" if self.rounds else "")
            + ")"
        )
        if not self.complete:
            text += ", check cut short by the timeout"
        if self.above:
            where = "enforced there" if self.angle in self.enforced else "between enforced angles"
            text += f", ABOVE 1 at {self.angle:g} deg ({where}): the bound is NOT met"
        return text


def _check(model, params, grid, deadline, enforced=()) -> EnergyCheck:
    theta, phi = _incidences(model, grid)
    result = albedo(model, params, theta, phi, deadline=deadline)
    value = np.asarray(result.value).reshape(theta.size, -1)
    error = np.asarray(result.error).reshape(theta.size, -1)
    i, c = np.unravel_index(np.argmax(value), value.shape)
    above = np.unique(theta[(value > 1 + ABOVE_TOL).any(axis=1)])
    return EnergyCheck(
        float(value[i, c]),
        float(error[i, c]),
        float(theta[i]),
        tuple(float(a) for a in above),
        tuple(enforced),
        complete=bool(np.isfinite(error).all()) and not result.stopped,
    )


def enforce_energy(problem, found, code, options, t0: float):
    """Check an energy-conserving fit; where its albedo passes 1, hold those angles
    too and polish again (module docstring).

    Returns
    -------
    problem, found, code, EnergyCheck or None
        The problem of the last search (its rows), that search (``n_evals`` counts
        every round), its nlopt code, and the last check (None without energy rows).
    """
    from .engine import search

    if problem.energy is None or found.best is None:
        return problem, found, code, None
    deadline = t0 + options.timeout if options.timeout is not None else None
    local = replace(options, global_algorithm=None, restarts=0)
    rounds = 0
    while True:
        check = _checked(problem, found, deadline, rounds)
        remaining = options.max_evals - found.n_evals
        late = deadline is not None and time.perf_counter() > deadline
        if not check.above or rounds >= MAX_ROUNDS or found.stopped or late or remaining < 1:
            return problem, found, code, check
        problem = copy.copy(problem)
        problem.energy = problem.energy.with_angles(check.above)
        again, code = search(problem, replace(local, max_evals=remaining), found.best_x, True, t0)
        again.n_evals += found.n_evals
        found, rounds = again, rounds + 1


def _checked(problem, found, deadline, rounds) -> EnergyCheck:
    """The full-accuracy check of the search's best point (within the deadline, plus
    CHECK_GRACE seconds to report something)."""
    params = problem.params_of(found.best)
    if deadline is not None:
        deadline = max(deadline, time.perf_counter() + CHECK_GRACE)
    energy = problem.energy
    enforced = tuple(sorted(set(energy.grid) | set(energy.extra)))
    return replace(_check(problem.model, params, CHECK_GRID, deadline, enforced), rounds=rounds)
