"""brdffit: fit analytic BRDF models to measured reflectance, with uncertainties."""

from .errors import BrdfFitError, DataError, FitError, FormatError, ModelError, ParameterError
from .compare import compare
from .fitting import fit
from .geometry import Geometry
from .measurements import Measurements
from .models import REGISTRY, get_model, list_models

__all__ = [
    "REGISTRY",
    "get_model",
    "list_models",
    "Geometry",
    "Measurements",
    "fit",
    "compare",
    "BrdfFitError",
    "DataError",
    "FitError",
    "FormatError",
    "ModelError",
    "ParameterError",
]

__version__ = "0.1.0"
