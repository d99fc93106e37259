"""Bounded linear least squares for the linear coefficients (variable projection).

For given shape parameters a model is ``offset + A x`` with a design matrix
``A`` of a few columns (K <= 4 for single models) and coefficients ``x`` per
colour channel. The fitting engine needs, thousands of times per fit, the
weighted least-squares solution of

    minimise  sum_m w_mc (y_mc - offset_m - A_m x_c)^2   subject to  lo <= x_c <= hi

for every channel c at once. With K this small the exact solution is found by
enumerating the active sets: every coefficient is either free, at its lower
bound or at its upper bound; each of the 3^K combinations is a small linear
system solved for all channels in one batched call, and the feasible one with
the least residual is the optimum (the problem is convex, so the best feasible
stationary point of a face is the global minimum). Everything is expressed
through the Gram matrix ``A^T W A`` and ``A^T W y``, so the residual sum of
squares comes out without forming residuals (its absolute error is the
round-off of ``y^T W y``, about 1e-15 of it: far below the noise of any
data). Larger K falls back to :func:`scipy.optimize.lsq_linear` per channel.
Further linear inequality rows (Ashikhmin-Shirley's triangle, energy
conservation) are handled by enumerating active sets of rows and solving the
KKT system of each.
"""

from __future__ import annotations

import itertools
from functools import cache, lru_cache

import numpy as np
from scipy.optimize import lsq_linear

__all__ = ["Normal", "normal_equations", "solve_bounded"]

#: Above this many coefficients enumeration (3^K systems) is slower than BVLS.
MAX_ENUMERATED = 5


class Normal:
    """The normal equations of one weighted problem: Gram (C, K, K), rhs (C, K), yWy (C,)."""

    __slots__ = ("gram", "rhs", "yy")

    def __init__(self, gram: np.ndarray, rhs: np.ndarray, yy: np.ndarray):
        self.gram, self.rhs, self.yy = gram, rhs, yy


def weighted_target(y: np.ndarray, w: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """``W y`` and ``y^T W y`` per channel, to reuse when the target does not change."""
    wy = y if w is None else y * (w if w.ndim == 2 else w[:, None])
    return wy, np.einsum("mc,mc->c", wy, y)


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
        gram = np.einsum("mkc,mlc->ckl", wa, columns)
        rhs = np.einsum("mkc,mc->ck", columns, wy)
        yy = np.einsum("mc,mc->c", wy, y)
        return Normal(gram, rhs, yy)
    if w is None or w.ndim == 1:
        wa = columns if w is None else columns * w[:, None]
        gram = np.broadcast_to(wa.T @ columns, (c, k, k))
    else:
        iu = _upper_triangle(k)
        gram_flat = w.T @ (columns[:, iu[0]] * columns[:, iu[1]])  # (C, P)
        gram = np.empty((c, k, k))
        gram[:, iu[0], iu[1]] = gram_flat
        gram[:, iu[1], iu[0]] = gram_flat
    wy, yy = weighted if weighted is not None else weighted_target(y, w)
    rhs = (columns.T @ wy).T  # (C, K)
    return Normal(gram, rhs, yy)


@cache
def _upper_triangle(k: int) -> tuple[np.ndarray, np.ndarray]:
    """``np.triu_indices(k)``, made once per K (a fit asks for it at every step)."""
    return np.triu_indices(k)


@cache
def _states(k: int) -> np.ndarray:
    """All 3^K assignments: 0 = at lower bound, 1 = free, 2 = at upper bound."""
    return np.array(list(itertools.product((0, 1, 2), repeat=k)), dtype=np.int8)


def _objective(normal: Normal, x: np.ndarray) -> np.ndarray:
    """Residual sum of squares x^T G x - 2 x^T b + yWy for x of shape (..., C, K)."""
    gx = np.einsum("ckl,...cl->...ck", normal.gram, x)
    return (
        np.einsum("...ck,...ck->...c", x, gx)
        - 2 * np.einsum("...ck,ck->...c", x, normal.rhs)
        + normal.yy
    )


def solve_bounded(
    normal: Normal, lower: np.ndarray, upper: np.ndarray, constraints=None
) -> tuple[np.ndarray, np.ndarray]:
    """Exact bounded least squares for every channel.

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
    """
    k = normal.rhs.shape[1]
    if k > MAX_ENUMERATED:
        return _solve_bvls(normal, lower, upper)
    # Fast path: the unconstrained solution, when it is inside the bounds for
    # every channel (the usual case near a good fit), is the answer.
    try:
        x = np.linalg.solve(normal.gram, normal.rhs[..., None])[..., 0]
    except np.linalg.LinAlgError:
        x = None
    if x is not None and np.isfinite(x).all() and _feasible(x, lower, upper, constraints).all():
        return x, np.maximum(_objective(normal, x), 0.0)
    x, rss = _enumerate(normal, lower, upper)
    if constraints is None:
        return x, rss
    # Only the channels whose box solution breaks a further row need the general
    # (slower) enumeration.
    bad = ~_feasible(x, lower, upper, constraints, tol=1e-12)
    if bad.any():
        a, b = constraints
        sub = Normal(normal.gram[bad], normal.rhs[bad], normal.yy[bad])
        sub_b = b[bad] if np.ndim(b) == 2 else b
        x[bad], rss[bad] = _enumerate_general(sub, lower, upper, (a, sub_b))
    return x, rss


def _feasible(x, lower, upper, constraints, tol=0.0) -> np.ndarray:
    """Which rows of x (..., K) satisfy the bounds and constraints (within tol)."""
    slack = tol * np.maximum(1.0, np.abs(x))
    ok = ((x >= lower - slack) & (x <= upper + slack)).all(axis=-1)
    if constraints is not None:
        a, b = constraints
        ok &= ((x @ a.T) <= b + tol * np.maximum(1.0, np.abs(b))).all(axis=-1)
    return ok


@lru_cache(maxsize=64)
def _active_sets(rows_bytes: bytes, shape: tuple) -> tuple:
    """Every set of at most K linearly independent constraint rows."""
    rows = np.frombuffer(rows_bytes).reshape(shape)
    k = shape[1]
    out = []
    for size in range(k + 1):
        for active in itertools.combinations(range(shape[0]), size):
            if size == 0 or np.linalg.matrix_rank(rows[list(active)]) == size:
                out.append(active)
    return tuple(out)


def _enumerate_general(normal: Normal, lower, upper, constraints):
    """Active-set enumeration with general inequality rows: for every set of at most
    K active rows (bounds written as rows too), the KKT system of the equality-
    constrained problem is solved for all channels; the best feasible point is the
    optimum of the convex problem."""
    c, k = normal.rhs.shape
    a_extra, b_extra = constraints
    b_extra = np.broadcast_to(np.asarray(b_extra, dtype=float), (c, len(a_extra)))
    rows, rhs = [], []
    for j in range(k):
        e = np.zeros(k)
        e[j] = 1.0
        rows.append(-e)
        rhs.append(-lower[j])
        if np.isfinite(upper[j]):
            rows.append(e)
            rhs.append(upper[j])
    rows += list(np.asarray(a_extra, dtype=float))
    rows = np.array(rows)
    rhs = np.concatenate(
        [np.broadcast_to(np.array(rhs, dtype=float), (c, len(rhs))), b_extra], axis=1
    )
    best_x = np.zeros((c, k))
    best_rss = np.full(c, np.inf)
    for active in _active_sets(rows.tobytes(), rows.shape):
        size = len(active)
        a_s = rows[list(active)]
        kkt = np.zeros((c, k + size, k + size))
        kkt[:, :k, :k] = normal.gram
        kkt[:, :k, k:] = a_s.T
        kkt[:, k:, :k] = a_s
        vec = np.concatenate([normal.rhs, rhs[:, list(active)]], axis=1)
        try:
            sol = np.linalg.solve(kkt, vec[..., None])[..., 0]
        except np.linalg.LinAlgError:
            continue
        x = sol[:, :k]
        ok = _feasible(x, lower, upper, constraints, tol=1e-10) & np.isfinite(x).all(axis=1)
        rss = np.where(ok, _objective(normal, x), np.inf)
        better = rss < best_rss
        best_x[better], best_rss[better] = x[better], rss[better]
    if not np.isfinite(best_rss).all():
        raise np.linalg.LinAlgError("no feasible point found for the linear coefficients")
    return np.clip(best_x, lower, upper), np.maximum(best_rss, 0.0)


def _enumerate(normal: Normal, lower: np.ndarray, upper: np.ndarray):
    """Try every active set (see the module docstring) for every channel at once."""
    c, k = normal.rhs.shape
    states = _states(k)
    if np.isinf(upper).any():
        states = states[~((states == 2) & np.isinf(upper)).any(axis=1)]
    free = states == 1
    fixed_val = np.where(states == 0, lower, np.where(states == 2, upper, 0.0))  # (S, K)
    # Reduced system per state: G_ff x_f = b_f - G_fc x_c; solved with a masked
    # matrix (identity on the non-free rows) so that every state is one batch.
    eye = np.eye(k)
    g = normal.gram[None, :, :, :]  # (1, C, K, K)
    fmask = free[:, None, :, None] & free[:, None, None, :]
    a = np.where(fmask, g, eye)  # (S, C, K, K)
    b = normal.rhs[None] - np.einsum("ckl,sl->sck", normal.gram, fixed_val)
    b = np.where(free[:, None, :], b, fixed_val[:, None, :])
    # Regularise nearly singular Grams (collinear columns) by a tiny ridge scaled
    # to the Gram's size, so that solve never fails; the feasible check below
    # still picks the best exact candidate.
    scale = np.maximum(np.abs(np.diagonal(normal.gram, axis1=1, axis2=2)).max(axis=1), 1e-300)
    a = a + (1e-12 * scale)[None, :, None, None] * eye * fmask
    x = np.linalg.solve(a, b[..., None])[..., 0]  # (S, C, K)
    tol = 1e-12 * np.maximum(1.0, np.abs(x))
    feasible = ((x >= lower - tol) & (x <= upper + tol)).all(axis=2)  # (S, C)
    rss = _objective(normal, x)
    rss = np.where(feasible, rss, np.inf)
    best = np.argmin(rss, axis=0)  # (C,)
    chan = np.arange(c)
    x_best = np.clip(x[best, chan], lower, upper)
    rss_best = rss[best, chan]
    if not np.isfinite(rss_best).all():  # numerically degenerate: fall back
        return _solve_bvls(normal, lower, upper)
    return x_best, np.maximum(rss_best, 0.0)


def _solve_bvls(normal: Normal, lower: np.ndarray, upper: np.ndarray):
    """Bounded least squares per channel through a Cholesky factor of the Gram."""
    c, k = normal.rhs.shape
    x = np.empty((c, k))
    for ch in range(c):
        g = normal.gram[ch] + 1e-12 * max(np.abs(np.diag(normal.gram[ch])).max(), 1e-300) * np.eye(
            k
        )
        r = np.linalg.cholesky(g).T  # G = R^T R, so ||R x - R^-T b||^2 = x^T G x - 2 b^T x + const
        target = np.linalg.solve(r.T, normal.rhs[ch])
        x[ch] = np.clip(
            lsq_linear(r, target, bounds=(lower, upper), method="bvls").x, lower, upper
        )
    return x, np.maximum(_objective(normal, x), 0.0)
