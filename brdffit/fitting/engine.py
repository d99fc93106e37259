"""The nlopt search of a fit: a global stage over the box of the shape parameters,
then local polishes.

1. A global nlopt algorithm over the whole box (default ``GN_CRS2_LM``, chosen
   by the comparison in ``benchmarks/bench_fit_algorithms.py``); above
   :data:`GLOBAL_SAMPLES` samples it scouts a seeded subsample (it only has to
   find the right basin).
2. A local polish (default ``LN_BOBYQA``) on every sample, from the best global
   point, from the user's ``start`` if given, and from ``restarts`` further
   distinct good points of the global stage; the best polished point wins.

Above ``coarse_above`` samples the coarse-to-fine schedule of
:mod:`brdffit.fitting.schedule` runs both stages on a stratified subsample and
then one polish on every sample from the subsample's best point.

The objective never returns NaN (nlopt hangs on NaN with some algorithms; a
shape the model cannot take gets :data:`~brdffit.fitting.problem.BAD_LOSS`),
the search never outlives its budget or deadline, and it stops when a
``progress`` callback raises :class:`StopFit` or returns ``False``. Any other
exception of a callback, or of the model, stops nlopt and is raised again to
the caller of :func:`brdffit.fit`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import nlopt
import numpy as np

from ..errors import FitError
from .problem import BAD_LOSS, Problem
from .schedule import FINE_FTOL, FINE_STEP, note, stratified_rows, subproblem

#: A polish's relative tolerance on the loss (the polish on all of large data stops at
#: the looser :data:`~brdffit.fitting.schedule.FINE_FTOL`).
POLISH_FTOL = 1e-12

__all__ = [
    "CONVERGED",
    "GLOBAL_SAMPLES",
    "FitProgress",
    "Search",
    "StopFit",
    "reason",
    "search",
]

#: Above this many samples the global stage works on a seeded subsample of this size.
GLOBAL_SAMPLES = 20_000
#: nlopt's codes of a polish that ended on its tolerance.
CONVERGED = {nlopt.SUCCESS, nlopt.STOPVAL_REACHED, nlopt.FTOL_REACHED, nlopt.XTOL_REACHED}
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
BUDGET, TIMEOUT = "evaluation budget used up", "timeout"
#: Why a fit stopped when its progress callback asked it to.
STOPPED = "stopped by the progress callback"


@dataclass(frozen=True)
class FitProgress:
    """What a ``progress`` callback receives."""

    stage: str
    n_evals: int
    max_evals: int
    best_loss: float
    seconds: float


class StopFit(Exception):
    """Raise it in a ``progress`` callback to stop a fit: the fit returns its best point
    so far, not converged, its message saying it was stopped. (Returning ``False``
    from the callback does the same.) Any other exception raised in a callback
    propagates to the caller of :func:`brdffit.fit`."""


def reason(code) -> str:
    """An nlopt result code in words."""
    return _REASONS.get(code, f"nlopt result {code}")


class Search:
    """The objective handed to nlopt: counts, keeps the best, obeys budget, deadline
    and the progress callback. ``stopped`` says why it ended early ("" if it did not)."""

    def __init__(self, problem: Problem, max_evals: int, deadline: float, progress, t0=None):
        self.problem, self.max_evals, self.deadline = problem, max_evals, deadline
        self.progress = progress
        self.n_evals = 0
        self.best = None
        self.best_x = None
        self.history: list[tuple[float, np.ndarray]] = []
        self.stage = ""
        self.t0 = time.perf_counter() if t0 is None else t0
        self.stopped = ""
        self.opt = None
        self.error: BaseException | None = None
        #: The coarse-to-fine schedule in words ("" when the search ran on all samples).
        self.schedule = ""

    def __call__(self, x, grad=None):
        if self.stopped == STOPPED:
            self.opt.force_stop()
            return self.best.loss
        if self.n_evals >= self.max_evals or time.perf_counter() > self.deadline:
            self.stopped = BUDGET if self.n_evals >= self.max_evals else TIMEOUT
            self.opt.force_stop()
            return self.best.loss if self.best is not None else BAD_LOSS
        try:
            loss = self.evaluate(x)
            if self.n_evals % 25 == 0:
                self.report()
        except BaseException as exc:  # a bug or the caller's: stop nlopt, raise after it
            self.error = exc
            self.opt.force_stop()
            return BAD_LOSS
        if self.stopped:
            self.opt.force_stop()
        return loss

    def evaluate(self, x) -> float:
        """The objective at ``x``, counted and remembered."""
        self.n_evals += 1
        x = np.array(x, dtype=float)
        sol = self.problem.solve(x)
        self.history.append((sol.loss, x))
        if self.best is None or sol.loss < self.best.loss:
            self.best, self.best_x = sol, x
        return sol.loss

    def report(self):
        """Tell the progress callback; a :class:`StopFit` or a ``False`` answer stops
        the search, any other exception propagates."""
        if self.progress is None or self.best is None:
            return
        seconds = time.perf_counter() - self.t0
        report = FitProgress(self.stage, self.n_evals, self.max_evals, self.best.loss, seconds)
        try:
            answer = self.progress(report)
        except StopFit:
            answer = False
        if answer is False:
            self.stopped = STOPPED

    def run(
        self, algorithm: str, x0, budget: int, stage: str, step=None, ftol=POLISH_FTOL
    ) -> int | None:
        """Run one nlopt stage; return nlopt's result code (None if it could not start).
        ``step``: a local algorithm's initial step, as a share of each range; ``ftol``:
        its relative tolerance on the loss."""
        if not self.stopped and self.n_evals >= self.max_evals:
            self.stopped = BUDGET
        elif not self.stopped and time.perf_counter() > self.deadline:
            self.stopped = TIMEOUT
        if self.stopped:
            return None
        self.stage = stage
        opt = self.opt = _optimiser(algorithm, self.problem, step, ftol)
        opt.set_min_objective(self)
        opt.set_maxeval(int(min(budget, self.max_evals - self.n_evals)))
        opt.set_maxtime(max(self.deadline - time.perf_counter(), 1e-3))
        p = self.problem
        try:
            opt.optimize(np.clip(np.asarray(x0, dtype=float), p.lower, p.upper))
        except (nlopt.ForcedStop, nlopt.RoundoffLimited, RuntimeError, ValueError):
            pass  # nlopt's own ends; the code below says which
        except nlopt.invalid_argument:
            # e.g. NEWUOA, which needs at least two free parameters
            field = "global_algorithm" if stage == "global" else "local_algorithm"
            raise FitError(
                f"{field}={algorithm!r} cannot run on this problem with {p.dim} free shape "
                f"parameter(s) of {p.model.name}; choose another algorithm (LN_BOBYQA works "
                "for any number)",
                field,
            ) from None
        finally:
            # The optimiser holds this search as its objective, out of the garbage
            # collector's sight: kept here too, the two would keep each other, and the
            # problem with its arrays (a leak of 80 MB a reweighting round on MERL).
            self.opt = None
        if self.error is not None:
            raise self.error
        code = opt.last_optimize_result()
        if code == nlopt.MAXTIME_REACHED:
            self.stopped = self.stopped or TIMEOUT
        elif code == nlopt.MAXEVAL_REACHED and self.n_evals >= self.max_evals:
            self.stopped = self.stopped or BUDGET
        if self.stopped != STOPPED:
            self.report()
        return code


def _optimiser(algorithm: str, problem: Problem, step=None, ftol=POLISH_FTOL):
    """An nlopt optimiser of ``algorithm`` on the problem's box, with the stage's
    tolerances (the global stage runs to its budget; the polish to 1e-7 in x or
    ``ftol`` relative in the loss, its initial step ``step`` of each range, 0.05 by
    default)."""
    opt = nlopt.opt(getattr(nlopt, algorithm), problem.dim)
    opt.set_lower_bounds(problem.lower)
    opt.set_upper_bounds(problem.upper)
    if algorithm.startswith("G"):
        if algorithm.startswith(("GN_MLSL", "G_MLSL", "GD_MLSL")):
            local = nlopt.opt(nlopt.LN_BOBYQA, problem.dim)
            local.set_xtol_rel(1e-4)
            opt.set_local_optimizer(local)
        opt.set_population(0)
    else:
        opt.set_xtol_rel(1e-7)
        opt.set_ftol_rel(ftol)
        opt.set_initial_step((0.05 if step is None else step) * (problem.upper - problem.lower))
    return opt


def search(problem: Problem, options, x_start, have_start: bool, t0: float):
    """Search the shape parameters of ``problem`` with resolved
    :class:`~brdffit.fitting.options.FitOptions`; return the search (its best point,
    counts and why it stopped) and the nlopt code of the winning polish."""
    deadline = t0 + options.timeout if options.timeout is not None else float("inf")
    main = Search(problem, options.max_evals, deadline, options.progress, t0)
    if problem.dim == 0:  # nothing to search (nor to seed: 15 us of a 0.5 ms fit)
        main.evaluate(np.zeros(0))
        return main, nlopt.SUCCESS
    nlopt.srand(options.seed)
    if problem.geometry.m > max(options.coarse_above, options.coarse_samples):
        return _coarse_to_fine(main, options, x_start, have_start)
    starts = [x_start] if (have_start or options.global_algorithm is None) else []
    if options.global_algorithm is not None:
        scout = _scout(main, options)
        scout.run(options.global_algorithm, x_start, options.global_evals, "global")
        _absorb(main, scout)
        if scout.best is not None:
            starts.append(scout.best_x.copy())
        starts += _distinct_starts(scout, options.restarts, starts)
    code = _polish(main, starts, options.local_algorithm, options.local_evals)
    if main.best is None and options.global_algorithm is not None and scout.best is not None:
        # The scout's stage ended the search (budget, deadline, callback) before any
        # polish: its best point, evaluated once on all the samples, is the answer.
        main.evaluate(scout.best_x)
    return main, code


def _polish(main: Search, starts: list, algorithm: str, budget: int):
    winner = None
    for i, x0 in enumerate(starts):
        before = main.best.loss if main.best is not None else np.inf
        code = main.run(algorithm, x0, budget, f"local {i + 1}/{len(starts)}")
        if code is None:
            break
        # The code that counts is that of the polish which found the best point.
        if winner is None or main.best.loss < before:
            winner = code
    return winner


def _scout(main: Search, options) -> Search:
    """The search of the global stage: ``main`` itself, or, for large data, a search
    on a seeded subsample of GLOBAL_SAMPLES samples (the polish then runs on all)."""
    p = main.problem
    if p.data.n <= GLOBAL_SAMPLES:
        return main
    index = np.sort(
        np.random.default_rng(options.seed).choice(p.data.n, GLOBAL_SAMPLES, replace=False)
    )
    weights = None if options.weights is None else np.asarray(options.weights)[index]
    sub = Problem(p.data.subset(index), p.model, loss=options.loss, weights=weights,
                  fixed=p.fixed, energy_conserving=options.energy_conserving)  # fmt: skip
    return Search(sub, main.max_evals, main.deadline, main.progress, main.t0)


def _coarse_to_fine(main: Search, options, x_start, have_start: bool):
    """The search of :mod:`~brdffit.fitting.schedule`: both stages on a stratified
    subsample, then one polish on every sample from the subsample's best point."""
    p = main.problem
    sub_problem = subproblem(p, *stratified_rows(p, options.coarse_samples, options.seed))
    sub = Search(sub_problem, main.max_evals, main.deadline, main.progress, main.t0)
    starts = [x_start] if (have_start or options.global_algorithm is None) else []
    if options.global_algorithm is not None:
        sub.run(options.global_algorithm, x_start, options.global_evals, "global")
        if sub.best is not None:
            starts.append(sub.best_x.copy())
        starts += _distinct_starts(sub, options.restarts, starts)
    _polish(sub, starts, options.local_algorithm, options.local_evals)
    _absorb(main, sub)
    x0 = sub.best_x if sub.best is not None else x_start
    code = main.run(options.local_algorithm, x0, options.local_evals, "local on all samples",
                    FINE_STEP, FINE_FTOL)  # fmt: skip
    if main.best is None and sub.best is not None:
        main.evaluate(sub.best_x)  # the subsample's search used up the budget or time
    main.schedule = note(sub_problem, p, sub.n_evals, main.n_evals - sub.n_evals)
    return main, code


def _absorb(main: Search, scout: Search):
    """Take over the scout's counts and stop reason (its losses are on another sample set)."""
    if scout is main:
        return
    main.n_evals += scout.n_evals
    main.stopped = main.stopped or scout.stopped
    if scout.error is not None:
        raise scout.error


def _distinct_starts(search: Search, count: int, exclude: list) -> list:
    """Up to ``count`` good points of the history, each at least 0.1 of the box away
    (in the search space) from every point already chosen: in the order of their
    losses, the first far enough from ``exclude`` and from those chosen before it."""
    if count <= 0 or not search.history:
        return []
    p = search.problem
    width = np.where(p.upper > p.lower, p.upper - p.lower, 1.0)
    points = np.array([x for _, x in search.history])
    order = np.argsort([loss for loss, _ in search.history], kind="stable")
    far = np.ones(len(points), dtype=bool)
    for c in exclude:
        far &= np.max(np.abs((points - c) / width), axis=1) > 0.1
    out = []
    while len(out) < count:
        left = order[far[order]]
        if not left.size:
            break
        out.append(search.history[left[0]][1])
        far &= np.max(np.abs((points - out[-1]) / width), axis=1) > 0.1
    return out
