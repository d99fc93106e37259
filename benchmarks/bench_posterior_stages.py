"""Where the CPU time of ``bench_posterior``'s posterior goes, stage by stage.

The task of ``bench_posterior.py`` (ward_anisotropic, 10,000 samples, sigma given),
``sample_posterior(data, fit, seed=s, max_seconds=None)`` for ``--runs`` seeds after
one untimed run; the functions of each stage are wrapped with
``time.process_time`` and each stage counts its own time only (a stage called from
another is taken out of the caller's): the problem and target, the Laplace start,
the walkers' start, the design of every batch of walkers, their weighted sums and
solves, the rest of the log-density (bounds, noise, truncation masses), emcee's own
moves and bookkeeping, the convergence assessments, the coefficient draws and
building the result. The wrapped names exist in every tree since c65122c, so the
same file times another tree with ``PYTHONPATH=TREE``.

    python benchmarks/bench_posterior_stages.py [--runs 5] [--kernels 1|0]
"""

from __future__ import annotations

import argparse
import collections
import sys
import time

from bench_posterior import make_data

from brdffit import fit, kernels
from brdffit.posterior import chain, sample
from brdffit.posterior import target as target_module

#: Stage -> (module or class, attribute) of the functions it times.
STAGES = {
    "problem and target": (sample, "_target"),
    "Laplace start": (sample, "laplace"),
    "walkers' start": (sample, "start_walkers"),
    "design": (target_module.Target, "designs"),
    "weighted sums and solves": (target_module.Target, "_stats"),
    "rest of the log-density": (target_module.Target, "log_prob"),
    "emcee's moves and bookkeeping": (sample, "run_chain"),
    "convergence assessments": (chain, "assess"),
    "coefficient draws": (sample, "_coefficient_draws"),
    "building the result": (sample, "_posterior"),
}

SELF = collections.defaultdict(float)
CALLS = collections.defaultdict(int)
_stack: list[float] = []


def _wrap(owner, name: str, stage: str) -> None:
    function = getattr(owner, name)

    def timed(*args, **kwargs):
        _stack.append(0.0)
        start = time.process_time()
        try:
            return function(*args, **kwargs)
        finally:
            elapsed = time.process_time() - start
            children = _stack.pop()
            SELF[stage] += elapsed - children
            CALLS[stage] += 1
            if _stack:
                _stack[-1] += elapsed

    setattr(owner, name, timed)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--kernels", type=int, default=1, choices=(0, 1))
    args = parser.parse_args(argv)
    for stage, (owner, name) in STAGES.items():
        _wrap(owner, name, stage)
    data = make_data(0)
    result = fit(data, "ward_anisotropic")
    with kernels.use(bool(args.kernels)):
        sample.sample_posterior(data, result, seed=0, max_seconds=None)  # loads numba
        SELF.clear()
        CALLS.clear()
        start = time.process_time()
        for seed in range(args.runs):
            post = sample.sample_posterior(data, result, seed=seed, max_seconds=None)
        total = (time.process_time() - start) / args.runs
    print(f"# {sample.__file__}: kernels {'on' if args.kernels else 'off'}, {args.runs} runs\n")
    print("| stage | ms a run | calls a run |")
    print("| --- | ---: | ---: |")
    for stage in STAGES:
        ms, calls = SELF[stage] * 1000 / args.runs, CALLS[stage] / args.runs
        print(f"| {stage} | {ms:.1f} | {calls:.0f} |")
    other = total - sum(SELF.values()) / args.runs
    print(f"| other (sample_posterior's own) | {other * 1000:.1f} | |")
    print(f"| **total** | **{total * 1000:.1f}** | |")
    print(f"\nlast run: {post.message}; {len(post.samples)} samples")
    return 0


if __name__ == "__main__":
    sys.exit(main())
