"""``/jobs``: long fits and posteriors, stored before they are accepted."""

from __future__ import annotations

from fastapi import APIRouter, Query, Response

import brdffit

from ..convert import fit_kwargs, located, measurements, read_upload
from ..deps import RunnerDep, SettingsDep, StoreDep
from ..errors import ApiError
from ..schemas import ErrorOut, FitIn, FitOptions, JobOut, JobStatus
from ..store import data_to_bytes
from .common import (
    ERRORS,
    NOT_FOUND,
    ChannelsField,
    FileField,
    FormatField,
    ModelField,
    OptionsField,
    SubsampleField,
    form_options,
    stored_options,
)

__all__ = ["router"]

router = APIRouter(tags=["jobs"])
ACCEPTED = {**ERRORS, 202: {"description": "Accepted; stored before this answer."}}
CONFLICT = {**NOT_FOUND, 409: {"model": ErrorOut, "description": "The job's status forbids it."}}


def _submit(store, runner, response: Response, model: str, kwargs: dict, data, notes,
            export=()) -> dict:  # fmt: skip
    """Check the job as ``brdffit.fit`` would, without fitting (bad input is a 422 now,
    not a failed job later), store it (with its ``export`` targets, made by the
    worker after the fit), then hand it to a worker."""
    brdffit.check_fit(data, model, **kwargs)
    job = store.create(model, stored_options(kwargs, export), data_to_bytes(data), notes)
    runner.submit(job["id"], job["attempt"])
    response.headers["Location"] = f"/jobs/{job['id']}"
    return job


def _job(store, job_id: str) -> dict:
    job = store.get(job_id)
    if job is None:
        raise ApiError(404, f"there is no job {job_id!r} (it may have been deleted)", "id")
    return job


@router.post("/jobs", status_code=202, response_model=JobOut, responses=ACCEPTED)
def create_job(body: FitIn, response: Response, settings: SettingsDep, store: StoreDep,
               runner: RunnerDep):  # fmt: skip
    """Queue ``brdffit.fit(data, model, **options)`` (with the posterior when
    ``uncertainty`` is true); answers 202 once the job is stored."""
    data, notes = measurements(body.data, settings.max_samples)
    kwargs = fit_kwargs(body, settings.job_timeout)
    with located("data"):  # a fault the fit's check finds in the data (values too large...)
        return _submit(store, runner, response, body.model, kwargs, data, notes, body.export)


@router.post("/jobs/file", status_code=202, response_model=JobOut, responses=ACCEPTED)
def create_job_file(
    response: Response,
    settings: SettingsDep,
    store: StoreDep,
    runner: RunnerDep,
    file: FileField,
    model: ModelField,
    format: FormatField = None,
    subsample: SubsampleField = None,
    channels: ChannelsField = None,
    options: OptionsField = "{}",
):
    """``POST /jobs`` with an uploaded file."""
    options_in: FitOptions = form_options(options)
    data, notes = read_upload(file.file.read(), file.filename, format, subsample, channels,
                              settings.max_samples)  # fmt: skip
    kwargs = fit_kwargs(options_in, settings.job_timeout)
    return _submit(store, runner, response, model, kwargs, data, notes, options_in.export)


@router.get("/jobs", response_model=list[JobOut], responses=ERRORS)
def list_jobs(store: StoreDep, status: JobStatus | None = None,
              limit: int = Query(100, ge=1, le=1000)):  # fmt: skip
    """The most recent jobs (without their results), newest first."""
    return store.list(status, limit)


@router.get("/jobs/{job_id}", response_model=JobOut, responses=NOT_FOUND)
def get_job(job_id: str, store: StoreDep):
    """The job's status, its last progress, and its result or its error."""
    return _job(store, job_id)


@router.post("/jobs/{job_id}/cancel", response_model=JobOut, responses=CONFLICT)
def cancel_job(job_id: str, store: StoreDep, runner: RunnerDep):
    """Stop a queued or running job and keep it, ``cancelled``, with its inputs (a running
    one stops at its next progress report); ``resubmit`` runs it again. Deleting a
    job is a separate act: ``DELETE /jobs/{id}``."""
    if not store.cancel(job_id):
        job = _job(store, job_id)
        raise ApiError(409, f"job {job_id} is {job['status']}; only queued or running jobs "
                       "can be cancelled", "id")  # fmt: skip
    runner.cancel(job_id)
    return _job(store, job_id)


@router.delete("/jobs/{job_id}", status_code=204, responses=NOT_FOUND)
def delete_job(job_id: str, store: StoreDep, runner: RunnerDep):
    """Delete a job, its inputs and its result, for good: a queued one never runs, a
    running one stops at its next report. To stop a job and keep it, cancel it
    (``POST /jobs/{id}/cancel``)."""
    if not store.delete(job_id):
        raise ApiError(404, f"there is no job {job_id!r}", "id")
    runner.cancel(job_id)
    return Response(status_code=204)


@router.post("/jobs/{job_id}/resubmit", status_code=202, response_model=JobOut,
             responses=CONFLICT)  # fmt: skip
def resubmit_job(job_id: str, store: StoreDep, runner: RunnerDep):
    """Run an ``interrupted``, ``failed`` or ``cancelled`` job again, with its inputs."""
    attempt = store.requeue(job_id)
    if attempt is None:
        job = _job(store, job_id)
        raise ApiError(409, f"job {job_id} is {job['status']}; only interrupted, failed or "
                       "cancelled jobs can be resubmitted", "id")  # fmt: skip
    runner.submit(job_id, attempt)
    return _job(store, job_id)
