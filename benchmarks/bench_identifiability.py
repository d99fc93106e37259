"""The post-fit identifiability check on a whole MERL file: a given version of the
module beside this tree's, in one run.

The benchmark writes bench_merl's MERL file (``cook_torrance`` truth, 1.1 M cells
above the horizon, RGB, 1 % noise), fits it once per model with this tree
(``loss="l2"``), then times ``identifiability.unidentified`` on the fit's problem and
parameters: this tree's module (``new``) and the module file given with ``--old``
(``old``, e.g. ``git show main:brdffit/fitting/identifiability.py > /tmp/old.py``),
loaded into the same package, alternating, ``--repeats`` times each. Figures are
medians of the CPU time (``time.process_time``), with the verdicts of both (they
must agree).

    python benchmarks/bench_identifiability.py --old /tmp/old.py [--models ggx]
"""

from __future__ import annotations

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import importlib.util  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))


def load_old(path: str):
    """The module at ``path``, loaded as ``brdffit.fitting._identifiability_old``."""
    spec = importlib.util.spec_from_file_location("brdffit.fitting._identifiability_old", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--old", required=True, help="a file of the module to compare with")
    parser.add_argument("--models", default="ggx")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args(argv)

    import bench_merl

    import brdffit
    from brdffit.fitting import identifiability as new
    from brdffit.fitting.problem import Problem

    old = load_old(args.old)
    print(f"load average: {os.getloadavg()}; brdffit from {brdffit.__file__}")
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "truth.binary"
        bench_merl.write_file(path)
        data = brdffit.read(str(path))
    print(f"{data.n} samples, {data.geometry().m} above the horizon, {data.n_channels} channels")
    print("| model | old s | new s | new / old | verdicts old | verdicts new |")
    print("| --- | ---: | ---: | ---: | --- | --- |")
    for model in args.models.split(","):
        result = brdffit.fit(data, model, loss="l2")
        problem = Problem(data, model, loss="l2")
        times = {"old": [], "new": []}
        verdicts = {}
        for _ in range(args.repeats):
            for label, module in (("old", old), ("new", new)):
                start = time.process_time()
                verdicts[label] = module.unidentified(problem, result.params)
                times[label].append(time.process_time() - start)
        t_old, t_new = statistics.median(times["old"]), statistics.median(times["new"])
        print(f"| {model} | {t_old:.3f} | {t_new:.3f} | {t_new / t_old:.2f} | "
              f"{sorted(verdicts['old']) or '-'} | {sorted(verdicts['new']) or '-'} |",
              flush=True)  # fmt: skip
        if verdicts["old"] != verdicts["new"]:
            print(f"  verdicts differ: {verdicts}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
