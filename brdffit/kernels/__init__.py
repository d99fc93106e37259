"""Compiled kernels: the prepared evaluation of the common models in one fused loop.

The numpy models (:mod:`brdffit.models`) evaluate a formula as a sequence of array
operations, each with its temporary array. The loops of the ``loops*`` modules of
this package (:mod:`brdffit.kernels.loops` and its siblings), compiled by numba,
compute the same formula pair by pair in one pass over a few cached parameter-free
inputs, which is what a fit does thousands of times. :func:`install` binds them to
the registered models in place of their design functions; the numpy design stays
as the reference and as the fallback when numba is not installed or the kernels
are switched off:

- by default they run on geometries of at least :data:`MIN_PAIRS` direction pairs:
  below that a fit is short anyway, and importing numba and loading the compiled
  loops (0.2 s of CPU, 0.5 s before the loops loaded without numba's registries,
  :mod:`brdffit.kernels._cached`; ``benchmarks/bench_cold_start.py --first-fit``)
  would cost a small fit more than it saves, so small fits run exactly as without
  numba (and never import it); a model may set its own size (``he``'s series repays
  the load at every size, :class:`brdffit.kernels.bind.CompiledDesign`);
- the environment variable ``BRDFFIT_KERNELS=0`` switches them off for a process,
  ``BRDFFIT_KERNELS=1`` on for every size;
- ``with brdffit.kernels.use(False):`` (or ``use(True)``) does the same for a block
  (the tests run every model's reference tests both ways).

The loops are compiled on first use and cached on disk (numba's ``cache=True``);
a process loads them from there without numba's registries
(:mod:`brdffit.kernels._cached`).
"""

from __future__ import annotations

import contextlib
import importlib
import importlib.util
import os
import sys
import warnings

__all__ = ["COMPILED_MODELS", "MIN_PAIRS", "available", "enabled", "install", "use", "wanted"]

#: The smallest geometry the kernels run on by default (see the module docstring).
MIN_PAIRS = 10_000

_SWITCH = {"0": False, "false": False, "no": False, "1": True, "true": True, "yes": True}
#: None: by size (the default); True: always; False: never.
_state = {"on": _SWITCH.get(os.environ.get("BRDFFIT_KERNELS", "").strip().lower())}


def available() -> bool:
    """Whether numba is installed (without importing it)."""
    return importlib.util.find_spec("numba") is not None


_AVAILABLE = available()


def enabled() -> bool:
    """Whether the compiled kernels may be used now (numba installed, not switched off)."""
    return _AVAILABLE and _state["on"] is not False


def wanted(pairs: int, minimum: int = MIN_PAIRS, modules: tuple = ("loops",)) -> bool:
    """Whether to use the compiled kernels on a geometry of ``pairs`` valid pairs
    (by default from ``minimum`` pairs on: :data:`MIN_PAIRS`, or a model's own) with
    the loops of ``modules`` (modules of this package, imported here on first use)."""
    if not (_AVAILABLE and pairs > 0) or _state["on"] is False:
        return False
    return (_state["on"] is True or pairs >= minimum) and all(_loaded(m) for m in modules)


def _loaded(module: str) -> bool:
    """Import the loop module ``module`` (and numba) once; if that fails (a numba that
    does not support the installed numpy, say), warn once and run the numpy formulas
    of the models that need it from then on.

    Only the modules a model needs are imported: a ward fit imported all six, the
    five it does not use 18-20 ms of CPU from source (benchmarks/README.md, "The
    first compiled fit in a process")."""
    loaded = _state.setdefault("loaded", {})
    if module not in loaded:
        try:
            importlib.import_module(f".{module}", __name__)
        except Exception as exc:  # ImportError, or numba's own errors on import
            warnings.warn(
                f"brdffit's compiled kernels are off: importing them failed ({exc}); "
                "the numpy formulas run instead",
                RuntimeWarning,
                stacklevel=4,
            )
            loaded[module] = False
        else:
            loaded[module] = True
            _lighten()
    return loaded[module]


def _lighten() -> None:
    """Let the cached loops of the kernel modules imported so far load without
    numba's registries (:mod:`brdffit.kernels._cached`), each module once. Where that
    fails (another numba's internals), the loops load numba's way: slower, the same
    values, and the kernels stay on."""
    try:
        from ._cached import lighten
    except Exception:
        return
    done = _state.setdefault("lightened", set())
    for name, module in list(sys.modules.items()):
        if name.startswith(f"{__name__}.") and module is not None and name not in done:
            done.add(name)
            try:
                lighten(module)
            except Exception:
                continue


@contextlib.contextmanager
def use(on: bool | None = True):
    """Switch the compiled kernels on (for every size), off, or back to by size
    (``None``) within a ``with`` block."""
    before = _state["on"]
    _state["on"] = None if on is None else bool(on)
    try:
        yield
    finally:
        _state["on"] = before


def install(registry) -> None:
    """Bind the compiled loops to the models of ``registry`` that have one.

    Each such model's ``design`` becomes a :class:`~brdffit.kernels.bind.CompiledDesign`
    wrapping the numpy design (once: installing twice changes nothing)."""
    from .bind import MODULES, SPECS, CompiledDesign

    for name, compiled in SPECS.items():
        model = registry.get(name)
        if model is None or isinstance(model.design, CompiledDesign):
            continue
        # Model is a frozen dataclass: its design is replaced as its __post_init__ sets
        # its own fields.
        object.__setattr__(
            model, "design", CompiledDesign(model.design, compiled, wanted, MODULES[name])
        )


COMPILED_MODELS = (
    "ggx",
    "beckmann",
    "ward",
    "cook_torrance",
    "blinn",
    "ward_anisotropic",
    "ashikhmin_shirley",
    "ggx_anisotropic",
    "beckmann_anisotropic",
    "cook_torrance_schlick",
    "torrance_sparrow",
    "phong",
    "phong_normalized",
    "blinn_normalized",
    "ashikhmin_phong",
    "heidrich_seidel",
    "schlick",
    "wang",
    "blake",
    "gaussian",
    "lafortune",
    "ohara",
    "fournier",
    "gltf_pbr",
    "gltf_pbr_anisotropic",
    "mitsuba_roughconductor",
    "mitsuba_roughconductor_anisotropic",
    "mitsuba_principled",
    "mitsuba_principled_anisotropic",
    "mitsuba_roughplastic",
    "he",
)
