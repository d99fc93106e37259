"""Posterior sampling with the compiled kernels against the numpy formulas, one run.

The task of ``bench_posterior.py`` (ward_anisotropic, 10,000 samples, sigma given,
one channel) and the same fit; then ``sample_posterior(data, fit, seed=s,
max_seconds=None)`` with the kernels on and off (``brdffit.kernels.use``),
alternating, ``--runs`` times each; CPU seconds (``time.process_time``) and wall
seconds, medians, and the posterior means of the two (same seed, so the same
chain up to the rounding of the kernels).

    python benchmarks/bench_posterior_kernels.py [--runs 3]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

from bench_posterior import make_data

from brdffit import fit, kernels
from brdffit.posterior.sample import sample_posterior


def timed(data, result, seed: int, on: bool) -> tuple:
    with kernels.use(on):
        cpu, wall = time.process_time(), time.perf_counter()
        post = sample_posterior(data, result, seed=seed, max_seconds=None)
        return time.process_time() - cpu, time.perf_counter() - wall, post


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args(argv)
    with open("/proc/loadavg") as handle:
        load = " ".join(handle.read().split()[:3])
    data = make_data(0)
    result = fit(data, "ward_anisotropic")
    runs = {True: [], False: []}
    for seed in range(args.runs):
        for on in (True, False):
            runs[on].append(timed(data, result, seed, on))
    print(f"# Posterior sampling, compiled kernels vs numpy (load average {load})\n")
    print("| path | CPU s (median) | wall s (median) | mean alpha_x | mean alpha_y | steps |")
    print("| --- | ---: | ---: | ---: | ---: | ---: |")
    for on in (True, False):
        cpu = statistics.median(r[0] for r in runs[on])
        wall = statistics.median(r[1] for r in runs[on])
        post = runs[on][0][2]
        means = post.samples.mean(axis=0)
        ax, ay = (float(means[post.names.index(k)]) for k in ("alpha_x", "alpha_y"))
        name = "compiled" if on else "numpy"
        steps = post.chain.shape[0]
        print(f"| {name} | {cpu:.2f} | {wall:.2f} | {ax:.6g} | {ay:.6g} | {steps} |")
    on = statistics.median(r[0] for r in runs[True])
    off = statistics.median(r[0] for r in runs[False])
    print(f"\nSpeed-up (CPU): {off / on:.2f}x\n\nCommand: python {' '.join(sys.argv)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
