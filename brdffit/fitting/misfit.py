"""Misfit is not noise: does the model describe the data to within their noise?

A fit reports intervals as if its residuals were independent noise. When the
model cannot describe the data, the residuals are systematic instead: they
keep their sign over whole regions of the highlight. Two tests, on the
standardised residuals ``z = (f - y) / sigma`` (the data's sigma, or the fitted
noise model's for the ``mixed`` loss; for another loss, its weighted
transformed residuals, whose scale is unknown):

* serial correlation along the highlight: the samples ordered by the half-vector
  angle ``theta_h`` (ties by the difference angle ``theta_d``; Rusinkiewicz
  1998), and again by ``theta_d`` first; the lag-1 autocorrelation ``rho`` of
  each channel's ``z`` in that order. Independent residuals give
  ``sqrt(m) rho ~ N(0, 1)`` (m samples; Box and Pierce 1970, JASA 65, 1509,
  the large-sample law of residual autocorrelations), tested in its form that
  holds for unequal variances too (the sum of the products ``z_i z_(i+1)`` over
  the root of the sum of their squares; the same idea as the
  Durbin-Watson and Wald-Wolfowitz runs tests of residuals ordered by a
  regressor, Draper and Smith, Applied Regression Analysis, 3rd ed., sec. 7.2
  and 7.3). Misfit when the largest ``sqrt(m) rho`` exceeds the one-sided
  ``N(0, 1)`` quantile of :data:`ALPHA` divided by the number of tests
  (Bonferroni over the channels and the two orderings);
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

import numpy as np
from scipy.stats import norm

__all__ = ["ALPHA", "assess", "misfit_test"]

#: Level of the misfit tests (false alarm rate of a fit whose model is right).
ALPHA = 1e-6


def _angles(data) -> tuple[np.ndarray, np.ndarray]:
    """theta_h and theta_d of every sample (Rusinkiewicz 1998)."""
    h = data.wi + data.wo
    h = h / np.maximum(np.linalg.norm(h, axis=1, keepdims=True), 1e-300)
    theta_h = np.arccos(np.clip(h[:, 2], -1.0, 1.0))
    theta_d = np.arccos(np.clip(np.einsum("ij,ij->i", data.wi, h), -1.0, 1.0))
    return theta_h, theta_d


def _lag1(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lag-1 autocorrelation of each column of ``z`` (M, C), and its test statistic
    ``sum x / sqrt(sum x^2)`` of the products ``x_i = z_i z_(i+1)``: under independence
    the products have mean 0 and are uncorrelated, so it is N(0, 1) for large M
    even when the residuals' variances differ (as the transformed residuals of a
    loss without a noise model do)."""
    z = z - z.mean(axis=0)
    x = z[1:] * z[:-1]
    den = np.maximum(np.einsum("mc,mc->c", z, z), 1e-300)
    stat = x.sum(axis=0) / np.sqrt(np.maximum(np.einsum("mc,mc->c", x, x), 1e-300))
    return x.sum(axis=0) / den, stat


def misfit_test(data, z: np.ndarray, keep: np.ndarray, n_params: int, chi2_known: bool) -> dict:
    """The misfit tests on standardised residuals ``z`` (N, C) of the samples ``keep``.

    Returns the ``misfit`` record of a FitResult: ``detected``, ``serial_correlation``
    (the largest lag-1 autocorrelation), ``serial_z`` (it times sqrt(m)),
    ``threshold_z``, ``ordered_by``, ``reduced_chi2``, ``chi2_tested`` and a ``message``.
    """
    theta_h, theta_d = _angles(data)
    z, theta_h, theta_d = z[keep], theta_h[keep], theta_d[keep]
    c = z.shape[1]
    best = (-np.inf, 0.0, "theta_h")
    for name, order in (
        ("theta_h", np.lexsort((theta_d, theta_h))),
        ("theta_d", np.lexsort((theta_h, theta_d))),
    ):
        rho, stat = _lag1(z[order])
        i = int(np.argmax(stat))
        if stat[i] > best[0]:
            best = (float(stat[i]), float(rho[i]), name)
    threshold = float(norm.isf(ALPHA / (2 * c)))
    dof = max(z.size - n_params, 1)
    reduced = float(np.sum(z * z) / dof)
    chi2_bad = chi2_known and reduced > 1.0 + float(norm.isf(ALPHA)) * math.sqrt(2.0 / dof)
    serial_bad = best[0] > threshold
    detected = bool(serial_bad or chi2_bad)
    return {
        "detected": detected,
        "serial_correlation": best[1],
        "serial_z": best[0],
        "threshold_z": threshold,
        "ordered_by": best[2],
        "reduced_chi2": reduced,
        "chi2_tested": bool(chi2_known),
        "message": _message(detected, best, threshold, reduced, chi2_bad),
    }


def _message(detected, best, threshold, reduced, chi2_bad) -> str:
    serial = (
        f"lag-1 correlation of the residuals along {best[2]} {best[1]:.3g} "
        f"(z {best[0]:.3g}, threshold {threshold:.3g})"
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
        return (pred - y) / noise.sigma(pred), keep
    if data.sigma is not None and problem.loss.name == "chi2":
        return (pred - y) / np.asarray(data.sigma), keep
    from .losses import LossContext

    ctx = LossContext(cos_i=np.maximum(data.wi[:, 2], 0.0), y=y, sigma=data.sigma, weights=None)
    loss = problem.loss
    return loss.transform(pred, ctx) - loss.transform(y, ctx), keep


def assess(problem, result, noise) -> dict:
    """The fields a fit adds for its noise model and misfit verdict: ``noise``,
    ``misfit``, ``metrics`` (AIC and BIC with the fit's own likelihood) and the
    ``message`` with the verdict when misfit is found."""
    params = dict(result.params)
    z, keep = standardised(problem, params, noise)
    chi2_known = noise is None and problem.loss.name == "chi2"
    k = result.n_params + (2 if noise is not None else 0)
    misfit = misfit_test(problem.data, z, keep, k, chi2_known)
    metrics = dict(result.metrics)
    base = _minus_two_log_likelihood(problem, params, noise, z)
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


def _minus_two_log_likelihood(problem, params, noise, z) -> float | None:
    """``-2 ln L`` up to a constant common to every model on the same data: Gaussian
    with the fitted noise model, or, for a loss without one, with one unknown variance
    on its (weighted) transformed residuals profiled out, ``n ln(S / n)``. None for
    chi2, whose metrics already use the data's sigma."""
    if noise is not None:
        pred = problem.predict(params)
        s2 = noise.sigma(pred) ** 2
        terms = np.log(2 * np.pi * s2) + z * z
        u = problem.user_weights
        if u is not None:
            terms = terms * np.asarray(u)[:, None]
        return float(terms.sum())
    if problem.loss.name == "chi2":
        return None
    n = problem.data.values.size
    total = max(problem.exact_loss(params) * problem.norm, 1e-300)
    return n * math.log(total / n)
