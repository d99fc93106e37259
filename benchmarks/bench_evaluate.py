"""Evaluation throughput of every registered model, on one core.

For each model, the number of BRDF samples per second of

- ``evaluate_prepared``: the directions prepared once into a ``Geometry`` (what a
  fit does: thousands of evaluations on the same directions), and
- ``evaluate``: direction checks and preparation on every call,

on the same random direction pairs over the upper hemisphere, at the model's
default parameters, in the same run. Each figure is the median of ``--repeats``
timed calls after one untimed call (which fills the geometry's caches of
parameter-free terms, as the first evaluation of a fit does), per second of CPU
time of this process (what a call costs with the core to itself, the figure
that the shared machines we run on can reproduce) and per second of wall time.

Prepared evaluation runs the compiled kernels (brdffit.kernels) where a model has
one; the ``numpy`` column times the same call with the kernels off, in the same run.
When Mitsuba 3 is installed with its LLVM backend, its ``roughconductor`` (GGX, and
Beckmann for ``beckmann``) is timed on the same pairs on one thread, and every
model's prepared CPU-time figure is compared to it, measured again after each model
(the ratio is to the mean of Mitsuba's rates just before and just after the model: on a
shared machine the speed drifts over a run, and a reference timed once at the start
made the last models' ratios move by 20 %; issue 13: at least as fast, for
ggx, beckmann, cook_torrance, ward, blinn, ward_anisotropic, ashikhmin_shirley).

Usage::

    python benchmarks/bench_evaluate.py [--models blinn,ward] [--pairs 1000000] [--repeats 5]
"""

from __future__ import annotations

import os

# One core: the thread pools are sized when numpy is first imported.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from _mitsuba import mitsuba_rates  # noqa: E402

from brdffit import kernels  # noqa: E402
from brdffit.data.geometry import directions_from_angles  # noqa: E402
from brdffit.errors import BrdfFitError  # noqa: E402
from brdffit.models import REGISTRY, get_model  # noqa: E402

#: The models issue 13 asks to be at least as fast as Mitsuba's LLVM backend.
MITSUBA_TARGETS = (
    "ggx",
    "beckmann",
    "cook_torrance",
    "ward",
    "blinn",
    "ward_anisotropic",
    "ashikhmin_shirley",
)


def random_pairs(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Direction pairs uniform over the upper hemisphere (cos(theta) uniform in (0, 1])."""
    rng = np.random.default_rng(seed)
    cos_theta = 1.0 - rng.uniform(0.0, 1.0, (2, n))
    phi = rng.uniform(0.0, 2.0 * np.pi, (2, n))
    wi, wo = directions_from_angles(np.arccos(cos_theta), phi, degrees=False)
    return wi, wo


def median_seconds(call, repeats: int) -> tuple[float, float]:
    """Median CPU time and median wall time of ``repeats`` calls, after one untimed
    call. CPU time (of this process) is what a call costs when it has the core to
    itself; wall time also counts the time other processes hold it."""
    call()
    cpu, wall = [], []
    for _ in range(repeats):
        start_cpu, start_wall = time.process_time(), time.perf_counter()
        call()
        cpu.append(time.process_time() - start_cpu)
        wall.append(time.perf_counter() - start_wall)
    return statistics.median(cpu), statistics.median(wall)


def measure(model, wi, wo, repeats: int) -> dict:
    """Prepared and unprepared throughput in M samples/s, by CPU and by wall time."""
    params = model.defaults()
    geometry = model.prepare(wi, wo)
    prepared = median_seconds(lambda: model.evaluate_prepared(geometry, params), repeats)
    with kernels.use(False):
        numpy = median_seconds(lambda: model.evaluate_prepared(geometry, params), repeats)
    unprepared = median_seconds(lambda: model.evaluate(wi, wo, params), repeats)
    n = wi.shape[0] / 1e6
    rate = {}
    timed = (("prepared", prepared), ("numpy", numpy), ("unprepared", unprepared))
    for key, (cpu, wall) in timed:
        # process_time ticks may be coarse; a call too short to register is reported as
        # at least one tick long rather than dividing by zero
        rate[key], rate[key + "_wall"] = n / max(cpu, 1e-9), n / max(wall, 1e-9)
    return rate


def cpu_description() -> str:
    """Model name, family/model, clock, cache and SIMD flags of the first CPU."""
    info = {}
    try:
        with open("/proc/cpuinfo") as handle:
            for line in handle:
                key, _, value = line.partition(":")
                if not key.strip():
                    break  # the end of the first processor's block
                info.setdefault(key.strip(), value.strip())
    except OSError:
        return "unknown (no /proc/cpuinfo)"
    simd = [
        f
        for f in ("sse4_2", "avx", "avx2", "fma", "avx512f")
        if f in info.get("flags", "").split()
    ]
    return (
        f"{info.get('model name', 'unknown')} (family {info.get('cpu family', '?')}, "
        f"model {info.get('model', '?')}), {info.get('cpu MHz', '?')} MHz, "
        f"cache {info.get('cache size', '?')}, SIMD: {' '.join(simd) or 'none listed'}"
    )


def machine() -> list[str]:
    """CPU, versions, thread settings and load, for the report."""
    try:
        with open("/proc/loadavg") as handle:
            load = " ".join(handle.read().split()[:3])
    except OSError:
        load = "unknown"
    names = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
    threads = ", ".join(f"{v}={os.environ[v]}" for v in names)
    coretype = os.environ.get("OPENBLAS_CORETYPE")
    return [
        f"CPU: {cpu_description()}; {os.cpu_count()} logical CPUs",
        f"Python {platform.python_version()}, numpy {np.__version__}, {platform.platform()}",
        f"Threads: {threads}" + (f", OPENBLAS_CORETYPE={coretype}" if coretype else ""),
        f"Load average (1, 5, 15 min) at start: {load}",
    ]


def versus(name: str, rate: float, mitsuba: dict) -> str:
    """The ratio to Mitsuba's GGX (its Beckmann for beckmann), and the verdict for
    the models the issue names."""
    reference = mitsuba.get("beckmann" if name.startswith("beckmann") else "ggx")
    if reference is None:
        return ""
    text = f"{rate / reference:.2f}x"
    if name in MITSUBA_TARGETS:
        text += ": " + ("met" if rate >= reference else "NOT met")
    return text


def parse_args(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--models", default="", help="comma-separated names (default: all)")
    parser.add_argument("--pairs", type=int, default=1_000_000, help="direction pairs per call")
    parser.add_argument("--repeats", type=int, default=5, help="timed calls per figure (median)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the direction pairs")
    parser.add_argument(
        "--alpha", type=float, default=0.1, help="Mitsuba's roughness (brdffit: defaults)"
    )
    args = parser.parse_args(argv)
    if args.pairs < 1:
        parser.error(f"--pairs={args.pairs} must be at least 1")
    if args.repeats < 1:
        parser.error(f"--repeats={args.repeats} must be at least 1")
    return args


def main(argv=None) -> int | str:
    args = parse_args(argv)
    names = [n.strip() for n in args.models.split(",") if n.strip()] or list(REGISTRY)
    try:
        models = [get_model(name) for name in names]
    except BrdfFitError as exc:
        return f"bench_evaluate: {exc}"
    wi, wo = random_pairs(args.pairs, args.seed)
    print("# Evaluation throughput (one core)\n")
    for line in machine():
        print(f"- {line}")
    print(
        f"- {args.pairs} random pairs over the hemisphere, default parameters, "
        f"median of {args.repeats} calls\n"
    )
    mitsuba, note = mitsuba_rates(wi, wo, args.alpha, args.repeats, median_seconds)
    print(
        f"- Mitsuba reference: {note}; roughconductor alpha={args.alpha:g}: "
        + (", ".join(f"{k} {v:.1f} M/s" for k, v in mitsuba.items()) or "not measured")
        + "\n"
    )
    print(
        "| model | compiled | prepared (M/s) | numpy (M/s) | speed-up | unprepared (M/s) "
        "| vs Mitsuba | prepared, wall (M/s) |"
    )
    print("| --- | --- | ---: | ---: | ---: | ---: | --- | ---: |")
    references = [mitsuba]
    for model in models:
        rate = measure(model, wi, wo, args.repeats)
        if mitsuba:  # Mitsuba again after each model: its ratio is to the mean of the two
            after, _ = mitsuba_rates(wi, wo, args.alpha, args.repeats, median_seconds)
            beside = {k: (references[-1][k] + after[k]) / 2 for k in after}
            references.append(after)
        print(
            f"| {model.name} | {'yes' if model.name in kernels.COMPILED_MODELS else ''} | "
            f"{rate['prepared']:.1f} | {rate['numpy']:.1f} | "
            f"{rate['prepared'] / rate['numpy']:.1f} | {rate['unprepared']:.1f} | "
            f"{versus(model.name, rate['prepared'], beside if mitsuba else {})} | "
            f"{rate['prepared_wall']:.1f} |",
            flush=True,
        )
    print(
        "\nM/s: million BRDF samples per second of CPU time of this process (median); "
        "the wall columns divide by elapsed time instead, which on a loaded machine "
        "includes time other processes held the core."
    )
    if mitsuba:
        print(
            "\nvs Mitsuba: to the mean of Mitsuba's rates measured just before and just "
            "after the model (the machine's speed drifts over a run); Mitsuba's rates "
            "over the run: "
            + ", ".join(
                f"{k} {min(r[k] for r in references):.1f}-{max(r[k] for r in references):.1f} M/s"
                for k in mitsuba
            )
        )
    print(f"\nCommand: python {' '.join(sys.argv)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
