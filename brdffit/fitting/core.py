"""The fitting engine: global search on nlopt, then a local polish.

``fit(data, model)`` estimates the parameters of any registered model (or sum
of lobes) from measurements. The optimiser searches only the free shape
parameters (log10 space for log-scale ones); the linear coefficients are solved
at every step (:class:`~brdffit.fitting.problem.Problem`). The strategy:

1. a global nlopt algorithm over the whole box of the shape parameters
   (default ``GN_CRS2_LM``, chosen by the comparison in
   ``benchmarks/bench_fit_algorithms.py``);
2. a local polish (default ``LN_BOBYQA``) from the best global point, from the
   user's ``start`` if given, and from ``restarts`` further distinct good points
   of the global stage; the best polished point wins.

The objective never returns NaN (nlopt hangs on NaN with some algorithms), a
fit never outlives its ``timeout``, and a fit that did not converge says so.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace

import nlopt
import numpy as np

from ..errors import FitError
from ..models import get_model
from .losses import LossContext
from .problem import Problem
from .result import FitResult, metrics_of

__all__ = ["DEFAULT_GLOBAL", "DEFAULT_LOCAL", "FitProgress", "fit"]

DEFAULT_GLOBAL = "GN_CRS2_LM"
#: Above this many samples the global stage works on a seeded subsample of this size.
GLOBAL_SAMPLES = 20_000
DEFAULT_LOCAL = "LN_BOBYQA"
_CONVERGED = {nlopt.SUCCESS, nlopt.STOPVAL_REACHED, nlopt.FTOL_REACHED, nlopt.XTOL_REACHED}
_REASONS = {
    nlopt.SUCCESS: "success",
    nlopt.STOPVAL_REACHED: "objective reached its stop value",
    nlopt.FTOL_REACHED: "relative change of the loss below tolerance",
    nlopt.XTOL_REACHED: "relative change of the parameters below tolerance",
    nlopt.MAXEVAL_REACHED: "evaluation budget used up",
    nlopt.MAXTIME_REACHED: "time limit reached",
    nlopt.ROUNDOFF_LIMITED: "stopped by round-off",
    nlopt.FORCED_STOP: "stopped",
}


@dataclass(frozen=True)
class FitProgress:
    """What a ``progress`` callback receives."""

    stage: str
    n_evals: int
    max_evals: int
    best_loss: float
    seconds: float


class _Stop(Exception):
    pass


class _Search:
    """The objective handed to nlopt: counts, keeps the best, obeys budget and deadline."""

    def __init__(self, problem: Problem, max_evals: int, deadline: float, progress):
        self.problem = problem
        self.max_evals = max_evals
        self.deadline = deadline
        self.progress = progress
        self.n_evals = 0
        self.best = None
        self.history: list[tuple[float, np.ndarray]] = []
        self.stage = ""
        self.t0 = time.perf_counter()
        self.stopped = ""
        self.opt = None
        self.error = None
        self.global_problem = None

    def __call__(self, x, grad=None):
        if self.n_evals >= self.max_evals or time.perf_counter() > self.deadline:
            self.stopped = (
                "evaluation budget used up" if self.n_evals >= self.max_evals else "timeout"
            )
            self.opt.force_stop()
            return self.best.loss if self.best is not None else 1e300
        self.n_evals += 1
        try:
            sol = self.problem.solve(np.asarray(x, dtype=float))
        except Exception as exc:  # a bug, not bad input: stop nlopt and re-raise after it
            self.error = exc
            self.opt.force_stop()
            return 1e300
        self.history.append((sol.loss, np.array(x, dtype=float)))
        if self.best is None or sol.loss < self.best.loss:
            self.best = sol
            self.best_x = np.array(x, dtype=float)
        if self.progress is not None and self.n_evals % 25 == 0:
            self.report()
        return sol.loss

    def scout(self) -> _Search:
        """A search for the global stage: on the same problem, or, for large data, on
        a seeded subsample of GLOBAL_SAMPLES samples (the global stage only has to
        find the right basin; the polish then runs on every sample)."""
        if self.global_problem is None:
            return self
        out = _Search(self.global_problem, self.max_evals, self.deadline, self.progress)
        out.t0 = self.t0
        return out

    def absorb(self, scout: _Search):
        """Take over the scout's counts (its losses are on another sample set)."""
        if scout is self:
            return
        self.n_evals += scout.n_evals
        self.stopped = self.stopped or scout.stopped
        if scout.error is not None:
            raise scout.error

    def report(self):
        if self.progress is not None and self.best is not None:
            self.progress(
                FitProgress(
                    self.stage,
                    self.n_evals,
                    self.max_evals,
                    self.best.loss,
                    time.perf_counter() - self.t0,
                )
            )

    def run(self, algorithm: str, x0, budget: int, stage: str) -> int | None:
        """Run one nlopt stage; return nlopt's result code (None if it raised)."""
        p = self.problem
        remaining = min(budget, self.max_evals - self.n_evals)
        if self.max_evals - self.n_evals <= 0:
            self.stopped = "evaluation budget used up"
            return None
        if time.perf_counter() > self.deadline:
            self.stopped = "timeout"
            return None
        self.stage = stage
        opt = nlopt.opt(getattr(nlopt, algorithm), p.dim)
        self.opt = opt
        opt.set_lower_bounds(p.lower)
        opt.set_upper_bounds(p.upper)
        opt.set_min_objective(self)
        opt.set_maxeval(int(remaining))
        opt.set_maxtime(max(self.deadline - time.perf_counter(), 1e-3))
        if algorithm.startswith("G"):
            if algorithm.startswith(("GN_MLSL", "G_MLSL", "GD_MLSL")):
                local = nlopt.opt(nlopt.LN_BOBYQA, p.dim)
                local.set_xtol_rel(1e-4)
                opt.set_local_optimizer(local)
            opt.set_population(0)
        else:
            opt.set_xtol_rel(1e-7)
            opt.set_ftol_rel(1e-12)
            opt.set_initial_step(0.05 * (p.upper - p.lower))
        try:
            opt.optimize(np.clip(np.asarray(x0, dtype=float), p.lower, p.upper))
            code = opt.last_optimize_result()
        except (nlopt.ForcedStop, nlopt.RoundoffLimited, RuntimeError, ValueError):
            code = opt.last_optimize_result()
        except nlopt.invalid_argument:
            # e.g. NEWUOA, which needs at least two free parameters
            field = "global_algorithm" if stage == "global" else "local_algorithm"
            raise FitError(
                f"{field}={algorithm!r} cannot run on this problem with {p.dim} free shape "
                f"parameter(s) of {p.model.name}; choose another algorithm (LN_BOBYQA works "
                "for any number)",
                field,
            ) from None
        if self.error is not None:
            raise self.error
        if code == nlopt.MAXTIME_REACHED:
            self.stopped = "timeout"
        elif code == nlopt.MAXEVAL_REACHED and self.n_evals >= self.max_evals:
            self.stopped = "evaluation budget used up"
        self.report()
        return code


def _algorithm(name, field: str, prefix: tuple) -> str | None:
    if name is None or name == "none":
        return None
    if not isinstance(name, str) or not hasattr(nlopt, name) or not name.startswith(prefix):
        kinds = (
            "global (GN_...)" if prefix[0].startswith("G") else "local derivative-free (LN_...)"
        )
        raise FitError(f"{field}={name!r} is not an nlopt {kinds} algorithm name", field)
    return name


def _positive_int(value, field: str, default: int) -> int:
    if value is None:
        return default
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value <= 0:
        raise FitError(f"{field}={value!r} must be a positive whole number", field)
    return int(value)


def _distinct_starts(search: _Search, count: int, exclude: list) -> list:
    """Up to ``count`` good points of the history, each at least 0.1 of the box away
    (in the search space) from every point already chosen."""
    p = search.problem
    width = np.where(p.upper > p.lower, p.upper - p.lower, 1.0)
    chosen = list(exclude)
    out = []
    for _, x in sorted(search.history, key=lambda t: t[0]):
        if len(out) >= count:
            break
        if all(np.max(np.abs((x - c) / width)) > 0.1 for c in chosen):
            chosen.append(x)
            out.append(x)
    return out


def fit(
    data,
    model,
    *,
    loss: str | None = None,
    weights=None,
    fixed: Mapping | None = None,
    free=(),
    start: Mapping | None = None,
    global_algorithm: str | None = DEFAULT_GLOBAL,
    local_algorithm: str = DEFAULT_LOCAL,
    global_evals: int | None = None,
    local_evals: int | None = None,
    restarts: int = 2,
    max_evals: int | None = None,
    timeout: float | None = None,
    seed: int = 0,
    energy_conserving: bool = False,
    progress: Callable[[FitProgress], None] | None = None,
    uncertainty: bool = False,
    posterior_options: Mapping | None = None,
) -> FitResult:
    """Fit ``model`` to ``data``.

    Parameters
    ----------
    data : Measurements
    model : str or Model
        A registered name, a sum of lobes (``"lambert+cook_torrance+cook_torrance"``)
        or a Model.
    loss : str, optional
        ``l2``, ``cosine``, ``log``, ``cbrt``, ``relative`` or ``chi2``
        (:mod:`brdffit.fitting.losses`). Default: ``chi2`` when the data give per-sample
        sigma (weighted least squares, the maximum-likelihood fit for Gaussian
        noise of that sigma), ``l2`` otherwise.
    weights : array_like (N,), optional
        Per-sample weights.
    fixed : mapping, optional
        Parameters held at given values.
    free : sequence of str
        Parameters that the model holds by default (``Model.held``: material
        constants and instrument properties of ``he``) to search anyway.
    start : mapping, optional
        An initial guess of shape parameters; polished locally besides the global stage.
    global_algorithm, local_algorithm : str
        nlopt algorithm names; ``global_algorithm=None`` skips the global stage.
    global_evals, local_evals : int, optional
        Budgets of the stages (defaults grow with the number of shape params).
    restarts : int
        Further local polishes from distinct good points of the global stage.
    max_evals : int, optional
        Cap on all objective evaluations.
    timeout : float, optional
        Seconds; the fit returns its best point when it is reached.
    seed : int
        Seeds nlopt's stochastic algorithms; the same seed gives the same result.
    energy_conserving : bool
        Constrain the directional albedo to at most 1 at every incidence angle
        (0 to 85 degrees by 5, enforced exactly on the linear coefficients at
        every step; :mod:`brdffit.fitting.energy`). The result is then checked with the
        full-accuracy quadrature from 0 to 89 degrees: ``metrics["max_albedo"]``
        and the message say what was found.
    progress : callable, optional
        Called with a :class:`FitProgress` now and then.
    uncertainty : bool
        Also sample the posterior (:func:`brdffit.sample_posterior`) with
        ``posterior_options``; the result's ``posterior`` holds it.
    """
    t0 = time.perf_counter()
    if loss is None:
        loss = "chi2" if getattr(data, "sigma", None) is not None else "l2"
    if not isinstance(energy_conserving, bool):
        raise FitError(f"energy_conserving={energy_conserving!r} must be True or False",
                       "energy_conserving")  # fmt: skip
    fixed = _with_held(get_model(model), fixed, free)
    problem = Problem(data, model, loss=loss, weights=weights, fixed=fixed,
                      energy_conserving=energy_conserving)  # fmt: skip
    d = problem.dim
    global_algorithm = _algorithm(global_algorithm, "global_algorithm", ("GN_", "G_MLSL", "GD_"))
    local_algorithm = _algorithm(local_algorithm, "local_algorithm", ("LN_",))
    if local_algorithm is None:
        raise FitError(
            "local_algorithm is needed: the polish is what converges", "local_algorithm"
        )
    global_evals = _positive_int(global_evals, "global_evals", 60 + 60 * d)
    local_evals = _positive_int(local_evals, "local_evals", 100 + 100 * d)
    max_evals = _positive_int(max_evals, "max_evals", 10**9)
    if isinstance(restarts, bool) or not isinstance(restarts, (int, np.integer)) or restarts < 0:
        raise FitError(f"restarts={restarts!r} must be a whole number >= 0", "restarts")
    if timeout is not None and (not isinstance(timeout, (int, float)) or not timeout > 0):
        raise FitError(f"timeout={timeout!r} must be a positive number of seconds", "timeout")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise FitError(f"seed={seed!r} must be a whole number", "seed")
    if progress is not None and not callable(progress):
        raise FitError("progress must be a callable taking a FitProgress", "progress")
    x_start = problem.x_from_params({**_shape_defaults(problem), **(start or {})}) if d else None
    if start:
        unknown = [k for k in start if k not in {p.name for p in problem.free_shape}]
        if unknown:
            raise FitError(
                f"start gives {unknown[0]!r}, which is not a free shape parameter of "
                f"{problem.model.name} ({', '.join(p.name for p in problem.free_shape)})",
                "start",
            )
    deadline = t0 + timeout if timeout is not None else float("inf")
    search = _Search(problem, max_evals, deadline, progress)
    if data.n > GLOBAL_SAMPLES and global_algorithm is not None:
        index = np.sort(
            np.random.default_rng(int(seed)).choice(data.n, GLOBAL_SAMPLES, replace=False)
        )
        search.global_problem = Problem(
            data.subset(index), problem.model, loss=loss,
            weights=None if weights is None else np.asarray(weights)[index],
            fixed=fixed, energy_conserving=energy_conserving,
        )  # fmt: skip
    nlopt.srand(int(seed))
    code = _optimise(
        search,
        problem,
        x_start,
        bool(start),
        global_algorithm,
        local_algorithm,
        global_evals,
        local_evals,
        restarts,
    )
    result = _result(problem, search, code, time.perf_counter() - t0, locals())
    if uncertainty:
        from ..posterior.sample import sample_posterior

        post = sample_posterior(data, result, **dict(posterior_options or {}))
        result = replace(result, posterior=post)
    return result


def _with_held(model, fixed, free) -> dict:
    """The user's ``fixed``, plus the model's held parameters at their defaults
    unless they are named in ``free`` (or fixed by the user)."""
    if isinstance(free, str) or not all(isinstance(n, str) for n in free):
        raise FitError("free must be a list of parameter names", "free")
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


def _shape_defaults(problem: Problem) -> dict:
    return {p.name: p.default for p in problem.free_shape}


def _optimise(
    search,
    problem,
    x_start,
    have_start,
    global_algorithm,
    local_algorithm,
    global_evals,
    local_evals,
    restarts,
):
    """Global stage, then polishes; returns the nlopt code of the winning polish."""
    if problem.dim == 0:
        search.n_evals += 1
        search.best = problem.solve(np.zeros(0))
        search.best_x = np.zeros(0)
        return nlopt.SUCCESS
    starts = [x_start] if (have_start or global_algorithm is None) else []
    if global_algorithm is not None:
        scout = search.scout()
        scout.run(global_algorithm, x_start, global_evals, "global")
        search.absorb(scout)
        if scout.best is not None:
            starts.append(scout.best_x.copy())
        starts += _distinct_starts(scout, restarts, starts)
    winner = None
    for i, x0 in enumerate(starts):
        before = search.best.loss if search.best is not None else np.inf
        code = search.run(local_algorithm, x0, local_evals, f"local {i + 1}/{len(starts)}")
        if code is None:
            break
        # The code that counts is that of the polish which found the best point.
        if winner is None or search.best.loss < before:
            winner = code
    return winner


def _at_bounds(problem: Problem, x: np.ndarray) -> tuple:
    out = []
    for p, v, lo, hi in zip(problem.free_shape, x, problem.lower, problem.upper):
        tol = 1e-6 * max(hi - lo, 1e-12)
        if v <= lo + tol or v >= hi - tol:
            out.append(p.name)
    return tuple(out)


def _result(problem: Problem, search: _Search, code, seconds: float, options: dict) -> FitResult:
    if search.best is None:
        raise FitError(
            "the fit stopped before its first evaluation (timeout or max_evals)", "timeout"
        )
    params = problem.params_of(search.best)
    pred = problem.predict(params)
    data = problem.data
    ctx = LossContext(
        cos_i=np.maximum(data.wi[:, 2], 0.0),
        y=np.asarray(data.values),
        sigma=data.sigma,
        weights=None,
    )
    n_params = problem.dim + len(problem.free_coefs) * problem.n_channels
    converged = code in _CONVERGED and search.best.loss < 1e300 and not search.stopped
    reason = search.stopped or _REASONS.get(code, f"nlopt result {code}")
    at_bounds = _at_bounds(problem, search.best_x) if problem.dim else ()
    message = ("converged: " if converged else "not converged: ") + reason
    if at_bounds:
        message += "; at a bound of its range: " + ", ".join(at_bounds)
    metrics = metrics_of(pred, ctx.y, ctx, n_params)
    if problem.energy is not None:
        from .energy import check_energy

        top, err, angle = check_energy(problem.model, params)
        metrics["max_albedo"] = top
        message += f"; energy: max directional albedo {top:.6f} (+-{err:.1e}) at {angle:g} deg" + (
            "" if top <= 1 + 1e-3 else ", ABOVE 1 between the enforced angles"
        )
    keep = (
        "loss",
        "global_algorithm",
        "local_algorithm",
        "global_evals",
        "local_evals",
        "restarts",
        "max_evals",
        "timeout",
        "seed",
        "energy_conserving",
        "weights",
    )
    options = {k: options[k] for k in keep}
    if options["weights"] is not None:
        options["weights"] = np.array(options["weights"], dtype=float)
    return FitResult(
        model=problem.model.name,
        params=params,
        loss=problem.exact_loss(params),
        loss_name=problem.loss.name,
        metrics=metrics,
        n_samples=data.n,
        n_channels=problem.n_channels,
        n_values=int(ctx.y.size),
        n_params=n_params,
        n_evals=search.n_evals,
        seconds=seconds,
        converged=bool(converged),
        message=message,
        channels=tuple(data.channels),
        fixed=dict(problem.fixed),
        options=options,
        at_bounds=at_bounds,
    )
