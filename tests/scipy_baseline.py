"""The obvious alternative to brdffit's engine: scipy.optimize.least_squares over
every parameter (shape and per-channel linear), multi-start within the same
bounds. Used by tests/test_fit_real.py as the loss to beat and by
benchmarks/bench_fit.py as the speed baseline.

Written to be careful, not naive: log-scale parameters are searched in log10,
the Jacobian's sparsity is given (channel c's residuals depend on the shape
parameters and on channel c's linear parameters only, so finite differences
need few evaluations), and the geometry is prepared once, so that a speed
comparison measures the algorithms, not brdffit's geometry caching.
"""

from __future__ import annotations

import time

import numpy as np
from scipy.optimize import least_squares
from scipy.sparse import lil_matrix

from brdffit import get_model


def baseline_fit(data, model, starts: int = 4, seed: int = 0, max_nfev: int = 200, fixed=None):
    """Best of ``starts`` least_squares runs; returns (params, mean squared error,
    evaluations, seconds). ``fixed``: parameters held at given values, as brdffit
    holds them (``FitResult.fixed``: he's material constants and wavelengths)."""
    t0 = time.perf_counter()
    model = get_model(model)
    geometry = data.geometry()
    y = np.asarray(data.values, dtype=float)
    n, c = y.shape
    fixed = dict(fixed or {})
    shape = [p for p in model.shape_params if not p.per_channel and p.name not in fixed]
    linear = [p for p in model.linear_params if p.name not in fixed]
    lo = [np.log10(p.lower) if p.log_scale else p.lower for p in shape]
    hi = [np.log10(p.upper) if p.log_scale else p.upper for p in shape]
    for p in linear:
        lo += [p.lower] * c
        hi += [min(p.upper, 1e4)] * c
    lo, hi = np.array(lo), np.array(hi)

    def unpack(x):
        params = dict(fixed)
        for i, p in enumerate(shape):
            params[p.name] = float(np.clip(10 ** x[i] if p.log_scale else x[i], p.lower, p.upper))
        for j, p in enumerate(linear):
            block = x[len(shape) + j * c : len(shape) + (j + 1) * c]
            params[p.name] = np.clip(block, p.lower, p.upper)
        return params

    n_evals = [0]

    def residuals(x):
        n_evals[0] += 1
        f = np.asarray(model.evaluate_prepared(geometry, unpack(x), check=False))
        if f.ndim == 1:
            f = np.repeat(f[:, None], c, axis=1)
        r = (f - y).ravel()
        return np.where(np.isfinite(r), r, 1e10)

    sparsity = lil_matrix((n * c, len(lo)), dtype=int)
    sparsity[:, : len(shape)] = 1
    rows = np.arange(n * c).reshape(n, c)
    for j in range(len(linear)):
        for ch in range(c):
            sparsity[rows[:, ch], len(shape) + j * c + ch] = 1

    rng = np.random.default_rng(seed)
    best = None
    for k in range(starts):
        if k == 0:
            x0 = [np.log10(p.default) if p.log_scale else p.default for p in shape]
        else:
            x0 = list(rng.uniform(lo[: len(shape)], hi[: len(shape)]))
        for p in linear:
            x0 += [min(max(p.default, p.lower), p.upper)] * c
        x0 = np.clip(np.array(x0, dtype=float), lo, hi)
        sol = least_squares(
            residuals,
            x0,
            bounds=(lo, hi),
            jac_sparsity=sparsity,
            x_scale="jac",
            ftol=1e-12,
            xtol=1e-12,
            gtol=1e-12,
            max_nfev=max_nfev,
            method="trf",
        )
        mse = float(np.mean(sol.fun**2))
        if best is None or mse < best[1]:
            best = (unpack(sol.x), mse)
    return best[0], best[1], n_evals[0], time.perf_counter() - t0


def projected_baseline_fit(data, model, starts: int = 6, seed: int = 0):
    """least_squares over the shape parameters only (log10 where log-scale), from
    ``starts`` starts, with the linear parameters of each channel solved by
    scipy.optimize.nnls at every step: a careful fit written with scipy alone.

    nnls knows only non-negativity, a relaxation of the registry's bounds, so
    its loss is a fair (if anything generous) bar for brdffit's engine. For
    models whose linear parameters are mapped (Ashikhmin-Shirley) the solved
    coefficients are mapped back and clipped to the parameters' bounds, and the
    loss is that of the model at the clipped parameters.
    Returns (params, mean squared error).
    """
    from scipy.optimize import nnls

    model = get_model(model)
    geometry = data.geometry()
    y = np.asarray(data.values, dtype=float)
    n, c = y.shape
    shape = [p for p in model.shape_params if not p.per_channel]
    lo = np.array([np.log10(p.lower) if p.log_scale else p.lower for p in shape])
    hi = np.array([np.log10(p.upper) if p.log_scale else p.upper for p in shape])

    def params_at(x):
        values = {
            p.name: float(np.clip(10**v if p.log_scale else v, p.lower, p.upper))
            for p, v in zip(shape, x)
        }
        design = model.design(geometry, values)
        cols = np.stack([np.broadcast_to(col, (n,)) for col in design.columns], axis=1)
        offset = 0.0 if design.offset is None else design.offset[:, None]
        coefs = np.array([nnls(cols, (y - offset)[:, ch])[0] for ch in range(c)])
        named = {name: coefs[:, j] for j, name in enumerate(model.coefficients)}
        linear = model.params_from_coefficients(named) if model.from_coefficients is None else None
        if linear is None:  # mapped coefficients: map back by hand and clip
            rs = np.clip(named["rs"], 0.0, 1.0)
            rd = np.clip(named["rd_eff"] / np.maximum(1.0 - rs, 1e-12), 0.0, 1.0)
            linear = {"rd": rd, "rs": rs}
        for p in model.linear_params:
            linear[p.name] = np.clip(linear[p.name], p.lower, p.upper)
        return {**values, **linear}

    def residuals(x):
        f = np.asarray(model.evaluate_prepared(geometry, params_at(x), check=False))
        if f.ndim == 1:
            f = np.repeat(f[:, None], c, axis=1)
        r = (f - y).ravel()
        return np.where(np.isfinite(r), r, 1e10)

    rng = np.random.default_rng(seed)
    best = None
    for k in range(starts):
        if k == 0:
            x0 = np.array([np.log10(p.default) if p.log_scale else p.default for p in shape])
        else:
            x0 = rng.uniform(lo, hi)
        sol = least_squares(
            residuals, x0, bounds=(lo, hi), x_scale="jac", ftol=1e-12, xtol=1e-12, gtol=1e-12
        )
        mse = float(np.mean(sol.fun**2))
        if best is None or mse < best[1]:
            best = (params_at(sol.x), mse)
    return best
