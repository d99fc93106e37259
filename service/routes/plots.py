"""``GET /jobs/{id}/plot.png`` and ``GET /jobs/{id}/corner.png``: a job's pictures.

The fit plot of any job that is done, drawn at the first request and kept; the
corner plot, drawn by the worker of a job of ``POST /comparisons/file``
(:mod:`service.artifacts`).
"""

from __future__ import annotations

from fastapi import APIRouter, Response

from .. import artifacts
from ..deps import StoreDep
from ..errors import ApiError
from ..schemas import ErrorOut

__all__ = ["router"]

router = APIRouter(tags=["jobs"])
PNG = {200: {"content": {"image/png": {}}, "description": "A PNG image."}}
MISSING = {404: {"model": ErrorOut, "description": "No such job, or no such plot (yet)."}}


@router.get("/jobs/{job_id}/plot.png", response_class=Response, responses={**PNG, **MISSING})
def job_fit_plot(job_id: str, store: StoreDep):
    """The fit (planes of incidence, measured and fitted, and the residuals) of a job
    that is done."""
    return _plot(store, job_id, "plot.png")


@router.get("/jobs/{job_id}/corner.png", response_class=Response, responses={**PNG, **MISSING})
def job_corner_plot(job_id: str, store: StoreDep):
    """The posterior's corner plot, for the jobs of a comparison that sampled it."""
    return _plot(store, job_id, "corner.png")


def _plot(store, job_id: str, name: str) -> Response:
    job = store.get(job_id)
    if job is None:
        artifacts.forget(store.path, job_id)
        raise ApiError(404, f"there is no job {job_id!r} (it may have been deleted)", "id")
    done = job["status"] == "done"
    if name == "plot.png":
        png = artifacts.fit_plot(store.path, job) if done else None
    else:
        png = artifacts.load(store.path, job_id, name)
    if png is None:
        if job["status"] in ("queued", "running"):
            why = f"job {job_id} is {job['status']}; its plots can be drawn once it is done"
        elif name == "corner.png" and done and not job["result"].get("posterior"):
            why = f"job {job_id} has no corner plot: it did not sample the posterior"
        elif name == "corner.png" and done:
            why = (f"job {job_id} has no corner plot: its worker draws one only for the jobs "
                   "of POST /comparisons/file (the web page)")  # fmt: skip
        else:
            why = f"job {job_id} ({job['status']}) has no {name}"
        raise ApiError(404, why, "name")
    return Response(png, media_type="image/png", headers={"Cache-Control": "max-age=3600"})
