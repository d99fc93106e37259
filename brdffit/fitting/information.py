"""The Fisher information of a fit and what the identifiability check needs of it.

:mod:`brdffit.fitting.identifiability` forms ``F = J^T W J`` (Bates and Watts,
*Nonlinear Regression Analysis and Its Applications*, Wiley 1988, sections 2.2 and
3.5) from the Jacobian of the residuals, whose columns are of two kinds: a shape
parameter's column fills every channel's residuals, (M, C); a linear coefficient of
channel ``c`` fills channel ``c``'s only. So ``F`` has a structure that a dense
product ignores: the coefficients of two different channels never meet, and every
entry is a sum over the samples of one channel (or over every channel, between two
shape parameters).

:func:`channel_information` forms ``F`` from the per-channel sums
``G[k, l, c] = sum_m A_k[m, c] A_l[m, c]`` of a handful of (M, C) sources (a shape
column, or a linear parameter's column in every channel at once): ``K (K + 1) / 2``
reductions for K sources, instead of one column per coefficient and channel (63 for
a 31-band fit of ``kd`` and ``ks``). The tests hold it to the plain way, the product
of the columns themselves (``helpers.plain_information``).

:func:`inverse_diagonal` gives the diagonal of the inverse of the unit-diagonal
information when that diagonal and the existence of a Cholesky factor prove that no
eigenvalue lies below ``rtol`` of the largest (the check's rank test), and None
otherwise, where the check takes the eigendecomposition: the same verdict, at a third
of its cost for 63 parameters.
"""

from __future__ import annotations

import math

import numpy as np

from .channels import dot_by_channel

__all__ = [
    "CERTIFY_MARGIN",
    "by_parameter",
    "channel_information",
    "coefficient_diagonal",
    "inverse_diagonal",
    "judge",
    "linearised",
    "null_and_variance",
    "residual_variance",
]

#: :func:`inverse_diagonal` answers only when the smallest eigenvalue is proved to be at
#: least this many times ``rtol`` times the largest: far above the rounding of the
#: factor, the inverse and of the eigendecomposition it stands in for.
CERTIFY_MARGIN = 100.0


def channel_information(sources: list, layout: list, sqrt_w: np.ndarray | None) -> np.ndarray:
    """``J^T W J`` from (M, C) ``sources`` and the ``layout`` of the Jacobian's columns.

    Parameters
    ----------
    sources : list of ndarray (M, C)
        Derivatives of the prediction: a shape parameter's, or a linear parameter's
        in every channel (each channel's column by its own coefficient).
    layout : list of (int, int)
        Per column of ``J``: the source it comes from and its channel, or -1 for a
        column that fills every channel (a shape parameter).
    sqrt_w : ndarray (M, C) or None
        Square roots of the weights; None for unit weights.

    Returns
    -------
    ndarray (P, P)
        The information of the ``P = len(layout)`` columns.
    """
    if sqrt_w is not None:
        sources = [s * sqrt_w for s in sources]
    k, c = len(sources), sources[0].shape[1]
    gram = np.empty((k, k, c + 1))  # the last slot: the sum over the channels
    for i in range(k):
        for j in range(i, k):
            gram[i, j, :c] = gram[j, i, :c] = dot_by_channel(sources[i], sources[j])
    gram[:, :, c] = gram[:, :, :c].sum(axis=2)
    source = np.array([s for s, _ in layout])
    channel = np.array([ch for _, ch in layout])
    coef = channel >= 0
    row_coef, col_coef = coef[:, None], coef[None, :]
    slot = np.where(row_coef, channel[:, None], np.where(col_coef, channel[None, :], c))
    info = gram[source[:, None], source[None, :], slot]
    info[row_coef & col_coef & (channel[:, None] != channel[None, :])] = 0.0
    return info


def coefficient_diagonal(sources: list, layout: list, sqrt_w: np.ndarray | None):
    """The diagonal (P,) of :func:`channel_information` where the information is
    diagonal, else None: every column a coefficient of one source (one linear
    parameter, no shape parameter), each in its own channel, so that no two columns
    meet. Its entries are those of :func:`channel_information` (the same sums), without
    the (P, P) matrix nor, in :func:`null_and_variance`, its factorisation."""
    channels = [c for _, c in layout]
    if len(sources) != 1 or min(channels) < 0 or len(set(channels)) < len(channels):
        return None
    source = sources[0] if sqrt_w is None else sources[0] * sqrt_w
    return dot_by_channel(source, source)[channels]


def inverse_diagonal(unit: np.ndarray, rtol: float) -> np.ndarray | None:
    """The diagonal of ``unit^-1`` when ``unit`` (symmetric, unit diagonal) is proved to
    have no eigenvalue below ``rtol`` of its largest; None when it is not.

    When ``unit`` is positive definite (its Cholesky factor exists), the sum of the
    diagonal of its inverse is ``trace(unit^-1) = sum 1 / lambda``, so the smallest
    eigenvalue is at least ``1 / trace(unit^-1)``; the largest is at most
    ``trace(unit) = P``. The proof asks ``1 / trace(unit^-1) >= CERTIFY_MARGIN rtol P``
    (Golub and Van Loan, *Matrix Computations*, 4th ed., sections 2.3 and 4.2). A
    matrix that is not numerically positive definite fails the factorisation: None.
    """
    try:
        np.linalg.cholesky(unit)  # positive definite, or no proof
    except np.linalg.LinAlgError:
        return None
    diagonal = np.diag(np.linalg.inv(unit)).copy()  # 120 us, the factor's inverse 160 us
    total = float(diagonal.sum())
    if not np.isfinite(total) or total * CERTIFY_MARGIN * rtol * len(unit) > 1.0:
        return None
    return diagonal


def null_and_variance(unit: np.ndarray, rtol: float, shortcut: bool = True) -> tuple:
    """The null directions of ``unit`` (symmetric, unit diagonal), the eigenvectors of
    eigenvalues below ``rtol`` of the largest, each as the positions with weight in it,
    and the diagonal of the pseudo-inverse without them. With ``shortcut``, by the
    Cholesky factor where it proves there is none (:func:`inverse_diagonal`).

    A 1-D ``unit`` is the diagonal of a diagonal matrix (:func:`coefficient_diagonal`):
    with ``shortcut``, finite and positive entries are its eigenvalues, the proof of
    :func:`inverse_diagonal` is their reciprocals' sum, and the variances those
    reciprocals; anything else is answered for the (P, P) matrix."""
    if unit.ndim == 1:
        inverse = _diagonal_inverse(unit, rtol) if shortcut else None
        if inverse is not None:
            return [], inverse
        unit = np.diag(unit)
    variance = inverse_diagonal(unit, rtol) if shortcut else None
    if variance is not None:
        return [], variance
    eigval, eigvec = np.linalg.eigh(unit)
    null = eigval < rtol * eigval.max()
    sets = []
    for k in np.flatnonzero(null):
        weight = eigvec[:, k] ** 2
        sets.append(np.flatnonzero(weight > 0.01 * weight.max()))
    keep = ~null
    cov = (eigvec[:, keep] / eigval[keep]) @ eigvec[:, keep].T
    return sets, np.diag(cov)


def _diagonal_inverse(diagonal: np.ndarray, rtol: float) -> np.ndarray | None:
    """:func:`inverse_diagonal` of the diagonal matrix of ``diagonal``: its reciprocals
    where every entry is finite and positive (the Cholesky factor exists) and their sum
    passes the same proof; else None."""
    if not (np.isfinite(diagonal).all() and (diagonal > 0).all()):
        return None
    inverse = 1.0 / diagonal
    total = float(inverse.sum())
    if not np.isfinite(total) or total * CERTIFY_MARGIN * rtol * len(diagonal) > 1.0:
        return None
    return inverse


def by_parameter(out: dict) -> dict:
    """The identifiability check's reasons by name, its per-channel entries (``kd[r]``)
    gathered under their parameter's name."""
    merged: dict = {}
    for name, why in out.items():
        base, bracket, channel = name.partition("[")
        if bracket:
            merged.setdefault(base, {}).setdefault(why, []).append(channel.rstrip("]"))
        else:
            merged[name] = {why: []}
    return {
        name: "; ".join(
            why if not channels else f"channel(s) {', '.join(channels)}: {why}"
            for why, channels in reasons.items()
        )
        for name, reasons in merged.items()
    }


def judge(names, kinds, info, params, rtol: float, max_width: float) -> dict:
    """The identifiability check's verdicts (:mod:`brdffit.fitting.identifiability`):
    null directions (eigenvalues below ``rtol`` of the largest) of the unit-diagonal
    information ``info`` (its diagonal where it is diagonal: ``coefficient_diagonal``),
    then the shape parameters' relative widths above ``max_width``. A diagonal one of
    coefficients alone (no width to judge) is answered in floats where it can be
    (:func:`_coefficients_dead`: the same operations, so the same verdicts)."""
    if info.ndim == 1 and len(info) < 8 and all(kind == "coef" for kind in kinds):
        dead = _coefficients_dead(info.tolist(), rtol)
        if dead is not None:
            return by_parameter(dict.fromkeys([names[i] for i in dead], DEAD))
    out, diagonal = {}, info.ndim == 1 and np.isfinite(info).all()  # else as a matrix:
    info = np.diag(info) if info.ndim == 1 and not diagonal else info  # the plain way's
    scale = np.sqrt(info if diagonal else np.diag(info))
    dead = scale <= 1e-300 * max(scale.max(), 1e-300)
    for i in np.flatnonzero(dead):
        out[names[i]] = DEAD
    live = np.flatnonzero(~dead)
    if live.size == 0:
        return by_parameter(out)
    # a diagonal one's entries are the plain way's (its others are 0)
    unit = (info[live] / (scale[live] * scale[live]) if diagonal
            else info[np.ix_(live, live)] / np.outer(scale[live], scale[live]))  # fmt: skip
    null_sets, variance = null_and_variance(unit, rtol)
    for positions in null_sets:
        involved = [live[i] for i in positions]
        for i in involved:
            others = [names[j] for j in involved if j != i]
            out.setdefault(
                names[i],
                "the data do not separate it from "
                + (", ".join(others) or "nothing")
                + " (their combination leaves the fit unchanged: the Fisher information is "
                "singular)",
            )
    for pos, i in enumerate(live):
        if names[i] in out or kinds[i] == "coef":
            continue
        sd = math.sqrt(max(variance[pos], 0.0)) / scale[i]
        value = float(params[names[i]])
        width = math.log(10.0) * sd if kinds[i] == "log" else sd / max(abs(value), 1e-300)
        if width <= max_width:
            continue
        if kinds[i] == "log":
            spread = f"a relative width of {width:.3g}"
        else:  # at or near 0 a relative width says nothing (it was printed as 1e+297)
            spread = f"{value:.3g} +- {sd:.3g}, a relative width above {max_width:g}"
        out[names[i]] = (
            f"the data constrain it only to {spread} (1 sigma, from the Fisher information)"
        )
    return by_parameter(out)


#: The verdict on a parameter whose column of the Jacobian is zero.
DEAD = "the fitted model does not change with it at the data's directions"


def _coefficients_dead(values: list, rtol: float) -> list | None:
    """:func:`judge`'s dead positions of a diagonal information ``values`` whose every
    column is a coefficient, by the operations of its arrays on floats (square roots,
    the dead test, the unit entries and :func:`_diagonal_inverse`'s proof); None where
    judge's arrays decide (a value not finite and >= 0, a unit entry not finite and positive, or
    the proof failing). The proof's sum is taken in another order than numpy's, which
    cannot change it: every unit entry is 1 to rounding, the sum about its count (at
    most 7), far below the ``1 / (CERTIFY_MARGIN rtol P)`` it is held to."""
    if not all(math.isfinite(v) and v >= 0 for v in values):  # sums of squares
        return None
    scale = [math.sqrt(v) for v in values]
    floor = 1e-300 * max(max(scale), 1e-300)
    dead, total, live = [], 0.0, 0
    for i, (v, s) in enumerate(zip(values, scale)):
        if s <= floor:
            dead.append(i)
            continue
        unit = v / (s * s)
        if not (math.isfinite(unit) and unit > 0):
            return None
        total, live = total + 1.0 / unit, live + 1
    if live and (not math.isfinite(total) or total * CERTIFY_MARGIN * rtol * live > 1.0):
        return None
    return dead


def linearised(loss, ref: np.ndarray, ctx, unit: bool):
    """The identifiability check's weights (None for ``unit``: l2 without weights) and
    target of ``loss`` linearised at ``ref``, the weights in ``ref``'s shape (a
    broadcast only where they are not: 3 us for nothing)."""
    if unit:
        return None, ctx.y
    w, target = loss.linearised(ref, ctx)
    if np.shape(w) != ref.shape:
        w = np.broadcast_to(w if np.ndim(w) == 2 else np.asarray(w)[:, None], ref.shape)
    return w, target


def residual_variance(loss, target: np.ndarray, base, w, dof: float) -> float:
    """The identifiability check's scale of the information: 1 with sigma, else the
    residual variance of the fit's values ``base`` about ``target`` (weighted by ``w``
    unless None) over ``dof``."""
    if loss.needs_sigma:
        return 1.0
    d = np.subtract(target, base)
    total = np.einsum("mc,mc->", d, d) if w is None else np.einsum("mc,mc,mc->", w, d, d)
    return float(total) / dof
