"""The posterior sampler's weighted sums, compiled (:mod:`brdffit.posterior.target`).

For every walker ``a`` and channel ``c`` the marginal likelihood needs the weighted
Gram matrix ``G = A^T W_c A`` of the design's columns, the right-hand side ``A^T W_c
r_c`` and ``r_c^T W_c r_c``, with ``r = y - offset``. numpy forms each entry from a
(W, M) product of two columns and a contraction per channel (at 32 walkers, 10,000
samples and one channel, 0.8 ms a batch, two thirds of it temporaries and calls);
:func:`weighted_gram` reads the columns in place and sums each entry in one
vectorised pass, no temporary. Sums in another order than numpy's: they differ by
rounding (the tests hold them to the numpy formulas' to 1e-12 relative).
:func:`solve_gram` then inverts each (K, K) matrix and solves for the coefficients
in one call, where numpy's batched ``inv``, ``slogdet`` and ``einsum`` on arrays of
a few numbers cost a call each.
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["solve_gram", "weighted_gram"]

#: Reassociation (vectorised sums) but no assumption of finite values: a design that
#: is not finite must give a sum that is not, which marks its walker (``bad``).
FLAGS = {"reassoc", "contract", "nsz"}


@numba.njit(inline="always", fastmath=FLAGS, error_model="numpy")
def _sum1(u):
    s = 0.0
    for t in range(u.shape[0]):
        s += u[t]
    return s


@numba.njit(inline="always", fastmath=FLAGS, error_model="numpy")
def _sum2(u, v):
    s = 0.0
    for t in range(u.shape[0]):
        s += u[t] * v[t]
    return s


@numba.njit(inline="always", fastmath=FLAGS, error_model="numpy")
def _sum3(u, v, z):
    s = 0.0
    for t in range(u.shape[0]):
        s += u[t] * v[t] * z[t]
    return s


@numba.njit(inline="always", fastmath=FLAGS, error_model="numpy")
def _one_column(w, r_w, x):
    """``sum w x``, ``sum w x^2`` and ``sum r_w x`` in one pass over the column ``x``."""
    s_x = s_xx = s_rx = 0.0
    for t in range(x.shape[0]):
        wx = w[t] * x[t]
        s_x += wx
        s_xx += wx * x[t]
        s_rx += r_w[t] * x[t]
    return s_x, s_xx, s_rx


@numba.njit(inline="always", fastmath=FLAGS, error_model="numpy")
def _residual(w, y, o, wr):
    """``wr = w (y - o)``, and ``sum w (y - o)^2``."""
    total = 0.0
    for t in range(w.shape[0]):
        r = y[t] - o[t]
        wr[t] = w[t] * r
        total += wr[t] * r
    return total


@numba.njit(inline="always", fastmath=FLAGS, error_model="numpy")
def _four_columns(w, r_w, x, a, out):
    """:func:`_one_column` of walkers ``a`` to ``a + 3`` (rows of ``x``) in one pass:
    ``w`` and ``r_w`` read once for the four (the pass is bound by the loads)."""
    x0, x1, x2, x3 = x[a], x[a + 1], x[a + 2], x[a + 3]
    s0 = s1 = s2 = s3 = q0 = q1 = q2 = q3 = p0 = p1 = p2 = p3 = 0.0
    for t in range(w.shape[0]):
        wt, rt = w[t], r_w[t]
        v0, v1, v2, v3 = x0[t], x1[t], x2[t], x3[t]
        u0, u1, u2, u3 = wt * v0, wt * v1, wt * v2, wt * v3
        s0 += u0
        s1 += u1
        s2 += u2
        s3 += u3
        q0 += u0 * v0
        q1 += u1 * v1
        q2 += u2 * v2
        q3 += u3 * v3
        p0 += rt * v0
        p1 += rt * v1
        p2 += rt * v2
        p3 += rt * v3
    out[a, 0], out[a + 1, 0], out[a + 2, 0], out[a + 3, 0] = s0, s1, s2, s3
    out[a, 1], out[a + 1, 1], out[a + 2, 1], out[a + 3, 1] = q0, q1, q2, q3
    out[a, 2], out[a + 1, 2], out[a + 2, 2], out[a + 3, 2] = p0, p1, p2, p3


@numba.njit(inline="always", fastmath=FLAGS, error_model="numpy")
def _entry(w, cols, const, index, a, i, j, one, w_sum):
    """``sum_m w_m x_i x_j`` for columns ``i`` and ``j`` of walker ``a``; ``one`` (W, 3)
    the sums of :func:`_one_column` when there is one column that is not constant."""
    ci, cj = index[i], index[j]
    if ci < 0 and cj < 0:
        return const[i] * const[j] * w_sum
    if ci < 0 or cj < 0:
        scale, col = (const[i], cj) if ci < 0 else (const[j], ci)
        return scale * (one[a, 0] if cols.shape[0] == 1 else _sum2(w, cols[col, a]))
    return one[a, 1] if cols.shape[0] == 1 else _sum3(w, cols[ci, a], cols[cj, a])


@numba.njit(cache=True, fastmath=FLAGS, error_model="numpy")
def weighted_gram(cols, const, index, w_t, wy_t, y_t, off, gram, rhs, yy):
    """Write ``gram`` (W, C, K, K), ``rhs`` (W, C, K) and, with an offset, ``yy`` (W, C).

    Column ``i`` of walker ``a`` is ``cols[index[i], a]`` (M,) or, where ``index[i]``
    is negative, the constant ``const[i]``. ``w_t`` and ``wy_t`` (C, M) are the
    weights and the weighted data by channel, ``y_t`` (C, M) the data; ``off`` (W, M)
    the offset of each walker, or (0, M) without one: then ``rhs`` sums ``wy`` and
    ``yy`` is left as it is (the data's own, the same for every walker). With one
    column that is not constant (a lobe beside ``1/pi``) and no offset, its three sums
    take one pass for four walkers at a time."""
    walkers, channels, k = rhs.shape
    wr = np.empty(w_t.shape[1])
    one = np.zeros((walkers, 3))  # sum w x, sum w x^2, sum r x of the one column
    single, blocked = cols.shape[0] == 1, cols.shape[0] == 1 and off.shape[0] == 0
    for c in range(channels):
        w = w_t[c]
        w_sum, wy_sum = _sum1(w), _sum1(wy_t[c])
        if blocked:
            for a in range(0, walkers - walkers % 4, 4):
                _four_columns(w, wy_t[c], cols[0], a, one)
        for a in range(walkers):
            r_w, r_sum = wy_t[c], wy_sum
            if off.shape[0] > 0:
                yy[a, c] = _residual(w, y_t[c], off[a], wr)
                r_w, r_sum = wr, _sum1(wr)
            if single and (not blocked or a >= walkers - walkers % 4):
                one[a, 0], one[a, 1], one[a, 2] = _one_column(w, r_w, cols[0, a])
            for i in range(k):
                if index[i] < 0:
                    rhs[a, c, i] = const[i] * r_sum
                else:
                    rhs[a, c, i] = one[a, 2] if single else _sum2(r_w, cols[index[i], a])
                for j in range(i, k):
                    value = _entry(w, cols, const, index, a, i, j, one, w_sum)
                    gram[a, c, i, j] = value
                    gram[a, c, j, i] = value
    return gram


@numba.njit(inline="always", fastmath=FLAGS, error_model="numpy")
def _invert(aug, k):
    """Gauss-Jordan elimination with partial pivoting of ``aug = [G | I]`` (K, 2K) in
    place, leaving ``G^-1`` in its right half; returns ``log |det G|``."""
    log_det = 0.0
    for col in range(k):
        pivot = col
        for r in range(col + 1, k):
            if abs(aug[r, col]) > abs(aug[pivot, col]):
                pivot = r
        if pivot != col:
            for j in range(2 * k):
                aug[col, j], aug[pivot, j] = aug[pivot, j], aug[col, j]
        p = aug[col, col]
        log_det += np.log(abs(p))
        for j in range(2 * k):
            aug[col, j] /= p
        for r in range(k):
            if r != col:
                f = aug[r, col]
                for j in range(2 * k):
                    aug[r, j] -= f * aug[col, j]
    return log_det


@numba.njit(cache=True, fastmath=FLAGS, error_model="numpy")
def solve_gram(gram, rhs, yy, ridge, inv, beta, rss, log_det, bad):
    """For every walker and channel: ``G + ridge max|diag G| I``, its inverse ``inv``
    (W, C, K, K) and ``log |det|`` (W, C), the coefficients ``beta = inv rhs`` (W, C,
    K) and the residual sum of squares ``max(yy - rhs . beta, 0)`` (W, C). A walker
    with a sum that is not finite is ``bad`` (W,) and gets ``G = I``, ``rhs = 0``
    (numpy's formulas in :class:`~brdffit.posterior.target.Target`, by elimination
    on (K, 2K) instead of LAPACK's calls on arrays of a few numbers)."""
    walkers, channels, k = rhs.shape
    aug = np.empty((k, 2 * k))
    for a in range(walkers):
        finite = True
        for c in range(channels):
            for i in range(k):
                finite = finite and np.isfinite(rhs[a, c, i])
                for j in range(k):
                    finite = finite and np.isfinite(gram[a, c, i, j])
        bad[a] = not finite
        for c in range(channels):
            scale = 0.0
            for i in range(k):
                scale = max(scale, abs(gram[a, c, i, i]))
            scale = ridge * max(scale, 1e-300)
            for i in range(k):
                for j in range(k):
                    eye = 1.0 if i == j else 0.0
                    aug[i, j] = gram[a, c, i, j] + scale * eye if finite else eye
                    aug[i, k + j] = eye
            log_det[a, c] = _invert(aug, k)
            fit = 0.0
            for i in range(k):
                b = 0.0
                for j in range(k):
                    inv[a, c, i, j] = aug[i, k + j]
                    b += aug[i, k + j] * (rhs[a, c, j] if finite else 0.0)
                beta[a, c, i] = b
                fit += (rhs[a, c, i] if finite else 0.0) * b
            rss[a, c] = max(yy[a, c] - fit, 0.0)
    return rss
