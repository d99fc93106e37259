"""Whole-MERL fits: today's engine (a given commit) beside this tree, in one run.

The benchmark writes a full MERL file (every cell of the 90 x 90 x 180 table,
1.1 M cells above the horizon, RGB) from a known truth (``cook_torrance`` with
coloured ``kd`` and ``ks`` and 1 % seeded relative noise) with brdffit's MERL
writer, then fits it with each model (default: blinn, ward, cook_torrance, ggx)
by ``brdffit.fit`` with ``loss`` (``--loss``, default ``l2``: today's engine's
default for data without sigma; ``--loss default`` leaves each tree its own
default), each model in a fresh Python process per tree:

- ``old``: the tree of ``--old`` (a path, e.g. a worktree of today's commit made
  with ``git worktree add /tmp/brdffit-old <commit>``) first on ``PYTHONPATH``;
- ``new``: this tree first on ``PYTHONPATH``.

Each figure is the median over ``--repeats`` runs (old and new alternate) of the
CPU time of the fit alone (``time.process_time`` around ``brdffit.fit``, the file
already read): ``cold``, the process's first fit (it loads or compiles the
compiled kernels), and ``warm``, a second fit of the file read again (a user
fitting several models or files in one process); and of the process's peak
resident memory after the first fit (``ru_maxrss``, the whole process: interpreter,
file, fit).
The parameters of the two are compared (largest relative difference over every
parameter and channel; the issue asks for 0.1 %).

    python benchmarks/bench_merl.py --old /tmp/brdffit-old [--models ggx] [--repeats 3]

``--threshold`` times the search alone (global stage and polishes) on random subsets
of 25,000 to 200,000 samples of the file, on all samples and coarse to fine, in
this tree: what the default of ``FitOptions.coarse_above`` was chosen by.

``--breakdown`` (this tree, loss l2) splits a first fit's CPU beyond its warm fit, in
fresh processes (the kernels' disk cache warm: a first process fills it): numba's
import, the loop modules', numba's runtime, the loops' cache loads, the argument
types of each loop's first call, every other module the fit imports on first use,
and the rest (the first touch of the fit's memory, mostly) (:class:`Stages`).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
MODELS = ("blinn", "ward", "cook_torrance", "ggx")
TRUTH = {"kd": [0.12, 0.08, 0.05], "ks": [0.9, 0.7, 0.5], "m": 0.15, "eta": 1.6}


def write_file(path: Path) -> None:
    """The benchmark's MERL file: ``cook_torrance`` at TRUTH on every cell, 1 % noise."""
    import brdffit

    data = brdffit.synthesize("cook_torrance", TRUTH, geometry="merl", noise=0.01, seed=7)
    brdffit.write(str(path), data, format="merl")


def worker(path: str, model: str, loss: str) -> None:
    """Two fits in this process (cold, warm); prints their CPU times, the peak memory,
    and the parameters, evaluations and message of the first."""
    import brdffit

    options = {} if loss == "default" else {"loss": loss}
    seconds, results = [], []
    for _ in range(2):
        data = brdffit.read(path)
        start = time.process_time()
        results.append(brdffit.fit(data, model, **options))
        seconds.append(time.process_time() - start)
        if len(results) == 1:  # the peak of one fit (the second may add its garbage)
            peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    result = results[0]
    params = {k: np.atleast_1d(v).tolist() for k, v in result.params.items()}
    tree = str(Path(brdffit.__file__).parents[1])
    print(json.dumps({"tree": tree, "seconds": seconds[0], "warm": seconds[1],
                      "peak_mb": peak_mb, "params": params, "loss": float(result.loss),
                      "samples": int(data.n), "evals": int(result.n_evals),
                      "message": result.message, "loss_name": result.loss_name}))  # fmt: skip


class Stages:
    """CPU seconds of what a first fit does first, each exclusive of the others nested
    in it: each module it imports (numba with everything numba imports; a brdffit
    module without the third-party packages it imports), and, once numba is imported,
    numba's runtime (NRT) compiled, the loops' cache loads, and the argument types of
    each loop's first call. Imports are timed at importlib's ``_find_and_load``, which
    both ``import`` and ``importlib.import_module`` call for a module not yet loaded."""

    def __init__(self):
        self.seconds, self.nested, self.importing = {}, [], []

    def timed(self, function, label):
        """``function`` timed under ``label``, or, for an import (``label`` None), under
        the module's name, its own imports in it unless it is brdffit's."""

        def wrapper(*args, **kwargs):
            if label is None and self.importing and not self.importing[-1].startswith("brd"):
                return function(*args, **kwargs)  # numba's own imports are numba's
            name = label or self._module(args[0])
            self.importing += [args[0]] if label is None else []
            self.nested.append(0.0)
            start = time.process_time()
            try:
                return function(*args, **kwargs)
            finally:
                spent, nested = time.process_time() - start, self.nested.pop()
                self.importing = self.importing[: -1 if label is None else None]
                self.seconds[name] = self.seconds.get(name, 0.0) + spent - nested
                if self.nested:
                    self.nested[-1] += spent
                self._numba()

        return wrapper

    @staticmethod
    def _module(name: str) -> str:
        if name.split(".")[0] in ("numba", "llvmlite") and name != "numba.np.arrayobj":
            return "import numba" if name == "numba" else f"import {name} (numba's)"
        if name.startswith("brdffit.kernels."):
            return "import the loop modules (brdffit.kernels.*)"
        return f"import {name}"

    def install(self) -> None:
        from importlib import _bootstrap

        _bootstrap._find_and_load = self.timed(_bootstrap._find_and_load, None)
        self._numba()

    def _numba(self) -> None:
        """Time numba's pieces once numba is imported, and brdffit's runtime load
        (:mod:`brdffit.kernels._cached`) once it is."""
        if "numba.core.runtime.nrt" in sys.modules and "numba_done" not in self.seconds:
            self.seconds["numba_done"] = 0.0  # once
            from numba.core import caching, dispatcher
            from numba.core.runtime import nrt

            for owner, name, label in (
                (type(nrt.rtsys), "initialize", "numba's runtime (NRT)"),
                (caching.Cache, "_load_overload", "the loops' cache loads"),
                (dispatcher.Dispatcher, "typeof_pyval", "argument types of a loop's first call"),
            ):
                setattr(owner, name, self.timed(getattr(owner, name), label))
        cached = sys.modules.get("brdffit.kernels._cached")
        if cached is not None and "cached_done" not in self.seconds:
            self.seconds["cached_done"] = 0.0
            label = "numba's runtime (NRT)"
            cached._initialize_runtime = self.timed(cached._initialize_runtime, label)


def breakdown_worker(path: str, model: str) -> None:
    """A first and a warm fit in this process, the first's :class:`Stages` timed."""
    import brdffit

    stages, seconds, faults, system = Stages(), [], [], []
    for _ in range(2):
        data = brdffit.read(path)
        if not seconds:
            stages.install()
        before, start = resource.getrusage(resource.RUSAGE_SELF), time.process_time()
        brdffit.fit(data, model, loss="l2")
        seconds.append(time.process_time() - start)
        after = resource.getrusage(resource.RUSAGE_SELF)
        faults.append(after.ru_minflt - before.ru_minflt)
        system.append(after.ru_stime - before.ru_stime)
    stages.seconds.pop("numba_done", None)
    stages.seconds.pop("cached_done", None)
    print(json.dumps({"first": seconds[0], "warm": seconds[1], "stages": stages.seconds,
                      "faults": faults, "system": system}))  # fmt: skip


def breakdown(path: Path, models: list, repeats: int) -> None:
    """The table of :func:`breakdown_worker`'s stages, medians over fresh processes."""
    got = {}
    for model in models:
        call = f"breakdown_worker({str(path)!r}, {model!r})"
        got[model] = [run(ROOT, path, call) for _ in range(repeats)]

    def median(model, value):
        return statistics.median(value(r) for r in got[model])

    rows = [
        (name, lambda r, n=name: r["stages"].get(n, 0.0))
        for name in {n for runs in got.values() for r in runs for n in r["stages"]}
    ]
    rows = [row for row in rows if max(median(m, row[1]) for m in models) >= 5e-4]
    rows.sort(key=lambda row: -median(models[0], row[1]))
    rows += [
        ("the rest (first fit - warm fit - the above)",
         lambda r: r["first"] - r["warm"] - sum(r["stages"].values())),
        ("**first fit - warm fit**", lambda r: r["first"] - r["warm"]),
        ("first fit", lambda r: r["first"]),
        ("warm fit", lambda r: r["warm"]),
        ("the first fit's page faults, thousands (of its memory's first touch)",
         lambda r: r["faults"][0] / 1000.0),
        ("the first fit's system CPU s (the warm fit's: next row)", lambda r: r["system"][0]),
        ("the warm fit's system CPU s", lambda r: r["system"][1]),
    ]  # fmt: skip
    print(f"| a first fit's CPU s beyond its warm fit's (median of {repeats}) | "
          + " | ".join(models) + " |")  # fmt: skip
    print("| --- |" + " ---: |" * len(models))
    for label, value in rows:
        print(f"| {label} | " + " | ".join(f"{median(m, value):.3f}" for m in models) + " |")


def run(tree: Path, path: Path, call: str) -> dict:
    """The last JSON line ``bench_merl.<call>`` prints in a fresh process, ``tree``
    first on the path."""
    env = {**os.environ, "PYTHONPATH": str(tree), "OMP_NUM_THREADS": "1",
           "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}  # fmt: skip
    code = f"import sys; sys.path.insert(0, {str(HERE)!r}); import bench_merl; bench_merl.{call}"
    # cwd: the file's folder, so that no brdffit in the working directory shadows the tree
    out = subprocess.run(
        [sys.executable, "-c", code],
        env=env,
        capture_output=True,
        text=True,
        check=True,
        cwd=path.parent,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def threshold(path: Path, models: list, repeats: int) -> None:
    """The search alone (global stage and polishes) on random subsets of the file, all
    samples against coarse to fine (``coarse_above`` 0 and 10**9), in this process."""
    import brdffit
    from brdffit.fitting import core, engine

    full = brdffit.read(str(path))
    brdffit.fit(full.subset(np.arange(0, full.n, 50)), models[0], loss="l2")  # load kernels
    rng = np.random.default_rng(0)
    print("| samples | model | search on all, CPU s | coarse to fine, CPU s | evaluations |")
    print("| ---: | --- | ---: | ---: | --- |")
    for n in (25_000, 50_000, 100_000, 200_000):
        data = full.subset(np.sort(rng.choice(full.n, n, replace=False)))
        for model in models:
            cpu, evals = {}, {}
            for label, above in (("all", 10**9), ("staged", 0)):
                times = []
                for _ in range(repeats):
                    fresh = data.subset(np.arange(data.n))  # no geometry caches
                    options = {"loss": "l2", "coarse_above": above}
                    opts, problem, x0 = core._prepare(fresh, model, options)
                    start = time.process_time()
                    found, _ = engine.search(problem, opts, x0, False, time.perf_counter())
                    times.append(time.process_time() - start)
                cpu[label], evals[label] = statistics.median(times), found.n_evals
            print(f"| {n} | {model} | {cpu['all']:.3f} | {cpu['staged']:.3f} | "
                  f"{evals['all']}/{evals['staged']} |", flush=True)  # fmt: skip


def largest_difference(a: dict, b: dict) -> float:
    """Largest relative difference of any parameter value of ``b`` from ``a``."""
    worst = 0.0
    for name, values in a.items():
        x, y = np.asarray(values), np.asarray(b[name])
        worst = max(worst, float(np.max(np.abs(y - x) / np.maximum(np.abs(x), 1e-12))))
    return worst


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--old", help="path of today's tree (a worktree); needed unless "
                        "--threshold or --breakdown")  # fmt: skip
    parser.add_argument("--models", default=",".join(MODELS))
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--loss", default="l2", help="a loss name, or 'default'")
    parser.add_argument("--threshold", action="store_true",
                        help="time the search alone on subsets, with and without the "
                        "coarse-to-fine schedule (this tree only; --old is ignored)")  # fmt: skip
    parser.add_argument("--breakdown", action="store_true",
                        help="where a first fit's CPU beyond its warm fit's goes (this "
                        "tree)")  # fmt: skip
    args = parser.parse_args(argv)
    if args.threshold or args.breakdown:
        models = args.models.split(",")
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "truth.binary"
            write_file(path)
            if args.threshold:
                threshold(path, models, args.repeats)
            else:
                with open("/proc/loadavg") as handle:
                    print(f"- load average at start: {' '.join(handle.read().split()[:3])}\n")
                run(ROOT, path, f"worker({str(path)!r}, {models[0]!r}, 'l2')")  # cache warm
                breakdown(path, models, args.repeats)
        print(f"\nCommand: python {' '.join(sys.argv)}")
        return 0
    if args.old is None:
        parser.error("--old is needed (the path of today's tree)")
    old = Path(args.old).resolve()
    if not (old / "brdffit" / "__init__.py").is_file():
        return f"bench_merl: {old} has no brdffit package"
    with open("/proc/loadavg") as handle:
        load = " ".join(handle.read().split()[:3])
    print("# Whole-MERL fits, today's engine and this tree (one core each)\n")
    notes = []
    print(f"- old tree: {old}; new tree: {ROOT}; load average at start: {load}")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "truth.binary"
        write_file(path)
        print(f"- file: {path.stat().st_size / 1e6:.0f} MB; truth cook_torrance {TRUTH}\n")
        print(f"- loss: {args.loss}\n")
        print("| model | old CPU s | new CPU s | speed-up | old warm s | new warm s | warm "
              "speed-up | old peak MB | new peak MB | max param diff | old loss | new loss "
              "| evals old/new |")  # fmt: skip
        print("| --- |" + " ---: |" * 11 + " --- |")
        for model in args.models.split(","):
            runs = {"old": [], "new": []}
            for _ in range(args.repeats):
                for tree, name in ((old, "old"), (ROOT, "new")):
                    call = f"worker({str(path)!r}, {model!r}, {args.loss!r})"
                    runs[name].append(run(tree, path, call))
            o, n = runs["old"][0], runs["new"][0]
            assert Path(o["tree"]) == old and Path(n["tree"]) == ROOT, (o["tree"], n["tree"])
            t_old = statistics.median(r["seconds"] for r in runs["old"])
            t_new = statistics.median(r["seconds"] for r in runs["new"])
            w_old = statistics.median(r["warm"] for r in runs["old"])
            w_new = statistics.median(r["warm"] for r in runs["new"])
            m_old = statistics.median(r["peak_mb"] for r in runs["old"])
            m_new = statistics.median(r["peak_mb"] for r in runs["new"])
            diff = largest_difference(o["params"], n["params"])
            print(f"| {model} | {t_old:.2f} | {t_new:.2f} | {t_old / t_new:.1f}x | "
                  f"{w_old:.2f} | {w_new:.2f} | {w_old / w_new:.1f}x | "
                  f"{m_old:.0f} | {m_new:.0f} | {diff:.1e} | {o['loss']:.8g} | "
                  f"{n['loss']:.8g} | {o['evals']}/{n['evals']} |", flush=True)  # fmt: skip
            notes.append(f"- {model}, new: {n['loss_name']}; {n['message']}")
    print("\n" + "\n".join(notes))
    print(f"\nCommand: python {' '.join(sys.argv)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
