"""The solve of the linear coefficients (``brdffit.fitting.linear.solve_bounded``),
today's against an older revision's, in one run.

Each case is the solver's real input: the normal equations, bounds and rows
that ``Problem.solve`` hands it at the true shape of a synthetic problem
(captured by wrapping the solver). Data are made brighter than the model may
be, or with a coefficient near its bound, so that the unconstrained solution
is not the answer and the solver has work to do. For each case and solver:
the median time of ``--repeats`` calls (the two solvers alternate, in the same
process), the largest violation of a bound or row by the answer, and its
residual sum of squares. Then whole energy-conserving fits with each solver
(median of ``--fit-repeats``).

    python benchmarks/bench_linear.py [--old REV] [--repeats 200] [--fit-repeats 3]

``--old`` is a git revision whose ``brdffit/fitting/linear.py`` is loaded as the
old solver (default: the last revision with the active-set enumeration).
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _suite import machine  # noqa: E402

import brdffit  # noqa: E402
import brdffit.fitting.problem as problem_module  # noqa: E402
from brdffit.fitting.linear import solve_bounded  # noqa: E402

OLD_REV = "83d7c88"
HEADER = "| case | old ms | new ms | old/new | old violation | new violation | old rss | new rss |"
FIT_HEADER = (
    "\n| energy-conserving fit | old s | new s | old/new | old max albedo | new max albedo |"
)
PHONGS = [2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0]


def load_old(rev: str):
    source = subprocess.run(
        ["git", "show", f"{rev}:brdffit/fitting/linear.py"],
        cwd=ROOT,
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    path = Path(tempfile.mkdtemp()) / "linear_old.py"
    path.write_text(source)
    spec = importlib.util.spec_from_file_location("linear_old", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.solve_bounded


def phong_sum(n_lobes: int, ks: float) -> tuple[str, dict, dict]:
    """``lambert+phong+...``: 1 + n_lobes coefficients, exponents held fixed."""
    name = "lambert+" + "+".join(["phong"] * n_lobes)
    truth, fixed = {"lambert.kd": [0.9, 0.7, 0.5]}, {}
    for i, n in enumerate(PHONGS[:n_lobes], 1):
        truth[f"phong_{i}.ks"] = [ks, 0.75 * ks, 0.5 * ks]
        truth[f"phong_{i}.n"] = fixed[f"phong_{i}.n"] = n
    return name, truth, fixed


def cases():
    """(label, model, truth, fixed, energy_conserving, brighten)."""
    out = [
        ("ward, inside the bounds (K=2, unconstrained)", "ward",
         {"kd": [0.3, 0.2, 0.1], "ks": 0.3, "alpha": 0.1}, {}, False, 1.0),
        ("ward, kd near 0 (K=2, box)", "ward", {"kd": [0.0, 1e-3, 0.0], "ks": 0.3, "alpha": 0.1},
         {}, False, 1.0),
        ("ashikhmin_shirley, bright (K=2, 1 row)", "ashikhmin_shirley",
         {"rd": [0.6, 0.5, 0.4], "rs": [0.35, 0.3, 0.3], "nu": 50.0, "nv": 50.0}, {}, False, 1.5),
        ("phong, bright (K=2, 18 energy rows)", "phong",
         {"kd": [0.8, 0.6, 0.5], "ks": [3.0, 1.0, 2.0], "n": 5.0}, {}, True, 1.0),
    ]  # fmt: skip
    for lobes in (3, 5, 7):
        name, truth, fixed = phong_sum(lobes, 0.4)
        out.append(
            (f"{name}, bright (K={lobes + 1}, 18 energy rows)", name, truth, fixed, True, 1)
        )
    name, truth, fixed = phong_sum(7, 0.05)
    truth["lambert.kd"] = [0.0, 1e-3, 0.0]
    out.append((f"{name}, kd near 0 (K=8, box)", name, truth, fixed, False, 1.0))
    return out


def synthetic(model, truth, brighten: float):
    """800 hemisphere samples with 1 % noise (negative values kept), times ``brighten``."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        data = brdffit.synthesize(
            model, truth, geometry="hemisphere", n=800, noise=0.01, seed=2, channels=list("rgb")
        )
        values = data.values * brighten
        return brdffit.Measurements(data.wi, data.wo, values, channels=data.channels)


def captured_input(model, truth, fixed, energy, brighten):
    data = synthetic(model, truth, brighten)
    problem = problem_module.Problem(data, model, fixed=fixed, energy_conserving=energy)
    calls = []

    def spy(*args):
        calls.append(args)
        return solve_bounded(*args)

    problem_module.solve_bounded = spy
    try:
        problem.solve(problem.x_from_params({**brdffit.get_model(model).defaults(), **truth}))
    finally:
        problem_module.solve_bounded = solve_bounded
    return calls[-1]


def violation(x, lower, upper, constraints) -> float:
    worst = max(float((lower - x).max()), float((x - upper).max()), 0.0)
    if constraints is not None:
        a, b = constraints
        worst = max(worst, float((x @ a.T - b).max()))
    return worst


def time_solvers(solvers, args, repeats: int) -> list[float]:
    times = [[] for _ in solvers]
    for _ in range(repeats):
        for j, solver in enumerate(solvers):
            t0 = time.perf_counter()
            solver(*args)
            times[j].append(time.perf_counter() - t0)
    return [float(np.median(t)) for t in times]


def bench_solver(old, repeats: int):
    print(
        "| case | old ms | new ms | old/new | old violation | new violation | old rss | new rss |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for label, model, truth, fixed, energy, brighten in cases():
        args = captured_input(model, truth, fixed, energy, brighten)
        n_old = repeats if "K=2" in label or "K=8" in label else max(repeats // 20, 5)
        t_old, t_new = time_solvers([old, solve_bounded], args, n_old)
        x_old, rss_old = old(*args)
        x_new, rss_new = solve_bounded(*args)
        print(
            f"| {label} | {1e3 * t_old:.3f} | {1e3 * t_new:.3f} | {t_old / t_new:.1f} "
            f"| {violation(x_old, *args[1:]):.1e} | {violation(x_new, *args[1:]):.1e} "
            f"| {rss_old.sum():.6g} | {rss_new.sum():.6g} |"
        )


def bench_fits(old, repeats: int):
    print(
        "\n| energy-conserving fit | old s | new s | old/new | old max albedo | new max albedo |"
    )
    print("|---|---:|---:|---:|---:|---:|")
    name, truth, fixed = phong_sum(5, 0.4)
    del fixed["phong_1.n"], fixed["phong_2.n"]
    fits = [
        ("phong", {"kd": [0.8, 0.6, 0.5], "ks": [3.0, 1.0, 2.0], "n": 5.0}, {}),
        (name + " (2 free exponents)", truth, fixed),
    ]
    for label, params, held in fits:
        model = label.split(" ")[0]
        data = synthetic(model, params, 1.0)
        row = []
        for solver in (old, solve_bounded):
            problem_module.solve_bounded = solver
            times = []
            try:
                for _ in range(repeats):
                    t0 = time.perf_counter()
                    result = brdffit.fit(data, model, energy_conserving=True, fixed=held)
                    times.append(time.perf_counter() - t0)
            finally:
                problem_module.solve_bounded = solve_bounded
            row.append((float(np.median(times)), result.metrics["max_albedo"]))
        (t_old, a_old), (t_new, a_new) = row
        ratio = t_old / t_new
        print(f"| {label} | {t_old:.2f} | {t_new:.2f} | {ratio:.1f} | {a_old:.6f} | {a_new:.6f} |")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--old", default=OLD_REV)
    parser.add_argument("--repeats", type=int, default=200)
    parser.add_argument("--fit-repeats", type=int, default=3)
    opts = parser.parse_args()
    old = load_old(opts.old)
    print(f"machine: {machine()}; load average at start: {os.getloadavg()}")
    print(f"old: brdffit/fitting/linear.py at {opts.old}; new: the working tree\n")
    bench_solver(old, opts.repeats)
    bench_fits(old, opts.fit_repeats)
    print(f"\nload average at end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
