"""Answers of the comparison routes: several models fitted to one dataset, ranked.

A comparison is what :func:`brdffit.compare` answers, done as jobs
(:mod:`brdffit_service.comparisons`): :class:`EntryOut` mirrors a
``CompareEntry`` (``model``, ``bic``, ``aic``, ``heldout_rmse``, ranks) with the
job that fits it; :class:`ComparisonOut` the comparison's split and entries.
"""

from __future__ import annotations

from typing import Literal, get_args

from pydantic import BaseModel, Field

from .requests import JobStatus
from .results import ANSWER, MaybeFloat

__all__ = ["DELETED", "ComparisonBrief", "ComparisonOut", "EntryOut"]

#: A job of a comparison that no longer exists (DELETE /jobs/{id}).
DELETED = "deleted"
EntryStatus = Literal[(*get_args(JobStatus), DELETED)]


class EntryOut(BaseModel):
    """One model of a comparison: its job and, once the job is done, its scores."""

    model_config = ANSWER

    model: str = Field(description="The model's name, as given.")
    job: str = Field(
        description="The job fitting this model to the training part: GET /jobs/{job}."
    )
    status: EntryStatus = Field(
        description=f"The job's status (as GET /jobs/{{job}}), or `{DELETED}` once the job "
        "was deleted."
    )
    bic: MaybeFloat = Field(None, description="BIC of the fit on the training part, once done.")
    aic: MaybeFloat = Field(None, description="AIC of the fit on the training part, once done.")
    heldout_rmse: MaybeFloat = Field(
        None,
        description="RMSE of the fitted model on the held-out samples, over every channel "
        "(computed once, when the job is done); null while it runs or when not finite.",
    )
    rank_bic: int | None = Field(None, description="1 = the lowest BIC among the jobs done.")
    rank_heldout: int | None = Field(
        None, description="1 = the lowest held-out RMSE among the jobs done."
    )


class ComparisonOut(BaseModel):
    """A comparison: the split of the data and one entry per model."""

    model_config = ANSWER

    id: str = Field(description="The comparison's id, as in its URL /comparisons/{id}.")
    created: str = Field(description="When it was accepted (ISO 8601, UTC).")
    source: str = Field(description="The uploaded file's name.")
    test_fraction: float = Field(description="The share of the samples held out.")
    seed: int = Field(description="The seed of the split (the fit's `seed` option).")
    n_train: int = Field(description="Samples the models were fitted to.")
    n_test: int = Field(description="Samples held out, on which `heldout_rmse` is computed.")
    done: bool = Field(description="Every job has finished (done, failed, interrupted...).")
    entries: list[EntryOut] = Field(description="One per model, in the order given.")


class ComparisonBrief(BaseModel):
    """A comparison in the list GET /comparisons: what it compares, without scores."""

    model_config = ANSWER

    id: str = Field(description="The comparison's id: GET /comparisons/{id}.")
    created: str = Field(description="When it was accepted (ISO 8601, UTC).")
    source: str = Field(description="The uploaded file's name.")
    models: list[str] = Field(description="The models compared, in the order given.")
    jobs: list[str] = Field(description="Their jobs, in the same order.")
