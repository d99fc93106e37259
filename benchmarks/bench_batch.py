"""Batch fits on Dask: 2 workers against 1, and the cost per pair over a serial fit.

The same pairs (data_synthetic/ files x models, default budgets, seed 0) are
fitted three ways in one run, each repeated and the median kept:

- serially in this process: ``brdffit.read`` then ``brdffit.fit`` per pair
  (the floor: what a plain loop costs);
- ``brdffit.batch.fit_many`` on a LocalCluster of 1 worker process;
- ``fit_many`` on a LocalCluster of 2 worker processes (one thread each).

The clusters are started once and warmed up (a first small batch imports
brdffit on the workers) before timing, so the figures are the steady state of a
long batch; cluster start-up is reported on its own. Runs alternate between
the configurations so that a change of the shared machine's load hits all of
them. Throughput ratio = time with 1 worker / time with 2; overhead per pair =
(time with 1 worker - serial time) / pairs.

Run from the project root::

    python benchmarks/bench_batch.py                       # 28 files x ggx, cook_torrance
    python benchmarks/bench_batch.py --models ggx,ward,blinn --repeat 5
    python benchmarks/bench_batch.py --global-evals 2000   # longer fits
"""

from __future__ import annotations

import argparse
import logging
import os
import platform
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import distributed  # noqa: E402

import brdffit  # noqa: E402
from brdffit.batch import fit_many  # noqa: E402


def serial(files, models, options) -> tuple:
    """Wall and CPU seconds of a plain loop in this process."""
    t0, c0 = time.perf_counter(), time.process_time()
    for path in files:
        for model in models:
            brdffit.fit(brdffit.read(path), model, **options)
    return time.perf_counter() - t0, time.process_time() - c0, 0.0


def _worker_cpu(client) -> float:
    return sum(client.run(time.process_time).values())


def batch(client, files, models, options) -> tuple:
    """Wall seconds, CPU seconds of the workers, CPU seconds of this process (the
    scheduler of a LocalCluster runs here, with the client)."""
    w0, t0, c0 = _worker_cpu(client), time.perf_counter(), time.process_time()
    rows = list(fit_many(files, models, client=client, **options))
    seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
    failed = [r for r in rows if not r.ok]
    if len(rows) != len(files) * len(models) or failed:
        raise SystemExit(f"batch went wrong: {len(rows)} rows, failed: {failed[:1]}")
    return seconds, _worker_cpu(client) - w0, cpu


def cluster(n: int):
    t0 = time.perf_counter()
    c = distributed.LocalCluster(
        n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
        dashboard_address="127.0.0.1:0",
    )  # fmt: skip
    client = distributed.Client(c)
    return c, client, time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", default="ggx,cook_torrance")
    parser.add_argument("--files", type=int, default=0, help="first N files (0: all)")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--global-evals", type=int)
    args = parser.parse_args()
    logging.getLogger("distributed").setLevel(logging.WARNING)
    files = sorted(str(p) for p in (ROOT / "data_synthetic").glob("*.csv"))
    files = files[: args.files] if args.files else files
    models = args.models.split(",")
    options = {"seed": 0}
    if args.global_evals:
        options["global_evals"] = args.global_evals
    n = len(files) * len(models)
    print(f"# {n} pairs: {len(files)} files x {','.join(models)}; options {options}")
    print(f"# {platform.machine()}, {os.cpu_count()} CPUs, Python {platform.python_version()}, "
          f"dask distributed {distributed.__version__}")  # fmt: skip
    print(f"# load average at start: {os.getloadavg()[0]:.2f}")
    (c1, one, up1), (c2, two, up2) = cluster(1), cluster(2)
    print(f"# cluster start-up: 1 worker {up1:.2f} s, 2 workers {up2:.2f} s")
    for client in (one, two):
        batch(client, files[:2], models[:1], options)  # warm-up: imports on the workers
    times = {"serial": [], "1 worker": [], "2 workers": []}
    for _ in range(args.repeat):
        times["serial"].append(serial(files, models, options))
        times["1 worker"].append(batch(one, files, models, options))
        times["2 workers"].append(batch(two, files, models, options))
    for client, c in ((one, c1), (two, c2)):
        client.close()
        c.close()
    med = {k: statistics.median(t[0] for t in v) for k, v in times.items()}
    cpu = {k: [statistics.median(t[i] for t in v) for i in (1, 2)] for k, v in times.items()}
    print("| configuration | median (s) | runs (s) | pairs/s | CPU/pair: fits (ms) | "
          "CPU/pair: scheduler+client (ms) |")  # fmt: skip
    print("|---|--:|---|--:|--:|--:|")
    for k, v in times.items():
        runs = ", ".join(f"{t[0]:.2f}" for t in v)
        print(f"| {k} | {med[k]:.2f} | {runs} | {n / med[k]:.1f} | "
              f"{cpu[k][0] / n * 1000:.1f} | {cpu[k][1] / n * 1000:.1f} |")  # fmt: skip
    best = {k: min(t[0] for t in v) for k, v in times.items()}  # the least disturbed run
    print(f"throughput ratio 2 workers / 1 worker: {med['1 worker'] / med['2 workers']:.2f}x "
          f"of the medians, {best['1 worker'] / best['2 workers']:.2f}x of the fastest runs "
          f"(target >= 1.8x)")  # fmt: skip
    print(f"overhead per pair, 1 worker over serial: "
          f"{(med['1 worker'] - med['serial']) / n * 1000:.1f} ms (target <= 50 ms); "
          f"serial fit per pair {med['serial'] / n * 1000:.1f} ms; of the fastest runs "
          f"{(best['1 worker'] - best['serial']) / n * 1000:.1f} ms")  # fmt: skip
    extra = (sum(cpu["1 worker"]) - cpu["serial"][0]) / n * 1000
    print(f"CPU overhead per pair, 1 worker over serial: {extra:.1f} ms")
    print(f"# load average at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
