"""The third stage of :mod:`brdffit.fitting.linear`: least squares with linear
inequality constraints (LSI) for the channels whose box solution breaks a row (or
with more coefficients than the enumeration takes), exactly, by Lawson and Hanson's
reduction of LSI to a least-distance problem (LDP), the dual of a non-negative least
squares problem (:func:`scipy.optimize.nnls`): C. L. Lawson and R. J. Hanson,
*Solving Least Squares Problems* (Prentice-Hall 1974; SIAM 1995), chapter 23,
sections 3-5.
"""

from __future__ import annotations

import numpy as np

__all__ = ["FEASIBLE_TOL", "RIDGE", "scale", "solve_lsi"]

#: Relative ridge on a Gram whose columns are collinear, so its Cholesky factor exists.
RIDGE = 1e-12
#: Relative tolerance on the bounds and rows of a solution.
FEASIBLE_TOL = 1e-9


def scale(gram: np.ndarray) -> np.ndarray:
    """The largest diagonal entry of each Gram (C,), at least 1e-300."""
    return np.maximum(np.abs(np.diagonal(gram, axis1=-2, axis2=-1)).max(axis=-1), 1e-300)


def _inequalities(lower, upper, rows, c: int) -> tuple[np.ndarray, np.ndarray]:
    """Bounds and rows as one system ``D x <= d``: D (R, K), d (C, R)."""
    k = len(lower)
    finite = np.isfinite(upper)
    mats = [-np.eye(k), np.eye(k)[finite]]
    limits = [np.broadcast_to(-lower, (c, k)), np.broadcast_to(upper[finite], (c, finite.sum()))]
    if rows is not None:
        mats.append(rows[0])
        limits.append(rows[1])
    return np.vstack(mats), np.concatenate(limits, axis=1)


def solve_lsi(normal, lower, upper, rows) -> np.ndarray:
    """Least squares under ``D x <= d`` per channel by Lawson and Hanson's LSI ->
    LDP -> NNLS reduction (Solving Least Squares Problems, ch. 23).

    With the Cholesky factor ``G = L L^T`` and the unconstrained solution ``x0``,
    the objective is ``|z|^2 + const`` for ``z = L^T (x - x0)``, and the rows
    become ``-(D L^-T) z >= D x0 - d``: a least-distance problem (LDP), whose
    solution is read off the residual of one NNLS problem (their algorithm
    23.27). A relative ridge of ``RIDGE`` makes ``L`` exist for collinear columns.
    """
    c, k = normal.rhs.shape
    mat, limits = _inequalities(lower, upper, rows, c)
    gram = normal.gram + (RIDGE * scale(normal.gram))[:, None, None] * np.eye(k)
    if not (np.isfinite(gram).all() and np.isfinite(normal.rhs).all()):
        raise np.linalg.LinAlgError("the design of the linear coefficients is not finite")
    chol = np.linalg.cholesky(gram)
    x0 = np.linalg.solve(gram, normal.rhs[..., None])[..., 0]
    chol_inv = np.linalg.inv(chol)  # L^-1, so that L^-T = chol_inv^T
    x = np.empty((c, k))
    for ch in range(c):
        z, active = _least_distance(-mat @ chol_inv[ch].T, mat @ x0[ch] - limits[ch])
        x_ldp = np.clip(x0[ch] + chol_inv[ch].T @ z, lower, upper)
        x[ch] = _polish(x_ldp, gram[ch], normal.rhs[ch], (mat, limits[ch], active))
    return np.clip(x, lower, upper)


def _polish(x_ldp, gram, rhs, system) -> np.ndarray:
    """The LDP point, or the exact optimum on its active rows when that is feasible
    and no worse.

    Where columns are nearly collinear, ``L^-T`` stretches the poorly determined
    directions and the LDP point can miss a row by 1e-5 there; the active rows
    (the NNLS multipliers above 0) are then right, and the equality-constrained
    least squares on them, solved in the coefficients' own space, is exact.
    """
    mat, limits, active = system
    k = len(x_ldp)
    rows = mat[active]
    kkt = np.block([[gram, rows.T], [rows, np.zeros((len(rows), len(rows)))]])
    sol = np.linalg.lstsq(kkt, np.concatenate([rhs, limits[active]]), rcond=None)[0]
    candidates = [x_ldp, sol[:k]]
    slack = [mat @ x - limits for x in candidates]
    tol = FEASIBLE_TOL * np.maximum(1.0, np.abs(limits))
    value = [x @ gram @ x - 2 * rhs @ x for x in candidates]
    ok = [bool(np.isfinite(x).all() and (s <= tol).all()) for x, s in zip(candidates, slack)]
    if not any(ok):
        raise np.linalg.LinAlgError("no coefficients satisfy the bounds and constraints")
    if ok[1] and (not ok[0] or value[1] <= value[0]):
        return sol[:k]
    return x_ldp


def _least_distance(h: np.ndarray, viol: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The shortest ``z`` with ``h z >= viol`` (LDP), by Lawson and Hanson's
    algorithm 23.27: NNLS of ``[h^T; viol^T] u ~ e_(K+1)``; the problem is
    infeasible when the residual ``r`` vanishes, else ``z = -r[:K] / r[K]``.
    Returns ``z`` and which rows are active (``u > 0``).

    Each row is scaled to unit length and the right side to a largest entry of
    1 first: the set of solutions does not change, and NNLS sees numbers near 1.
    """
    k = h.shape[1]
    norms = np.linalg.norm(h, axis=1)
    null = norms <= 1e-300
    active = np.zeros(len(h), dtype=bool)
    if (viol[null] > 0).any():
        raise np.linalg.LinAlgError("a constraint row without coefficients is broken")
    h, viol = h[~null] / norms[~null, None], viol[~null] / norms[~null]
    top = viol.max(initial=0.0)
    if top <= 0:
        return np.zeros(k), active  # x0 obeys every row
    e = np.vstack([h.T, viol / top])
    f = np.zeros(k + 1)
    f[k] = 1.0
    try:
        from scipy.optimize import nnls  # on first need: scipy.optimize takes 0.2 s to import

        u, _ = nnls(e, f, maxiter=10 * e.shape[1] + 50)
    except RuntimeError as exc:  # iteration limit: report as no solution
        raise np.linalg.LinAlgError(str(exc)) from None
    r = e @ u - f
    if not -r[k] > 0:
        raise np.linalg.LinAlgError("no coefficients satisfy the bounds and constraints")
    active[~null] = u > 0
    return -r[:k] / r[k] * top, active
