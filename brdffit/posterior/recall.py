"""The statistics of the points the run evaluated, kept for the coefficient draws.

Every kept sample of the chain is a point the log-density was evaluated at (a
walker's start or an accepted proposal), and its coefficient draw needs that
point's least-squares coefficients and inverse Gram matrix
(:meth:`brdffit.posterior.target.Target.draw_coefficients`). :class:`Recall` keeps
them as the run computes them, batch by batch, so that the draws need not evaluate
the design again (a quarter of all the designs of ``bench_posterior``'s task),
within a budget of :data:`BUDGET` numbers: past it, the points not kept are
recomputed as before. The values are those of the same point's evaluation, by the
same formulas; a batch of other walkers can change only their rounding (the
compiled sums take four walkers at a time).
"""

from __future__ import annotations

import numpy as np

__all__ = ["BUDGET", "Recall"]

#: Numbers (float64) the recall keeps at most: 32 MB.
BUDGET = 4_000_000


class Recall:
    """Points (N, D) with their coefficients (N, C, K) and inverse Gram matrices
    (N, C, K, K), appended batch by batch while within :data:`BUDGET`."""

    def __init__(self, budget: int = BUDGET):
        self.budget = budget
        self.size = 0
        self.parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []

    def add(self, theta: np.ndarray, beta: np.ndarray, inv: np.ndarray) -> None:
        size = theta.size + beta.size + inv.size
        if self.size + size <= self.budget:
            self.size += size
            self.parts.append((np.array(theta, dtype=float), beta, inv))

    def find(self, theta: np.ndarray):
        """``(found (S,) bool, beta (S, C, K), inv (S, C, K, K))`` for the rows of
        ``theta`` (S, D) kept bitwise; the rows not found have zeros."""
        if not self.parts:
            return np.zeros(len(theta), dtype=bool), None, None
        points = np.concatenate([p[0] for p in self.parts])
        betas = np.concatenate([p[1] for p in self.parts])
        invs = np.concatenate([p[2] for p in self.parts])
        keys, wanted = _keys(points), _keys(np.asarray(theta, dtype=float))
        order = np.argsort(keys, kind="stable")
        sorted_keys = keys[order]
        at = np.minimum(np.searchsorted(sorted_keys, wanted), len(keys) - 1)
        found = sorted_keys[at] == wanted
        rows = order[at]
        beta = np.where(found[:, None, None], betas[rows], 0.0)
        inv = np.where(found[:, None, None, None], invs[rows], 0.0)
        return found, beta, inv


def _keys(points: np.ndarray) -> np.ndarray:
    """Each row's bytes as one comparable value (rows equal bitwise, keys equal)."""
    rows = np.ascontiguousarray(points)
    return rows.view(np.dtype((np.void, rows.dtype.itemsize * rows.shape[1]))).ravel()
