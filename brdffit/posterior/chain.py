"""Running the ensemble for :mod:`brdffit.posterior.sample`: start, moves, convergence.

Start. The walkers start from the Laplace approximation of the posterior: a
few Newton steps from the fit on the log-posterior, with the Hessian by central
finite differences in the search space (all stencil points in one vectorised
call), then Gaussian draws with the inverse of that Hessian as covariance,
redrawn where they fall outside the bounds. They therefore start close to the
posterior, and the burn-in is short.

Moves. A mixture of emcee moves, each a valid Metropolis-Hastings kernel, so
the mixture is one too (Tierney 1994, Ann. Statist. 22, 1701): an independence
proposal from a multivariate Student-t (4 degrees of freedom) centred on the
Laplace approximation, re-centred once from the walkers after ``ADAPT_AT``
steps (everything before is burn-in, so the kept chain is a fixed kernel), and
the differential-evolution moves of ter Braak (2006) and ter Braak and Vrugt
(2008), which follow curved or non-Gaussian posteriors where the independence
proposal is poor. For the near-Gaussian posteriors of well-measured materials
the independence proposal makes successive samples nearly independent: the
autocorrelation time drops to a few steps.

Convergence. The integrated autocorrelation time ``tau`` of each sampled
coordinate is emcee's estimator (the autocorrelation function averaged over
walkers, summed up to Sokal's self-consistent window ``M >= 5 tau``),
vectorised here (:func:`integrated_time`). Burn-in is ``ADAPT_AT`` steps plus
``BURN_TAUS`` autocorrelation times; the run has converged when the chain after
burn-in is at least ``TOL`` (50) autocorrelation times long, as emcee's
documentation advises for a reliable estimate. The effective sample size of a
coordinate is ``walkers x (steps after burn-in) / tau``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

__all__ = [
    "PosteriorProgress",
    "ChainResult",
    "laplace",
    "start_walkers",
    "run_chain",
    "integrated_time",
    "assess",
]

#: Autocorrelation times of sampling after burn-in that convergence needs.
TOL = 50
#: Autocorrelation times discarded after the adaptation step.
BURN_TAUS = 3
#: Steps before the independence proposal is re-centred from the walkers.
ADAPT_AT = 25
#: Degrees of freedom of the Student-t independence proposal (heavy tails).
NU = 6.0
#: Steps between convergence checks, at least (and at least 10 % of the chain).
CHECK_EVERY = 25


@dataclass(frozen=True)
class PosteriorProgress:
    """What a ``progress`` callback of :func:`brdffit.sample_posterior` receives."""

    steps: int
    max_steps: int
    seconds: float
    autocorr_time: float
    effective_samples: int
    converged: bool


@dataclass(frozen=True)
class ChainResult:
    chain: np.ndarray  # (steps, walkers, dim) in search space
    steps: int
    burn: int
    tau: np.ndarray  # (dim,)
    effective: np.ndarray  # (dim,)
    acceptance: float
    converged: bool
    stopped: str  # "", "time", "steps"


# -------------------------------------------------------------------- Laplace
def _hessian(target, theta, h):
    """Log-density, gradient and Hessian at ``theta`` by central differences."""
    d = len(theta)
    eye = np.eye(d) * h
    points = [theta]
    points += [theta + eye[i] for i in range(d)] + [theta - eye[i] for i in range(d)]
    pairs = [(i, j) for i in range(d) for j in range(i + 1, d)]
    for i, j in pairs:
        for si, sj in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
            points.append(theta + si * eye[i] + sj * eye[j])
    f = target.log_prob(np.array(points))
    f0, fp, fm = f[0], f[1 : 1 + d], f[1 + d : 1 + 2 * d]
    grad = (fp - fm) / (2 * h)
    hess = np.diag((fp - 2 * f0 + fm) / h**2)
    for n, (i, j) in enumerate(pairs):
        pp, pm, mp, mm = f[1 + 2 * d + 4 * n : 5 + 2 * d + 4 * n]
        hess[i, j] = hess[j, i] = (pp - pm - mp + mm) / (4 * h[i] * h[j])
    return f0, grad, hess


def _precision(hess, width):
    """``-hess`` made positive definite: in units of the box width no direction may be
    wider than a quarter of the box (flat or convex directions get that width)."""
    scaled = -hess * np.outer(width, width)
    scaled = np.where(np.isfinite(scaled), scaled, 0.0)
    vals, vecs = np.linalg.eigh(0.5 * (scaled + scaled.T))
    vals = np.maximum(vals, 16.0)
    return (vecs * vals) @ vecs.T / np.outer(width, width)


def laplace(target, theta0, iterations: int = 6):
    """Mode and covariance of the Laplace approximation, by damped Newton steps."""
    lo, hi = target.lower, target.upper
    width = hi - lo
    theta = np.clip(np.asarray(theta0, dtype=float), lo, hi)
    h = 1e-3 * width
    cov = np.diag((0.25 * width) ** 2)
    for _ in range(iterations):
        h = np.minimum(h, 0.45 * width)
        centre = np.clip(theta, lo + 1.01 * h, hi - 1.01 * h)
        f0, grad, hess = _hessian(target, centre, h)
        if not (np.isfinite(f0) and np.isfinite(grad).all()):
            break
        prec = _precision(hess, width)
        cov = np.linalg.inv(prec)
        sd = np.sqrt(np.diag(cov))
        h = np.clip(0.3 * sd, 1e-9 * width, 0.05 * width)
        step = cov @ grad
        trials = np.clip(centre + step * (0.5 ** np.arange(6))[:, None], lo, hi)
        values = target.log_prob(np.vstack([theta, trials]))
        best = int(np.argmax(values))
        if best == 0:
            break
        moved = trials[best - 1] - theta
        theta = trials[best - 1]
        if (np.abs(moved) < 0.01 * sd).all():
            break
    return theta, cov


def start_walkers(target, mean, cov, n_walkers: int, rng: np.random.Generator):
    """Draws of ``N(mean, cov)`` inside the bounds with a finite log-density."""
    lo, hi = target.lower, target.upper
    chol = np.linalg.cholesky(cov)
    out = np.empty((n_walkers, len(mean)))
    todo = np.arange(n_walkers)
    for _ in range(100):
        draw = mean + rng.standard_normal((len(todo), len(mean))) @ chol.T
        ok = ((draw > lo) & (draw < hi)).all(axis=1)
        ok[ok] = np.isfinite(target.log_prob(draw[ok]))
        out[todo[ok]] = draw[ok]
        todo = todo[~ok]
        if not len(todo):
            return out
        chol = chol * 0.5  # tighten around the mode until the draws are admissible
    out[todo] = np.clip(
        mean + 1e-6 * (hi - lo) * rng.standard_normal((len(todo), len(mean))), lo, hi
    )
    return out


# ---------------------------------------------------------------------- moves
class StudentIndependence:
    """Independence proposal from a multivariate Student-t (emcee ``MHMove`` function)."""

    def __init__(self, mean, cov, nu: float | None = None):
        self.nu = NU if nu is None else nu
        self.set(mean, cov)

    def set(self, mean, cov):
        self.mean = np.asarray(mean, dtype=float)
        self.chol = np.linalg.cholesky(cov)

    def log_density(self, x):
        z = np.linalg.solve(self.chol, (x - self.mean).T).T
        return -0.5 * (self.nu + len(self.mean)) * np.log1p((z * z).sum(axis=1) / self.nu)

    def __call__(self, coords, random):
        n, d = coords.shape
        z = random.randn(n, d) * np.sqrt(self.nu / random.chisquare(self.nu, n))[:, None]
        proposal = self.mean + z @ self.chol.T
        return proposal, self.log_density(coords) - self.log_density(proposal)


#: Weights of the moves: independence proposal, differential evolution, DE snooker.
MOVE_WEIGHTS = (0.75, 0.25, 0.0)


def _emcee():
    """emcee, imported on the first posterior (a fit without one does not need it), and
    without the scipy.stats it would import (:mod:`brdffit.posterior.emcee_import`)."""
    from .emcee_import import import_emcee

    return import_emcee()


def _moves(proposal):
    emcee = _emcee()
    kinds = (emcee.moves.MHMove(proposal), emcee.moves.DEMove(), emcee.moves.DESnookerMove())
    return [(move, w) for move, w in zip(kinds, MOVE_WEIGHTS) if w > 0]


# ------------------------------------------------------------------------ run
def integrated_time(chain: np.ndarray, c: float = 5.0) -> np.ndarray:
    """Integrated autocorrelation time of each coordinate of ``chain`` (steps, walkers, dim).

    The estimator of emcee (``emcee.autocorr.integrated_time``), vectorised over
    walkers and coordinates: the normalised autocorrelation function of each
    walker by FFT, averaged over walkers, summed as ``tau(M) = 1 + 2 sum_{t=1}^M
    rho(t)`` up to the smallest window ``M >= c tau(M)`` (Sokal 1997, "Monte
    Carlo methods in statistical mechanics", sec. 3; Goodman and Weare 2010). A
    walker that never moved counts as fully correlated (``rho = 1``), so a stuck
    walker shows as a long autocorrelation time rather than vanishing.
    """
    n = chain.shape[0]
    x = chain - chain.mean(axis=0)
    size = 1 << (2 * n - 1).bit_length()
    spectrum = np.fft.rfft(x, n=size, axis=0)
    acf = np.fft.irfft(spectrum * spectrum.conj(), n=size, axis=0)[:n]
    var = acf[0]
    with np.errstate(invalid="ignore", divide="ignore"):
        rho = np.where(var > 0, acf / np.where(var > 0, var, 1.0), 1.0).mean(axis=1)
    taus = 2.0 * np.cumsum(rho, axis=0) - 1.0  # (n, dim)
    m = np.arange(n)[:, None]
    ok = m >= c * taus
    window = np.where(ok.any(axis=0), ok.argmax(axis=0), n - 1)
    return taus[window, np.arange(chain.shape[2])]


def assess(chain: np.ndarray, min_burn: int):
    """Burn-in, autocorrelation times after it, effective sizes, convergence."""
    n, walkers, dim = chain.shape
    if n - min_burn < 10:
        nan = np.full(dim, np.nan)
        return min(min_burn, n), nan, np.zeros(dim), False
    tau_all = integrated_time(chain[min_burn:])
    burn = min_burn + math.ceil(BURN_TAUS * np.nanmax(tau_all))
    if n - burn < 10:
        return min(burn, n), tau_all, np.zeros(dim), False
    tau = np.maximum(integrated_time(chain[burn:]), 1.0)
    effective = walkers * (n - burn) / tau
    return burn, tau, effective, bool(n - burn >= TOL * tau.max())


def _adapt(proposal, chain):
    """Re-centre the proposal on the walkers' positions over the second half so far."""
    pts = chain[len(chain) // 2 :].reshape(-1, chain.shape[2])
    cov = np.cov(pts, rowvar=False).reshape(chain.shape[2], chain.shape[2])
    try:
        proposal.set(pts.mean(axis=0), cov)
    except np.linalg.LinAlgError:
        pass  # degenerate spread: keep the Laplace approximation


def _advance(sampler, state, count: int, deadline: float):
    """Run ``count`` steps from ``state``; stop early at the deadline."""
    for _ in sampler.sample(state, iterations=count):
        if time.perf_counter() > deadline:
            return sampler.get_last_sample(), "time"
    return sampler.get_last_sample(), ""


def run_chain(target, start, proposal, steps, max_steps, deadline, seed, progress, t0):
    """Run until converged (``steps="auto"``) or for ``steps`` steps, within the deadline."""
    walkers, dim = start.shape
    moves = _moves(proposal)
    emcee = _emcee()
    sampler = emcee.EnsembleSampler(walkers, dim, target.log_prob, vectorize=True, moves=moves)
    sampler.random_state = np.random.RandomState(seed).get_state()
    auto = steps == "auto"
    limit = max_steps if auto else int(steps)
    state, stopped = emcee.State(start), ""
    while sampler.iteration < limit and not stopped:
        n = sampler.iteration
        goal = ADAPT_AT if n < ADAPT_AT else n + max(CHECK_EVERY, n // 10)
        state, stopped = _advance(sampler, state, min(goal, limit) - n, deadline)
        if n < ADAPT_AT <= sampler.iteration:
            _adapt(proposal, sampler.get_chain())
        elif auto or progress is not None:
            burn, tau, eff, converged = assess(sampler.get_chain(), ADAPT_AT)
            if progress is not None:
                seconds = time.perf_counter() - t0
                ess = int(eff.min())
                progress(PosteriorProgress(sampler.iteration, limit, seconds,
                                           float(np.nanmax(tau)), ess, converged))  # fmt: skip
            if auto and converged:
                break
    if auto and not stopped and sampler.iteration >= limit:
        stopped = "steps"
    chain = sampler.get_chain()
    burn, tau, eff, converged = assess(chain, min(ADAPT_AT, len(chain)))
    acceptance = float(np.mean(sampler.acceptance_fraction))
    return ChainResult(chain, len(chain), burn, tau, eff, acceptance, converged, stopped)
