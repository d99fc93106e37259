"""Bodies and answers of the HTTP service, one to one with the library's calls.

- :mod:`.requests`: the bodies (:class:`DataIn` is ``Measurements.from_angles``,
  :class:`FitOptions` the options of :func:`brdffit.fit`...);
- :mod:`.results`: ``FitResult.to_dict()`` and ``Posterior.to_dict()``;
- :mod:`.models`: ``Model.to_dict()``, its properties, evaluations;
- :mod:`.service`: jobs, errors and health;
- :mod:`.comparisons`: comparisons of several models on one dataset.

Answers forbid keys they do not declare, so every key a client receives is
documented in the OpenAPI document; the tests compare each answer schema with
the keys of a real ``to_dict()``.
"""

from .comparisons import ComparisonBrief, ComparisonOut, EntryOut
from .models import ClassificationOut, EvaluateOut, ModelOut, ParamOut, PropertiesOut
from .requests import (
    EXAMPLE_DATA,
    DataIn,
    EvaluateIn,
    FitIn,
    FitOptions,
    JobStatus,
    PosteriorOptions,
)
from .results import FitResultOut, OptionsOut, PosteriorOut, SummaryOut, WeightsOut
from .service import ErrorItem, ErrorOut, HealthOut, JobOut, JobProgress

__all__ = [
    "EXAMPLE_DATA",
    "ClassificationOut",
    "ComparisonBrief",
    "ComparisonOut",
    "DataIn",
    "EntryOut",
    "ErrorItem",
    "ErrorOut",
    "EvaluateIn",
    "EvaluateOut",
    "FitIn",
    "FitOptions",
    "FitResultOut",
    "HealthOut",
    "JobOut",
    "JobProgress",
    "JobStatus",
    "ModelOut",
    "OptionsOut",
    "ParamOut",
    "PosteriorOptions",
    "PosteriorOut",
    "PropertiesOut",
    "SummaryOut",
    "WeightsOut",
]
