"""The linear part of the variable-projection objective of a
:class:`~brdffit.fitting.problem.Problem`: at one shape, the coefficients (kd,
ks... per channel) by bounded least squares (:mod:`brdffit.fitting.linear`) and the
exact loss, with Gauss-Newton passes for losses whose transform is not linear.
"""

from __future__ import annotations

import numpy as np

from .linear import normal_equations, solve_bounded, weighted_target

__all__ = [
    "BAD_LOSS",
    "Solution",
    "as_2d",
    "compact_weights",
    "least_squares",
    "solve_linear",
    "solve_normal",
    "stack_columns",
]

#: Gauss-Newton passes for losses whose transform is not linear (log, cbrt).
NONLINEAR_PASSES = 3
#: What the objective returns where the model is not finite: nlopt must never see NaN.
BAD_LOSS = 1e300


class Solution:
    """The result of the objective at one point: shape, coefficients (C, K), loss."""

    __slots__ = ("coefs", "loss", "shape")

    def __init__(self, shape, coefs, loss):
        self.shape, self.coefs, self.loss = shape, coefs, loss


def solve_linear(problem, shape, a, offset, constraints) -> Solution:
    """Coefficients under ``constraints`` (rows of this call) and the loss."""
    if problem.loss.linear:
        # For quadratic losses the weighted residual sum of squares of the
        # linear solve is the loss: no prediction needs to be formed.
        coefs, rss = least_squares(problem, a, offset, problem.w_lin, problem.z_lin, constraints)
        loss = (float(rss.sum()) + problem.invalid_loss) / problem.norm
    else:
        w, z = problem.w_lin, problem.z_lin
        for _ in range(NONLINEAR_PASSES):
            coefs, _ = least_squares(problem, a, offset, w, z, constraints)
            pred = _predict(a, offset, coefs, *problem.y.shape)
            w, z = compact_weights(*problem.loss.linearised(pred, problem.ctx))
        loss = problem.loss.value(pred, problem.ctx) * problem.loss.norm(problem.ctx)
        loss = (loss + problem.invalid_loss) / problem.norm
    if not np.isfinite(loss):
        loss = BAD_LOSS
    return Solution(shape, coefs, loss)


def solve_normal(problem, shape, normal, constraints) -> Solution:
    """Coefficients and loss from ready normal equations (a quadratic loss)."""
    coefs, rss = solve_bounded(normal, problem.coef_lower, problem.coef_upper, constraints)
    loss = (float(rss.sum()) + problem.invalid_loss) / problem.norm
    return Solution(shape, coefs, loss if np.isfinite(loss) else BAD_LOSS)


def least_squares(problem, a, offset, w, z, constraints):
    """Bounded least-squares coefficients (C, K) of ``z - offset`` on the columns ``a``
    with weights ``w``, and their weighted residual sums of squares (C,)."""
    c = z.shape[1]
    target = z if offset is None else z - offset
    reuse = problem._weighted if (offset is None and z is problem.z_lin) else None
    if a is None:
        _, yy = reuse if reuse is not None else weighted_target(target, w)
        return np.zeros((c, 0)), yy
    normal = normal_equations(a, target, w, reuse)
    return solve_bounded(normal, problem.coef_lower, problem.coef_upper, constraints)


def _predict(a, offset, coefs, m, c):
    if a is None:
        return np.broadcast_to(0.0 if offset is None else offset, (m, c)).copy()
    pred = np.einsum("mkc,ck->mc", a, coefs) if a.ndim == 3 else a @ coefs.T
    return pred if offset is None else pred + offset


def compact_weights(w: np.ndarray, z: np.ndarray):
    """Weights that are the same for every channel as (M,), all ones as None: the
    normal equations are then much cheaper to build."""
    if w.ndim == 2 and (w.shape[1] == 1 or _same_in_every_channel(w)):
        w = w[:, 0]
    if w.ndim == 1 and np.all(w == 1.0):
        w = None
    return w, z


def _same_in_every_channel(w: np.ndarray) -> bool:
    """Whether every row of ``w`` (M, C) holds one value; the first rows are compared
    first (weights that differ by channel, as the log loss's, differ there at once)."""
    head = w[:64]
    if not np.array_equal(head, np.broadcast_to(head[:, :1], head.shape)):
        return False
    return np.array_equal(w, np.broadcast_to(w[:, :1], w.shape))


def as_2d(a):
    return a if np.ndim(a) == 2 else np.asarray(a)[:, None]


def stack_columns(cols, m, c):
    if not cols:
        return None
    if any(np.ndim(col) == 2 for col in cols):
        return np.stack([np.broadcast_to(as_2d(col), (m, c)) for col in cols], axis=1)
    return np.stack(cols, axis=1)
