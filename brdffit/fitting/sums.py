"""The sums of squares behind a fit's metrics: every loss of
:data:`~brdffit.fitting.losses.LOSSES` at one prediction, in one pass over blocks of
samples.

A full MERL file has 3.3 million values; each loss formed on all of them at once
takes a dozen passes over arrays of 26 MB (the residual, the projected values,
their logarithms and cube roots, their squares), which run at the speed of main
memory. Here the same expressions run on blocks of :data:`BLOCK` samples, whose
temporaries stay in the processor's cache, and the partial sums are added: the
same numbers to round-off (the order of the additions differs).

Each quantity is formed once per block: the residual ``d = f - y`` serves every
loss whose transform is linear in ``f`` (``t(f) - t(y) = t(d)``: l2, cosine,
relative, chi2, mixed), and ``f cos(theta_i)`` and ``y cos(theta_i)`` serve both
non-linear ones (log and cbrt; :mod:`brdffit.fitting.losses` gives each formula,
from Löw et al. 2012 and Forés et al. 2012).
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np

from .. import kernels
from .channels import einsum
from .losses import LOSSES, LossContext

__all__ = ["BLOCK", "loss_sums"]

#: Samples per block of the compiled path: a block's (BLOCK, 3) arrays of doubles take
#: 384 KB.
BLOCK = 16_384
#: Values per block of numpy's path (data below ``kernels.MIN_PAIRS`` samples).
VALUES = 16_384


#: The fields of a loss context (``dataclasses.fields`` at every call: 2 us).
_FIELDS = fields(LossContext)


@dataclass(frozen=True)
class _BlockContext(LossContext):
    """A block's loss context; ``y_scale`` (the relative loss's per-channel scale) is
    that of all the samples, not of the block."""

    whole_scale: np.ndarray | None = None

    @property
    def y_scale(self) -> np.ndarray:
        return self.whole_scale


def loss_sums(pred: np.ndarray, ctx: LossContext) -> dict:
    """``sum_m w_m sum_c (t(f_mc) - t(y_mc))^2`` of every loss that ``ctx`` allows (chi2
    needs sigma, mixed the noise model's sigma), and ``rss``, the unweighted sum of
    squared residuals, for predictions ``pred`` (M, C) against ``ctx.y``."""
    names = _names(ctx)
    pred = np.asarray(pred, dtype=float)
    y = np.asarray(ctx.y, dtype=float)
    if pred.ndim == 1:
        pred, y = pred[:, None], y.reshape(len(y), -1)
    if kernels.wanted(len(y), modules=("loops_sums",)):  # samples, as models count pairs
        return _compiled(pred, y, ctx, names)
    if 0 < len(y) <= max(1, VALUES // y.shape[1]):  # one block: _by_blocks' sums, 10 us less
        # (a block's slices are the whole arrays, its y_scale the context's own)
        sums = _block_sums(pred, ctx if ctx.y is y else _whole(ctx, names), names)
        return {name: sums[name] for name in [*names, "rss"]}
    return _by_blocks(pred, y, ctx, _whole(ctx, names), names)


def _names(ctx: LossContext) -> list:
    """The losses that ``ctx`` allows (chi2 needs sigma, mixed the noise model's sigma)."""
    return [
        name
        for name, loss in LOSSES.items()
        if not (loss.needs_sigma and ctx.sigma is None)
        and not (loss.needs_noise and ctx.noise_sigma is None)
    ]


def _whole(ctx: LossContext, names: list) -> _BlockContext:
    """``ctx`` as the context of a block of all the samples."""
    return _BlockContext(**{f.name: getattr(ctx, f.name) for f in _FIELDS},
                         whole_scale=ctx.y_scale if "relative" in names else None)  # fmt: skip


def _by_blocks(pred, y, ctx: LossContext, whole: _BlockContext, names: list) -> dict:
    """:func:`loss_sums` block by block: the plain way, which the tests hold it to."""
    per_sample = [f.name for f in _FIELDS
                  if isinstance(getattr(ctx, f.name), np.ndarray)
                  and getattr(ctx, f.name).shape[:1] == y.shape[:1]]  # fmt: skip
    totals = dict.fromkeys([*names, "rss"], 0.0)
    rows = max(1, VALUES // y.shape[1])
    for start in range(0, len(y), rows):
        block = slice(start, start + rows)
        part = replace(whole, **{name: getattr(whole, name)[block] for name in per_sample})
        for name, value in _block_sums(pred[block], part, names).items():
            totals[name] += value
    return totals


def _compiled(pred: np.ndarray, y: np.ndarray, ctx: LossContext, names: list) -> dict:
    """:func:`loss_sums` with the linear losses summed by the compiled loop of
    :mod:`brdffit.kernels.loops_sums`, and the log and cbrt ones by numpy on blocks
    of the values it writes: ``ln`` of the ratio ``max(1 + f cos, 1e-12) / max(1 + y
    cos, 1e-12)`` (the difference of the two logarithms of :func:`_block_sums`,
    to rounding) and the cube roots of ``f cos`` and ``y cos``."""
    from ..kernels import loops_sums

    def per_value(a):
        if a is None:
            return np.empty((0, 0))
        a = np.asarray(a, dtype=float)
        return np.ascontiguousarray(np.broadcast_to(a.reshape(len(a), -1), y.shape))

    pred, y = np.ascontiguousarray(pred), np.ascontiguousarray(y)
    cos = np.ascontiguousarray(ctx.cos_i, dtype=float)
    w = None if ctx.weights is None else np.ascontiguousarray(ctx.weights, dtype=float)
    scale = 1e-3 * np.broadcast_to(ctx.y_scale, y.shape[1:]).astype(float)
    linear, every_w = np.zeros(len(loops_sums.NAMES)), np.empty(0) if w is None else w
    sigma, noise = per_value(ctx.sigma), per_value(ctx.noise_sigma)
    totals = dict(log=0.0, cbrt=0.0)
    buffers = np.empty((3, BLOCK, y.shape[1]))
    for start in range(0, len(y), BLOCK):
        size = min(BLOCK, len(y) - start)
        fc, yc, ratio = buffers[:, :size]
        loops_sums.sums_and_project(pred, y, cos, every_w, scale, sigma, noise, start,
                                    fc, yc, ratio, linear)  # fmt: skip
        weights = None if w is None else w[start : start + size]
        totals["log"] += _row_squares(np.log(ratio, out=ratio), weights)
        np.cbrt(fc, out=fc)
        totals["cbrt"] += _row_squares(np.subtract(fc, np.cbrt(yc, out=yc), out=fc), weights)
    totals.update(zip(loops_sums.NAMES, linear.tolist()))
    return {name: totals[name] for name in [*names, "rss"]}


def _row_squares(d: np.ndarray, weights) -> float:
    """``sum_b w_b sum_c d_bc^2`` of ``d`` (B, C)."""
    if weights is None:
        return float(einsum("bc,bc->", d, d))
    return float(einsum("bc,bc,b->", d, d, weights))


def _block_sums(pred: np.ndarray, ctx: LossContext, names: list) -> dict:
    """The sums of one block, in four arrays of its size (each op writes into one: fresh
    temporaries of a 31-band fit's 44,600 values cost page faults, 1 us each 4 KB): the
    residual and a scratch array, then ``f cos`` and ``y cos`` in the same two, whose
    log and cbrt terms are formed for both at once (the same values, half the calls)."""
    pair = np.empty((2, *np.shape(pred)))
    resid, scratch = np.subtract(pred, ctx.y, out=pair[0]), pair[1]
    w = ctx.weights
    out = {"rss": _sum_of_squares(resid, None)}
    cos = np.asarray(ctx.cos_i, dtype=float)[:, None]  # as (M, C) values where it serves
    if cos.size != pair[0].size and ("cosine" in names or "log" in names or "cbrt" in names):
        cos = np.repeat(cos, pair.shape[2], axis=1)  # three products of contiguous values,
    for name in names:  # not of rows of C against one (the same products, 4 us less)
        loss = LOSSES[name]
        if name == "l2" and w is None:
            out[name] = out["rss"]
        elif name == "cosine":
            out[name] = _sum_of_squares(np.multiply(resid, cos, out=scratch), w)
        elif name == "relative":
            out[name] = _sum_of_squares(_relative_in(resid, ctx, scratch), w)
        elif loss.linear:
            out[name] = _sum_of_squares(loss.transform(resid, ctx), w)
        elif name not in _PROJECTED:
            diff = loss.transform(pred, ctx) - loss.transform(ctx.y, ctx)
            out[name] = _sum_of_squares(diff, w)
    if "log" in names or "cbrt" in names:  # f cos and y cos, in the two arrays
        both = pair
        np.multiply(pred, cos, out=both[0]), np.multiply(ctx.y, cos, out=both[1])
        if "log" in names:  # ln(max(1 + f cos, 1e-12)) - ln(max(1 + y cos, 1e-12))
            t = np.add(both, 1.0)
            np.log(np.maximum(t, 1e-12, out=t), out=t)
            out["log"] = _sum_of_squares(np.subtract(t[0], t[1], out=t[0]), w)
        if "cbrt" in names:  # cbrt(f cos) - cbrt(y cos)
            np.cbrt(both, out=both)
            out["cbrt"] = _sum_of_squares(np.subtract(both[0], both[1], out=both[0]), w)
    return out


def _relative_in(d, ctx, out):
    """The relative loss's ``d / max(|y|, 1e-3 max|y|)``, written into ``out``."""
    scale = np.maximum(np.abs(ctx.y, out=out), 1e-3 * ctx.y_scale, out=out)
    return np.divide(d, scale, out=out)


#: The non-linear losses computed from ``f cos`` and ``y cos`` formed once (the tests
#: of the metrics hold them to each loss's own value).
_PROJECTED = ("log", "cbrt")


def _sum_of_squares(d: np.ndarray, weights) -> float:
    """``sum_m w_m sum_c d_mc^2`` without a squared copy of ``d``."""
    d = np.asarray(d, dtype=float)
    if d.ndim == 1:
        d = d[:, None]
    if weights is None:
        return float(einsum("mc,mc->", d, d))
    return float(einsum("mc,mc,m->", d, d, np.asarray(weights, dtype=float)))
