"""``POST /export``: a fitted material as a renderer's material, with its error.

The body holds a fit result (``FitResult.to_dict()``, or just its model, params
and channels), the target, and optionally the data: see
:func:`brdffit.export`. The answer is ``Export.to_dict()``.
"""

from __future__ import annotations

from fastapi import APIRouter
from pydantic import BaseModel, ConfigDict, Field

import brdffit

from ..convert import located, measurements
from ..deps import SettingsDep
from ..schemas import DataIn
from ..schemas.requests import ExportTarget as Target
from ..schemas.results import ExportOut
from .common import ERRORS

__all__ = ["router", "ExportIn", "ExportOut"]

router = APIRouter(tags=["export"])


class FittedMaterialIn(BaseModel):
    """A fit result: the ``to_dict()`` of :func:`brdffit.fit` (the answer of
    ``POST /fit``) or only its ``model``, ``params`` and ``channels``."""

    model_config = ConfigDict(extra="allow")

    model: str = Field(description="The fitted model, a registered name or a sum of lobes.")
    params: dict[str, float | list[float]] = Field(
        description="Every parameter of the model: a number, or one per channel."
    )
    channels: list[str] | None = Field(None, description="Channel names (r, g, b...).")


class ExportIn(BaseModel):
    """The body of ``POST /export``: :func:`brdffit.export` (result, target, data)."""

    model_config = ConfigDict(extra="forbid")

    result: FittedMaterialIn
    target: Target = Field(description="The renderer (GET /export/targets lists them).")
    data: DataIn | None = Field(
        None,
        description="Measurements: approximate exports are fitted to them, and the error "
        "is measured on their directions (default: on the fitted BRDF).",
    )


@router.get("/export/targets", response_model=dict[str, str])
def export_targets():
    """``brdffit.export_targets()``: target name -> what its document is."""
    return brdffit.export_targets()


@router.post("/export", response_model=ExportOut, responses=ERRORS)
def export(body: ExportIn, settings: SettingsDep):
    """``brdffit.export(result, target, data)``."""
    data = None
    if body.data is not None:
        data, _ = measurements(body.data, settings.fit_max_samples)
    with located("result", {"model"}):
        model = brdffit.get_model(body.result.model)
    with located("result.params", set(model.param_names) | set(body.result.params)):
        out = brdffit.export(body.result.model_dump(), body.target, data=data)
    return out.to_dict()
