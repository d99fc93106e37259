"""Cold start: the ``brdffit fit`` command of two trees, and a process's first compiled fit.

Command line (``--old PATH``): ``brdffit fit data_synthetic/ward.csv --model ward``
with and without ``--uncertainty`` (the README's first command), each run a fresh
process, the two trees alternating, ``--runs`` times each; medians (and ranges) of
the wall time and of the CPU time (user + system, ``RUSAGE_CHILDREN``). Two ways
of loading each tree's code:

- ``installed``: its ``brdffit`` package copied to a temporary folder and compiled
  to bytecode there (``compileall``, as ``pip install`` does), run as the console
  script does (``from brdffit.cli import main``);
- ``source``: run from the tree itself with ``PYTHONDONTWRITEBYTECODE=1``, so that
  Python compiles every module's source at every start (a development tree in an
  environment that sets the variable, as this machine's does).

First compiled fit (``--first-fit``, this tree only): where a process's first fit
with the compiled kernels spends its extra time, step by step in fresh processes
(the kernels' disk cache warm): ``import numba``, the loop module, the first loop's
first call (numba's runtime compiled, then the cache load:
:mod:`brdffit.kernels._cached`), a second loop's first call, the five loop modules
a ward fit no longer imports, and last what a cache load no longer does: numba's
target context's registries, which import ``scipy.linalg`` (numba's
``arraymath._check_blas``; a compilation still refreshes them); then each model's
first and second fit of the same 50,000 pairs. A random geometry of 50,000 pairs
takes neither the coarse-to-fine schedule nor the misfit test's counting sorts, whose
loops a whole MERL file's fit loads too: ``benchmarks/bench_merl.py --breakdown``
splits that fit's first-fit CPU by stage.

    python benchmarks/bench_cold_start.py --old /tmp/brdffit-old --runs 9
    python benchmarks/bench_cold_start.py --first-fit --runs 7
"""

from __future__ import annotations

import argparse
import compileall
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
DATA = ROOT / "data_synthetic" / "ward.csv"
COMMANDS = {
    "fit": ["fit", str(DATA), "--model", "ward"],
    "fit --uncertainty": ["fit", str(DATA), "--model", "ward", "--uncertainty"],
}
FIRST_FIT_MODELS = ("ward", "blinn", "ggx")


def install(tree: Path, target: Path) -> Path:
    """``tree``'s brdffit package copied under ``target`` and compiled to bytecode."""
    shutil.copytree(
        tree / "brdffit", target / "brdffit", ignore=shutil.ignore_patterns("__pycache__")
    )
    if not compileall.compile_dir(str(target / "brdffit"), quiet=1):
        raise SystemExit(f"bench_cold_start: {tree}'s package does not compile")
    return target


def timed_command(path: Path, argv: list, source: bool) -> tuple:
    """Wall and CPU seconds of one ``brdffit`` command with ``path`` first on the path."""
    env = {**os.environ, "PYTHONPATH": str(path)}
    env.pop("PYTHONPYCACHEPREFIX", None)
    if source:
        env["PYTHONDONTWRITEBYTECODE"] = "1"
    code = "import sys; from brdffit.cli import main; sys.exit(main())"
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(
        [sys.executable, "-c", code, *argv],
        env=env, cwd=path, check=True, stdout=subprocess.DEVNULL,
    )  # fmt: skip
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
    return wall, cpu


def summary(values: list) -> str:
    return f"{statistics.median(values):.2f} ({min(values):.2f}-{max(values):.2f})"


def command_line(old: Path, runs: int) -> None:
    """The table of the two trees' commands, installed and from source."""
    print("| code | command | old wall s | new wall s | old CPU s | new CPU s | CPU new/old |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: |")
    with tempfile.TemporaryDirectory() as tmp:
        installed = {
            "old": install(old, Path(tmp) / "old"),
            "new": install(ROOT, Path(tmp) / "new"),
        }
        for code in ("installed", "source"):
            paths = installed if code == "installed" else {"old": old, "new": ROOT}
            for name, argv in COMMANDS.items():
                got = {"old": [], "new": []}
                for _ in range(runs):
                    for tree in ("old", "new"):
                        got[tree].append(timed_command(paths[tree], argv, code == "source"))
                wall = {t: [w for w, _ in got[t]] for t in got}
                cpu = {t: [c for _, c in got[t]] for t in got}
                ratio = statistics.median(cpu["new"]) / statistics.median(cpu["old"])
                print(f"| {code} | `brdffit {name}` | {summary(wall['old'])} | "
                      f"{summary(wall['new'])} | {summary(cpu['old'])} | "
                      f"{summary(cpu['new'])} | {ratio:.2f} |", flush=True)  # fmt: skip


def steps_worker() -> None:
    """One fresh process: the CPU seconds of each step of a first compiled evaluation."""
    import numpy as np

    import brdffit  # noqa: F401
    from brdffit import kernels

    steps = {}

    def step(name, work):
        start = time.process_time()
        work()
        steps[name] = time.process_time() - start

    step("import numba", lambda: __import__("numba"))
    step("import the loop module", lambda: kernels.wanted(10**6, modules=("loops",)))
    from brdffit.kernels import loops

    x, out, targets = np.random.rand(50_000), np.empty(50_000), np.random.rand(3, 50_000)
    step("first call of a loop (numba's runtime, cache load)",
         lambda: loops.ward(x, x, 0.01, 1.0, 0.0, out))  # fmt: skip
    step("first call of a second loop (cache load)",
         lambda: loops.moments(x, np.empty(0), targets))  # fmt: skip
    others = ("loops_empirical", "loops_he", "loops_microfacet", "loops_renderers")
    step("the five loop modules a ward fit no longer imports",
         lambda: kernels.wanted(10**6, modules=(*others, "plastic_table")))  # fmt: skip
    from numba.core.registry import cpu_target

    step("numba's registries with scipy.linalg (no longer refreshed by a cache load)",
         cpu_target.target_context.refresh)  # fmt: skip
    print(json.dumps(steps))


def fits_worker(model: str) -> None:
    """One fresh process: CPU seconds of its first and second fit of 50,000 pairs."""
    import brdffit
    from brdffit import kernels

    with kernels.use(False):
        data = brdffit.synthesize(model, geometry="hemisphere", n=50_000, noise=0.01, seed=1)
    seconds = []
    for _ in range(2):
        start = time.process_time()
        brdffit.fit(data, model, loss="l2")
        seconds.append(time.process_time() - start)
    print(json.dumps({"first": seconds[0], "second": seconds[1]}))


def run_worker(call: str) -> dict:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OPENBLAS_NUM_THREADS": "1"}
    code = f"import sys; sys.path.insert(0, {str(HERE)!r}); import bench_cold_start as b; b.{call}"
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, cwd=ROOT, capture_output=True, text=True, check=True
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def first_fit(runs: int) -> None:
    """The steps of a first compiled evaluation, and first against second fits."""
    run_worker(f"fits_worker({FIRST_FIT_MODELS[0]!r})")  # the disk cache warm
    steps = [run_worker("steps_worker()") for _ in range(runs)]
    print("| step (fresh process, kernels' disk cache warm) | CPU s, median (range) |")
    print("| --- | ---: |")
    for name in steps[0]:
        print(f"| {name} | {summary([s[name] for s in steps])} |")
    print("\n| model | first fit CPU s | second fit CPU s | first - second |")
    print("| --- | ---: | ---: | ---: |")
    for model in FIRST_FIT_MODELS:
        fits = [run_worker(f"fits_worker({model!r})") for _ in range(runs)]
        first, second = [f["first"] for f in fits], [f["second"] for f in fits]
        extra = [a - b for a, b in zip(first, second)]
        print(f"| {model} | {summary(first)} | {summary(second)} | {summary(extra)} |", flush=True)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--old", help="path of today's tree (a worktree of its commit)")
    parser.add_argument("--runs", type=int, default=9)
    parser.add_argument("--first-fit", action="store_true", help="this tree's first fit")
    args = parser.parse_args(argv)
    with open("/proc/loadavg") as handle:
        load = " ".join(handle.read().split()[:3])
    print(
        f"- load average at start: {load}; {os.cpu_count()} CPUs; Python {sys.version.split()[0]}"
    )
    if args.first_fit:
        first_fit(args.runs)
    else:
        if args.old is None:
            parser.error("--old is needed (the path of today's tree), or --first-fit")
        old = Path(args.old).resolve()
        print(f"- old tree: {old}; new tree: {ROOT}; {args.runs} runs each, alternating\n")
        command_line(old, args.runs)
    with open("/proc/loadavg") as handle:
        print(f"\n- load average at the end: {' '.join(handle.read().split()[:3])}")
    print(f"\nCommand: python {' '.join(sys.argv)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
