"""Posterior sampling around a fit: ``sample_posterior(data, fit_result) -> Posterior``.

What is sampled
---------------
The fit's free shape parameters, in its search space (log10 for log-scale
ones), and, unless the data's sigma is used, the noise as ``log10(noise)``,
with emcee (Foreman-Mackey et al. 2013, PASP 125, 306). The linear
coefficients (kd, ks... per channel) are integrated out analytically and then
drawn exactly for every kept sample (:mod:`brdffit.posterior.target`, which
states the likelihood and the noise models); the moves, the start and the
convergence rule are in :mod:`brdffit.posterior.chain`.

Priors. Uniform within each parameter's bounds in the search space: uniform
for linear-scale parameters, log-uniform for log-scale ones (uniform in
log10); uniform in the coefficients on their bounds (kd in [0, 1]...); the
noise uniform in log10 (Jeffreys' prior for a scale) over 3 decades either side
of the fit's rms residual, a range that only binds for a degenerate fit.

Names. Shape parameters keep their names (``alpha``), the noise is ``noise``,
coefficients are ``name[channel]`` with the data's channel names (``kd[r]``,
``ks[550nm]``), or plain ``kd`` when the data have one channel. Coefficients
are those the fit solves (``model.coefficients``): for every model but
``ashikhmin_shirley`` they are its linear parameters; for it they are
``rd_eff = rd (1 - rs)`` and ``rs``, and the prior is uniform on their box
``rd_eff >= 0``, ``0 <= rs <= 1``.

The fit's sample weights (``fit_result.weights``, kept by
:func:`brdffit.fit`) weight the likelihood as they weighted the loss, scaled to mean 1 over the
samples whose weight is not zero (a sample of weight 0 leaves the likelihood).
The posterior of an ``energy_conserving`` fit is restricted as the fit was, to
directional albedo <= 1, by dropping the draws that exceed it
(:mod:`brdffit.posterior.energy`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from ..errors import FitError
from ..fitting.noise import NoiseModel
from ..fitting.problem import Problem
from ..words import plural
from .chain import (
    TOL,
    PosteriorProgress,
    StudentIndependence,
    laplace,
    run_chain,
    start_walkers,
)
from .energy import restrict_to_energy
from .options import _check_options
from .recall import Recall
from .result import NOISE_MEANING, Posterior
from .target import NOISE_MODELS, Target

__all__ = ["Posterior", "PosteriorProgress", "sample_posterior", "NOISE_MODELS", "NOISE_MEANING"]

NOISE_NAME = "noise"
#: What a posterior's message says when its fit's residuals are systematic.
CONDITIONAL = (
    "CONDITIONAL ON THE MODEL: the fit's residuals are systematic (misfit), so these "
    "intervals hold only if the model were right"
)
#: Independent draws when there is nothing to sample by MCMC (no shape parameter, noise given).
IID_DRAWS = 4000


# ---------------------------------------------------------------------- main
def sample_posterior(
    data,
    fit_result,
    *,
    walkers: int = 32,
    steps: int | str = "auto",
    max_steps: int = 20000,
    max_seconds: float | None = 60.0,
    seed: int | None = None,
    noise: str | None = None,
    progress: Callable[[PosteriorProgress], None] | None = None,
    **unknown: Any,
) -> Posterior:
    """Sample the posterior of the parameters of a fit.

    Parameters
    ----------
    data : Measurements
        The data the fit was made on.
    fit_result : FitResult
    walkers : int
        emcee walkers; at least twice the sampled dimensions (and 8).
    steps : int or "auto"
        ``"auto"``: run until converged (50 autocorrelation times after burn-in)
        or until ``max_steps`` or ``max_seconds``; an int: exactly that many steps
        (unless ``max_seconds`` ends the run first).
    max_steps : int
        Cap of ``steps="auto"``.
    max_seconds : float or None
        Wall-clock budget of the whole call; the run stops there, not converged.
        None or ``inf``: no limit (as ``timeout`` of :func:`brdffit.fit`).
    seed : int, optional
        Seeds the walkers, the moves and the coefficient draws (default: the fit's
        seed); the same seed gives the same samples.
    noise : {"given", "absolute", "relative", "mixed"}, optional
        Default: the fit's: ``"mixed"`` after a fit with the ``mixed`` loss (the
        default without sigma: the fitted ``sigma^2 = a^2 + (b f)^2``), else
        ``"given"`` when the data have sigma, else ``"absolute"``
        (:mod:`brdffit.posterior.target`).
    progress : callable, optional
        Called with a :class:`PosteriorProgress` at every convergence check.

    Returns
    -------
    Posterior
    """
    t0 = time.perf_counter()
    noise = _check_options(
        data, fit_result, walkers, steps, max_steps, max_seconds, seed, noise, progress, unknown
    )
    seed = int(fit_result.options.get("seed", 0) if seed is None else seed)
    deadline = t0 + max_seconds if max_seconds is not None else float("inf")
    problem, target = _target(data, fit_result, noise, walkers)
    run = (steps, max_steps, deadline, seed, progress, t0)
    common, info, note, kept_fraction = _draws(fit_result, problem, target, walkers, run)
    common.update(noise=noise, n_walkers=walkers, seed=seed)
    seconds = time.perf_counter() - t0
    return _posterior(common, info, max_seconds, seconds, note, kept_fraction)


def _draws(fit_result, problem, target, walkers: int, run: tuple):
    """The kept draws as the Posterior records them (with the chain), the run's
    diagnostics, the note on the draws (the energy restriction's, and that they are
    conditional on the model after a misfit) and the fraction the restriction kept."""
    deadline, seed = run[2], run[3]
    rng = np.random.default_rng([seed, 7])
    try:
        theta, chain, info = _shape_draws(target, walkers, rng, run)
        theta, coefs, note, kept_fraction = _coefficient_draws(
            fit_result, problem, target, theta, rng, deadline
        )
    finally:
        target.recall = None
    common = _common(problem, target, theta, coefs)
    common["chain"] = chain
    if fit_result.misfit and fit_result.misfit.get("detected"):
        note = "; ".join(x for x in (note, CONDITIONAL) if x)
    return common, info, note, kept_fraction


def _common(problem, target, theta, coefs) -> dict:
    """What the Posterior records of the problem and the draws (names, samples)."""
    names, samples = _samples(problem, target, theta, coefs)
    noise_name = (NOISE_NAME,) * target.estimates_noise
    return dict(
        model=problem.model.name,
        loss=problem.loss.name,
        names=names,
        samples=_canonical_samples(problem, names, samples),
        channels=tuple(problem.data.channels),
        sampled=tuple(p.name for p in problem.free_shape) + noise_name,
        sampled_log=tuple(bool(v) for v in target.log_scale) + (True,) * target.estimates_noise,
    )


def _check_dimensions(target, walkers: int) -> None:
    """Something to sample, and enough walkers for emcee."""
    if target.n_sampled == 0 and target.n_coefficients == 0:
        raise FitError(
            "every parameter of the fit is fixed and the noise is given: "
            "there is nothing to sample",
            "fixed",
        )
    if target.n_sampled and walkers < max(8, 2 * target.n_sampled):
        raise FitError(
            f"walkers={walkers} is too few: emcee needs at least {max(8, 2 * target.n_sampled)} "
            f"(8, and twice the {target.n_sampled} sampled dimensions)",
            "walkers",
        )


def _shape_draws(target, walkers: int, rng, run: tuple):
    """The kept points of the sampled dimensions (S, n_sampled), the chain and the
    run's diagnostics; without sampled dimensions, IID_DRAWS empty points."""
    if target.n_sampled == 0:
        return np.zeros((IID_DRAWS, 0)), np.zeros((0, walkers, 0)), None
    steps, max_steps, deadline, seed, progress, t0 = run
    mode, cov = laplace(target, target.theta_fit)
    target.recall = Recall()  # the points from here on: the chain's, for the draws
    start = start_walkers(target, mode, cov, walkers, rng)
    proposal = StudentIndependence(mode, cov)
    info = run_chain(target, start, proposal, steps, max_steps, deadline, seed, progress, t0)
    chain = info.chain
    kept = chain[info.burn :: _thin(info)] if info.burn < len(chain) else chain[-1:]
    return kept.reshape(-1, target.n_sampled), chain, info


def _coefficient_draws(fit_result, problem, target, theta, rng, deadline):
    """One draw of the coefficients per point of ``theta``; for an energy-conserving
    fit only the draws that keep its albedo rows, with the note and kept fraction."""
    coefs = target.draw_coefficients(theta, rng)
    if not fit_result.options.get("energy_conserving"):
        return theta, coefs, "", 1.0
    keep, note = restrict_to_energy(problem, target, theta, coefs, deadline)
    return theta[keep], coefs[keep], note, float(keep.mean())


def _target(data, fit_result, noise, walkers: int):
    """The fit's problem rebuilt on the data, and the log-posterior over it (checked
    to have something to sample with enough walkers)."""
    weights = fit_result.weights
    problem = Problem(
        data,
        fit_result.model,
        loss=fit_result.loss_name,
        weights=weights,
        fixed=dict(fit_result.fixed),
    )
    problem = _with_noise_model(problem, fit_result)
    if weights is not None:
        # Mean 1 over the samples that count: a zero weight removes a sample from
        # the likelihood, it does not lend its information to the others.
        weights = np.asarray(weights, dtype=float)
        weights = weights / np.mean(weights[weights > 0])
    target = Target(problem, noise, problem.x_from_params(fit_result.params), weights)
    _check_dimensions(target, walkers)
    return problem, target


def _with_noise_model(problem, fit_result):
    """The problem of a ``mixed`` fit weighted by its noise model at its prediction."""
    noise = fit_result.noise
    if not problem.loss.needs_noise:
        return problem
    if not noise or noise.get("model") != "mixed":
        raise FitError("a fit with the mixed loss must carry its noise model", "fit_result")
    pred = problem.predict(dict(fit_result.params))
    return problem.reweighted(NoiseModel(noise["a"], noise["b"]).sigma(pred))


def _thin(info) -> int:
    """Keep one step in ``round(tau)``: the kept samples are then nearly independent, and
    each costs one more evaluation of the design (for its coefficient draw)."""
    tau = info.tau[np.isfinite(info.tau)]
    return max(1, round(float(tau.max()))) if len(tau) else 1


def _samples(problem, target, theta, coefs):
    """Columns: coefficients per channel, free shape parameters, noise."""
    channels = problem.data.channels
    names, columns = [], []
    for j, coef in enumerate(problem.free_coefs):
        for c, ch in enumerate(channels):
            names.append(coef if len(channels) == 1 else f"{coef}[{ch}]")
            columns.append(coefs[:, c, j])
    shape = target.shape_values(theta[:, : target.n_shape])
    for i, p in enumerate(problem.free_shape):
        names.append(p.name)
        columns.append(shape[:, i])
    if target.estimates_noise:
        names.append(NOISE_NAME)
        columns.append(10.0 ** theta[:, target.n_shape])
    return tuple(names), np.column_stack(columns) if columns else np.zeros((len(theta), 0))


def _canonical_samples(problem, names, samples: np.ndarray) -> np.ndarray:
    """Each sample with its repeated lobes in the fit's canonical order.

    A sum with two lobes of one model has a posterior symmetric under swapping
    them (same likelihood, same prior box); walkers that cross over would mix
    the two labellings into one bimodal cloud. Relabelling every sample as the
    fit labels its optimum folds the posterior onto the ordered region, where
    it is the posterior of the labelled parameters.
    """
    model = problem.model
    if model.canonical is None or not len(samples):
        return samples
    params = {p.name for p in model.params}
    if not set(problem.free_coefs) <= params:
        return samples  # coefficients that are not parameters: left as drawn
    channels = problem.data.channels
    column = {name: i for i, name in enumerate(names)}

    def columns_of(name):
        if name in column:
            return [column[name]]
        return [column[f"{name}[{c}]"] for c in channels if f"{name}[{c}]" in column]

    free = {p.name: cols for p in model.params if (cols := columns_of(p.name))}
    base = {p.name: p.default for p in model.params}
    base.update(problem.fixed)
    out = samples.copy()
    for s, row in enumerate(samples):
        values = dict(base)
        values.update({name: row[cols] if len(cols) > 1 else row[cols[0]]
                       for name, cols in free.items()})  # fmt: skip
        ordered = model.canonical(values)
        for name, cols in free.items():
            out[s, cols] = ordered[name]
    return out


def _posterior(
    common: dict, info, max_seconds, seconds: float, energy_note: str, kept_fraction: float
) -> Posterior:
    """The Posterior with its diagnostics; ``kept_fraction`` of the draws survived the
    energy restriction (``energy_note`` says so), and the effective count with them."""
    note = f"; {energy_note}" if energy_note else ""
    if info is None:
        message = (
            "converged: nothing to sample by MCMC (no free shape parameter, noise given); "
            f"{len(common['samples'])} independent draws of the coefficients{note}"
        )
        return Posterior(
            **common,
            burn=0,
            thin=1,
            n_steps=0,
            autocorr_time={},
            effective_samples=len(common["samples"]),
            acceptance_fraction=1.0,
            converged=True,
            message=message,
            seconds=seconds,
        )
    n_post = info.steps - info.burn
    tau_max = float(np.nanmax(info.tau)) if np.isfinite(info.tau).any() else float("nan")
    ess = int(info.effective.min() * kept_fraction) if len(info.effective) else 0
    length = f"{n_post / tau_max:.0f}" if math.isfinite(tau_max) and n_post > 0 else "no"
    facts = (
        f"{plural(info.steps, 'step')}, burn-in {info.burn}, "
        f"{plural(length, 'autocorrelation time')} after burn-in, "
        f"{plural(ess, 'effective sample')}"
    )
    if info.converged:
        message = f"converged: {facts}"
    else:
        why = {
            "time": f"stopped by the time limit max_seconds={max_seconds}",
            "steps": "stopped at max_steps",
            "": "ran the steps asked for",
        }[info.stopped]
        message = f"not converged: {why}; {facts}, {TOL} are needed"
    message += note
    taus = {name: float(t) for name, t in zip(common["sampled"], info.tau)}
    return Posterior(
        **common,
        burn=info.burn,
        thin=_thin(info),
        n_steps=info.steps,
        autocorr_time=taus,
        effective_samples=ess,
        acceptance_fraction=info.acceptance,
        converged=info.converged,
        message=message,
        seconds=seconds,
    )
