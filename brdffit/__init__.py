"""brdffit: fit analytic BRDF models to measured reflectance, with uncertainties.

The public API: read and write measurements (a path, bytes or a file object),
get a model, fit it (with its posterior), compare models, fit many on Dask
(``fit_many``), export a fit to renderers, synthesize data. The core needs
numpy, scipy, nlopt and emcee only; plots, the web service, colour conversion,
batch fits and export previews are extras (:mod:`brdffit.extras`;
:class:`MissingExtraError` names the one missing).
"""

from .batch import fit_many  # Dask is imported when a batch runs, not here
from .data.geometry import Geometry
from .data.measurements import Measurements
from .errors import (
    BrdfFitError,
    DataError,
    FitError,
    FormatError,
    MissingExtraError,
    ModelError,
    ParameterError,
)
from .export import export, export_targets  # brdffit.export is the function
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
    "MissingExtraError",
    "ModelError",
    "ParameterError",
    "StopFit",
    "check_fit",
    "compare",
    "export",
    "export_targets",
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
