"""Mitsuba 3's LLVM backend evaluating its rough conductor, as a speed reference.

``roughconductor`` with ``material = none`` (a perfect conductor: F = 1), the GGX
or Beckmann distribution, variant ``llvm_ad_rgb`` (float32, RGB, vectorised by
Dr.Jit's LLVM backend) on one thread (``drjit.set_thread_count(1)``): the BSDF's
``eval`` on the same direction pairs as brdffit, in one call per timing, after an
untimed call that compiles the kernel. Mitsuba is a benchmark dependency only
(``pip install mitsuba``; the LLVM variants need the system's ``libllvm``, e.g.
``apt-get install libllvm19``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["mitsuba_rates"]

DISTRIBUTIONS = ("ggx", "beckmann")


def _load():
    """(mitsuba, drjit) on the LLVM RGB variant with one thread, or a reason why not."""
    try:
        import drjit as dr
        import mitsuba as mi

        mi.set_variant("llvm_ad_rgb")
    except Exception as exc:  # ImportError, or no libLLVM for the variant
        return None, f"Mitsuba's llvm_ad_rgb is not available ({type(exc).__name__}: {exc})"
    dr.set_thread_count(1)
    return (mi, dr), ""


def mitsuba_rates(wi: np.ndarray, wo: np.ndarray, alpha: float, repeats: int, timer) -> tuple:
    """M pairs/s of Mitsuba's rough conductor per distribution, or ({}, reason).

    ``timer(call, repeats) -> (cpu, wall)`` medians, the caller's timing function.
    """
    loaded, reason = _load()
    if loaded is None:
        return {}, reason
    mi, dr = loaded
    n = wi.shape[0]
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.wi = mi.Vector3f(np.ascontiguousarray(wi.T, dtype=np.float32))
    si.sh_frame = mi.Frame3f(mi.Vector3f(0.0, 0.0, 1.0))
    out = mi.Vector3f(np.ascontiguousarray(wo.T, dtype=np.float32))
    context = mi.BSDFContext()
    dr.eval(si, out)
    rates = {}
    for distribution in DISTRIBUTIONS:
        bsdf = mi.load_dict(
            {
                "type": "roughconductor",
                "distribution": distribution,
                "alpha": alpha,
                "material": "none",
            }
        )

        def call(bsdf=bsdf):
            value = bsdf.eval(context, si, out)
            dr.eval(value)

        cpu, _ = timer(call, repeats)
        rates[distribution] = n / 1e6 / max(cpu, 1e-9)
    version = getattr(mi, "__version__", "?")
    return rates, f"Mitsuba {version}, variant llvm_ad_rgb, drjit threads 1"
