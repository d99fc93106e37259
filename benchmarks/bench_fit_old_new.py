"""The fit benchmark's problems (benchmarks/_suite.py) by today's tree and this one,
in CPU time, alternating, in one run.

Each tree runs in its own process (``PYTHONPATH`` = the tree; the suite and its
data read from that tree): every problem fitted ``--fits`` times with
``brdffit.fit`` defaults, the median CPU time (``time.process_time``) of the fits,
their evaluations, loss, and whether they succeed by the suite's rule. The two
trees alternate ``--rounds`` times and the medians over the rounds are compared.
CPU times are printed to three significant digits (lambert's fit is 0.3 ms), the
verdict (how many at most 1.00x) last. CPU time, unlike bench_fit.py's wall clock, is
what a fit costs with the core to itself, which a shared machine can reproduce. Data
without sigma (the Cornell files) are fitted with ``loss="l2"`` in both trees: today's
engine's default for them (since issue 12 the default is the ``mixed`` noise model,
another fit).

    python benchmarks/bench_fit_old_new.py --old /tmp/brdffit-old [--rounds 3] [--fits 3]
        [--only lambert,ashikhmin_shirley]
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

ROOT = Path(__file__).resolve().parents[1]


def worker(fits: int, only: str = "") -> None:
    """In a tree's process: every problem of its suite (or those whose label holds
    one of the comma-separated words of ``only``), as JSON lines."""
    sys.path.insert(0, str(Path.cwd() / "benchmarks"))
    import _suite
    from _suite import cornell_cases, recovered, synthetic_cases

    import brdffit

    # the Cornell files where this tree's suite finds them (beside this benchmark's
    # tree: a worktree elsewhere, as /tmp/brdffit-old, would look in /tmp/shared)
    _suite.CORNELL = Path(os.environ.get("BRDFFIT_BENCH_CORNELL", _suite.CORNELL))

    words = [w for w in only.split(",") if w]
    for case in synthetic_cases() + cornell_cases():
        if words and not any(w in case.label for w in words):
            continue
        times, result = [], None
        options = {"loss": "l2"} if case.data.sigma is None else {}
        for _ in range(fits):
            start = time.process_time()
            result = brdffit.fit(case.data, case.model, **options)
            times.append(time.process_time() - start)
        ok = recovered(case, result.params) if case.truth is not None else None
        row = {"case": case.label, "cpu": statistics.median(times), "evals": result.n_evals,
               "loss": float(result.loss), "ok": ok}  # fmt: skip
        print(json.dumps(row), flush=True)


def run(tree: Path, fits: int, only: str = "") -> dict:
    env = {**os.environ, "PYTHONPATH": str(tree), "OMP_NUM_THREADS": "1",
           "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
           "BRDFFIT_BENCH_CORNELL": str(ROOT.parent / "shared" / "data" / "cornell")}  # fmt: skip
    code = f"import sys; sys.path.insert(0, {str(ROOT / 'benchmarks')!r}); " \
        f"import bench_fit_old_new as b; b.worker({fits}, {only!r})"  # fmt: skip
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=tree, check=True,
                         capture_output=True, text=True)  # fmt: skip
    rows = [json.loads(line) for line in out.stdout.splitlines() if line.startswith("{")]
    return {r["case"]: r for r in rows}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--old", required=True)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--fits", type=int, default=3)
    parser.add_argument(
        "--only", default="", help="comma-separated words: only problems whose label holds one"
    )
    args = parser.parse_args(argv)
    old = Path(args.old).resolve()
    with open("/proc/loadavg") as handle:
        load = " ".join(handle.read().split()[:3])
    rounds = {"old": [], "new": []}
    for _ in range(args.rounds):
        rounds["old"].append(run(old, args.fits, args.only))
        rounds["new"].append(run(ROOT, args.fits, args.only))
    print(f"# Fit problems, old ({old}) and new ({ROOT}), CPU s; load at start {load}\n")
    header = (
        "| problem | old CPU s | new CPU s | new/old | evals old/new | ok old/new | loss diff |"
    )
    print(header)
    print("| --- | ---: | ---: | ---: | --- | --- | ---: |")
    for case in rounds["old"][0]:
        t_old = statistics.median(r[case]["cpu"] for r in rounds["old"])
        t_new = statistics.median(r[case]["cpu"] for r in rounds["new"])
        o, n = rounds["old"][0][case], rounds["new"][0][case]
        diff = abs(n["loss"] - o["loss"]) / max(abs(o["loss"]), 1e-300)
        print(f"| {case} | {t_old:.3g} | {t_new:.3g} | {t_new / max(t_old, 1e-9):.2f} | "
              f"{o['evals']}/{n['evals']} | {o['ok']}/{n['ok']} | {diff:.1e} |")  # fmt: skip
    ratios = [statistics.median(r[c]["cpu"] for r in rounds["new"])
              / max(statistics.median(r[c]["cpu"] for r in rounds["old"]), 1e-9)
              for c in rounds["old"][0]]  # fmt: skip
    print(f"\n{sum(r <= 1.0 for r in ratios)} of {len(ratios)} at most 1.00x "
          f"(highest {max(ratios):.2f})")  # fmt: skip
    print(f"\nCommand: python {' '.join(sys.argv)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
