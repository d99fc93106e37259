"""The post-fit misfit test on a whole MERL file: a given commit's beside this tree's.

Writes the MERL file of ``bench_merl.py`` (``cook_torrance`` truth, 1 % noise, 1.1 M
cells x RGB), reads it once, and forms the standardised residuals of a ``ggx`` fit
stand-in (``ggx`` at fixed parameters against the file: systematic residuals, as a
misfitting fit leaves them). Then times ``misfit_test`` of ``--old`` (a git revision
whose ``brdffit/fitting/misfit.py`` is loaded beside this tree's) and of this tree,
alternating, ``--repeats`` times: the first call on the data and a second on the same
data (a refit, or another model on the same file), all samples and with every tenth
sample weighted 0. Prints the medians (wall time, ``time.perf_counter``) and checks
that the two trees return the same records.

    python benchmarks/bench_misfit.py --old main [--repeats 5]
"""

from __future__ import annotations

import argparse
import importlib.util
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))


def load_old(rev: str):
    """``brdffit/fitting/misfit.py`` of revision ``rev`` as a module."""
    text = subprocess.run(
        ["git", "show", f"{rev}:brdffit/fitting/misfit.py"],
        cwd=HERE.parent, capture_output=True, text=True, check=True,
    ).stdout  # fmt: skip
    path = Path(tempfile.mkdtemp()) / "misfit_old.py"
    path.write_text(text)
    spec = importlib.util.spec_from_file_location("brdffit.fitting._misfit_old", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--old", default="main", help="git revision to compare with")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    import bench_merl

    import brdffit
    from brdffit.fitting import misfit as new

    old = load_old(args.old)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.binary"
        bench_merl.write_file(path)
        data = brdffit.read(str(path))
    ggx = brdffit.get_model("ggx")
    params = {"kd": [0.1, 0.07, 0.05], "ks": [0.8, 0.6, 0.45], "alpha": 0.2, "f0": 0.04}
    pred = ggx.evaluate(data.wi, data.wo, params)
    y = np.asarray(data.values, dtype=float)
    z = (pred - y) / (0.01 * np.maximum(y, 1e-3))
    every = np.ones(data.n, dtype=bool)
    some = every.copy()
    some[::10] = False
    times: dict = {}
    for _ in range(args.repeats):
        for tree, module in (("old", old), ("new", new)):
            fresh = data.subset(np.arange(data.n))
            for label, keep in (("first", every), ("second", every), ("second, 10% w=0", some)):
                t0 = time.perf_counter()
                record = module.misfit_test(fresh, z, keep, 8, False)
                times.setdefault((tree, label), []).append(time.perf_counter() - t0)
                times.setdefault(("record", tree, label), record)
    for label in ("first", "second", "second, 10% w=0"):
        o = statistics.median(times[("old", label)])
        n = statistics.median(times[("new", label)])
        same = times[("record", "old", label)] == times[("record", "new", label)]
        print(f"{label:>16}: old {o:.3f} s, new {n:.3f} s, new/old {n / o:.3f}, same {same}")
    print(f"{data.n} samples x {data.n_channels} channels, median of {args.repeats}")


if __name__ == "__main__":
    main()
