"""The weighted sums of a batch of walkers' designs, for :class:`~brdffit.posterior.target.Target`.

:func:`weighted_sums` returns, for every walker and channel, the Gram matrix ``A^T
W_c A`` of the free columns, the right-hand side ``A^T W_c r_c`` and ``r_c^T W_c
r_c`` with ``r = y - offset``. Compiled in one pass per entry
(:func:`brdffit.kernels.loops_posterior.weighted_gram`) when the kernels are wanted
for ``M x C`` values and no column or offset differs by channel; else by numpy, one
contraction per entry and channel.
"""

from __future__ import annotations

import numpy as np

from .design import dense

__all__ = ["RIDGE", "statistics", "weighted_sums"]

#: Relative ridge on the Gram matrices (see :mod:`brdffit.posterior.target`).
RIDGE = 1e-12


def weighted_sums(target, cols, offset, w_count: int):
    """``(gram (W, C, K, K), rhs (W, C, K), yy (W, C))`` of the columns and offset of
    :func:`~brdffit.posterior.design.assemble` for ``w_count`` walkers."""
    return _sums(target, cols, offset, w_count)[:3]


def _sums(target, cols, offset, w_count: int):
    """:func:`weighted_sums`, and whether the compiled pass formed them."""
    m, c = target.y.shape
    compiled = _compiled(cols, offset, m * c)
    sums = _compiled_sums if compiled else _numpy_sums
    return (*sums(target, cols, offset, w_count), compiled)


def statistics(target, cols, offset, w_count: int):
    """``log |det G|`` (W, C) of the Gram matrices with their ridge, their inverses
    (W, C, K, K), the least-squares coefficients (W, C, K), the residual sums of
    squares (W, C) and a mask (W,) of walkers whose design is not finite."""
    gram, rhs, yy, compiled = _sums(target, cols, offset, w_count)
    k, c = len(cols), target.y.shape[1]
    if k == 0:
        rss = np.maximum(yy, 0.0)
        return np.zeros((w_count, c)), gram, rhs, rss, ~np.isfinite(rss).all(axis=1)
    if not compiled:
        return _numpy_solve(gram, rhs, yy, k)
    from ..kernels.loops_posterior import solve_gram

    inv, beta = np.empty_like(gram), np.empty_like(rhs)
    rss, log_det = np.empty((w_count, c)), np.empty((w_count, c))
    bad = np.empty(w_count, dtype=np.bool_)
    yy = np.ascontiguousarray(yy)
    solve_gram(gram, rhs, yy, RIDGE, inv, beta, rss, log_det, bad)
    return log_det, inv, beta, rss, bad


def _numpy_solve(gram, rhs, yy, k: int):
    scale = np.maximum(np.abs(np.diagonal(gram, axis1=2, axis2=3)).max(axis=2), 1e-300)
    gram += (RIDGE * scale)[..., None, None] * np.eye(k)
    bad = ~(np.isfinite(gram).all(axis=(1, 2, 3)) & np.isfinite(rhs).all(axis=(1, 2)))
    gram[bad], rhs[bad] = np.eye(k), 0.0
    inv = np.linalg.inv(gram)
    beta = np.einsum("wckl,wcl->wck", inv, rhs)
    rss = np.maximum(yy - np.einsum("wck,wck->wc", rhs, beta), 0.0)
    return np.linalg.slogdet(gram)[1], inv, beta, rss, bad


def _compiled(cols, offset, values: int) -> bool:
    if any(np.ndim(x) > 2 for x in cols) or np.ndim(offset) > 2:
        return False
    from .. import kernels

    return kernels.wanted(values, modules=("loops_posterior",))


def _compiled_sums(target, cols, offset, w_count: int):
    from ..kernels.loops_posterior import weighted_gram

    m, c = target.y.shape
    k = len(cols)
    index = np.full(k, -1, dtype=np.int64)
    const = np.zeros(k)
    arrays = []
    for i, col in enumerate(cols):
        if np.ndim(col) == 0:
            const[i] = float(col)
        else:
            index[i] = len(arrays)
            arrays.append(_rows(col, w_count, m))
    if len(arrays) == 1:
        stacked = arrays[0][None]  # the one column in place: no copy
    else:
        stacked = np.stack(arrays) if arrays else np.empty((0, w_count, m))
    if offset is None:
        off = np.empty((0, m))
        yy = np.array(np.broadcast_to(target.yy, (w_count, c)), order="C")
    else:
        off = _rows(offset, w_count, m)
        yy = np.empty((w_count, c))
    gram, rhs = np.empty((w_count, c, k, k)), np.empty((w_count, c, k))
    weighted_gram(stacked, const, index, target.w_t, target.wy_t, target.y_t, off, gram, rhs, yy)
    return gram, rhs, yy


def _rows(x, w_count: int, m: int) -> np.ndarray:
    """``x`` as a writable C-contiguous (W, M) array: itself when it is one, else a copy
    (numba compiles, and loads, a signature apart for a read-only or strided array)."""
    x = np.asarray(x, dtype=float)
    if x.shape == (w_count, m) and x.flags.c_contiguous and x.flags.writeable:
        return x
    return np.array(np.broadcast_to(x, (w_count, m)), order="C")


def _numpy_sums(target, cols, offset, w_count: int):
    m, c = target.y.shape
    k = len(cols)
    if offset is None:
        wr = None
        yy = np.broadcast_to(target.yy, (w_count, c))
    else:
        resid = target.y - dense(offset, w_count, m, c)
        wr = target.w * resid
        yy = np.einsum("wmc,wmc->wc", wr, resid)
    gram = np.empty((w_count, c, k, k))
    rhs = np.empty((w_count, c, k))
    for i in range(k):
        rhs[:, :, i] = _cross(target, cols[i], wr, w_count, m)
        for j in range(i, k):
            gram[:, :, i, j] = gram[:, :, j, i] = _gram_entry(target, cols[i], cols[j])
    return gram, rhs, yy


def _gram_entry(target, u, v):
    """``sum_m w_mc u_m v_m`` for two columns, (W, C) or (C,); constants factor out."""
    if np.ndim(u) == 0 and np.ndim(v) == 0:
        return u * v * target.w_sum
    if np.ndim(u) == 0 or np.ndim(v) == 0:
        scalar, col = (u, v) if np.ndim(u) == 0 else (v, u)
        return scalar * _weighted(col, target.w_t)
    return _weighted(u * v, target.w_t)


def _cross(target, u, wr, w_count: int, m: int):
    """``sum_m u_m r_mc`` with ``r = w y`` (``wr`` None) or the weighted residuals
    ``wr`` (W, M, C) left after an offset."""
    if wr is None:
        if np.ndim(u) == 0:
            return u * target.wy_t.sum(axis=1)
        return _weighted(u, target.wy_t)
    if np.ndim(u) == 0:
        return u * wr.sum(axis=1)
    if np.ndim(u) == 3:
        return np.einsum("wmc,wmc->wc", u, wr)
    u = np.broadcast_to(u, (w_count, m))
    return np.matmul(u[:, None, :], wr)[:, 0, :]


def _weighted(col, weights_t):
    """``sum_m col_m w_mc`` (W, C) for ``weights_t`` = ``w`` transposed, (C, M) contiguous.

    One contiguous dot product per channel with einsum, not a matrix product:
    OpenBLAS threads (W, M) x (M, C) products, and on a busy machine its threads
    waiting for a core made them ten times slower and erratic (measured at
    W = 32, M = 10^4, C = 3: 5.7 ms median against 0.7 ms for this, which
    never exceeded 0.9 ms)."""
    if np.ndim(col) == 3:
        return np.einsum("wmc,cm->wc", col, weights_t)
    return np.stack([np.einsum("...m,m->...", col, wc) for wc in weights_t], axis=-1)
