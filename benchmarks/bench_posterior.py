"""Posterior sampling speed: ``brdffit.sample_posterior`` against plain emcee.

The task: ward_anisotropic (kd, ks, alpha_x, alpha_y) on 10,000 samples spread
over the hemisphere, one channel, Gaussian noise of sigma = 0.01 given with the
data. Measured: wall-clock seconds until the run has converged (at least 50
integrated autocorrelation times of sampling after burn-in) with at least
1,000 effective samples, from the same fit.

* brdffit: ``sample_posterior(data, fit_result, seed=s, max_seconds=None)``:
  alpha_x and alpha_y sampled (log10), kd and ks integrated out and drawn
  exactly, the log-density vectorised over walkers on the prepared geometry.
* plain emcee: ``emcee.EnsembleSampler(32, 4, log_prob)`` with its default
  stretch move, one call per walker (emcee's default), all four parameters
  sampled (kd, ks and log10 alphas, the same priors), the log-density written
  directly in numpy from the angles, so the half vector and cosines are
  recomputed at every call; started in a small ball around the fit (as emcee's
  tutorial does); run in chunks of 100 steps, each followed by the same
  convergence test as brdffit's (``brdffit.posterior.chain.assess``).
* plain emcee, vectorised (``vectorize=True``, one call per step), for context.

Run: ``python benchmarks/bench_posterior.py [--runs 3] [--cap 600]``. It prints
a Markdown table with the medians; benchmarks/README.md records one run.
"""

from __future__ import annotations

import argparse
import math
import platform
import time

import emcee
import numpy as np

from brdffit import Measurements, fit, get_model
from brdffit.posterior.chain import assess
from brdffit.posterior.sample import sample_posterior

N_SAMPLES = 10_000
SIGMA = 0.01
TRUTH = {"kd": 0.3, "ks": 0.4, "alpha_x": 0.12, "alpha_y": 0.3}
WALKERS = 32
TARGET_ESS = 1000
LOWER = np.array([0.0, 0.0, -3.0, -3.0])  # kd, ks, log10 alpha_x, log10 alpha_y
UPPER = np.array([1.0, 10.0, 0.0, 0.0])


def make_data(seed: int = 0) -> Measurements:
    rng = np.random.default_rng(seed)
    theta = np.degrees(np.arccos(rng.uniform(0.05, 1.0, (2, N_SAMPLES))))
    phi = rng.uniform(0.0, 360.0, (2, N_SAMPLES))
    probe = Measurements.from_angles(theta[0], phi[0], theta[1], phi[1], np.zeros(N_SAMPLES))
    f = get_model("ward_anisotropic").evaluate(probe.wi, probe.wo, TRUTH)
    y = f + SIGMA * rng.standard_normal(N_SAMPLES)
    return Measurements.from_angles(
        theta[0], phi[0], theta[1], phi[1], y, sigma=np.full(N_SAMPLES, SIGMA)
    )


class DirectLogProb:
    """The log-posterior written out in numpy from the angles, nothing prepared:
    Ward's anisotropic lobe (MODELS.md) with the half vector recomputed per call."""

    def __init__(self, data: Measurements):
        ti, pi_, to, po = (np.radians(a) for a in data.angles())
        self.angles = ti, pi_, to, po
        self.y = data.values[:, 0]
        self.inv_var = 1.0 / data.sigma[:, 0] ** 2

    def model(self, kd, ks, ax, ay):
        ti, pi_, to, po = self.angles
        li = np.stack([np.sin(ti) * np.cos(pi_), np.sin(ti) * np.sin(pi_), np.cos(ti)])
        vo = np.stack([np.sin(to) * np.cos(po), np.sin(to) * np.sin(po), np.cos(to)])
        h = li + vo
        h = h / np.linalg.norm(h, axis=0)
        expo = ((h[0] / ax) ** 2 + (h[1] / ay) ** 2) / h[2] ** 2
        lobe = np.exp(-expo) / (4 * np.pi * ax * ay * np.sqrt(li[2] * vo[2]))
        return kd / np.pi + ks * lobe

    def __call__(self, p):
        p = np.asarray(p, dtype=float)
        if p.ndim == 2:  # vectorised: one row per walker
            out = np.full(len(p), -np.inf)
            ok = ((p >= LOWER) & (p <= UPPER)).all(axis=1)
            if ok.any():
                q = p[ok]
                f = self.model(q[:, :1], q[:, 1:2], 10 ** q[:, 2:3], 10 ** q[:, 3:4])
                out[ok] = -0.5 * ((f - self.y) ** 2 * self.inv_var).sum(axis=1)
            return out
        if not ((p >= LOWER) & (p <= UPPER)).all():
            return -np.inf
        f = self.model(p[0], p[1], 10 ** p[2], 10 ** p[3])
        return float(-0.5 * ((f - self.y) ** 2 * self.inv_var).sum())


def run_brdffit(data, result, seed: int) -> dict:
    t0 = time.perf_counter()
    post = sample_posterior(data, result, seed=seed, max_seconds=None)
    seconds = time.perf_counter() - t0
    ok = post.converged and post.effective_samples >= TARGET_ESS
    return {
        "seconds": seconds,
        "ok": ok,
        "steps": post.n_steps,
        "tau": max(post.autocorr_time.values()),
        "ess": post.effective_samples,
    }


def run_plain(data, result, seed: int, vectorize: bool, cap: float) -> dict:
    log_prob = DirectLogProb(data)
    p = result.params
    centre = np.array([p["kd"], p["ks"], math.log10(p["alpha_x"]), math.log10(p["alpha_y"])])
    rng = np.random.default_rng(seed)
    start = centre + 1e-4 * rng.standard_normal((WALKERS, 4))
    t0 = time.perf_counter()
    sampler = emcee.EnsembleSampler(WALKERS, 4, log_prob, vectorize=vectorize)
    sampler.random_state = np.random.RandomState(seed).get_state()
    state = start
    while True:
        state = sampler.run_mcmc(state, 100)
        _, tau, eff, converged = assess(sampler.get_chain(), 0)
        seconds = time.perf_counter() - t0
        if (converged and eff.min() >= TARGET_ESS) or seconds > cap:
            break
    ok = converged and eff.min() >= TARGET_ESS
    return {
        "seconds": seconds,
        "ok": ok,
        "steps": sampler.iteration,
        "tau": float(np.nanmax(tau)),
        "ess": int(eff.min()),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--cap", type=float, default=600.0, help="seconds per baseline run")
    parser.add_argument("--vectorised-runs", type=int, default=1)
    args = parser.parse_args()
    data = make_data()
    result = fit(data, "ward_anisotropic")
    print(f"fit: {result.message}; {dict(result.params)}")
    rows = {
        "brdffit.sample_posterior": [run_brdffit(data, result, s) for s in range(args.runs)],
        "plain emcee (one call per walker)": [
            run_plain(data, result, s, False, args.cap) for s in range(args.runs)
        ],
        "plain emcee, vectorize=True": [
            run_plain(data, result, s, True, args.cap) for s in range(args.vectorised_runs)
        ],
    }
    print(
        f"\n{platform.processor() or platform.machine()}, Python {platform.python_version()}, "
        f"numpy {np.__version__}, emcee {emcee.__version__}\n"
    )
    print("| sampler | runs | median s | s per run | steps | max tau | min ESS | all converged |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    medians = {}
    for name, runs in rows.items():
        secs = [r["seconds"] for r in runs]
        medians[name] = float(np.median(secs))
        cells = [
            name,
            str(len(runs)),
            f"{medians[name]:.2f}",
            ", ".join(f"{s:.2f}" for s in secs),
            ", ".join(str(r["steps"]) for r in runs),
            ", ".join(f"{r['tau']:.1f}" for r in runs),
            ", ".join(str(r["ess"]) for r in runs),
            str(all(r["ok"] for r in runs)),
        ]
        print("| " + " | ".join(cells) + " |")
    ours = medians["brdffit.sample_posterior"]
    for name in list(rows)[1:]:
        print(f"\nspeed-up over {name}: {medians[name] / ours:.1f}x")


if __name__ == "__main__":
    main()
