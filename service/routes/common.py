"""What the routes share: documented error answers, the upload form's fields."""

from __future__ import annotations

from typing import Annotated

from fastapi import File, Form, UploadFile
from fastapi.exceptions import RequestValidationError
from pydantic import ValidationError

from ..schemas import ErrorOut, FitOptions

__all__ = [
    "ERRORS",
    "NOT_FOUND",
    "SERVER_ERRORS",
    "ChannelsField",
    "FileField",
    "FormatField",
    "ModelField",
    "OptionsField",
    "SubsampleField",
    "form_options",
]

SERVER_ERRORS = {
    400: {"model": ErrorOut, "description": "A body that cannot be read at all."},
    500: {"model": ErrorOut, "description": "A bug (logged)."},
}
ERRORS = {
    413: {"model": ErrorOut, "description": "The body is larger than the server takes."},
    422: {"model": ErrorOut, "description": "Input that cannot be used; `field` says which."},
}
NOT_FOUND = {404: {"model": ErrorOut, "description": "No such model or job."}}

FILE_DOC = "The data file: CSV, ASTM, pbrt .brdf, MERL .binary, MBSDF, RGL .bsdf or NPZ."
FORMAT_DOC = "The file's format when its name and first bytes do not tell."
OPTIONS_DOC = "The options of the fit as a JSON object (FitOptions)."
FileField = Annotated[UploadFile, File(description=FILE_DOC)]
ModelField = Annotated[str, Form(max_length=500, description="A model name or a sum.")]
FormatField = Annotated[str | None, Form(max_length=20, description=FORMAT_DOC)]
SubsampleField = Annotated[int | None, Form(ge=1, le=10**6, description="MERL: every n-th.")]
ChannelsField = Annotated[str | None, Form(max_length=2000, description="Channels: a,b,c")]
OptionsField = Annotated[str, Form(max_length=100_000, description=OPTIONS_DOC)]


def form_options(options: str) -> FitOptions:
    """The form field ``options`` (JSON) as FitOptions; its errors are under ``options.``."""
    try:
        return FitOptions.model_validate_json(options or "{}")
    except ValidationError as exc:
        errors = [_not_json(e, options) if e["type"] == "json_invalid" else
                  {**e, "loc": ("options", *e["loc"])} for e in exc.errors()]  # fmt: skip
        raise RequestValidationError(errors) from None


def _not_json(error: dict, options: str) -> dict:
    """The error of an ``options`` field that is not JSON (not of the request's body)."""
    value = options if len(options) <= 60 else options[:57] + "..."
    reason = (error.get("ctx") or {}).get("error", "malformed")
    message = (f"{value!r} is not valid JSON ({reason}); give a JSON object of fit options, "
               'such as {"seed": 3}')  # fmt: skip
    return {"type": "options_not_json", "loc": ("options",), "msg": message}


def stored_options(kwargs: dict, export) -> dict:
    """What a job stores: the fit's keyword arguments and, when asked, the export targets
    its worker makes after the fit (``POST /jobs``, ``/batches``, ``/comparisons``)."""
    return {**kwargs, "export": list(export)} if export else kwargs
