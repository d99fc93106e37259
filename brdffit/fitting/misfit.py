"""Misfit is not noise: does the model describe the data to within their noise?

A fit reports intervals as if its residuals were independent noise. When the
model cannot describe the data, the residuals are systematic instead: they
keep their sign over whole regions of the highlight. Two tests, on the
standardised residuals ``z = (f - y) / sigma`` (the data's sigma, or the fitted
noise model's for the ``mixed`` loss; for another loss, its weighted
transformed residuals, whose scale is unknown):

* a runs test along the highlight: the samples ordered by the half-vector
  angle ``theta_h`` (ties by the difference angle ``theta_d``; Rusinkiewicz
  1998), and again by ``theta_d`` first; in each order and channel, the
  Wald-Wolfowitz runs test of the residuals' signs (Wald and Wolfowitz 1940,
  Ann. Math. Statist. 11, 147; its use on residuals ordered by a regressor:
  Draper and Smith, Applied Regression Analysis, 3rd ed., sec. 7.2). Too few
  runs means residuals of one sign in whole regions. Signs make it immune to
  unequal variances and single large residuals (a grazing sample). Misfit
  when the largest runs ``z`` exceeds the one-sided ``N(0, 1)`` quantile of
  :data:`ALPHA` divided by the number of tests (Bonferroni over the channels
  and the two orderings);
* reduced chi-square, when the sigma is the data's: ``chi2 / (n - k)`` above
  ``1 + z sqrt(2 / (n - k))`` at the same level. (Under a fitted noise model it
  is near 1 by construction; it is reported, not tested.)

A fit found to misfit keeps its intervals, which are then conditional on the
model: the ``mixed`` noise model's estimated ``a`` and ``b`` absorb the
discrepancy as noise (wider intervals), but correlated residuals carry less
information than independent ones, which no noise level can express.
"""

from __future__ import annotations

import math
from dataclasses import replace
from functools import lru_cache
from statistics import NormalDist

import numpy as np

from .runs import orders as _stable_orders
from .runs import residual_signs as _residual_signs
from .runs import runs as _runs
from .runs import sign_codes as _sign_codes

__all__ = ["ALPHA", "MISFIT_LOSS", "RUNS_SAMPLES", "assess", "misfit_test", "refit_on_misfit"]

#: Level of the misfit tests (false alarm rate of a fit whose model is right).
ALPHA = 1e-6
#: A fit whose residual rms is below this fraction of the data's reproduces them to
#: the fit's precision: noiseless data, whose residual signs follow the arithmetic,
#: not a misfit. The engine stops when the parameters change by less than 1e-7
#: relative (engine.py, ``set_xtol_rel``), which leaves residuals of 1e-9 to 1e-8 of
#: noiseless data's rms (measured on ward, ggx and blinn, three seeds); no
#: measurement is that close to any model.
EXACT = 1e-6


def _keys(data, step: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Sort keys of theta_h and theta_d of every ``step``-th sample (Rusinkiewicz 1998): ``-N.H``
    and ``-V.H``, which order the samples as the angles do (``arccos`` decreases)
    without computing them; the cosines of the data's geometry where every pair is
    above the horizon (the models have usually computed them), else from ``H = L + V``
    (``V.H = |L + V| / 2``, as :attr:`Geometry.cos_d`)."""
    geometry = data.geometry() if hasattr(data, "geometry") else None
    if geometry is not None and geometry.all_valid:
        return np.negative(geometry.cos_h[::step]), np.negative(geometry.cos_d[::step])
    h = data.wi[::step] + data.wo[::step]
    length = np.sqrt(np.einsum("ij,ij->i", h, h))
    cos_h = h[:, 2] / np.maximum(length, 1e-300)
    return np.negative(cos_h, out=cos_h), np.multiply(length, -0.5, out=length)


#: Samples per block where a check forms the noise model's sigma (16,384: 384 KB of RGB).
BLOCK = 16_384
#: Key of the two sample orders in :meth:`brdffit.data.geometry.Geometry.cached`.
ORDERS_KEY = "misfit.orders"
#: The runs test takes at most about this many samples: of more, every ``k``-th in
#: the data's order, the smallest ``k`` enough (a systematic sample). Its two sorts
#: were most of its cost (50-90 ms of a 0.4 s fit of a whole MERL file); on 300,000
#: samples it still finds a misfit whose runs ``z`` on all of them is twice the
#: threshold (``z`` grows as the root of the samples); a MERL file's misfits reach
#: several hundred. The reduced chi-square takes every sample.
RUNS_SAMPLES = 300_000


def _sort_orders(data, step: int = 1) -> np.ndarray:
    """Every ``step``-th sample's index (0, 1, ... among them), ordered by
    ``(theta_h, theta_d)`` and by ``(theta_d, theta_h)``, the rows of one (2, n) array.

    Stable sorts: ties of both angles keep the samples' order, so the order of a
    subset of the samples is this order with the others left out. Kept as 32-bit
    indices where they fit: half the memory of the cache (a whole MERL file's fit
    peaked past 600 MB with 64-bit ones).
    """
    key_h, key_d = _keys(data, step)
    kind = np.int32 if key_h.size < 2**31 else np.intp
    by_h, by_d = _stable_orders(key_h, key_d)
    out = np.empty((2, by_h.size), dtype=kind)
    out[0], out[1] = by_h, by_d
    return out


def _orders(data, step: int = 1) -> np.ndarray:
    """:func:`_sort_orders`, computed once per geometry (and step): they depend on the
    directions only, which a :class:`~brdffit.Measurements` never changes."""
    geometry = getattr(data, "geometry", None)
    if geometry is None:
        return _sort_orders(data, step)
    return geometry().cached((ORDERS_KEY, step), lambda: _sort_orders(data, step))


def misfit_test(data, z: np.ndarray, keep: np.ndarray, n_params: int, chi2_known: bool) -> dict:
    """The misfit tests on standardised residuals ``z`` (N, C) of the samples ``keep``.

    Returns the ``misfit`` record of a FitResult: ``detected``, ``runs_ratio`` (runs
    counted over runs expected, in the ordering and channel of the largest
    ``runs_z``), ``runs_z``, ``threshold_z``, ``ordered_by``, ``reduced_chi2``,
    ``chi2_tested``, ``refit_loss`` (None; see :func:`refit_on_misfit`) and a ``message``.
    The two sample orders are sorted once per geometry (:func:`_orders`); the runs test
    takes one sample in ``k`` of more than :data:`RUNS_SAMPLES` (its message says so).
    """
    keep = np.asarray(keep, dtype=bool)
    everything = bool(keep.all())
    n = len(z)
    step = max(1, -(-n // RUNS_SAMPLES))
    codes = _sign_codes(z[::step])
    if not everything:
        codes[:, ~keep[::step]] = 0  # left out of the runs as exact zeros are: orders whole
    z = np.ascontiguousarray(z) if everything else np.compress(keep, z, axis=0)
    return _verdict(data, codes, step, n, float(np.sum(z * z)), z.size, n_params, chi2_known)


def _verdict(data, codes, step, n, squares, count, n_params, chi2_known) -> dict:
    """:func:`misfit_test`'s record from the sign ``codes`` (C, N / step) of every
    ``step``-th of the ``n`` samples and the sum of ``squares`` of the ``count``
    standardised residuals of the samples kept."""
    # both orders' rows (theta_h's channels, then theta_d's) counted in one call: the
    # first largest z is the one the orders' loop kept (a later order's only if larger)
    c = len(codes)
    both = np.take(codes, _orders(data, step), axis=1).swapaxes(0, 1).reshape(2 * c, -1)
    runs, expected, stat = _runs(both)
    i = int(np.argmax(stat))
    best = (float(stat[i]), float(runs[i] / max(expected[i], 1.0)), ("theta_h", "theta_d")[i // c])
    threshold = _upper_quantile(ALPHA / (2 * c))
    dof = max(count - n_params, 1)
    reduced = squares / dof
    chi2_bad = chi2_known and reduced > 1.0 + _upper_quantile(ALPHA) * math.sqrt(2.0 / dof)
    serial_bad = best[0] > threshold
    detected = bool(serial_bad or chi2_bad)
    return {
        "detected": detected,
        "runs_ratio": best[1],
        "runs_z": best[0],
        "threshold_z": threshold,
        "ordered_by": best[2],
        "reduced_chi2": reduced,
        "chi2_tested": bool(chi2_known),
        "refit_loss": None,
        "message": _message(detected, best, threshold, reduced, chi2_bad, step, n),
    }


def _from_metrics(problem, result, n_params: int, pred=None) -> dict | None:
    """:func:`misfit_test` of an unweighted ``l2`` fit (or ``chi2`` on the data's sigma)
    without its residuals on every sample: their sum of squares is the fit's metric
    (``l2`` times the values, or ``chi2``), and the runs test's signs those of
    ``(f - y) / sigma`` on its own samples, the values :func:`standardised` forms.
    None for the other fits (their residuals are transformed or weighted)."""
    data, name = problem.data, problem.loss.name
    if problem.user_weights is not None or name not in ("l2", "chi2"):
        return None
    if name == "chi2" and data.sigma is None:
        return None
    n = data.n
    step = max(1, -(-n // RUNS_SAMPLES))
    pred = problem.predict(dict(result.params)) if pred is None else pred
    values = np.asarray(data.values, dtype=float)
    if name == "chi2":
        z = np.subtract(pred[::step].T, values[::step].T)  # (C, N): a table's columns
        z /= np.asarray(data.sigma)[::step].T  # are rows (the same values, signs)
        codes, squares = _sign_codes(z.T), result.metrics["chi2"]
    else:  # the signs of pred - values (in one compiled pass on large data)
        codes = _residual_signs(pred, values, step)
        squares = result.metrics["l2"] * result.n_values
    return _verdict(data, codes, step, n, squares, result.n_values, n_params, name == "chi2")


@lru_cache(maxsize=64)  # the same few levels at every fit: 2 us each
def _upper_quantile(p: float) -> float:
    """The ``N(0, 1)`` quantile exceeded with probability ``p`` (``scipy.stats.norm.isf``,
    ``-ndtri(p)``), by the standard library's ``NormalDist`` (Wichura's algorithm AS241,
    to about 1e-16; scipy.stats and scipy.special take 0.7 s to import)."""
    return -NormalDist().inv_cdf(p)


def _message(detected, best, threshold, reduced, chi2_bad, step=1, n=0) -> str:
    sample = f", on one in {step} of the {n:,} samples" if step > 1 else ""
    serial = (
        f"residual signs along {best[2]} form {best[1]:.3g} of the runs that noise "
        f"would (runs test z {best[0]:.3g}, threshold {threshold:.3g}{sample})"
    )
    if not detected:
        return f"no misfit found: {serial}, reduced chi-square {reduced:.3g}"
    why = []
    if best[0] > threshold:
        why.append(serial)
    if chi2_bad:
        why.append(f"reduced chi-square {reduced:.3g} under the data's sigma")
    return (
        "MISFIT: the model does not describe the data, its residuals are systematic ("
        + "; ".join(why)
        + "); the intervals are conditional on the model"
    )


def standardised(problem, params, noise) -> tuple[np.ndarray, np.ndarray]:
    """Standardised residuals (N, C) of a fit and the samples they count on (weight > 0)."""
    data = problem.data
    y = np.asarray(data.values, dtype=float)
    pred = problem.predict(params)
    u = problem.user_weights
    keep = np.ones(data.n, dtype=bool) if u is None else np.asarray(u) > 0
    if noise is not None:
        z = np.subtract(pred, y)  # divided in place by blocks: no sigma of the data's size
        for start in range(0, len(z), BLOCK):
            rows = slice(start, start + BLOCK)
            z[rows] /= noise.sigma(pred[rows])
        return z, keep
    if data.sigma is not None and problem.loss.name == "chi2":
        return (pred - y) / np.asarray(data.sigma), keep
    from .losses import LossContext

    ctx = LossContext(cos_i=np.maximum(data.wi[:, 2], 0.0), y=y, sigma=data.sigma, weights=None)
    loss = problem.loss
    transformed = loss.transform(pred, ctx)  # a new array but for l2 (pred itself)
    out = None if transformed is pred else transformed
    return np.subtract(transformed, loss.transform(y, ctx), out=out), keep


def assess(problem, result, noise, pred=None) -> dict:
    """The fields a fit adds for its noise model and misfit verdict: ``noise``,
    ``misfit``, ``metrics`` (AIC and BIC with the fit's own likelihood) and the
    ``message`` with the verdict when misfit is found (``result``: a FitResult or its
    fields; ``pred``: :meth:`Problem.predict` at its params, when the caller holds it)."""
    params = dict(result.params)
    k = result.n_params + (2 if noise is not None else 0)
    misfit = _from_metrics(problem, result, k, pred) if noise is None else None
    z = None  # the residuals on every sample: formed where the verdict needs them
    if misfit is None:
        z, keep = standardised(problem, params, noise)
        chi2_known = noise is None and problem.loss.name == "chi2"
        misfit = misfit_test(problem.data, z, keep, k, chi2_known)
    if misfit["detected"] and _exact(problem, result):
        note = f"to the fit's precision ({EXACT:g} of their rms)"
        message = f"no misfit: the model reproduces the data {note}; {misfit['message']}"
        misfit.update(detected=False, message=message)
    metrics = dict(result.metrics)
    if noise is not None:
        metrics["mixed"] = result.loss  # the mixed loss needs the fit's noise model
    base = _minus_two_log_likelihood(problem, params, noise, z, result.loss)
    if base is not None:
        metrics["aic"] = base + 2 * k
        metrics["bic"] = base + k * math.log(result.n_values)
    message = result.message + ("; " + misfit["message"] if misfit["detected"] else "")
    return {
        "noise": noise_record(problem, noise),
        "misfit": misfit,
        "metrics": metrics,
        "message": message,
    }


def _exact(problem, result) -> bool:
    """Whether the fit reproduces the data to its precision: residual rms (the fit's
    ``rmse`` metric) below :data:`EXACT` times the data's (noiseless data; signs of its
    last digits are not misfit)."""
    y = np.asarray(problem.data.values, dtype=float).reshape(result.n_samples, -1)
    y_rms = math.sqrt(float(np.einsum("mc,mc->", y, y)) / y.size)
    return bool(result.metrics["rmse"] <= EXACT * y_rms)


def noise_record(problem, noise) -> dict:
    """What a FitResult says of its noise model."""
    if noise is not None:
        return {**noise.to_dict(), "meaning": "sigma^2 = a^2 + (b f)^2, estimated with the fit"}
    if problem.loss.name == "chi2":
        return {"model": "given", "a": None, "b": None, "meaning": "the data's sigma"}
    return {
        "model": "loss",
        "a": None,
        "b": None,
        "meaning": f"constant on the {problem.loss.name} loss's transformed values "
        "(not estimated)",
    }


def _minus_two_log_likelihood(problem, params, noise, z, loss: float) -> float | None:
    """``-2 ln L`` up to a constant common to every model on the same data: Gaussian
    with the fitted noise model, or, for a loss without one, with one unknown variance
    on its (weighted) transformed residuals profiled out, ``n ln(S / n)`` (``S`` from
    the fit's exact ``loss``). None for chi2, whose metrics already use the data's
    sigma."""
    if noise is not None:
        pred = problem.predict(params)
        u = problem.user_weights
        total = 0.0
        # ln(2 pi s^2) + z^2 by blocks of samples, in place: no array of the data's
        # size (a MERL file's check peaked on five of them)
        for start in range(0, len(pred), BLOCK):
            rows = slice(start, start + BLOCK)
            terms = noise.sigma(pred[rows])
            np.square(terms, out=terms)
            terms *= 2 * np.pi
            np.log(terms, out=terms)
            terms += np.square(z[rows])
            if u is not None:
                terms *= np.asarray(u)[rows, None]
            total += float(terms.sum())
        return total
    if problem.loss.name == "chi2":
        return None
    n = problem.data.values.size
    total = max(loss * problem.norm, 1e-300)
    return n * math.log(total / n)


#: What the default fit of data without sigma refits with when the noise-model fit
#: misfits: Löw et al.'s E2 (:mod:`brdffit.fitting.losses`).
MISFIT_LOSS = "log"


def refit_on_misfit(fit, data, model, options: dict, result):
    """The default fit of data without sigma, once its noise-model fit misfits.

    When the model describes the data, the ``mixed`` fit is the maximum-likelihood
    one. When it cannot (misfit found), the residuals are discrepancy, not noise:
    a noise model estimated from them weights the fit towards wherever the
    discrepancy happens to be small in relative terms, and weighted and unweighted
    fits then estimate different things, none of them "the" parameters (White 1981,
    "Consequences and detection of misspecified nonlinear regression models",
    JASA 76, 419). The fit is then refitted with :data:`MISFIT_LOSS`, the error
    measure that Löw, Kronander, Ynnerman and Unger (2012, ACM TOG 31(1)) found
    closest to rendered appearance for fitting measured materials; the result
    keeps the misfit verdict (``misfit["refit_loss"]``), and its message says so.
    An explicit ``loss``, data with sigma, and a search cut short are never
    refitted; the refit shares the fit's ``max_evals`` and ``timeout``.
    """
    if options.get("loss") is not None or not result.misfit["detected"]:
        return result
    if result.loss_name != "mixed" or not result.converged:
        return result  # a search cut short (budget, timeout, callback) proves no misfit
    budget = {"loss": MISFIT_LOSS, "uncertainty": False}
    if options.get("max_evals") is not None:
        budget["max_evals"] = options["max_evals"] - result.n_evals
    if options.get("timeout") is not None:
        budget["timeout"] = options["timeout"] - result.seconds
    if budget.get("max_evals", 1) < 1 or budget.get("timeout", 1.0) <= 0:
        return result
    again = fit(data, model, **{**options, **budget})
    noise = result.noise
    note = (
        f"; refitted with the {MISFIT_LOSS} loss (the noise model a = {noise['a']:.3g}, "
        f"b = {noise['b']:.3g} estimated from these residuals is the model's discrepancy, "
        "not noise)"
    )
    # The verdict on the fit reported: the refit's when it sees the misfit too.
    verdict = again.misfit if again.misfit["detected"] else result.misfit
    misfit = {**verdict, "refit_loss": MISFIT_LOSS}
    message = again.message
    if not again.misfit["detected"]:
        message += "; " + result.misfit["message"]
    return replace(
        again,
        misfit=misfit,
        message=message + note,
        n_evals=again.n_evals + result.n_evals,
        seconds=again.seconds + result.seconds,
    )


def describe(result) -> list[str]:
    """Lines for the command line: the noise model of a fit and the misfit verdict."""
    noise, misfit, lines = result.noise, result.misfit, []
    if noise:
        if noise["model"] == "mixed":
            lines.append(
                f"noise: sigma^2 = a^2 + (b f)^2 estimated with the fit, a = {noise['a']:.3g}, "
                f"b = {noise['b']:.3g} (the default without sigma: measured noise grows with "
                "the signal above a floor)"
            )
        else:
            lines.append(f"noise: {noise['meaning']}")
    if misfit:
        lines.append(misfit["message"] if misfit["detected"] else f"misfit: {misfit['message']}")
        if misfit.get("refit_loss"):
            lines.append(
                f"the default refitted with the {misfit['refit_loss']} loss: the model "
                "cannot describe these data, and the intervals are conditional on it"
            )
    return lines
