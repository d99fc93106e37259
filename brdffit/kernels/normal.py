"""The normal equations of the variable projection without the design matrix.

For the models ``kd/pi + ks * lobe`` (and any design whose columns are constants
but one), ``Problem`` used to stack the columns into an (M, K) matrix and form
``A^T W A`` and ``A^T W y`` from it: two passes over a matrix it built for them
(measured on a whole MERL file: three quarters of a fit's time). With one array
column ``l`` and constant columns ``c_j`` everything they need is five sums, taken
in one compiled pass over ``l``, the weights and the weighted targets::

    S0 = sum w,  S1 = sum w l,  S2 = sum w l^2,  T0_c = sum (W y)_c,  T1_c = sum (W y)_c l

``gram[j, k] = c_j c_k S0``, ``c_j S1`` or ``S2``; ``rhs[c, j] = c_j T0_c`` or
``T1_c`` (the normal equations of weighted least squares; e.g. Golub and Van Loan,
Matrix Computations, 4th ed., section 5.3). Sums run in the loop's order, not
numpy's pairwise order: they differ by rounding (relative 1e-16 times the square
root of the number of samples at worst).
"""

from __future__ import annotations

import weakref

import numpy as np

__all__ = ["assemble", "normal_equations"]


def _loops():
    from . import loops

    return loops


#: One entry, the problem being fitted: weak references to its weights (None when
#: unweighted) and weighted targets, and the values derived from them.
_constant_cache: list = []


def _constants(w, wy) -> tuple:
    """``S0``, ``T0``, the weighted targets transposed to (C, M) and, for weights per
    channel (M, C), the weights transposed (else None), contiguous, for the loops'
    per-channel sums; computed once per (weights, targets) (a fit solves the same
    targets thousands of times). The cache refers to the arrays weakly, so it does not
    keep a finished problem's arrays alive."""
    for ref_w, ref_wy, values in _constant_cache:
        if ref_wy() is wy and (w is None if ref_w is None else ref_w() is w):
            return values
    # The per-channel sums from the transposed copies: numpy sums an (M, C) array's
    # columns one row at a time (32 ms on a MERL file's targets, 2 ms on a row each).
    if w is None:
        s0, w_t = float(wy.shape[0]), None
    elif w.ndim == 1:
        s0, w_t = float(np.sum(w)), None
    else:
        w_t = np.ascontiguousarray(w.T, dtype=float)
        s0 = w_t.sum(axis=1)
    wy_t = np.ascontiguousarray(wy.T, dtype=float)
    values = (s0, wy_t.sum(axis=1), wy_t, w_t)
    _constant_cache[:] = [(None if w is None else weakref.ref(w), weakref.ref(wy), values)]
    weakref.finalize(wy, _constant_cache.clear)  # the copies go with the targets
    return values


def normal_equations(columns: list, y: np.ndarray, w, weighted, normal_class):
    """``normal_class(gram (C, K, K), rhs (C, K), yy (C,))`` from ``columns`` (K items,
    each a float or an (M,) array, at most one array), targets ``y`` (M, C), weights
    ``w`` (None, (M,) or (M, C): the ``mixed`` loss weighs every value by its own
    sigma) and ``weighted = (W y, y^T W y)``; None when the columns are not of that
    form (then the caller stacks them). With weights per channel every sum is per
    channel: ``S0_c = sum_m w_mc``, ``S1_c``, ``S2_c`` likewise."""
    arrays = [col for col in columns if np.ndim(col)]
    if len(arrays) != 1 or arrays[0].ndim != 1:
        return None
    if w is not None and not (w.ndim == 1 or w.shape == y.shape):
        return None
    wy, yy = weighted
    s0, t0, wy_t, w_t = _constants(w, wy)
    lobe = np.ascontiguousarray(arrays[0], dtype=float)
    if w_t is None:
        weights = np.empty(0) if w is None else np.ascontiguousarray(w, dtype=float)
        s1, s2, t1 = _loops().moments(lobe, weights, wy_t)
    else:
        s1, s2, t1 = _loops().moments_by_channel(lobe, w_t, wy_t)
    return assemble(columns, (s0, s1, s2), t0, t1, yy, normal_class)


def assemble(columns: list, s: tuple, t0, t1, yy, normal_class):
    """``normal_class(gram, rhs, yy)`` from the sums of the module: ``s = (S0, S1, S2)``,
    ``t0``, ``t1`` and ``yy``, each a float or (C,), for ``columns`` (K items, each a
    float or the one (M,) array column)."""
    k, c = len(columns), np.shape(yy)[0]
    gram = np.empty((c, k, k))
    rhs = np.empty((c, k))
    for j, cj in enumerate(columns):
        for i, ci in enumerate(columns):
            if np.ndim(cj) and np.ndim(ci):
                gram[:, j, i] = s[2]
            elif np.ndim(cj) or np.ndim(ci):
                gram[:, j, i] = s[1] * float(ci if np.ndim(cj) else cj)
            else:
                gram[:, j, i] = s[0] * float(cj) * float(ci)
        rhs[:, j] = t1 if np.ndim(cj) else t0 * float(cj)
    return normal_class(gram, rhs, yy)
