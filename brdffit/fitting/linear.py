"""Bounded, linearly constrained least squares for the linear coefficients
(variable projection).

For given shape parameters a model is ``offset + A x`` with a design matrix
``A`` of a few columns (K <= 4 for single models, more for sums of lobes) and
coefficients ``x`` per colour channel. The fitting engine needs, thousands of
times per fit, the weighted least-squares solution of

    minimise  sum_m w_mc (y_mc - offset_m - A_m x_c)^2
    subject to  lo <= x_c <= hi  and  R x_c <= r_c

for every channel c at once, where the rows ``R`` are the model's own
inequalities (Ashikhmin-Shirley's triangle) and, in an energy-conserving fit,
the directional albedo at a grid of incidence angles. Everything is expressed
through the Gram matrix ``G = A^T W A`` and ``A^T W y``, so the residual sum of
squares comes out without forming residuals (its absolute error is the
round-off of ``y^T W y``, about 1e-15 of it: far below the noise of any data).

Three stages, each only for the channels the previous one left:

1. the unconstrained solution, when it obeys every bound and row (the usual
   case near a good fit);
2. for K <= ``MAX_ENUMERATED`` and the bounds alone, enumeration of the 3^K
   active sets (each coefficient free, at its lower or at its upper bound),
   all solved for all channels in one batched call; the problem is convex, so
   the best feasible stationary point of a face is the global minimum;
3. otherwise (more coefficients, or rows that the box solution breaks) the
   exact solution by Lawson and Hanson's reduction of least squares with
   linear inequality constraints (LSI) to a least-distance problem (LDP),
   which is the dual of a non-negative least-squares problem
   (:func:`scipy.optimize.nnls`): C. L. Lawson and R. J. Hanson, *Solving
   Least Squares Problems* (Prentice-Hall 1974; SIAM 1995), chapter 23,
   sections 3-5. Bounds and rows of any number are handled alike. NNLS is
   an active-set method with finite termination whose main iterations each
   add one row to the active set; here its iterations are capped at
   ``10 R + 50`` for R rows (each O(R K + K^3)), so the cost of a call is bounded,
   and a call that reached the cap would count as having no solution.
   The NNLS multipliers also name the active rows, whose equality-constrained
   least squares then gives the point exactly where columns are nearly
   collinear (:mod:`brdffit.fitting.lsi`).
"""

from __future__ import annotations

import itertools
import math
from functools import cache, lru_cache

import numpy as np

from .channels import dot_by_channel, einsum
from .lsi import RIDGE, solve_lsi
from .lsi import scale as _scale

__all__ = ["Normal", "normal_equations", "offset_normal", "solve_bounded"]

#: Up to this many coefficients the bounds alone are solved by enumerating the
#: 3^K active sets (batched over channels: faster than NNLS per channel).
MAX_ENUMERATED = 5

try:  # numpy's own batched LAPACK solve, without np.linalg.solve's checks (8 -> 3 us)
    from numpy.linalg._umath_linalg import solve as _gufunc_solve
except ImportError:  # a numpy without it: the public function (the same LAPACK call)
    _gufunc_solve = None


def _batched_solve(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.linalg.solve(a, b)`` for stacks of small systems (..., K, K), (..., K, 1),
    called thousands of times a fit. It is LAPACK's gesv as np.linalg.solve calls it,
    without the wrapper's type checks; a singular matrix raises LinAlgError as there."""
    if _gufunc_solve is None:
        return np.linalg.solve(a, b)
    with np.errstate(invalid="raise", over="ignore", divide="ignore", under="ignore"):
        try:
            return _gufunc_solve(a, b, signature="dd->d")
        except FloatingPointError:
            raise np.linalg.LinAlgError("Singular matrix") from None


class Normal:
    """The normal equations of one weighted problem: Gram (C, K, K), rhs (C, K), yWy (C,)."""

    __slots__ = ("gram", "rhs", "yy")

    def __init__(self, gram: np.ndarray, rhs: np.ndarray, yy: np.ndarray):
        self.gram, self.rhs, self.yy = gram, rhs, yy


def weighted_target(y: np.ndarray, w: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """``W y`` and ``y^T W y`` per channel, to reuse when the target does not change."""
    wy = y if w is None else y * (w if w.ndim == 2 else w[:, None])
    return wy, dot_by_channel(wy, y)


def normal_equations(
    columns: np.ndarray, y: np.ndarray, w: np.ndarray | None, weighted: tuple | None = None
) -> Normal:
    """Build the normal equations.

    Parameters
    ----------
    columns : (M, K) or (M, K, C) array (per-channel columns)
    y : (M, C) targets (offset already subtracted)
    w : None, (M,) or (M, C) non-negative weights
    weighted : (W y, y^T W y), optional
        From :func:`weighted_target`, when the same target is solved many times.
    """
    k = columns.shape[1]
    c = y.shape[1]
    if columns.ndim == 3:
        wy = y if w is None else y * (w if w.ndim == 2 else w[:, None])
        wa = columns if w is None else columns * (w if w.ndim == 2 else w[:, None])[:, None, :]
        gram = einsum("mkc,mlc->ckl", wa, columns)
        rhs = einsum("mkc,mc->ck", columns, wy)
        yy = einsum("mc,mc->c", wy, y)
        return Normal(gram, rhs, yy)
    if w is None or w.ndim == 1:
        wa = columns if w is None else columns * w[:, None]
        gram = np.broadcast_to(wa.T @ columns, (c, k, k))
    elif k == 1:  # the same product and matmul, without the pairs' fancy indexing (4 us)
        gram = (w.T @ (columns * columns)).reshape(c, 1, 1)
    else:
        iu = _upper_triangle(k)
        gram_flat = w.T @ (columns[:, iu[0]] * columns[:, iu[1]])  # (C, P)
        gram = np.empty((c, k, k))
        gram[:, iu[0], iu[1]] = gram_flat
        gram[:, iu[1], iu[0]] = gram_flat
    wy, yy = weighted if weighted is not None else weighted_target(y, w)
    # (C, K): from the side whose layout numpy's matmul takes without a copy (a
    # column-major table's values: 13 against 31 us for 1,439 x 31)
    rhs = wy.T @ columns if wy.flags.f_contiguous else (columns.T @ wy).T
    return Normal(gram, rhs, yy)


def offset_normal(
    columns: np.ndarray, offset: np.ndarray, w: np.ndarray | None, y: np.ndarray, weighted: tuple
) -> Normal | None:
    """:func:`normal_equations` of the target ``y - offset`` for an offset column (M, 1)
    shared by the channels, from ``(W y, y^T W y)`` of :func:`weighted_target`, without
    the (M, C) target: ``A^T W (y - o) = A^T W y - A^T W o`` and ``(y - o)^T W (y - o) =
    y^T W y - 2 o^T W y + o^T W o``, products of the (M, K) columns and (M, 1) offset
    with the (M, C) arrays made once per problem (the same sums regrouped; their
    rounding is that of ``y^T W y``, as the residual sum of squares' already is). None
    for per-channel columns, offsets or weights (then :func:`normal_equations`: with
    (M, C) weights, as chi2's, forming the target costs less than the products)."""
    if columns.ndim != 2 or offset.ndim != 2 or offset.shape[1] != 1 or np.ndim(w) == 2:
        return None
    wy, yy = weighted
    normal = normal_equations(columns, y, w, weighted)  # the Gram and A^T W y
    wo = offset if w is None else offset * w[:, None]
    oo = float(wo[:, 0] @ offset[:, 0])
    normal.rhs -= (columns.T @ wo).T
    normal.yy = yy - 2.0 * (offset.T @ wy)[0] + oo
    return normal


@cache
def _upper_triangle(k: int) -> tuple[np.ndarray, np.ndarray]:
    """``np.triu_indices(k)``, made once per K (a fit asks for it at every step)."""
    return np.triu_indices(k)


@lru_cache(maxsize=64)
def _box_states(lower: tuple, upper: tuple):
    """The 3^K active sets of the bounds (0 = at the lower bound, 1 = free, 2 = at
    the upper bound; none at an infinite one) as masks: free (S, K), the fixed
    values (S, K), free x free (S, 1, K, K), the identity, and the identity on the
    free x free entries (where the ridge goes). Made once per bounds."""
    k = len(lower)
    states = np.array(list(itertools.product((0, 1, 2), repeat=k)), dtype=np.int8)
    states = states[~((states == 2) & np.isinf(upper)).any(axis=1)]
    free = states == 1
    fixed_val = np.where(states == 0, lower, np.where(states == 2, upper, 0.0))
    fmask = free[:, None, :, None] & free[:, None, None, :]
    eye = np.eye(k)
    return free, fixed_val, fmask, eye, eye * fmask


def _objective(normal: Normal, x: np.ndarray) -> np.ndarray:
    """Residual sum of squares x^T G x - 2 x^T b + yWy for x of shape (..., C, K)."""
    gx = einsum("ckl,...cl->...ck", normal.gram, x)
    return (
        einsum("...ck,...ck->...c", x, gx)
        - 2 * einsum("...ck,ck->...c", x, normal.rhs)
        + normal.yy
    )


def _state_objective(normal: Normal, x: np.ndarray) -> np.ndarray:
    """:func:`_objective` of x (S, C, K), its ``G x`` by one batched matmul (an einsum
    over the states costs twice as much); the same sums of K products."""
    gx = np.matmul(normal.gram, x[..., None])[..., 0]
    return einsum("sck,sck->sc", x, gx) - 2 * einsum("sck,ck->sc", x, normal.rhs) + normal.yy


def solve_bounded(
    normal: Normal, lower: np.ndarray, upper: np.ndarray, constraints=None
) -> tuple[np.ndarray, np.ndarray]:
    """Exact bounded, linearly constrained least squares for every channel.

    Parameters
    ----------
    normal : Normal
    lower, upper : (K,) bounds (upper may be inf)
    constraints : (A, b), optional
        Further linear inequalities ``A x <= b`` (A of shape (R, K), b of shape
        (R,) or (C, R)) that every channel's coefficients obey
        (Ashikhmin-Shirley's ``rd (1 - rs) <= 1 - rs``, energy conservation).

    Returns
    -------
    x : (C, K) coefficients; rss : (C,) weighted residual sums of squares

    Raises
    ------
    numpy.linalg.LinAlgError
        When no coefficients satisfy the bounds and rows of some channel (the
        fitting objective turns this into its "infeasible" value).
    """
    c, k = normal.rhs.shape
    rows = _per_channel(constraints, c)
    x = _unconstrained(normal)
    few = rows is None and x.size <= FEW and np.shape(lower) == np.shape(upper) == (k,)
    if few and _inside(x.tolist(), *(np.asarray(b, float).tolist() for b in (lower, upper))):
        return x, np.maximum(_objective(normal, x), 0.0)  # the usual case, in floats
    todo = ~_feasible(x, lower, upper, rows)  # NaN (a singular Gram) fails every bound
    if not todo.any():  # the usual case near a good fit
        return x, np.maximum(_objective(normal, x), 0.0)
    every = todo.all()
    if k <= MAX_ENUMERATED:
        x_box, rss_box = _enumerate(normal if every else _channels(normal, todo), lower, upper)
        ok = np.isfinite(rss_box)
        if rows is None and every and ok.all():
            return x_box, rss_box  # the usual bounded case: nothing else to do
        x[todo] = x_box
        # Channels whose box solution is degenerate or breaks a row go on.
        if rows is not None:
            ok[ok] = _feasible(x_box[ok], lower, upper, _subset(rows, todo, ok), 1e-12)
        todo[todo] = ~ok
    if todo.any():
        x[todo] = solve_lsi(_channels(normal, todo), lower, upper, _subset(rows, todo))
    return x, np.maximum(_objective(normal, x), 0.0)


#: Coefficients (channels x columns) up to which :func:`_inside` tells the bounds in
#: floats (its comparisons are :func:`_feasible`'s: 4 us less at every evaluation).
FEW = 64


def _inside(x: list, lower: list, upper: list) -> bool:
    """:func:`_feasible` without constraints of every row of ``x`` (rows of floats):
    within the bounds and finite (NaN fails every comparison, as there)."""
    return all(lo <= v <= hi and abs(v) < math.inf
               for row in x for v, lo, hi in zip(row, lower, upper))  # fmt: skip


def _unconstrained(normal: Normal) -> np.ndarray:
    """The unconstrained solution per channel (NaN where the Gram is singular)."""
    try:
        return _batched_solve(normal.gram, normal.rhs[..., None])[..., 0]
    except np.linalg.LinAlgError:
        return np.full(normal.rhs.shape, np.nan)


def _channels(normal: Normal, which: np.ndarray) -> Normal:
    return Normal(normal.gram[which], normal.rhs[which], normal.yy[which])


def _per_channel(constraints, c: int):
    """Constraints as ``(A (R, K), b (C, R))``, or None."""
    if constraints is None:
        return None
    a, b = constraints
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if b.shape == (c, len(a)):
        return a, b
    out = np.empty((c, len(a)))  # np.broadcast_to's values, without its 2 us of checks
    out[...] = b
    return a, out


def _subset(rows, *masks):
    """The constraints of some channels (boolean masks applied in turn)."""
    if rows is None:
        return None
    a, b = rows
    for mask in masks:
        b = b[mask]
    return a, b


def _feasible(x, lower, upper, constraints, tol=0.0) -> np.ndarray:
    """Which rows of x (..., K) satisfy the bounds and constraints (within tol).

    With ``tol`` 0 the slacks are 0 where ``x`` and the rows' bounds are finite and
    NaN (failing) where they are not: the comparisons without them and a finiteness
    test give the same answers, at half the cost (a fit asks at every step)."""
    if not tol:
        ok = ((x >= lower) & (x <= upper) & (np.abs(x) < np.inf)).all(axis=-1)
        if constraints is not None:
            a, b = constraints
            ok &= ((x @ a.T) <= b).all(axis=-1) & (np.abs(b) < np.inf).all(axis=-1)
        return ok
    slack = tol * np.maximum(1.0, np.abs(x))
    ok = ((x >= lower - slack) & (x <= upper + slack)).all(axis=-1)
    if constraints is not None:
        a, b = constraints
        ok &= ((x @ a.T) <= b + tol * np.maximum(1.0, np.abs(b))).all(axis=-1)
    return ok


def _enumerate(normal: Normal, lower: np.ndarray, upper: np.ndarray):
    """Try every active set of the bounds (see the module docstring) for every
    channel at once: the coefficients (C, K) and residual sums of squares (C,),
    inf for a channel without a feasible candidate."""
    c = normal.rhs.shape[0]
    free, fixed_val, fmask, eye, ridge_mask = _box_states(tuple(lower), tuple(upper))
    # Reduced system per state: G_ff x_f = b_f - G_fc x_c; solved with a masked
    # matrix (identity on the non-free rows) so that every state is one batch.
    a = np.where(fmask, normal.gram, eye)  # (S, C, K, K)
    b = normal.rhs - einsum("ckl,sl->sck", normal.gram, fixed_val)
    np.copyto(b, fixed_val[:, None, :], where=~free[:, None, :])
    # Regularise nearly singular Grams (collinear columns) by a tiny ridge scaled
    # to the Gram's size, so that solve never fails; the feasible check below
    # still picks the best exact candidate.
    a += (RIDGE * _scale(normal.gram))[:, None, None] * ridge_mask
    x = _batched_solve(a, b[..., None])[..., 0]  # (S, C, K)
    tol = 1e-12 * np.maximum(1.0, np.abs(x))
    feasible = ((x >= lower - tol) & (x <= upper + tol)).all(axis=2)  # (S, C)
    rss = _state_objective(normal, x)
    rss[~feasible] = np.inf
    best = np.argmin(rss, axis=0)  # (C,)
    chan = np.arange(c)
    return np.clip(x[best, chan], lower, upper), np.maximum(rss[best, chan], 0.0)
