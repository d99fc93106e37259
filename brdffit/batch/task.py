"""What runs on a Dask worker: read a source, fit one model, pack the answer.

Only plain data crosses a process. The source travels as a path (read here,
on the worker, so a large file is never shipped through the scheduler) or as
:class:`~brdffit.Measurements` (scattered once by the client). nlopt objects
are built inside :func:`brdffit.fit` on the worker. The answer is a dict of
builtins, numpy arrays and frozen-dataclass "wire" records: FitResult and
Posterior keep read-only ``MappingProxyType`` views, which pickle refuses, so
they travel as ``(class, init fields)`` and are rebuilt by :func:`unwire`
(their ``__post_init__`` makes the views again).
"""

from __future__ import annotations

import dataclasses
import importlib
import time
from types import MappingProxyType

import brdffit

__all__ = ["run_pair", "unwire", "wire"]

_WIRE = "__brdffit_dataclass__"


def wire(value):
    """``value`` with frozen dataclasses and mapping views turned into plain data."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        cls = type(value)
        fields = dataclasses.fields(value)
        fields = {f.name: wire(getattr(value, f.name)) for f in fields if f.init}
        return {_WIRE: f"{cls.__module__}:{cls.__qualname__}", "fields": fields}
    if isinstance(value, (dict, MappingProxyType)):
        return {k: wire(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(wire(v) for v in value)
    return value


def unwire(value):
    """The inverse of :func:`wire`; only classes of the ``brdffit`` package are rebuilt."""
    if isinstance(value, dict) and _WIRE in value:
        module, _, name = value[_WIRE].partition(":")
        if module.split(".")[0] != "brdffit":
            raise TypeError(f"refusing to rebuild {value[_WIRE]}: not a brdffit class")
        cls = getattr(importlib.import_module(module), name)
        return cls(**{k: unwire(v) for k, v in value["fields"].items()})
    if isinstance(value, dict):
        return {k: unwire(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(unwire(v) for v in value)
    return value


def _worker_address() -> str:
    try:
        from distributed import get_worker

        return get_worker().address
    except (ImportError, ValueError):
        return ""


def run_pair(source, model: str, uncertainty: bool, test_fraction, fit_options: dict) -> dict:
    """Fit ``model`` to ``source`` (a path or Measurements); never raises for a bad pair.

    Returns a dict with ``result`` (wired FitResult) or ``error`` (message,
    type, field), ``seconds``, ``worker``, and ``heldout_rmse`` /
    ``heldout_loss`` when ``test_fraction`` is given. The held-out errors come
    from :func:`brdffit.compare` with this one model and the fit's seed, so
    every model of a file is scored on the same seeded split.
    """
    t0 = time.perf_counter()
    out = {"worker": _worker_address(), "result": None, "error": None}
    try:
        data = source if isinstance(source, brdffit.Measurements) else brdffit.read(source)
        result = brdffit.fit(data, model, uncertainty=uncertainty, **fit_options)
        out["result"] = wire(result)
        if test_fraction:
            options = dict(fit_options)
            seed = options.pop("seed", 0)
            entry = brdffit.compare(
                data, [model], test_fraction=test_fraction, seed=seed, **options
            ).entries[0]
            out["heldout_rmse"], out["heldout_loss"] = entry.heldout_rmse, entry.heldout_loss
    except Exception as exc:  # a bad pair is a row, never the end of the batch
        out["result"] = None
        out["error"] = (str(exc) or repr(exc), type(exc).__name__, getattr(exc, "field", None))
    out["seconds"] = time.perf_counter() - t0
    return out
