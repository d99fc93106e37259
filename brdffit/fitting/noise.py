"""The noise of measurements without sigma: ``sigma^2 = a^2 + (b f)^2``, estimated with the fit.

Most measured BRDF files give no per-sample sigma. A gonioreflectometer's error
grows with the signal (a relative part ``b``) above a floor near zero (an
absolute part ``a``, dark current, stray light). Plain least squares assumes
constant noise, so the highlight, hundreds of times brighter than the rest,
decides the fit; weighting by the measured values instead (``relative``) fails
where they are near or below zero.

The default loss of data without sigma, ``mixed``, therefore fits the model
and the variance function together, by iteratively reweighted least squares
with the variance function estimated by maximum likelihood from the residuals
(Carroll and Ruppert 1988, "Transformation and Weighting in Regression",
Chapman and Hall, ch. 2 and 3: generalised least squares with an estimated
variance function; the weights are built from the model's prediction, never
from the measured values, which their ch. 2 shows is what keeps the estimate
consistent):

1. round 0: the usual global search and polishes with unit weights (``l2``);
2. each further round: ``(a, b)`` by maximum likelihood of the residuals
   ``r = y - f`` under ``N(0, a^2 + b^2 f^2)`` (:func:`estimate`), then a local
   polish from the current point with weights ``1 / (a^2 + (b f)^2)``, ``f``
   the current prediction; the linear coefficients stay solved exactly at every
   step (variable projection), only the shape parameters are searched;
3. it stops when ``(a, b)`` change by less than :data:`TOLERANCE` or after
   :data:`ROUNDS` rounds.

``a`` has a floor of :data:`FLOOR` times the median prediction, so that a
prediction of zero never gets an infinite weight.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .engine import search

__all__ = ["FLOOR", "ROUNDS", "TOLERANCE", "NoiseModel", "estimate", "reweight"]

#: Reweighting rounds after the first fit, at most.
ROUNDS = 4
#: Relative change of a and b below which the rounds stop.
TOLERANCE = 0.05
#: The absolute floor a is at least this times the median |prediction| (a prediction
#: of zero then never gets an infinite weight).
FLOOR = 1e-3
#: Points of the grid of the noise model's ratio b^2 f^2 / a^2 (see :func:`estimate`).
GRID = 25
#: Above this many values, (a, b) are estimated on every k-th value only (a systematic
#: sample of at most this many): two numbers need no more, their relative standard
#: error is then about sqrt(2 / 300,000) = 0.3 %, and each of the estimate's ~40
#: passes over a MERL file's 3.3 M values took 60 ms (12 s of a 32 s default fit).
MAX_VALUES = 300_000
#: Residuals and predictions within 2^-UNIT_RANGE .. 2^UNIT_RANGE (about 1e-6 .. 1e6)
#: are estimated in the data's unit; others in a scaled one (:func:`_unit`).
UNIT_RANGE = 20


@dataclass(frozen=True)
class NoiseModel:
    """Gaussian noise with ``sigma^2 = a^2 + (b f)^2`` about the model's value ``f``.

    Attributes
    ----------
    a : float
        The absolute floor, in the units of the data (1/sr).
    b : float
        The relative part (a fraction of the value).
    """

    a: float
    b: float

    def sigma(self, f) -> np.ndarray:
        """The standard deviation at model values ``f``."""
        out = np.array(f, dtype=float)  # a copy, squared in place (no temporaries)
        if not out.ndim:
            return np.sqrt(self.a**2 + (self.b * out) ** 2)
        out *= self.b
        np.square(out, out=out)
        out += self.a**2
        return np.sqrt(out, out=out)

    def close_to(self, other: NoiseModel, tol: float) -> bool:
        return all(
            abs(u - v) <= tol * max(abs(u), abs(v), 1e-300)
            for u, v in ((self.a, other.a), (self.b, other.b))
        )

    def to_dict(self) -> dict:
        return {"model": "mixed", "a": float(self.a), "b": float(self.b)}


def _dot(a: np.ndarray, b: np.ndarray) -> float:
    """``sum(a * b)`` of two 1-D arrays, without BLAS: OpenBLAS runs ``ddot`` of
    more than 10,000 elements on several threads, and on a busy machine their
    start costs milliseconds per call (3 ms against 8 us measured here on 12,000
    values at load 6), which made this estimate take seconds."""
    return float(np.sum(a * b))


def estimate(resid, pred, weights=None) -> NoiseModel:
    """Maximum-likelihood ``(a, b)`` of residuals ``resid`` at predictions ``pred``.

    Maximises the Gaussian likelihood of the residuals with variance
    ``s_i = a^2 + b^2 f_i^2`` (Carroll and Ruppert 1988, sec. 3.2, the
    pseudo-likelihood of the variance function). Written as
    ``s_i = c (1 + rho g_i)`` (``g = f^2`` scaled to mean 1), the scale ``c``
    has the closed form ``c(rho) = sum u r^2 / (1 + rho g) / sum u``, so the
    likelihood is profiled over the one ratio ``rho``: a grid of
    :data:`GRID` values of ``log10 rho`` in [-12, 12], a decade apart (the profile can have
    more than one local optimum), refined by a bounded Brent search around the
    best, and the two pure forms (``rho = 0``, only ``a``; ``rho -> inf``, only
    ``b`` above the floor) compared with it. ``a`` keeps its floor
    (:data:`FLOOR`). Above :data:`MAX_VALUES` values, on every k-th of them. Values
    far from 1 (beyond ``2^±UNIT_RANGE``) are estimated in a unit of their size
    (:func:`_unit`), so that no square or sum overflows.

    Parameters
    ----------
    resid, pred : array_like (M, C)
    weights : array_like (M,), optional
        Sample weights ``u`` (a sample of weight 0 does not count).
    """
    resid, pred = np.asarray(resid, dtype=float), np.asarray(pred, dtype=float)
    unit = _unit(resid, pred)
    if unit != 1.0:  # in a unit of the data's size (see _unit): a scales with it, b not
        noise = estimate(resid / unit, pred / unit, weights)
        return NoiseModel(noise.a * unit, noise.b)
    r2 = resid**2
    g = pred**2
    u = np.ones(r2.shape[0]) if weights is None else np.asarray(weights, dtype=float)
    u = np.broadcast_to(u[:, None], r2.shape)
    keep = (u > 0) & np.isfinite(r2) & np.isfinite(g)
    r2, g, u = _thinned(r2[keep], g[keep], u[keep])
    if not r2.size:
        return NoiseModel(0.0, 0.0)
    return _estimate(r2, g, u)


def _unit(resid: np.ndarray, pred: np.ndarray) -> float:
    """The unit in which :func:`estimate` works: 1 (the data's own, bit for bit as
    ever) while the largest finite ``|resid|``, ``|pred|`` is within ``2^±UNIT_RANGE``,
    else the power of two nearest it. The profile sums squares divided by predictions
    and multiplied by ratios up to 1e12: values of 1e20 overflowed there and the
    likelihood came out NaN or inf (and squares of values above 1e154 are inf). A
    power of two scales exactly; in it the squares are below 4 and no sum overflows."""
    top = 0.0
    for a in (resid, pred):
        finite = np.abs(a[np.isfinite(a)])
        top = max(top, float(finite.max(initial=0.0)))
    if top == 0.0 or abs(math.log2(top)) <= UNIT_RANGE:
        return 1.0
    return 2.0 ** round(math.log2(top))


def _estimate(r2, g, u) -> NoiseModel:
    """:func:`estimate` of squared residuals ``r2``, squared predictions ``g`` and
    weights ``u`` (1-D, kept and thinned)."""
    u = u / u.sum()
    g_scale = max(_dot(u, g), 1e-300)
    gn = g / g_scale
    p_min = max((FLOOR * float(np.median(np.sqrt(g)))) ** 2, 1e-30 * _dot(u, r2), 1e-300)
    ur2 = u * r2
    with np.errstate(over="ignore"):  # a prediction of 0 under a large residual: inf
        relative_c = max(_dot(ur2, 1.0 / np.maximum(gn, 1e-300)), 1e-300)

    profile = _profile(u, ur2, gn, relative_c, p_min)
    grid = np.linspace(-12.0, 12.0, GRID)
    values = [profile(x)[0] for x in grid]
    i = int(np.argmin(values))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, GRID - 1)]
    found = _bounded_minimum(lambda x: profile(x)[0], lo, hi)
    # The pure relative form, unless a prediction of 0 under a residual rules it out.
    relative = [(profile(15.0)[0], 15.0)] if relative_c < math.inf else []
    best = min([(found.fun, float(found.x)), (values[i], float(grid[i])), *relative])
    _, c = profile(best[1])
    if best[1] >= 15.0:
        return NoiseModel(math.sqrt(p_min), math.sqrt(c / g_scale))
    rho = 10.0 ** best[1]
    return NoiseModel(math.sqrt(max(c, p_min)), math.sqrt(c * rho / g_scale))


def _profile(u, ur2, gn, relative_c: float, p_min: float):
    """The profile of :func:`estimate`: ``log_rho -> (-log-likelihood per unit weight,
    c)``. Its values are those of the formulas written out (``v = 1 + rho g``,
    ``c = sum u r^2 / v``, ``s = max(c v, p_min)``, ``sum u ln s + sum u r^2 / s``): the
    same operations on the same values, in two buffers reused by every call instead
    of seven new arrays (each of them a fresh mapping of 2.4 MB to fault in: the
    estimate's ~35 calls took 0.2 s on a MERL file's 300,000 values)."""
    v, t = np.empty_like(gn), np.empty_like(gn)

    def total(a, b) -> float:  # _dot(a, b) with b in t: sum(a * b), t overwritten
        np.multiply(a, b, out=t)
        return float(np.sum(t))

    def profile(log_rho: float) -> tuple[float, float]:
        if log_rho >= 15.0:  # the pure relative form, with the floor
            c = relative_c
            with np.errstate(over="ignore"):  # inf: a variance no sample fits (-inf ln L)
                np.multiply(gn, c, out=v)
        else:
            np.multiply(gn, 10.0**log_rho, out=v)
            np.add(v, 1.0, out=v)
            c = max(total(ur2, np.divide(1.0, v, out=t)), 1e-300)
            np.multiply(v, c, out=v)
        s = np.maximum(v, p_min, out=v)
        return total(u, np.log(s, out=t)) + total(ur2, np.divide(1.0, s, out=t)), c

    return profile


def _thinned(*arrays):
    """The arrays, or every k-th of their values when they hold over :data:`MAX_VALUES`."""
    step = _step(arrays[0].size)
    return arrays if step == 1 else tuple(a[::step] for a in arrays)


def _step(size: int) -> int:
    """The ``k`` of :func:`_thinned` for ``size`` values: the smallest that keeps at most
    :data:`MAX_VALUES` (:func:`_systematic_sample` reads the same values)."""
    return max(-(-size // MAX_VALUES), 1)


def _round_noise(problem, found) -> tuple:
    """The prediction (N, C) at the search's best point and the noise estimated there."""
    params = problem.params_of(found.best)
    pred = problem.predict(params)
    y = np.asarray(problem.data.values, dtype=float)
    valid = problem.geometry.valid
    weights = problem.user_weights
    w = None if weights is None else np.asarray(weights, dtype=float)
    sample = _systematic_sample(y, pred, None if problem.geometry.all_valid else valid, w)
    if sample is not None:
        return pred, estimate(*sample)
    noise = estimate((y - pred)[valid], pred[valid], None if w is None else w[valid])
    return pred, noise


def _systematic_sample(y, pred, valid, w):
    """The residuals, predictions (K, 1) and weights (K,) that :func:`estimate` would
    keep of the valid rows of ``y - pred`` (every k-th value, :func:`_thinned`), read
    directly (a MERL file: 3.3 M residuals, squares and masks were formed to keep
    300,000 of them), or None when estimate would drop some values first (a weight
    of 0, a value that is not finite or whose square is not): then the full arrays.
    The values and their order are those of the full path, so (a, b) are the same."""
    ends = [(a.max(initial=0.0), -a.min(initial=0.0)) for a in (y, pred)]
    bound = np.max(ends)  # max |y|, max |pred|; NaN if either holds one
    if not bound < 1e150 or (w is not None and not w.min(initial=1.0) > 0.0):
        return None  # NaN fails the comparisons; squares of |y - pred| < 2e150 are finite
    rows = np.arange(y.shape[0]) if valid is None else np.flatnonzero(valid)
    c = y.shape[1]
    step = _step(rows.size * c)
    flat = np.arange(0, rows.size * c, step)
    index, channel = rows[flat // c], flat % c
    f = pred[index, channel]
    resid = y[index, channel] - f
    return resid[:, None], f[:, None], None if w is None else w[index]


def _counted(progress, before: int, max_evals: int, label: str):
    """The fit's progress callback, told the evaluations of the earlier rounds too."""
    if progress is None:
        return None

    def report(p):
        return progress(replace(p, n_evals=p.n_evals + before, max_evals=max_evals,
                                stage=f"{label}, {p.stage}"))  # fmt: skip

    return report


def reweight(first: list, code, options, t0: float):
    """The reweighting rounds of the ``mixed`` loss after the first search.

    Parameters
    ----------
    first : list
        ``[problem, found]``: the problem of the first search (unit weights for the
        ``mixed`` loss) and the search, as :func:`brdffit.fitting.engine.search`
        returned it; emptied here (the caller keeps no reference, so the first
        problem's arrays go when the first round's problem replaces it).
    code
        The nlopt code of that search.
    options : FitOptions
        The fit's resolved options: the rounds share its ``max_evals`` and
        ``timeout`` (the deadline counts from ``t0``).

    Returns
    -------
    problem, found, code, NoiseModel or None
        The problem whose weights the final search used, that search (its
        ``n_evals`` counts every round), its nlopt code, and the noise model
        of those weights; unchanged with None for every other loss.
    """
    problem, found = first
    first.clear()
    if not problem.loss.needs_noise or found.best is None:
        return problem, found, code, None
    local = replace(options, global_algorithm=None, restarts=0)
    used, rounds = None, 0
    for _ in range(ROUNDS):
        if found.stopped:
            break
        pred, noise = _round_noise(problem, found)
        problem.let_go()  # its search is done: its inputs go before the next round's
        if used is not None and noise.close_to(used, TOLERANCE):
            break
        remaining = options.max_evals - found.n_evals
        if remaining < 1:
            break
        used, rounds = noise, rounds + 1
        problem = problem.reweighted(noise.sigma(pred))
        opts = replace(local, max_evals=remaining,
                       progress=_counted(options.progress, found.n_evals, options.max_evals,
                                         f"reweighted {rounds}"))  # fmt: skip
        # The round before's search, prediction and problem (its weights: five arrays
        # of the data's size) go before this round's search builds its own.
        start, evals = found.best_x, found.n_evals
        found = pred = None
        found, code = search(problem, opts, start, True, t0)
        found.n_evals += evals
    if used is None:
        # No round could run (budget, deadline): the noise is estimated at the point
        # found, and the loss reported with it.
        pred, used = _round_noise(problem, found)
        problem = problem.reweighted(used.sigma(pred))
    return problem, found, code, used


def _bounded_minimum(function, lo: float, hi: float):
    """Brent's bounded minimum of ``function`` on ``[lo, hi]`` to 1e-3 in x (scipy's
    ``minimize_scalar``, imported here: scipy.optimize takes 0.2 s to import)."""
    from scipy.optimize import minimize_scalar

    return minimize_scalar(function, bounds=(lo, hi), method="bounded", options={"xatol": 1e-3})
