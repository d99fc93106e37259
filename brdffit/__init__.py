"""brdffit: fit analytic BRDF models to measured reflectance, with uncertainties."""

from .data.geometry import Geometry
from .data.measurements import Measurements
from .errors import BrdfFitError, DataError, FitError, FormatError, ModelError, ParameterError
from .fitting.compare import compare
from .fitting.core import check_fit, fit
from .fitting.engine import StopFit
from .io import read, write
from .models import REGISTRY, get_model, list_models
from .posterior.sample import sample_posterior
from .synth import synthesize

__all__ = [
    "REGISTRY",
    "BrdfFitError",
    "DataError",
    "FitError",
    "FormatError",
    "Geometry",
    "Measurements",
    "ModelError",
    "ParameterError",
    "StopFit",
    "check_fit",
    "compare",
    "fit",
    "get_model",
    "list_models",
    "read",
    "sample_posterior",
    "synthesize",
    "write",
]

__version__ = "0.1.0"
