"""The design of a :class:`~brdffit.fitting.problem.Problem` at a batch of walkers'
shape values, for :class:`~brdffit.posterior.target.Target`.

One call of the model's design broadcasts over the batch when the model allows it
(checked once against one-at-a-time calls, :func:`batches_agree`); otherwise the
design is evaluated one walker at a time (:func:`looped_design`). A model whose
design is a compiled lobe ``kd/pi + ks lobe`` (:mod:`brdffit.kernels.bind`) has its
lobe written by its loop straight into the rows of one (W, M) array
(:func:`lobe_design`), without the per-walker mappings and the stacking of the
batched call. Either way the columns of the fixed coefficients are folded into the
offset (:func:`assemble`).
"""

from __future__ import annotations

import importlib

import numpy as np

from ..models.base import INV_PI

__all__ = [
    "NotBatched",
    "assemble",
    "batched_design",
    "batches_agree",
    "compiled_lobe",
    "dense",
    "lobe_design",
    "looped_design",
]


class NotBatched(Exception):
    """The model's design does not broadcast over a batch of shape values."""


def batches_agree(problem, shape_params, shapes: np.ndarray) -> bool:
    """Whether the batched design of ``shapes`` succeeds and equals the looped one."""
    try:
        batched = batched_design(problem, shape_params, shapes)
    except Exception:  # any failure on arrays means: evaluate one walker at a time
        return False
    looped = looped_design(problem, shape_params, shapes)
    w, m, c = len(shapes), problem.geometry.m, problem.n_channels
    for one, two in zip((*batched[0], batched[1]), (*looped[0], looped[1])):
        if (one is None) != (two is None):
            return False
        if one is not None:
            one, two = dense(one, w, m, c), dense(two, w, m, c)
            if one.shape != two.shape or not np.allclose(one, two, 1e-10, 0, equal_nan=True):
                return False
    return True


def _fixed_shape(problem) -> dict:
    return {
        q.name: problem.fixed[q.name]
        for q in problem.model.shape_params
        if q.name in problem.fixed
    }


def batched_design(problem, shape_params, shapes: np.ndarray):
    """The free columns and the offset from one call with (W, 1) shape values."""
    w, m = len(shapes), problem.geometry.m
    params = {q.name: shapes[:, i : i + 1] for i, q in enumerate(shape_params)}
    design = problem.model.design(problem.geometry, {**params, **_fixed_shape(problem)})
    for part in (*design.columns, design.offset):
        if part is not None and np.ndim(part) != 0 and np.shape(part) not in ((m,), (w, m)):
            raise NotBatched
    cols = [float(col) if np.ndim(col) == 0 else np.asarray(col) for col in design.columns]
    return assemble(problem, cols, design.offset)


def looped_design(problem, shape_params, shapes: np.ndarray):
    """The free columns and the offset from one call per row of ``shapes``."""
    p, g = problem, problem.geometry
    designs, fixed = [], _fixed_shape(p)
    for row in shapes:
        params = {q.name: float(v) for q, v in zip(shape_params, row)}
        designs.append(p.model.design(g, {**params, **fixed}))
    two_d = any(np.ndim(x) == 2 for d in designs for x in (*d.columns, d.offset))

    def stack(parts):
        if all(np.ndim(x) == 0 for x in parts) and len({float(x) for x in parts}) == 1:
            return float(parts[0])
        dense = [
            np.broadcast_to(np.asarray(x, dtype=float), (g.m,)) if np.ndim(x) < 2 else x
            for x in parts
        ]
        if two_d:
            dense = [x[:, None] * np.ones(p.n_channels) if x.ndim == 1 else x for x in dense]
        return np.stack(dense)

    cols = [stack([d.columns[j] for d in designs]) for j in range(len(designs[0].columns))]
    offsets = [d.offset for d in designs]
    offset = (
        None
        if all(o is None for o in offsets)
        else stack([0.0 if o is None else o for o in offsets])
    )
    return assemble(problem, cols, offset)


def compiled_lobe(problem):
    """The compiled lobe of the problem's model (the ``_Lobe`` of
    :mod:`brdffit.kernels.bind`: its loop, inputs and shape arguments), or None when
    its design is not one."""
    design = problem.model.design
    lobe = getattr(design, "compiled", None)
    if not all(hasattr(lobe, name) for name in ("loop", "loops", "prepare", "shape")):
        return None
    if getattr(design, "minimum", None) is not None:
        return None
    return lobe


def lobe_runs(problem, lobe) -> bool:
    """Whether the compiled lobe runs on the problem's geometry now: the kernels on
    and, by default, from :data:`brdffit.kernels.MIN_PAIRS` values (pairs times
    channels) on, the rule of the weighted sums (:mod:`brdffit.posterior.gram`): where
    those load numba, the lobe's loop costs little more, and thousands of designs
    repay it (a fit's own design counts pairs only)."""
    from .. import kernels

    values = problem.geometry.m * problem.n_channels
    return kernels.wanted(values, modules=problem.model.design.modules)


def lobe_design(problem, lobe, shape_params, shapes: np.ndarray):
    """The free columns and the offset of a compiled lobe's design ``(1/pi, lobe)``
    at every row of ``shapes``: the lobe of each walker written by its loop into a
    row of one (W, M) array (what the batched call computes, the same values)."""
    g = problem.geometry
    loop = getattr(importlib.import_module(f"brdffit.kernels.{lobe.loops}"), lobe.loop)
    inputs, shape_of, fixed = lobe.prepare(g), lobe.shape, _fixed_shape(problem)
    names = [q.name for q in shape_params]
    rows = np.empty((len(shapes), g.m))
    for row, values in zip(rows, shapes.tolist()):
        params = dict(zip(names, values))
        params.update(fixed)
        loop(*inputs, *shape_of(params), 1.0, 0.0, row)
    return assemble(problem, [INV_PI, rows], None)


def assemble(problem, cols, offset):
    """The free columns, and the offset with the fixed coefficients' columns added.

    A column is a float (constant), an (M,) array (the same for every walker),
    (W, M), or (W, M, C) when it differs per channel. The offset is None,
    (M,), (W, M), (W, M, C) or (1, M, C): a coefficient fixed per channel times a
    column the same for every walker (a constant or (M,) column times (C,) values
    made a (C,) or (M, C) offset, read as (M,) or (W, M)).
    """
    p = problem
    for i, name in zip(p.fixed_index, p.fixed_coefs):
        value = np.asarray(p.fixed[name], dtype=float)
        col = np.asarray(cols[i], dtype=float)
        if value.ndim and col.ndim < 2:
            col = np.broadcast_to(col, (1, p.geometry.m))
        term = col[..., None] * value if value.ndim else col * float(value)
        offset = term if offset is None else _add(np.asarray(offset, dtype=float), term)
    return [cols[i] for i in p.coef_index], offset


def _add(a, b):
    """Sum of two offsets; an (M,) or (W, M) one is broadcast over channels of a (W, M, C) one."""
    if a.ndim != b.ndim and 3 in (a.ndim, b.ndim):
        a, b = (a, b[..., None]) if a.ndim == 3 else (a[..., None], b)
    return a + b


def dense(x, w: int, m: int, c: int) -> np.ndarray:
    """A column or offset as a (W, M, C) array (a view where broadcasting allows)."""
    x = np.asarray(x, dtype=float)
    if x.ndim == 3:
        return np.broadcast_to(x, (w, m, c))
    return np.broadcast_to(np.broadcast_to(x, (w, m))[..., None], (w, m, c))
