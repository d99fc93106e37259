"""Fitting: data and a model in, a :class:`FitResult` out.

The flow inside: :mod:`.options` validates what the caller asked for,
:mod:`.problem` prepares the objective (variable projection: the linear
parameters solved by :mod:`.linear`, the loss from :mod:`.losses`),
:mod:`.engine` searches the shape parameters with nlopt, :mod:`.energy`
checks the result's albedo, :mod:`.result` holds the answer and
:mod:`.compare` ranks several models on the same data.
"""

from .compare import Comparison, compare
from .core import check_fit, fit
from .engine import FitProgress, StopFit
from .options import FitOptions
from .result import FitResult

__all__ = [
    "Comparison",
    "FitOptions",
    "FitProgress",
    "FitResult",
    "StopFit",
    "check_fit",
    "compare",
    "fit",
]
