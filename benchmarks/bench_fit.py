"""Fitting speed and success against the obvious alternative, in one run.

For every model on its data_synthetic/ dataset and for blinn, ward,
cook_torrance and ashikhmin_shirley on the Cornell files: brdffit.fit with its
defaults, and scipy.optimize.least_squares over every parameter (shape and
per-channel linear), multi-start (4 starts) within the same bounds, with the
Jacobian's sparsity given and the geometry prepared once
(tests/scipy_baseline.py). Then the targets of the fitting issue: cook_torrance
on a Cornell file (1439 samples x 31 bands) under 1 s, and a 100,000-sample
dataset under 10 s (medians of repeated runs).

    python benchmarks/bench_fit.py [--skip-scipy] [--repeats 5] [--fit-repeats 3]

brdffit's time per case is the median of ``--fit-repeats`` identical seeded
fits; scipy's is one run (its Cornell fits take minutes each).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _suite import CORNELL, cornell_cases, machine, recovered, synthetic_cases
from scipy_baseline import baseline_fit

import brdffit


def run_cases(cases, with_scipy: bool, repeats: int):
    """Each case by brdffit (median time of ``repeats`` seeded, identical fits) and,
    once, by the scipy baseline (minutes per Cornell case: one run each)."""
    rows = []
    for case in cases:
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            ours = brdffit.fit(case.data, case.model)
            times.append(time.perf_counter() - t0)
        t_ours = float(np.median(times))
        row = {"case": case, "ours": ours, "t_ours": t_ours}
        if with_scipy:
            params, mse, evals, t_sp = baseline_fit(
                case.data, case.model, starts=4, fixed=ours.fixed
            )
            row.update(scipy_params=params, scipy_loss=mse, scipy_evals=evals, t_scipy=t_sp)
        rows.append(row)
    return rows


def success(row, which: str) -> bool:
    case = row["case"]
    if which == "ours":
        params, loss = row["ours"].params, row["ours"].loss
    else:
        params, loss = row["scipy_params"], row["scipy_loss"]
    if case.truth is not None:
        return recovered(case, params)
    best = min(row["ours"].loss, row.get("scipy_loss", np.inf))
    return loss <= best * (1 + 1e-4)


def table(rows, with_scipy: bool):
    head = "| problem | brdffit s | evals | ok |"
    if with_scipy:
        head += " scipy s | evals | ok | speed-up |"
    print(head)
    print("|" + "---|" * (head.count("|") - 1))
    for row in rows:
        line = (
            f"| {row['case'].label} | {row['t_ours']:.3f} | {row['ours'].n_evals} | "
            f"{'yes' if success(row, 'ours') else 'NO'} |"
        )
        if with_scipy:
            line += (
                f" {row['t_scipy']:.2f} | {row['scipy_evals']} | "
                f"{'yes' if success(row, 'scipy') else 'NO'} | "
                f"{row['t_scipy'] / row['t_ours']:.0f}x |"
            )
        print(line)


def summary(rows, with_scipy: bool):
    n = len(rows)
    ok = sum(success(r, "ours") for r in rows)
    synth = [r for r in rows if r["case"].truth is not None]
    print(
        f"\nbrdffit: {ok}/{n} succeeded; synthetic recovery "
        f"{sum(success(r, 'ours') for r in synth)}/{len(synth)}; "
        f"total {sum(r['t_ours'] for r in rows):.1f} s, "
        f"median {np.median([r['t_ours'] for r in rows]):.3f} s"
    )
    if with_scipy:
        ok_s = sum(success(r, "scipy") for r in rows)
        ratios = [r["t_scipy"] / r["t_ours"] for r in rows]
        print(
            f"scipy least_squares: {ok_s}/{n} succeeded; "
            f"total {sum(r['t_scipy'] for r in rows):.1f} s"
        )
        print(
            f"speed-up per problem: median {np.median(ratios):.0f}x, min {min(ratios):.0f}x; "
            "total time ratio "
            f"{sum(r['t_scipy'] for r in rows) / sum(r['t_ours'] for r in rows):.0f}x"
        )


def timed(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def targets(repeats: int):
    print("\n| target | median s | limit s | met |")
    print("|---|---|---|---|")
    if CORNELL.exists():
        for f in ["garnet_red.astm", "krylon_blue.astm", "acryl_blue.brdf"]:
            data = brdffit.read(CORNELL / f)
            t = timed(lambda d=data: brdffit.fit(d, "cook_torrance"), repeats)
            print(
                f"| cook_torrance on {f} (1439 x 31) | {t:.3f} | 1 | {'yes' if t < 1 else 'NO'} |"
            )
    truth = {"kd": [0.2, 0.3, 0.4], "ks": [0.5, 0.6, 0.7], "m": 0.15, "eta": 1.6}
    big = brdffit.synthesize(
        "cook_torrance",
        truth,
        geometry="hemisphere",
        n=100_000,
        noise=0.01,
        seed=1,
        channels=["r", "g", "b"],
    )
    t = timed(lambda: brdffit.fit(big, "cook_torrance"), max(1, repeats // 2))
    print(
        f"| cook_torrance on 100,000 samples x 3 channels | {t:.3f} | 10 | "
        f"{'yes' if t < 10 else 'NO'} |"
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--skip-scipy", action="store_true")
    ap.add_argument("--repeats", type=int, default=5, help="runs of each target")
    ap.add_argument("--fit-repeats", type=int, default=3, help="brdffit runs per case")
    args = ap.parse_args()
    print(f"machine: {machine()}\n")
    rows = run_cases(synthetic_cases() + cornell_cases(), not args.skip_scipy, args.fit_repeats)
    table(rows, not args.skip_scipy)
    summary(rows, not args.skip_scipy)
    targets(args.repeats)


if __name__ == "__main__":
    main()
