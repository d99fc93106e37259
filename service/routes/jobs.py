"""The routes: short handlers that call the library and return its ``to_dict()``s."""

from __future__ import annotations

from functools import lru_cache
from typing import Annotated, Literal

import numpy as np
from fastapi import APIRouter, File, Form, Query, Request, Response, UploadFile
from fastapi.exceptions import RequestValidationError
from pydantic import ValidationError

import brdffit
from brdffit.errors import ModelError
from brdffit.models import REGISTRY
from brdffit.models.base import HIGHLIGHTS, OPERANDS, ORIGINS, SYMMETRIES

from .convert import finite, fit_kwargs, located, measurements, read_upload, sample_limit
from .errors import ApiError
from .schemas import (
    ErrorOut,
    EvaluateIn,
    EvaluateOut,
    FitIn,
    FitOptions,
    FitResultOut,
    HealthOut,
    JobOut,
    JobStatus,
    ModelOut,
)
from .store import data_to_bytes

__all__ = ["router"]

ERRORS = {
    413: {"model": ErrorOut, "description": "The body is larger than the server takes."},
    422: {"model": ErrorOut, "description": "Input that cannot be used; `field` says which."},
}
NOT_FOUND = {404: {"model": ErrorOut, "description": "No such model or job."}}

router = APIRouter(
    responses={
        400: {"model": ErrorOut, "description": "A body that cannot be read at all."},
        500: {"model": ErrorOut, "description": "A bug (logged)."},
    }
)


def _error(status: int, message: str, field: str | None = None):
    return ApiError(status, message, field)


@lru_cache(maxsize=256)
def _properties(name: str) -> dict:
    from brdffit.models.properties import model_properties

    return finite(model_properties(REGISTRY[name]))


def _model_out(model, properties: bool) -> dict:
    out = model.to_dict()
    if properties:
        if model.name in REGISTRY:
            out["properties"] = _properties(model.name)
        else:
            from brdffit.models.properties import model_properties

            out["properties"] = finite(model_properties(model))
    return out


# ------------------------------------------------------------------ service
@router.get("/health", response_model=HealthOut, tags=["service"])
def health(request: Request):
    """Liveness, the version, the number of job workers and of jobs in each status."""
    state = request.app.state
    return {
        "status": "ok",
        "version": brdffit.__version__,
        "workers": state.settings.workers,
        "jobs": state.store.counts(),
    }


# ------------------------------------------------------------------- models
@router.get("/models", response_model=list[ModelOut], responses=ERRORS, tags=["models"])
def list_models(
    origin: Literal[ORIGINS] | None = None,  # type: ignore[valid-type]
    symmetry: Literal[SYMMETRIES] | None = None,  # type: ignore[valid-type]
    operand: Literal[OPERANDS] | None = None,  # type: ignore[valid-type]
    highlight: Literal[HIGHLIGHTS] | None = None,  # type: ignore[valid-type]
    wave_optics: bool | None = None,
    properties: bool = Query(False, description="Add measured albedo and reciprocity."),
):
    """``brdffit.list_models(**filters)``: the models whose classification matches."""
    filters = dict(origin=origin, symmetry=symmetry, operand=operand, highlight=highlight,
                   wave_optics=wave_optics)  # fmt: skip
    models = brdffit.list_models(**{k: v for k, v in filters.items() if v is not None})
    return [_model_out(m, properties) for m in models]


@router.get("/models/{name}", response_model=ModelOut, responses={**ERRORS, **NOT_FOUND},
            tags=["models"])  # fmt: skip
def get_model(name: str, properties: bool = Query(False, description="Add measured albedo.")):
    """``brdffit.get_model(name).to_dict()``; a sum of lobes (``lambert+blinn``) works too."""
    try:
        model = brdffit.get_model(name)
    except ModelError as exc:
        raise _error(404, str(exc), "name") from None
    return _model_out(model, properties)


# -------------------------------------------------------------- evaluation
@router.post("/evaluate", response_model=EvaluateOut, responses=ERRORS, tags=["fit"])
def evaluate(body: EvaluateIn, request: Request):
    """``Model.evaluate`` at direction pairs given as angles in degrees."""
    sample_limit(len(body.theta_i), request.app.state.settings.max_samples, "theta_i")
    model = brdffit.get_model(body.model)
    pairs = brdffit.Measurements.from_angles(
        body.theta_i, body.phi_i, body.theta_o, body.phi_o, np.zeros(len(body.theta_i))
    )
    with located("params", set(body.params) | set(model.param_names)):
        params = model.check_params({**model.defaults(), **body.params})
    values = model.evaluate(pairs.wi, pairs.wo, params)
    return {"model": model.name, "params": finite(params), "values": finite(values)}


# ---------------------------------------------------------------- fitting
@router.post("/fit", response_model=FitResultOut, responses=ERRORS, tags=["fit"])
def fit(body: FitIn, request: Request):
    """``brdffit.fit(data, model, **options)``, within the server's limits of samples
    (``fit_max_samples``) and seconds (``fit_timeout``, for the fit and for the
    posterior); longer work belongs to ``POST /jobs``."""
    settings = request.app.state.settings
    data, notes = measurements(body.data, settings.fit_max_samples)
    result = request.app.state.fits.run(data, body.model, fit_kwargs(body, settings.fit_timeout))
    return {**result, "data_notes": notes}


def _options(options: str) -> FitOptions:
    """The form field ``options`` (JSON) as FitOptions; its errors are under ``options.``."""
    try:
        return FitOptions.model_validate_json(options or "{}")
    except ValidationError as exc:
        errors = [{**e, "loc": ("options", *e["loc"])} for e in exc.errors()]
        raise RequestValidationError(errors) from None


FILE_DOC = "The data file: CSV, ASTM, pbrt .brdf, MERL .binary, MBSDF or NPZ."
FORMAT_DOC = "The file's format when its name and first bytes do not tell."
OPTIONS_DOC = "The options of the fit as a JSON object (FitOptions)."
FileField = Annotated[UploadFile, File(description=FILE_DOC)]
ModelField = Annotated[str, Form(max_length=500, description="A model name or a sum.")]
FormatField = Annotated[str | None, Form(max_length=20, description=FORMAT_DOC)]
SubsampleField = Annotated[int | None, Form(ge=1, le=10**6, description="MERL: every n-th.")]
ChannelsField = Annotated[str | None, Form(max_length=2000, description="Channels: a,b,c")]
OptionsField = Annotated[str, Form(max_length=100_000, description=OPTIONS_DOC)]


@router.post("/fit/file", response_model=FitResultOut, responses=ERRORS, tags=["fit"])
def fit_file(
    request: Request,
    file: FileField,
    model: ModelField,
    format: FormatField = None,
    subsample: SubsampleField = None,
    channels: ChannelsField = None,
    options: OptionsField = "{}",
):
    """``brdffit.fit(brdffit.read(file), model, **options)``, as ``POST /fit``."""
    settings = request.app.state.settings
    fit_options = _options(options)
    data, notes = read_upload(file.file.read(), file.filename, format, subsample, channels,
                              settings.fit_max_samples)  # fmt: skip
    kwargs = fit_kwargs(fit_options, settings.fit_timeout)
    return {**request.app.state.fits.run(data, model, kwargs), "data_notes": notes}


# ------------------------------------------------------------------- jobs
def _submit(request: Request, response: Response, model_name: str, options: FitOptions, data,
            notes: list):  # fmt: skip
    state = request.app.state
    kwargs = fit_kwargs(options, state.settings.job_timeout)
    # One evaluation checks the model, the options and the data now, so that bad input
    # is a 422 here rather than a failed job later.
    check = {"max_evals": 1, "restarts": 0, "uncertainty": False, "energy_conserving": False}
    brdffit.fit(data, model_name, **(kwargs | check))
    job = state.store.create(model_name, kwargs, data_to_bytes(data), notes)
    state.runner.submit(job["id"], job["attempt"])
    response.headers["Location"] = f"/jobs/{job['id']}"
    return job


JOB_RESPONSES = {**ERRORS, 202: {"description": "Accepted; stored before this answer."}}


@router.post("/jobs", status_code=202, response_model=JobOut, responses=JOB_RESPONSES,
             tags=["jobs"])  # fmt: skip
def create_job(body: FitIn, request: Request, response: Response):
    """Queue ``brdffit.fit(data, model, **options)`` (with the posterior when
    ``uncertainty`` is true); answers 202 once the job is stored."""
    data, notes = measurements(body.data, request.app.state.settings.max_samples)
    return _submit(request, response, body.model, body, data, notes)


@router.post("/jobs/file", status_code=202, response_model=JobOut, responses=JOB_RESPONSES,
             tags=["jobs"])  # fmt: skip
def create_job_file(
    request: Request,
    response: Response,
    file: FileField,
    model: ModelField,
    format: FormatField = None,
    subsample: SubsampleField = None,
    channels: ChannelsField = None,
    options: OptionsField = "{}",
):
    """``POST /jobs`` with an uploaded file."""
    fit_options = _options(options)
    data, notes = read_upload(file.file.read(), file.filename, format, subsample, channels,
                              request.app.state.settings.max_samples)  # fmt: skip
    return _submit(request, response, model, fit_options, data, notes)


@router.get("/jobs", response_model=list[JobOut], responses=ERRORS, tags=["jobs"])
def list_jobs(request: Request, status: JobStatus | None = None,
              limit: int = Query(100, ge=1, le=1000)):  # fmt: skip
    """The most recent jobs (without their results), newest first."""
    return request.app.state.store.list(status, limit)


def _job(request: Request, job_id: str) -> dict:
    job = request.app.state.store.get(job_id)
    if job is None:
        raise _error(404, f"there is no job {job_id!r} (it may have been deleted)", "id")
    return job


@router.get("/jobs/{job_id}", response_model=JobOut, responses=NOT_FOUND, tags=["jobs"])
def get_job(request: Request, job_id: str):
    """The job's status, its last progress, and its result or its error."""
    return _job(request, job_id)


@router.delete("/jobs/{job_id}", status_code=204, responses=NOT_FOUND, tags=["jobs"])
def delete_job(request: Request, job_id: str):
    """Forget a job: a queued one never runs, a running one stops at its next report."""
    if not request.app.state.store.delete(job_id):
        raise _error(404, f"there is no job {job_id!r}", "id")
    request.app.state.runner.cancel(job_id)
    return Response(status_code=204)


@router.post("/jobs/{job_id}/resubmit", status_code=202, response_model=JobOut,
             responses={**NOT_FOUND, 409: {"model": ErrorOut}}, tags=["jobs"])  # fmt: skip
def resubmit_job(request: Request, job_id: str):
    """Run an ``interrupted`` or ``failed`` job again, with the inputs it was given."""
    attempt = request.app.state.store.requeue(job_id)
    if attempt is None:
        job = _job(request, job_id)
        raise _error(409, f"job {job_id} is {job['status']}; only interrupted or failed jobs "
                     "can be resubmitted", "id")  # fmt: skip
    request.app.state.runner.submit(job_id, attempt)
    return _job(request, job_id)
