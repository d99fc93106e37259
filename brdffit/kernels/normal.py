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

import numpy as np

__all__ = ["assemble", "from_prepared", "lobe_column", "prepare_targets", "prepare_weights"]


def _loops():
    from . import loops

    return loops


def prepare_weights(w) -> tuple:
    """``S0`` and the weights as the loops read them, from ``w`` (None, (M,) or
    (M, C)): (M,) as they are, (M, C) transposed to (C, M) and contiguous, None as
    an empty array. Made once per problem (a fit solves the same targets thousands
    of times); ``w`` is not needed after it."""
    if w is None:
        return None, np.empty(0)
    if w.ndim == 1:
        return float(np.sum(w)), np.ascontiguousarray(w, dtype=float)
    w_t = np.ascontiguousarray(w.T, dtype=float)
    return w_t.sum(axis=1), w_t


def prepare_targets(wy) -> tuple:
    """``T0`` and the weighted targets ``wy`` (M, C) transposed to (C, M), contiguous
    (numpy sums an (M, C) array's columns one row at a time: 32 ms on a MERL file's
    targets, 2 ms on a row each); ``wy`` is not needed after it."""
    wy_t = np.ascontiguousarray(wy.T, dtype=float)
    return wy_t.sum(axis=1), wy_t


def from_prepared(columns: list, lobe: np.ndarray, prepared: tuple, yy, normal_class):
    """``normal_class(gram (C, K, K), rhs (C, K), yy (C,))`` from ``columns`` (K items,
    each a float or an (M,) array, exactly one array: ``lobe``, contiguous, as
    :func:`lobe_column` gives it), the weights' and targets' ``prepared = (S0, w, T0,
    wy_t)`` (:func:`prepare_weights`, :func:`prepare_targets`; ``S0`` None for unit
    weights) and ``yy = y^T W y`` (C,).
    With weights per channel (the ``mixed`` and ``log`` losses weigh every value by
    its own) every sum is per channel: ``S0_c = sum_m w_mc``, ``S1_c``, ``S2_c``."""
    s0, w, t0, wy_t = prepared
    if s0 is None:
        s0 = float(len(lobe))
    if w.ndim == 1:
        s1, s2, t1 = _loops().moments(lobe, w, wy_t)
    else:
        s1, s2, t1 = _loops().moments_by_channel(lobe, w, wy_t)
    return assemble(columns, (s0, s1, s2), t0, t1, yy, normal_class)


def lobe_column(columns: list):
    """The one array column (M,) of ``columns``, contiguous; None when they have not
    exactly one (then the caller stacks them)."""
    arrays = [col for col in columns if np.ndim(col)]
    if len(arrays) != 1 or arrays[0].ndim != 1:
        return None
    return np.ascontiguousarray(arrays[0], dtype=float)


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
