"""Prepared evaluation of some models by another tree and this one, in one process,
interleaved, beside Mitsuba 3's LLVM backend: before/after ratios in one run.

``bench_evaluate.py`` run once per tree compares each tree with Mitsuba in its own
run; on a shared machine the load moves between the runs by more than the change
being measured (memory-bound loops lose 30 % to another process's traffic). Here
the other tree's ``brdffit`` is imported as ``brdffit_old`` (a link to its package
in a scratch folder: the package imports itself relatively), both evaluate the same
pairs (``bench_evaluate.random_pairs``) at the model's defaults, alternating model
by model (each tree first in every other round) for ``--rounds`` rounds, and
Mitsuba's rough conductor is timed before and after (its mean rate is the
reference: GGX's, Beckmann's for the Beckmann models).
Each figure is the median over the rounds of the median CPU time of ``--repeats``
calls after one untimed call (which fills the geometry's caches).

    python benchmarks/bench_evaluate_old_new.py --old /tmp/brdffit-old \\
        --models beckmann_anisotropic,gltf_pbr_anisotropic [--rounds 7] [--repeats 7]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import importlib  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

from _mitsuba import mitsuba_rates  # noqa: E402
from bench_evaluate import machine, median_seconds, random_pairs  # noqa: E402

from brdffit.models import get_model  # noqa: E402


def old_models(tree: Path, scratch: str):
    """``brdffit.models`` of the tree at ``tree``, imported as ``brdffit_old.models``."""
    package = tree / "brdffit"
    if not (package / "__init__.py").is_file():
        raise SystemExit(f"--old={tree}: no brdffit package there ({package})")
    os.symlink(package, Path(scratch) / "brdffit_old")
    sys.path.insert(0, scratch)
    return importlib.import_module("brdffit_old.models")


def reference(mitsuba: list, name: str) -> float | None:
    """Mitsuba's mean rate (M pairs/s) over its timings, Beckmann's for beckmann*."""
    key = "beckmann" if name.startswith("beckmann") else "ggx"
    rates = [m[key] for m in mitsuba if key in m]
    return statistics.mean(rates) if rates else None


def _cpu(model, geometry, params, repeats: int) -> float:
    """Median CPU seconds of ``repeats`` prepared evaluations, after an untimed one."""
    return median_seconds(lambda: model.evaluate_prepared(geometry, params), repeats)[0]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--old", required=True, help="the other tree (its folder)")
    parser.add_argument("--models", required=True, help="comma-separated names")
    parser.add_argument("--pairs", type=int, default=1_000_000)
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args(argv)
    names = [n.strip() for n in args.models.split(",") if n.strip()]
    wi, wo = random_pairs(args.pairs)
    with tempfile.TemporaryDirectory() as scratch:
        old = old_models(Path(args.old).resolve(), scratch)
        print("# Prepared evaluation, old and new tree in one process\n")
        for line in machine():
            print(f"- {line}")
        cases = []
        for name in names:
            new_model, old_model = get_model(name), old.get_model(name)
            params = new_model.defaults()
            cases.append((name, new_model, new_model.prepare(wi, wo), old_model,
                          old_model.prepare(wi, wo), params))  # fmt: skip
        mitsuba = [mitsuba_rates(wi, wo, 0.1, args.repeats, median_seconds)[0]]
        seconds = {}
        for k in range(args.rounds):
            for name, new_model, new_g, old_model, old_g, params in cases:
                trees = [("old", old_model, old_g), ("new", new_model, new_g)]
                for tree, model, g in trees[:: 1 if k % 2 else -1]:  # each first in turn
                    cpu = _cpu(model, g, params, args.repeats)
                    seconds.setdefault((name, tree), []).append(cpu)
        mitsuba.append(mitsuba_rates(wi, wo, 0.1, args.repeats, median_seconds)[0])
    rates = ", ".join(f"{k} {m[k]:.1f}" for m in mitsuba for k in sorted(m))
    print(f"- {args.pairs} pairs, {args.rounds} rounds of {args.repeats} calls; "
          f"Mitsuba (before, after) M/s: {rates or 'not measured'}\n")  # fmt: skip
    print("| model | old M/s | new M/s | new/old | old vs Mitsuba | new vs Mitsuba |")
    print("| --- | ---: | ---: | ---: | ---: | ---: |")
    for name, *_ in cases:
        old_rate, new_rate = (
            args.pairs / 1e6 / statistics.median(seconds[(name, t)]) for t in ("old", "new")
        )
        ref = reference(mitsuba, name)
        vs = [f"{r / ref:.2f}x" if ref else "" for r in (old_rate, new_rate)]
        print(f"| {name} | {old_rate:.1f} | {new_rate:.1f} | {new_rate / old_rate:.2f} | "
              f"{vs[0]} | {vs[1]} |")  # fmt: skip
    print(f"\nCommand: python {' '.join(sys.argv)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
