"""Evaluation cost of the He-Torrance-Sillion-Greenberg model, on one core.

Three tables, from the same random direction pairs over the upper hemisphere:

1. Throughput of ``he`` (prepared geometry, as in a fit) at its default
   parameters with 1, 3 and 31 wavelengths, by its compiled loop
   (brdffit.kernels.loops_he, when numba is installed) and by numpy, next to
   ``cook_torrance`` at its defaults, in M pair-channels per second (one BRDF
   value each).
2. The parts of one evaluation at the default parameters: the shadowing, ``K``,
   the Newton iteration of ``z0``, Fresnel and the series over m, by numpy and by
   the compiled loop, in ns per pair.
3. The series over m of the directional-diffuse term, alone (numpy; the compiled
   series in its own column): mean and largest
   number of terms per element and time, for surfaces from smooth to rough
   (sigma0 / lambda, hence g), at the default truncation bound (1e-6 of the
   lobe's peak) and at looser and tighter ones, with the largest error measured
   against a sum truncated at 1e-13 (relative to the peak).

Each time is the median of ``--repeats`` timed calls after one untimed call.

Usage::

    python benchmarks/bench_he.py [--pairs 100000] [--repeats 3]
"""

from __future__ import annotations

import argparse
import sys

import bench_evaluate  # before numpy: it pins the thread pools to one core
import numpy as np

from brdffit import kernels
from brdffit.data.geometry import Geometry
from brdffit.models import get_model
from brdffit.models.he_terms import SERIES_TOLERANCE, dd_series
from brdffit.models.wave import HE, series_arguments

WAVELENGTHS = {1: [550.0], 3: [450.0, 550.0, 650.0], 31: list(np.arange(400.0, 701.0, 10.0))}
#: sigma0 in micrometres at 550 nm: smooth (g < 1), intermediate (g ~ 10), rough (g ~ 1e3).
SURFACES = {"smooth": 0.02, "default": 0.18, "rough": 2.0}
TOLERANCES = (1e-3, SERIES_TOLERANCE, 1e-9)
#: The compiled loop's module: the model asks for it at every size (brdffit.models.wave).
LOOPS = ("loops_he",)


def throughput_table(wi, wo, repeats: int) -> None:
    geometry = Geometry(wi, wo)
    cook = get_model("cook_torrance")
    base = bench_evaluate.median_seconds(
        lambda: cook.evaluate_prepared(geometry, cook.defaults()), repeats
    )[0]
    print(
        "| model | path | channels | M pair-channels/s | ns per pair-channel "
        "| x cook_torrance |\n| --- | --- | ---: | ---: | ---: | ---: |"
    )
    print(
        f"| cook_torrance | compiled | 1 | {wi.shape[0] / base / 1e6:.2f} | "
        f"{base / wi.shape[0] * 1e9:.0f} | 1 |"
    )
    for count, wavelengths in WAVELENGTHS.items():
        params = {**HE.defaults(), "wavelength": wavelengths}
        for path, on in (("compiled", None), ("numpy", False)):
            if on is None and not kernels.wanted(geometry.m, 1, LOOPS):
                continue
            with kernels.use(on):
                seconds = bench_evaluate.median_seconds(
                    lambda params=params: HE.evaluate_prepared(geometry, params), repeats
                )[0]
            per = seconds / (wi.shape[0] * count)
            print(
                f"| he | {path} | {count} | {1e-6 / per:.2f} | {per * 1e9:.0f} | "
                f"{per * wi.shape[0] / base:.0f} |",
                flush=True,
            )


def parts_table(wi, wo, repeats: int) -> None:
    """Where one evaluation's time goes, at the default parameters, one wavelength."""
    from brdffit.models.he_terms import effective_roughness_ratio, roughness_k, shadowing
    from brdffit.models.shared import fresnel_conductor

    geometry = Geometry(wi, wo)
    params = HE.check_params(HE.defaults())
    shape = {p.name: params[p.name] for p in HE.shape_params}
    ratio = shape["tau"] / shape["sigma0"]
    ci, co, cd = geometry.cos_i, geometry.cos_o, geometry.cos_d
    g, a, _ = series_arguments(geometry, shape)
    k_sum = roughness_k(ci, ratio) + roughness_k(co, ratio)
    parts = [
        ("numpy", "shadowing S of L and V", lambda: (shadowing(ci, ratio), shadowing(co, ratio))),
        ("numpy", "K of L and V", lambda: roughness_k(ci, ratio) + roughness_k(co, ratio)),
        ("numpy", "z0 and sigma (Newton)", lambda: effective_roughness_ratio(k_sum)),
        ("numpy", "Fresnel", lambda: fresnel_conductor(cd, shape["eta"], shape["k"])),
        ("numpy", "series over m", lambda: dd_series(g, a)),
        ("numpy", "whole evaluation", lambda: _numpy_evaluation(geometry, params)),
    ]
    if kernels.wanted(geometry.m, 1, LOOPS):
        from brdffit.kernels import loops_he

        values = np.array([shape["sigma0"], shape["tau"], shape["eta"], shape["k"], 1e-6])
        sigma, common, out = np.empty(geometry.m), np.empty(geometry.m), np.empty(g.size)
        parts += [
            ("compiled", "S, K, z0 and Fresnel",
             lambda: loops_he.pair_terms(ci, co, cd, values, sigma, common)),
            ("compiled", "series over m", lambda: loops_he.dd_series_blocks(g, a, 1e-6, out)),
            ("compiled", "whole evaluation", lambda: HE.evaluate_prepared(geometry, params)),
        ]  # fmt: skip
    print("| path | part | ns per pair |\n| --- | --- | ---: |")
    for path, label, call in parts:
        seconds = bench_evaluate.median_seconds(call, repeats)[0]
        print(f"| {path} | {label} | {seconds / geometry.m * 1e9:.0f} |", flush=True)


def _numpy_evaluation(geometry, params):
    with kernels.use(False):
        return HE.evaluate_prepared(geometry, params)


def series_table(wi, wo, repeats: int) -> None:
    geometry = Geometry(wi, wo)
    compiled = kernels.wanted(geometry.m, 1, LOOPS)
    print(
        "| surface | sigma0 (um) | median g | max g | tolerance | mean terms | max terms "
        "| ms | ns per element | compiled ns per element | max error / peak |"
    )
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for label, sigma0 in SURFACES.items():
        shape = {**HE.defaults(), "sigma0": sigma0}
        g, a, _ = series_arguments(geometry, shape)
        exact = dd_series(g, a, 1e-13)
        peak = dd_series(g, np.zeros_like(a), 1e-13)
        for tol in TOLERANCES:
            seconds = bench_evaluate.median_seconds(
                lambda g=g, a=a, tol=tol: dd_series(g, a, tol), repeats
            )[0]
            fast = _compiled_series_ns(g, a, tol, repeats) if compiled else "-"
            value, terms = dd_series(g, a, tol, count_terms=True)
            error = np.max(np.abs(value - exact) / np.where(peak > 0, peak, 1.0))
            print(
                f"| {label} | {sigma0:g} | {np.median(g):.3g} | {g.max():.3g} | {tol:g} | "
                f"{terms.mean():.1f} | {terms.max()} | {seconds * 1e3:.1f} | "
                f"{seconds / g.size * 1e9:.0f} | {fast} | {error:.1e} |",
                flush=True,
            )


def _compiled_series_ns(g, a, tol: float, repeats: int) -> str:
    from brdffit.kernels.loops_he import dd_series_blocks

    out = np.empty(g.size)
    seconds = bench_evaluate.median_seconds(lambda: dd_series_blocks(g, a, tol, out), repeats)[0]
    return f"{seconds / g.size * 1e9:.0f}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pairs", type=int, default=100_000, help="direction pairs")
    parser.add_argument("--repeats", type=int, default=3, help="timed calls per figure (median)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the direction pairs")
    args = parser.parse_args(argv)
    if args.pairs < 1 or args.repeats < 1:
        parser.error("--pairs and --repeats must be at least 1")
    wi, wo = bench_evaluate.random_pairs(args.pairs, args.seed)
    print("# He-Torrance-Sillion-Greenberg: evaluation cost (one core)\n")
    for line in bench_evaluate.machine():
        print(f"- {line}")
    print(f"- {args.pairs} random pairs, median of {args.repeats} calls\n")
    print("## Throughput at the default parameters\n")
    throughput_table(wi, wo, args.repeats)
    print("\n## Where the time goes: default parameters, one wavelength (550 nm)\n")
    parts_table(wi, wo, args.repeats)
    print("\n## The series over m (directional diffuse), one wavelength (550 nm)\n")
    series_table(wi, wo, args.repeats)
    print(f"\nCommand: python {' '.join(sys.argv)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
