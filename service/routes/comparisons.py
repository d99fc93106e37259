"""``POST /comparisons/file``, ``GET /comparisons/{id}``: several models, one dataset.

What :func:`brdffit.compare` does in one call, as jobs the page (or any client)
can follow one by one: see :mod:`service.comparisons`. Each model's fit is an
ordinary job (``GET /jobs/{id}``: progress, result, plots); the comparison
answers the ranks by BIC and by held-out RMSE of the jobs done.
"""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Form, Query, Response

import brdffit

# Service internals, imported in this one place (issue 16).
from .. import artifacts
from ..comparisons import ComparisonStore, ranks
from ..convert import fit_kwargs, model_names, read_upload
from ..deps import RunnerDep, SettingsDep, StoreDep
from ..errors import ApiError
from ..schemas import ComparisonBrief, ComparisonOut, ErrorOut
from ..schemas.comparisons import DELETED
from ..store import data_to_bytes
from .common import ERRORS as FORM_ERRORS
from .common import FileField, FormatField, OptionsField, form_options, stored_options

__all__ = ["router"]

router = APIRouter(tags=["comparisons"])
MAX_MODELS = 12
ERRORS = {404: {"model": ErrorOut, "description": "No such comparison."}, **FORM_ERRORS}


ModelsField = Annotated[str, Form(max_length=2000, description="Model names: ward,ggx,blinn")]
FractionField = Annotated[
    float, Form(gt=0, le=0.9, allow_inf_nan=False, description="Share of samples held out.")
]


@router.post("/comparisons/file", status_code=202, response_model=ComparisonOut,
             responses=ERRORS)  # fmt: skip
def create_comparison(
    response: Response,
    settings: SettingsDep,
    store: StoreDep,
    runner: RunnerDep,
    file: FileField,
    models: ModelsField,
    format: FormatField = None,
    options: OptionsField = "{}",
    test_fraction: FractionField = 0.2,
):
    """Split the file's data (seeded by ``options.seed``), queue one job per model on the
    training part, keep the held-out part; answers 202 with the comparison."""
    names, fit_options = model_names(models, MAX_MODELS), form_options(options)
    data, notes = read_upload(file.file.read(), file.filename, format, None, None,
                              settings.max_samples)  # fmt: skip
    train, test = data.split(test_fraction, seed=fit_options.seed)
    kwargs = fit_kwargs(fit_options, settings.job_timeout)
    for name in names:  # bad options are a 422 now, not a failed job later
        brdffit.check_fit(train, name, **kwargs)
    blob = data_to_bytes(train)
    jobs = [store.create(name, stored_options(kwargs, fit_options.export), blob, notes)
            for name in names]  # fmt: skip
    source = file.filename or "upload"
    # Stored before the jobs are submitted: a worker done with its fit looks its
    # comparison up to score the fit on the held-out samples.
    comparison_id = ComparisonStore(store.path).create(
        source, names, [job["id"] for job in jobs], test, test_fraction, fit_options.seed,
        train.n,
    )  # fmt: skip
    for job in jobs:
        artifacts.want(store.path, job["id"])
        runner.submit(job["id"], job["attempt"])
    response.headers["Location"] = f"/comparisons/{comparison_id}"
    return _comparison(store, comparison_id)


@router.get("/comparisons", response_model=list[ComparisonBrief], responses=ERRORS)
def list_comparisons(store: StoreDep, limit: int = Query(20, ge=1, le=1000)):
    """The most recent comparisons, newest first."""
    return ComparisonStore(store.path).list(limit)


@router.get("/comparisons/{comparison_id}", response_model=ComparisonOut, responses=ERRORS)
def get_comparison(comparison_id: str, store: StoreDep):
    """Each model's job status, BIC, held-out RMSE and ranks (among the jobs done)."""
    return _comparison(store, comparison_id)


def _comparison(store, comparison_id: str) -> dict:
    comparisons = ComparisonStore(store.path)
    row = comparisons.get(comparison_id)
    if row is None:
        raise ApiError(404, f"there is no comparison {comparison_id!r}", "id")
    entries = []
    for name, job_id in zip(row["models"], row["jobs"]):
        job = store.get(job_id)
        entry = {"model": name, "job": job_id, "status": job["status"] if job else DELETED,
                 "bic": None, "aic": None, "heldout_rmse": None}  # fmt: skip
        result = (job or {}).get("result")
        if result:
            entry["bic"], entry["aic"] = result["metrics"].get("bic"), result["metrics"].get("aic")
            attempt, rmse = row["scores"].get(job_id, (None, None))
            if attempt != job["attempt"]:  # not scored by its worker (an older comparison)
                rmse = comparisons.score(job_id, job["attempt"], name, result["params"],
                                         comparison_id)  # fmt: skip
            entry["heldout_rmse"] = rmse
        entries.append(entry)
    for key, rank in (("bic", "rank_bic"), ("heldout_rmse", "rank_heldout")):
        for entry, r in zip(entries, ranks([e.get(key) for e in entries])):
            entry[rank] = r
    done = not any(e["status"] in ("queued", "running") for e in entries)
    fields = {k: row[k] for k in ComparisonOut.model_fields if k in row}
    return {**fields, "done": done, "entries": entries}
