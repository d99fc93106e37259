"""Which nlopt global algorithm should the fitting engine use by default?

Every candidate runs the same strategy (global stage with the same budget, then
LN_BOBYQA polishes from the best point and 2 further distinct points) on the
data_synthetic/ suite, on seeded random truths anywhere in the parameter box
(noiseless, so that only the optimiser can fail), and on the Cornell files.
"none" is a local polish from the default start alone. Reported per algorithm:
success rate, median and total time, median evaluations.

    python benchmarks/bench_fit_algorithms.py [--per-model 3] [--algorithms A,B]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _suite import cornell_cases, machine, random_cases, recovered, synthetic_cases

import brdffit

CANDIDATES = [
    "GN_DIRECT_L",
    "GN_DIRECT_L_RAND",
    "GN_CRS2_LM",
    "GN_ISRES",
    "GN_ESCH",
    "GN_MLSL_LDS",
    "none",
]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-model", type=int, default=3)
    ap.add_argument("--algorithms", default=",".join(CANDIDATES))
    args = ap.parse_args()
    cases = synthetic_cases() + random_cases(args.per_model) + cornell_cases()
    algorithms = args.algorithms.split(",")
    runs = {}
    for alg in algorithms:
        for case in cases:
            t0 = time.perf_counter()
            r = brdffit.fit(
                case.data,
                case.model,
                global_algorithm=None if alg == "none" else alg,
                restarts=0 if alg == "none" else 2,
                seed=1,
            )
            runs[alg, case.label] = (r, time.perf_counter() - t0)
    best = {c.label: min(runs[a, c.label][0].loss for a in algorithms) for c in cases}
    print(f"machine: {machine()}")
    print(
        f"{len(cases)} problems: {sum(c.truth is not None for c in cases)} with known truth, "
        f"{sum(c.truth is None for c in cases)} real\n"
    )
    print("| algorithm | success | failed on | median s | total s | median evals |")
    print("|---|---|---|---|---|---|")
    for alg in algorithms:
        ok, failed, secs, evals = 0, [], [], []
        for c in cases:
            r, s = runs[alg, c.label]
            secs.append(s)
            evals.append(r.n_evals)
            if c.truth is not None:
                good = recovered(c, r.params)
            else:
                good = r.loss <= best[c.label] * (1 + 1e-4) + 1e-300
            ok += good
            if not good:
                failed.append(c.label.split("/", 1)[1])
        shown = ", ".join(failed[:4]) + (f" (+{len(failed) - 4})" if len(failed) > 4 else "")
        print(
            f"| {alg} | {ok}/{len(cases)} ({100 * ok / len(cases):.0f} %) | {shown or '-'} | "
            f"{np.median(secs):.3f} | {sum(secs):.1f} | {int(np.median(evals))} |"
        )


if __name__ == "__main__":
    main()
