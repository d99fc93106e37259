"""Energy conservation in fits: directional albedo <= 1 at every incidence angle.

The directional albedo ``a(L) = integral f(L, V) cos(theta_o) dw_o`` is linear
in a model's coefficients: with the design ``f = offset + sum_j c_j column_j``,

    a(theta_i) = a_offset(theta_i) + sum_j c_j a_j(theta_i),

where ``a_j`` is the albedo of column j alone. So for each shape the fitting
engine tries, the bound ``a(theta_i) <= 1`` on a grid of incidence angles is a
set of linear inequality rows on the coefficients, and the bounded least-squares
solve of :mod:`brdffit.linear` enforces it exactly, channel by channel. The
optimiser over the shape parameters needs no constraint of its own: every
point it evaluates already carries the best coefficients that conserve energy,
and a shape for which no coefficients can (its offset alone reflects more than
it receives) gets the objective's "infeasible" value, a barrier nlopt stays
away from.

The albedos of the columns come from :func:`brdffit.properties.albedo` (the
graded quadrature about the mirror direction) at a fixed coarse accuracy, for
all columns at once: the coefficients are set to the unit vectors as
pseudo-channels. The fit then checks its result with the full-accuracy
quadrature (``rtol = 1e-6``) on a finer grid, and says what it found.
"""

from __future__ import annotations

import numpy as np

from .errors import FitError
from .properties import albedo

__all__ = ["EnergyRows", "check_energy", "INCIDENCE_GRID", "CHECK_GRID"]

#: Incidence angles (degrees) where the fit enforces albedo <= 1.
INCIDENCE_GRID = np.arange(0.0, 86.0, 5.0)
#: Incidence angles (degrees) where the result is checked.
CHECK_GRID = np.concatenate([np.arange(0.0, 88.0, 2.5), [89.0]])
#: Accuracy of the column albedos inside the fit (relative), and its finest level.
ROW_RTOL = 1e-3
ROW_LEVEL = 1


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
        self.grid = np.asarray(grid, dtype=float)

    def rows(self, shape: dict) -> tuple[np.ndarray, np.ndarray]:
        """(A, b): A of shape (T, K_free), b of shape (C, T) or (T,), for ``shape``."""
        p = self.problem
        names = list(p.model.coefficients)
        k = len(names)
        # Pseudo-channel 0 has every coefficient 0 (the offset alone); channel j + 1
        # has coefficient j at 1.
        coefs = {name: np.eye(k + 1, k, -1)[:, j] for j, name in enumerate(names)}
        linear = p.model.params_from_coefficients(coefs)
        result = albedo(p.model, {**shape, **linear}, self.grid, rtol=ROW_RTOL,
                        max_level=ROW_LEVEL)  # fmt: skip
        a = np.atleast_2d(result.value)  # (T, K + 1)
        if a.shape[1] == 1:
            a = np.repeat(a, k + 1, axis=1)
        offset = a[:, 0]
        columns = a[:, 1:] - offset[:, None]
        bound = 1.0 - offset
        for name in p.fixed_coefs:
            value = np.asarray(p.fixed[name], dtype=float)
            bound = bound - np.multiply.outer(value, columns[:, names.index(name)])
        return columns[:, p.coef_index], bound


def check_energy(model, params, grid=CHECK_GRID) -> tuple[float, float, float]:
    """Max albedo over the grid and channels, its error estimate, and its angle."""
    result = albedo(model, params, grid)
    value = np.asarray(result.value).reshape(grid.size, -1)
    error = np.asarray(result.error).reshape(grid.size, -1)
    i, c = np.unravel_index(np.argmax(value), value.shape)
    return float(value[i, c]), float(error[i, c]), float(grid[i])
