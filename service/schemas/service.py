"""Answers about the service itself: jobs, errors, health."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, Field

from .requests import JobStatus
from .results import ANSWER, FitResultOut, MaybeFloat

__all__ = ["ErrorItem", "ErrorOut", "HealthOut", "JobOut", "JobProgress"]


class ErrorItem(BaseModel):
    """One problem of a request."""

    model_config = ANSWER

    field: str | None = Field(description="The input that is wrong, as a dotted path.")
    message: str = Field(description="What is wrong with it.")


class ErrorOut(BaseModel):
    """Every 4xx and 5xx answer, and the error of a failed job: what is wrong, and where."""

    model_config = ANSWER

    field: str | None = Field(description="The input that is wrong, as a dotted path.")
    message: str = Field(description="A sentence saying what is wrong and what is needed.")
    kind: str = Field(description="The error's class (DataError, ValidationError...).")
    errors: list[ErrorItem] = Field(default_factory=list, description="Every problem found.")


class JobProgress(BaseModel):
    """The last progress report of a running job: the fit's, then the posterior's."""

    model_config = ANSWER

    stage: str = Field(description='"global", "local 1/3"... of the fit, or "posterior".')
    seconds: float = Field(description="Seconds since the stage's call started.")
    n_evals: int | None = Field(None, description="Fit: evaluations so far.")
    max_evals: int | None = Field(None, description="Fit: the budget of evaluations.")
    best_loss: MaybeFloat = Field(None, description="Fit: the best loss so far.")
    steps: int | None = Field(None, description="Posterior: steps so far.")
    max_steps: int | None = Field(None, description="Posterior: the most it will take.")
    autocorr_time: MaybeFloat = Field(
        None, description="Posterior: the largest autocorrelation time estimated so far."
    )
    effective_samples: int | None = Field(
        None, description="Posterior: the smallest effective sample size so far."
    )
    converged: bool | None = Field(None, description="Posterior: converged already.")


class JobOut(BaseModel):
    """A job: its state, its last progress, and its result or error."""

    model_config = ANSWER

    id: str = Field(description="The job's id, as in its URL /jobs/{id}.")
    status: JobStatus = Field(
        description="queued, running, done, failed, interrupted (the server stopped "
        "while it ran, or its worker died: POST /jobs/{id}/resubmit runs it again), or "
        "cancelled (POST /jobs/{id}/cancel; kept, and can be resubmitted)."
    )
    model: str = Field(description="The model being fitted.")
    created: str = Field(description="When it was accepted (ISO 8601, UTC).")
    started: str | None = Field(None, description="When its current attempt started.")
    finished: str | None = Field(None, description="When its current attempt ended.")
    attempt: int = Field(description="How many times the job was submitted.")
    progress: JobProgress | None = Field(None, description="Its last progress report.")
    result: FitResultOut | None = Field(None, description="The fit, once done.")
    error: ErrorOut | None = Field(
        None, description="Why it failed, was interrupted or was cancelled."
    )
    data_notes: list[str] | None = Field(
        None,
        description="What reading the job's data noticed (values below zero, pairs a "
        "reader dropped); kept with the job.",
    )


class HealthOut(BaseModel):
    """Liveness and load of the service."""

    model_config = ANSWER

    status: Literal["ok"] = Field(description="Always ok: the service answers.")
    version: str = Field(description="The version of brdffit.")
    workers: int = Field(description="Worker processes running jobs.")
    jobs: dict[str, int] = Field(description="Number of jobs in each status.")
