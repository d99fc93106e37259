"""Posterior sampling with the compiled kernels against the numpy formulas, one run.

The task of ``bench_posterior.py`` (ward_anisotropic, 10,000 samples, sigma given,
one channel) and the same fit; then ``sample_posterior(data, fit, seed=s,
max_seconds=None)`` with the kernels on and off (``brdffit.kernels.use``),
alternating, ``--runs`` times each; CPU seconds (``time.process_time``) and wall
seconds, medians, and the posterior means of the two (same seed, so the same
chain up to the rounding of the kernels).

With ``--against TREE`` (a source tree of brdffit, such as another branch's
worktree) the same measurements run in child processes, this tree's and TREE's
alternating, ``--rounds`` times, each child timing ``--runs`` seeds after one
untimed run (numba's loading); the table then has a row per tree and path, and
the ratio of the two trees' medians, with the statistics of the chains (means,
the largest autocorrelation time, the effective samples) to show they match.

    python benchmarks/bench_posterior_kernels.py [--runs 3]
    python benchmarks/bench_posterior_kernels.py --against /work/main --rounds 3
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

from bench_posterior import make_data

from brdffit import fit, kernels
from brdffit.posterior.sample import sample_posterior

HERE = Path(__file__).resolve().parent


def timed(data, result, seed: int, on: bool) -> tuple:
    with kernels.use(on):
        cpu, wall = time.process_time(), time.perf_counter()
        post = sample_posterior(data, result, seed=seed, max_seconds=None)
        return time.process_time() - cpu, time.perf_counter() - wall, post


def _load() -> str:
    with open("/proc/loadavg") as handle:
        return " ".join(handle.read().split()[:3])


def _summary(post) -> dict:
    means = post.samples.mean(axis=0)
    return {
        "alpha_x": float(means[post.names.index("alpha_x")]),
        "alpha_y": float(means[post.names.index("alpha_y")]),
        "steps": int(post.chain.shape[0]),
        "tau": max(post.autocorr_time.values()),
        "ess": int(post.effective_samples),
    }


def child(runs: int) -> int:
    """Time ``runs`` seeds with the kernels on, then off, after an untimed run each;
    print them as one JSON line."""
    data = make_data(0)
    result = fit(data, "ward_anisotropic")
    out = {}
    for on in (True, False):
        timed(data, result, 0, on)  # loads numba and the loops: not timed
        rows = [timed(data, result, seed, on) for seed in range(runs)]
        out["compiled" if on else "numpy"] = {
            "cpu": [r[0] for r in rows],
            "wall": [r[1] for r in rows],
            "chains": [_summary(r[2]) for r in rows],
        }
    print(json.dumps(out))
    return 0


def against(other: str, runs: int, rounds: int) -> int:
    """This tree against ``other``, child processes alternating."""
    trees = {"this": str(HERE.parent), "against": str(Path(other).resolve())}
    load = _load()
    results = {name: {"compiled": [], "numpy": []} for name in trees}
    for _ in range(rounds):
        for name, tree in trees.items():
            env = dict(os.environ, PYTHONPATH=tree, OPENBLAS_NUM_THREADS="1")
            command = [sys.executable, str(HERE / Path(__file__).name), "--child"]
            command += ["--runs", str(runs)]
            done = subprocess.run(command, env=env, capture_output=True, text=True, check=True)
            for path, value in json.loads(done.stdout.strip().splitlines()[-1]).items():
                results[name][path].append(value)
    print(f"# Posterior sampling, {trees['this']} against {trees['against']}")
    print(f"(load average {load} at the start, {_load()} at the end)\n")
    print("| tree | path | CPU s (median) | range | mean alpha_x | mean alpha_y | steps | tau "
          "| ESS |")  # fmt: skip
    print("| --- | --- | ---: | --- | ---: | ---: | ---: | ---: | ---: |")
    medians = {}
    for name in trees:
        for path in ("compiled", "numpy"):
            cpu = [c for r in results[name][path] for c in r["cpu"]]
            medians[name, path] = statistics.median(cpu)
            s = results[name][path][0]["chains"][0]
            print(
                f"| {name} | {path} | {medians[name, path]:.3f} | {min(cpu):.3f}-{max(cpu):.3f} "
                f"| {s['alpha_x']:.9g} | {s['alpha_y']:.9g} | {s['steps']} | {s['tau']:.4g} "
                f"| {s['ess']} |"
            )
    for path in ("compiled", "numpy"):
        ratio = medians["against", path] / medians["this", path]
        print(f"\n{path}: against / this = {ratio:.2f}x")
    print(f"\nCommand: python {' '.join(sys.argv)}")
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--against", help="another brdffit source tree, timed alternately")
    parser.add_argument("--rounds", type=int, default=3, help="child processes per tree")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        return child(args.runs)
    if args.against:
        return against(args.against, args.runs, args.rounds)
    load = _load()
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
        s = _summary(runs[on][0][2])
        name = "compiled" if on else "numpy"
        print(
            f"| {name} | {cpu:.2f} | {wall:.2f} | {s['alpha_x']:.6g} | {s['alpha_y']:.6g} "
            f"| {s['steps']} |"
        )
    on = statistics.median(r[0] for r in runs[True])
    off = statistics.median(r[0] for r in runs[False])
    print(f"\nSpeed-up (CPU): {off / on:.2f}x\n\nCommand: python {' '.join(sys.argv)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
