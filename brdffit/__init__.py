"""brdffit: fit analytic BRDF models to measured reflectance, with uncertainties."""

from .batch import fit_many  # Dask is imported when a batch runs, not here
from .compare import compare
from .errors import BrdfFitError, DataError, FitError, FormatError, ModelError, ParameterError
from .fitting import fit
from .geometry import Geometry
from .io import read, write
from .measurements import Measurements
from .models import REGISTRY, get_model, list_models
from .posterior import sample_posterior
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
    "compare",
    "fit",
    "fit_many",
    "get_model",
    "list_models",
    "read",
    "sample_posterior",
    "synthesize",
    "write",
]

__version__ = "0.1.0"
