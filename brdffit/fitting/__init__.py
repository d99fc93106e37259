"""Fitting: data and a model in, a :class:`FitResult` out.

The flow inside: :mod:`.core` is ``fit`` itself; :mod:`.options` validates
what the caller asked for, :mod:`.problem` prepares the objective (variable
projection: the linear parameters solved by :mod:`.solve` and :mod:`.linear`,
the loss from :mod:`.losses`, the noise model of the ``mixed`` loss from
:mod:`.noise`), :mod:`.engine` searches the shape parameters with nlopt,
:mod:`.energy` checks the result's albedo, :mod:`.misfit` tests the residuals
against the noise, :mod:`.identifiability` names the parameters the data do
not constrain, :mod:`.result` holds the answer and :mod:`.compare` ranks
several models on the same data.
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
