"""The linear part of the variable-projection objective of a
:class:`~brdffit.fitting.problem.Problem`: at one shape, the coefficients (kd,
ks... per channel) by bounded least squares (:mod:`brdffit.fitting.linear`) and the
exact loss, with Gauss-Newton passes for losses whose transform is not linear.
"""

from __future__ import annotations

import numpy as np

from .. import kernels
from ..kernels import normal as kernels_normal
from .linear import Normal, normal_equations, offset_normal, solve_bounded, weighted_target

__all__ = [
    "BAD_LOSS",
    "Solution",
    "as_2d",
    "compact_weights",
    "least_squares",
    "solve_linear",
    "solve_log",
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
    w, z, _ = problem.linearisation()
    if problem.loss.linear:
        # For quadratic losses the weighted residual sum of squares of the
        # linear solve is the loss: no prediction needs to be formed.
        coefs, rss = least_squares(problem, a, offset, w, z, constraints)
        loss = (float(rss.sum()) + problem.invalid_loss) / problem.norm
    else:
        for _ in range(NONLINEAR_PASSES):
            coefs, _ = least_squares(problem, a, offset, w, z, constraints)
            pred = _predict(a, offset, coefs, *problem.y.shape)
            w, z = compact_weights(*problem.loss.linearised(pred, problem.ctx))
        loss = problem.loss.value(pred, problem.ctx) * problem.loss.norm(problem.ctx)
        loss = (loss + problem.invalid_loss) / problem.norm
    if not np.isfinite(loss):
        loss = BAD_LOSS
    return Solution(shape, coefs, loss)


def solve_log(problem, shape, columns, offset, constraints) -> Solution | None:
    """:func:`solve_linear` for the ``log`` loss with compiled passes
    (:mod:`brdffit.kernels.loss_log`), for designs of one array column and constants
    without an offset: the same :data:`NONLINEAR_PASSES` Gauss-Newton passes, the
    first from the linearisation at the data, each later one and the loss in one
    pass over the samples. None where that does not apply (then solve_linear)."""
    if (
        problem.loss.name != "log"
        or offset is not None
        or not kernels.wanted(len(problem.y), modules=("loss_log", "loops"))  # + moments
    ):
        return None
    arrays = [k for k, col in enumerate(columns) if np.ndim(col)]
    if len(arrays) != 1 or np.ndim(columns[arrays[0]]) != 1:
        return None
    from ..kernels import loss_log

    lobe = np.ascontiguousarray(columns[arrays[0]], dtype=float)
    cos_i, ty_t, u, first, yy = _log_inputs(problem)
    normal = kernels_normal.from_prepared(columns, lobe, first, yy, Normal)
    constant = np.array([0.0 if np.ndim(col) else float(col) for col in columns])
    for i in range(NONLINEAR_PASSES):
        coefs, _ = solve_bounded(normal, problem.coef_lower, problem.coef_upper, constraints)
        sums = loss_log.log_sums(lobe, cos_i, ty_t, u, coefs @ constant, coefs[:, arrays[0]])
        if i < NONLINEAR_PASSES - 1:
            s, t0, t1, yy = sums[:3], sums[3], sums[4], sums[5]
            normal = kernels_normal.assemble(columns, s, t0, t1, yy, Normal)
    loss = (float(sums[6].sum()) + problem.invalid_loss) / problem.norm
    return Solution(shape, coefs, loss if np.isfinite(loss) else BAD_LOSS)


def _log_inputs(problem) -> tuple:
    """What every compiled log pass of ``problem`` reads, made once per problem:
    cos(theta_i) (M,), the transformed data (C, M), the sample weights (M,) (ones
    without), and the first pass's inputs and ``y'Wy`` (:func:`first_pass`: the
    linearisation at the data)."""
    if problem.log_inputs is None:
        ctx = problem.ctx
        m = len(ctx.cos_i)
        problem.log_inputs = (
            np.ascontiguousarray(ctx.cos_i, dtype=float),
            np.ascontiguousarray(problem.loss.target(ctx).T, dtype=float),
            np.ones(m) if ctx.weights is None else np.ascontiguousarray(ctx.weights, dtype=float),
            *first_pass(problem),
        )
    return problem.log_inputs


def linear_terms(problem) -> tuple:
    """Weights (M,), (M, C) or None and targets (M, C) of ``problem``'s loss
    linearised at its data."""
    if problem.loss.name == "l2":  # t(f) = f: the weights are the user's, the target y
        u = problem.ctx.weights
        return None if u is None or np.all(u == 1.0) else u, problem.y
    return compact_weights(*problem.loss.linearised(problem.y, problem.ctx))


def first_pass(problem) -> tuple:
    """What the compiled normal equations read of the linearisation at the data
    (:func:`brdffit.kernels.normal.prepare_weights` and ``prepare_targets``) and its
    ``y'Wy``, made once per problem (until :meth:`Problem.let_go`); the
    linearisation's own (M, C) arrays are not kept (50 to 75 MB on a MERL file
    besides these copies)."""
    state = problem._prepared
    if state is None:
        w, z = linear_terms(problem)
        wy, yy = weighted_target(z, w)
        del z
        s0, w = kernels_normal.prepare_weights(w)
        t0, wy_t = kernels_normal.prepare_targets(wy)
        del wy
        state = problem._prepared = ((s0, w, t0, wy_t), yy)  # one assignment
    return state


def compiled_normal(problem, free, offset):
    """The normal equations of ``problem``'s quadratic loss in one compiled pass over
    the columns ``free``, without stacking them (:mod:`brdffit.kernels.normal`),
    where that applies (no offset, one array column, the kernels wanted); else None."""
    if offset is not None or not problem.loss.linear or not kernels.wanted(problem.geometry.m):
        return None
    lobe = kernels_normal.lobe_column(free)
    if lobe is None:
        return None
    prepared, yy = first_pass(problem)
    return kernels_normal.from_prepared(free, lobe, prepared, yy, Normal)


def solve_normal(problem, shape, normal, constraints) -> Solution:
    """Coefficients and loss from ready normal equations (a quadratic loss)."""
    coefs, rss = solve_bounded(normal, problem.coef_lower, problem.coef_upper, constraints)
    loss = (float(rss.sum()) + problem.invalid_loss) / problem.norm
    return Solution(shape, coefs, loss if np.isfinite(loss) else BAD_LOSS)


def least_squares(problem, a, offset, w, z, constraints):
    """Bounded least-squares coefficients (C, K) of ``z - offset`` on the columns ``a``
    with weights ``w``, and their weighted residual sums of squares (C,)."""
    c = z.shape[1]
    _, z_lin, weighted = problem.linearisation()
    if offset is not None and a is not None and z is z_lin and weighted is not None:
        normal = offset_normal(a, offset, w, z, weighted)  # no (M, C) z - offset formed
        if normal is not None:
            return solve_bounded(normal, problem.coef_lower, problem.coef_upper, constraints)
    target = z if offset is None else z - offset
    reuse = weighted if (offset is None and z is z_lin) else None
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
    first = w[0].tolist() if len(w) else []  # chi2's and log's differ in the first row:
    if any(v != first[0] for v in first):  # its floats (NaN != NaN, as == fails below)
        return False
    head = w[:64]  # (a == a[:, :1]).all() is np.array_equal of the broadcast, 4 us less
    if not (head == head[:, :1]).all():
        return False
    return bool((w == w[:, :1]).all())


def as_2d(a):
    return a if np.ndim(a) == 2 else np.asarray(a)[:, None]


def stack_columns(cols, m, c):
    if not cols:
        return None
    if any(np.ndim(col) == 2 for col in cols):
        return np.stack([np.broadcast_to(as_2d(col), (m, c)) for col in cols], axis=1)
    if len(cols) == 1:  # np.stack's new (M, 1) array: a copy of the column as one (2 us)
        return np.asarray(cols[0]).reshape(-1, 1).copy()
    return np.stack(cols, axis=1)
