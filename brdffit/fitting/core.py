"""``fit(data, model)`` and ``check_fit(data, model)``: the fitting front end.

``fit`` estimates the parameters of any registered model (or sum of lobes) from
measurements, in four steps:

1. the options are gathered and checked (:mod:`.options`, one
   :class:`~brdffit.fitting.options.FitOptions` with one ``validate()``);
2. the model is bound to the data (:class:`~brdffit.fitting.problem.Problem`:
   the free shape parameters are searched, in log10 for log-scale ones, the
   linear coefficients are solved at every step);
3. nlopt searches the shape parameters, globally and then by local polishes
   (:mod:`.engine`);
4. the best point becomes a :class:`~brdffit.fitting.result.FitResult`, with
   every metric, a message saying how the search ended, the energy check of an
   ``energy_conserving`` fit, and the posterior when ``uncertainty`` is asked.

``check_fit`` does steps 1 and 2 only: it raises exactly what ``fit`` would
raise for bad data, a bad model or bad options, without evaluating the model.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from time import perf_counter
from types import SimpleNamespace

import numpy as np

from ..data.measurements import Measurements
from ..errors import DataError, FitError, under_option
from ..models import get_model
from . import sums
from .energy import enforce_energy
from .engine import CONVERGED, FitProgress, StopFit, reason, search
from .losses import LossContext
from .misfit import assess, refit_on_misfit
from .noise import reweight
from .options import DEFAULT_GLOBAL, DEFAULT_LOCAL, FitOptions
from .problem import BAD_LOSS, Problem, linear_at_bounds
from .result import FitResult, beyond_reach, metrics_of

#: The largest |value| of fitted data must lie in this range: the fit squares
#: residuals and weights (1/sigma^2) and sums up to 1e9 of them, which must stay
#: finite and above the subnormals (1e-308) in double precision.
VALUE_RANGE = (1e-100, 1e100)
#: sigma over the largest |value| must lie in this range: the squared residuals over
#: sigma^2, residuals on the values' scale, must stay finite and normal (within
#: 1e+-200, room left for sums) in double precision. (A relative sigma of 1 % on a
#: value 1e-30 of the largest is 1e-32 of it: allowed.)
SIGMA_RANGE = (1e-100, 1e100)
#: Seconds of the timeout that must be left for the posterior to be sampled at all.
MIN_POSTERIOR_SECONDS = 0.1

__all__ = [
    "DEFAULT_GLOBAL",
    "DEFAULT_LOCAL",
    "FitOptions",
    "FitProgress",
    "StopFit",
    "check_fit",
    "fit",
]


def fit(data, model, **options) -> FitResult:
    """Fit ``model`` to ``data``.

    Parameters
    ----------
    data : Measurements
    model : str or Model
        A registered name, a sum of lobes (``"lambert+cook_torrance+cook_torrance"``)
        or a Model.
    **options
        The options of :class:`~brdffit.fitting.options.FitOptions`, which says
        what each means: ``loss``, ``weights``, ``fixed``, ``free``, ``start``,
        ``global_algorithm``, ``local_algorithm``, ``global_evals``,
        ``local_evals``, ``restarts``, ``max_evals``, ``timeout``, ``seed``,
        ``coarse_above``, ``coarse_samples``, ``energy_conserving``, ``progress``,
        ``uncertainty``, ``posterior_options``.

    Returns
    -------
    FitResult
        Its ``converged`` and ``message`` say how the search ended (tolerance,
        budget, ``timeout``, or stopped by the ``progress`` callback through
        :class:`StopFit` or a ``False`` answer).

    Raises
    ------
    brdffit.errors.BrdfFitError
        For bad data, model or options (what :func:`check_fit` raises).
    """
    t0 = perf_counter()
    opts, problem, x_start = _prepare(data, model, options)
    found, code = search(problem, opts, x_start, bool(opts.start), t0)
    # The mixed loss (the default without sigma) reweights by its fitted noise model;
    # the first search is handed over in a list it empties, so that its problem (arrays
    # of the data's size) can go when the first round's replaces it.
    first = [problem, found]
    del problem, found
    problem, found, code, noise = reweight(first, code, opts, t0)
    # An energy-conserving fit: checked, and polished again where albedo passes 1.
    problem, found, code, energy = enforce_energy(problem, found, code, opts, t0)
    problem.let_go()  # the search's inputs go before the checks form their arrays
    fields, pred = _result(problem, found, code, opts, perf_counter() - t0, energy)
    # the checks' fields join the result's before it is built, once
    fields.update(assess(problem, SimpleNamespace(**fields), noise, pred))
    result = FitResult(**fields)
    # The fitted prediction (shared by the metrics and the misfit verdict) and the
    # problem go before a refit builds its own (a MERL file's peak: 130 MB less).
    del pred, problem, found
    result = refit_on_misfit(fit, data, model, options, result)
    if opts.uncertainty:
        result = _with_posterior(data, result, opts, t0)
    return result


def _with_posterior(data, result: FitResult, opts: FitOptions, t0: float) -> FitResult:
    """The posterior of ``result`` sampled within what is left of the fit's
    ``timeout`` (its ``max_seconds`` capped there); none when nothing is left."""
    from ..posterior.sample import sample_posterior

    options = dict(opts.posterior_options or {})
    if opts.timeout is not None:
        left = t0 + opts.timeout - perf_counter()
        if left < MIN_POSTERIOR_SECONDS:
            note = "; posterior not sampled: the timeout was reached"
            return replace(result, message=result.message + note)
        given = options.get("max_seconds", 60.0)
        options["max_seconds"] = left if given is None else min(given, left)
    return replace(result, posterior=sample_posterior(data, result, **options))


def check_fit(data, model, **options) -> None:
    """Raise what :func:`fit` would raise for ``data``, ``model`` and ``options``,
    without fitting (the model is not evaluated): a quick check of a fit to run later.

    The options of ``posterior_options`` are checked by
    :func:`brdffit.sample_posterior` when it runs (only their being a mapping is
    checked here).

    Raises
    ------
    brdffit.errors.BrdfFitError
        A :class:`~brdffit.errors.FitError`, :class:`~brdffit.errors.ModelError`,
        :class:`~brdffit.errors.ParameterError` or :class:`~brdffit.errors.DataError`
        whose ``field`` names what is wrong.
    """
    _prepare(data, model, options)


for _function in (fit, check_fit):
    _function.__signature__ = FitOptions.signature(_function)


def _prepare(data, model, options: Mapping):
    """The checked options (defaults resolved), the problem, and the start point."""
    opts = FitOptions.of(options).validate()
    if not isinstance(data, Measurements):
        raise DataError(
            f"data must be Measurements (from brdffit.read or Measurements.from_angles), "
            f"not {type(data).__name__}",
            "data",
        )
    _check_signal(data)
    model = get_model(model)
    fixed = _with_held(model, opts.fixed, opts.free)
    opts = opts.with_loss(has_sigma=data.sigma is not None)
    problem = Problem(data, model, loss=opts.loss, weights=opts.weights, fixed=fixed,
                      energy_conserving=opts.energy_conserving)  # fmt: skip
    opts = opts.with_budgets(problem.dim)
    return opts, problem, _start(problem, opts.start)


def _check_signal(data: Measurements) -> None:
    """Refuse data with no value above 0 (every model is >= 0: the fit would only
    find coefficients of 0, every shape parameter left where it started), and values
    or sigma at scales the least squares cannot carry (:data:`VALUE_RANGE`,
    :data:`SIGMA_RANGE`)."""
    values = np.asarray(data.values, dtype=float)
    high, low = float(values.max()), float(values.min())  # no temporaries (3.3 M on MERL)
    if not high > 0:
        what = "0" if high == low == 0 else "0 or below"
        raise DataError(
            f"the data have no signal to fit: all {values.size} values are {what}; a "
            "reflectance model needs values above 0 (check the file's value column and "
            "units)",
            "values",
        )
    top = max(high, -low)
    if not VALUE_RANGE[0] <= top <= VALUE_RANGE[1]:
        raise DataError(
            f"the largest value is {top:.3g}: fitting needs the largest |value| between "
            f"{VALUE_RANGE[0]:g} and {VALUE_RANGE[1]:g} (squares and sums of squares must "
            "stay finite and normal in double precision); rescale the values",
            "values",
        )
    if data.sigma is not None:  # the least and largest sigma / top: those of sigma over
        sigma = np.asarray(data.sigma, dtype=float)  # it (a division rounds monotonically)
        for bad, limit, why in (
            (sigma.min() / top < SIGMA_RANGE[0], "min", "the weights 1/sigma^2 would overflow"),
            (sigma.max() / top > SIGMA_RANGE[1], "max", "the weights 1/sigma^2 would underflow"),
        ):
            if bad:
                sigma = float(getattr(np.asarray(data.sigma), limit)())
                raise DataError(
                    f"sigma {sigma:.3g} is {sigma / top:.3g} times the largest value "
                    f"({top:.3g}): {why}; sigma must be between {SIGMA_RANGE[0]:g} and "
                    f"{SIGMA_RANGE[1]:g} times it (give sigma in the values' units)",
                    "sigma",
                )


def _with_held(model, fixed, free) -> dict:
    """The user's ``fixed``, plus the model's held parameters at their defaults
    unless they are named in ``free`` (or fixed by the user)."""
    for name in free:
        if name not in model.held:
            held = ", ".join(model.held) or "none"
            raise FitError(
                f"free names {name!r}, which {model.name} does not hold (it holds: {held})",
                "free",
            )
    out = {n: model.param(n).default for n in model.held if n not in free}
    out.update(fixed or {})
    return out


def _start(problem: Problem, start) -> np.ndarray | None:
    """The start point in the search space: the user's ``start`` over the defaults."""
    names = [p.name for p in problem.free_shape]
    unknown = [k for k in (start or {}) if k not in names]
    if unknown:
        raise FitError(
            f"start gives {unknown[0]!r}, which is not a free shape parameter of "
            f"{problem.model.name} ({', '.join(names) or 'none'})",
            "start",
        )
    if not problem.dim:
        return None
    params = {p.name: p.default for p in problem.free_shape}
    for name, value in (start or {}).items():
        with under_option("start", name):
            params[name] = problem.model.param(name).check(value)
    return problem.x_from_params(params)


def _at_bounds(problem: Problem, x: np.ndarray, params: Mapping) -> tuple:
    """The free parameters at a bound of their range: shape parameters in the search
    space (within 1e-6 of it), linear ones (kd, ks...) in any channel (the solve clips
    them there; :func:`~brdffit.fitting.problem.linear_at_bounds`)."""
    out = []
    for p, v, lo, hi in zip(problem.free_shape, x, problem.lower, problem.upper):
        tol = 1e-6 * max(hi - lo, 1e-12)
        if v <= lo + tol or v >= hi - tol:
            out.append(p.name)
    for p in problem.model.linear_params:
        if p.name in problem.fixed:
            continue
        low, high = linear_at_bounds(p, params[p.name])
        if low.any() or high.any():
            out.append(p.name)
    return tuple(out)


def _result(
    problem: Problem, found, code, opts: FitOptions, seconds: float, energy=None
) -> tuple[dict, np.ndarray]:
    """The fields of the FitResult of the search's best point, and the prediction there
    (N, C), which :meth:`Problem.predict` gives to later callers while it is held."""
    if found.best is None:
        raise FitError(
            "the fit stopped before its first evaluation (timeout or max_evals)", "timeout"
        )
    params = problem.params_of(found.best)
    data = problem.data
    y = np.asarray(data.values)  # a table's columns: row by row for one block of metrics
    y = np.ascontiguousarray(y) if y.size <= sums.VALUES else y  # (the same values)
    ctx = LossContext(cos_i=np.maximum(data.wi[:, 2], 0.0), y=y, sigma=data.sigma, weights=None)
    n_params = problem.dim + len(problem.free_coefs) * problem.n_channels
    pred = problem.predict(params)  # held while exact_loss shares it (Problem.predict)
    metrics = metrics_of(pred, y, ctx, n_params)
    # The l2 loss without weights is the l2 metric (the same sum over every value, the
    # pairs below the horizon predicted 0): not summed a second time (3.3 M on MERL).
    unweighted_l2 = problem.loss.name == "l2" and problem.user_weights is None
    loss = metrics["l2"] if unweighted_l2 else problem.exact_loss(params, pred)
    converged = code in CONVERGED and found.best.loss < BAD_LOSS and not found.stopped
    at_bounds = _at_bounds(problem, found.best_x if problem.dim else (), params)
    deadline = None if opts.timeout is None else (perf_counter() - seconds) + opts.timeout
    unidentified = _unidentified(problem, params, deadline, pred)
    message = ("converged: " if converged else "not converged: ") + (found.stopped or reason(code))
    if at_bounds:
        message += "; at a bound of its range: " + ", ".join(at_bounds)
    if unidentified:
        message += "; not identified by the data: " + ", ".join(unidentified)
    message += beyond_reach(problem.model, params, at_bounds, y, pred)
    if found.schedule:
        message += "; " + found.schedule
    if energy is not None:
        metrics["max_albedo"] = energy.top
        message += energy.note()
    fields = dict(
        model=problem.model.name,
        params=params,
        loss=loss,
        loss_name=problem.loss.name,
        metrics=metrics,
        n_samples=data.n,
        n_channels=problem.n_channels,
        n_values=int(y.size),
        n_params=n_params,
        n_evals=found.n_evals,
        seconds=seconds,
        converged=bool(converged),
        message=message,
        channels=tuple(data.channels),
        fixed=dict(problem.fixed),
        options=opts.record(),
        at_bounds=at_bounds,
        weights=opts.weights,
        unidentified=unidentified,
    )
    return fields, pred


def _unidentified(problem: Problem, params: Mapping, deadline=None, pred=None) -> dict:
    """The parameters the data do not constrain, with why
    (:mod:`brdffit.fitting.identifiability`, given the fit's prediction ``pred``); none
    where the check cannot be made."""
    from .identifiability import unidentified

    try:
        return unidentified(problem, params, deadline, pred)
    except (np.linalg.LinAlgError, FloatingPointError, ValueError):
        return {}
