"""Compiled kernels: the prepared evaluation of the common models in one fused loop.

The numpy models (:mod:`brdffit.models`) evaluate a formula as a sequence of array
operations, each with its temporary array. The loops of
:mod:`brdffit.kernels.loops`, compiled by numba, compute the same formula pair by
pair in one pass over a few cached parameter-free inputs, which is what a fit does
thousands of times. :func:`install` binds them to the registered models in place
of their design functions; the numpy design stays as the reference and as the
fallback when numba is not installed or the kernels are switched off:

- the environment variable ``BRDFFIT_KERNELS=0`` switches them off for a process;
- ``with brdffit.kernels.use(False):`` switches them off for a block (the tests run
  every model's reference tests both ways).

The loops are compiled on first use and cached on disk (numba's ``cache=True``).
"""

from __future__ import annotations

import contextlib
import importlib.util
import os

__all__ = ["COMPILED_MODELS", "available", "enabled", "install", "use"]

_state = {"on": os.environ.get("BRDFFIT_KERNELS", "1").strip() not in ("0", "false", "no")}


def available() -> bool:
    """Whether numba is installed (without importing it)."""
    return importlib.util.find_spec("numba") is not None


_AVAILABLE = available()


def enabled() -> bool:
    """Whether the compiled kernels are used now."""
    return _AVAILABLE and _state["on"]


@contextlib.contextmanager
def use(on: bool = True):
    """Switch the compiled kernels on or off within a ``with`` block."""
    before = _state["on"]
    _state["on"] = bool(on)
    try:
        yield
    finally:
        _state["on"] = before


def install(registry) -> None:
    """Bind the compiled loops to the models of ``registry`` that have one.

    Each such model's ``design`` becomes a :class:`~brdffit.kernels.bind.CompiledDesign`
    wrapping the numpy design (once: installing twice changes nothing)."""
    from .bind import SPECS, CompiledDesign

    for name, compiled in SPECS.items():
        model = registry.get(name)
        if model is None or isinstance(model.design, CompiledDesign):
            continue
        # Model is a frozen dataclass: its design is replaced as its __post_init__ sets
        # its own fields.
        object.__setattr__(model, "design", CompiledDesign(model.design, compiled, enabled))


COMPILED_MODELS = (
    "ggx",
    "beckmann",
    "ward",
    "cook_torrance",
    "blinn",
    "ward_anisotropic",
    "ashikhmin_shirley",
)
