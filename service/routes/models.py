"""``GET /models`` and ``GET /models/{name}``: the registry, ``Model.to_dict()``."""

from __future__ import annotations

from functools import lru_cache
from typing import Literal

from fastapi import APIRouter, Query

import brdffit
from brdffit.errors import ModelError
from brdffit.jsonable import jsonable
from brdffit.models import REGISTRY
from brdffit.models.base import HIGHLIGHTS, OPERANDS, ORIGINS, SYMMETRIES
from brdffit.models.properties import model_properties

from ..errors import ApiError
from ..schemas import ModelOut
from .common import ERRORS, NOT_FOUND

__all__ = ["router"]

router = APIRouter(tags=["models"])
PROPERTIES_DOC = "Add the measured albedo and reciprocity (model_properties)."


@lru_cache(maxsize=256)
def _registered_properties(name: str) -> dict:
    return jsonable(model_properties(REGISTRY[name]))


def _model_out(model, properties: bool) -> dict:
    out = model.to_dict()
    if properties:
        registered = model.name in REGISTRY  # a sum of lobes is measured each time
        out["properties"] = (
            _registered_properties(model.name) if registered else jsonable(model_properties(model))
        )
    return out


@router.get("/models", response_model=list[ModelOut], responses=ERRORS)
def list_models(
    origin: Literal[ORIGINS] | None = None,  # type: ignore[valid-type]
    symmetry: Literal[SYMMETRIES] | None = None,  # type: ignore[valid-type]
    operand: Literal[OPERANDS] | None = None,  # type: ignore[valid-type]
    highlight: Literal[HIGHLIGHTS] | None = None,  # type: ignore[valid-type]
    wave_optics: bool | None = None,
    properties: bool = Query(False, description=PROPERTIES_DOC),
):
    """``brdffit.list_models(**filters)``: the models whose classification matches."""
    filters = dict(origin=origin, symmetry=symmetry, operand=operand, highlight=highlight,
                   wave_optics=wave_optics)  # fmt: skip
    models = brdffit.list_models(**{k: v for k, v in filters.items() if v is not None})
    return [_model_out(m, properties) for m in models]


@router.get("/models/{name}", response_model=ModelOut, responses={**ERRORS, **NOT_FOUND})
def get_model(name: str, properties: bool = Query(False, description=PROPERTIES_DOC)):
    """``brdffit.get_model(name).to_dict()``; a sum of lobes (``lambert+blinn``) works too."""
    try:
        model = brdffit.get_model(name)
    except ModelError as exc:
        raise ApiError(404, str(exc), "name") from None
    return _model_out(model, properties)
