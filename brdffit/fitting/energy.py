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
get the incidence azimuths 0, 45 and 90 degrees as well. The fit then checks
its result with the adaptive full-accuracy quadrature (``rtol = 1e-6``) on a
finer grid, and says what it found.
"""

from __future__ import annotations

import numpy as np

from ..data.geometry import Geometry
from ..errors import FitError
from ..models.properties import ANISOTROPIC_PHI_I, albedo, quadrature_nodes

__all__ = ["EnergyRows", "check_energy", "INCIDENCE_GRID", "CHECK_GRID"]

#: Incidence angles (degrees) where the fit enforces albedo <= 1.
INCIDENCE_GRID = np.arange(0.0, 86.0, 5.0)
#: Incidence angles (degrees) where the result is checked.
CHECK_GRID = np.concatenate([np.arange(0.0, 88.0, 2.5), [89.0]])
#: Resolution of the fixed rule used inside the fit (azimuths, radial intervals):
#: 32 azimuths erred by 5 % on ward_anisotropic at 85 degrees, 64 by 3e-4
#: (tests/fitting/test_energy.py checks 1e-3 against the adaptive quadrature).
ROW_AZIMUTHS, ROW_INTERVALS = 64, 8


class EnergyRows:
    """Albedo rows ``A c <= 1 - a_offset`` of a problem's free coefficients."""

    def __init__(self, problem, grid=INCIDENCE_GRID):
        model = problem.model
        if any(p.per_channel for p in model.params):
            raise FitError(
                f"energy_conserving is not supported for {model.name}: its columns differ "
                "per channel (wavelength)",
                "energy_conserving",
            )
        self.problem = problem
        theta = np.asarray(grid, dtype=float)
        phi = np.zeros(1)
        if model.classification.symmetry == "anisotropic":
            phi = np.asarray(ANISOTROPIC_PHI_I, dtype=float)
        theta, phi = (a.ravel() for a in np.meshgrid(theta, phi, indexing="ij"))
        wi, wo, self.weights, _, _ = quadrature_nodes(
            np.radians(theta), np.radians(phi), ROW_AZIMUTHS, ROW_INTERVALS
        )
        self.geometry = Geometry(wi, wo, check=False)

    def rows(self, shape: dict) -> tuple[np.ndarray, np.ndarray]:
        """(A, b): A of shape (T, K_free), b of shape (T,) or (C, T), for ``shape``."""
        p = self.problem
        design = p.model.design(self.geometry, shape)
        n_angles = self.weights.shape[0]

        def integrate(values):
            full = self.geometry.scatter(np.broadcast_to(values, (self.geometry.m,)).copy())
            return (self.weights * full.reshape(n_angles, -1)).sum(axis=1)

        columns = np.stack([integrate(c) for c in design.columns], axis=1)
        bound = np.ones(n_angles)
        if design.offset is not None:
            bound = bound - integrate(design.offset)
        names = list(p.model.coefficients)
        for name in p.fixed_coefs:
            value = np.asarray(p.fixed[name], dtype=float)
            bound = bound - np.multiply.outer(value, columns[:, names.index(name)])
        return columns[:, p.coef_index], bound


def check_energy(model, params, grid=CHECK_GRID) -> tuple[float, float, float]:
    """Max albedo over the grid (and the azimuths of an anisotropic model) and
    channels, its error estimate, and its incidence angle."""
    phi = np.zeros(1)
    if model.classification.symmetry == "anisotropic":
        phi = np.asarray(ANISOTROPIC_PHI_I, dtype=float)
    theta, phi = np.meshgrid(np.asarray(grid, dtype=float), phi, indexing="ij")
    result = albedo(model, params, theta.ravel(), phi.ravel())
    value = np.asarray(result.value).reshape(theta.size, -1)
    error = np.asarray(result.error).reshape(theta.size, -1)
    i, c = np.unravel_index(np.argmax(value), value.shape)
    return float(value[i, c]), float(error[i, c]), float(theta.ravel()[i])
