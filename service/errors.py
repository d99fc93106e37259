"""Every error answer of the service, from one set of exception handlers.

Every error answers with :class:`~brdffit_service.schemas.ErrorOut`:

- a library error (:class:`brdffit.BrdfFitError`) -> 422, naming its ``field``;
- a body that does not match its schema -> 422, naming every field;
- an :class:`ApiError` of a route (not found, conflict...) -> its status;
- a body larger than ``max_body_bytes`` -> 413 (:mod:`brdffit_service.middleware`);
- anything else is a bug: logged with its traceback, answered with a JSON 500.
"""

from __future__ import annotations

import logging

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from pydantic import ValidationError
from starlette.exceptions import HTTPException

from brdffit.errors import BrdfFitError

__all__ = ["ApiError", "KINDS", "error_body", "error_response", "install_handlers"]

log = logging.getLogger("brdffit.service")

KINDS = {404: "NotFound", 405: "MethodNotAllowed", 409: "Conflict", 413: "TooLarge",
         503: "Unavailable"}  # fmt: skip
UNREADABLE = "There was an error parsing the body"


class ApiError(HTTPException):
    """An answer with a status, the field at fault and a sentence."""

    def __init__(self, status: int, message: str, field: str | None = None, kind: str = ""):
        super().__init__(status, message)
        self.field = field
        self.kind = kind or KINDS.get(status, "HTTPError")


def error_body(message: str, field: str | None, kind: str, errors=None) -> dict:
    """The JSON of :class:`~brdffit_service.schemas.ErrorOut`."""
    items = errors if errors is not None else [{"field": field, "message": message}]
    return {"field": field, "message": message, "kind": kind, "errors": items}


def error_response(status: int, body: dict, headers=None) -> JSONResponse:
    return JSONResponse(status_code=status, content=body, headers=headers)


def _validation_item(err: dict) -> dict:
    if err.get("type") == "json_invalid":
        where = err.get("loc", ("body", "?"))[-1]
        reason = (err.get("ctx") or {}).get("error", "malformed")
        message = f"the body is not valid JSON: {reason} at character {where}"
        return {"field": "body", "message": message}
    loc = [str(part) for part in err.get("loc", ())]
    if loc and loc[0] in ("body", "query", "path", "form"):
        loc = loc[1:] or loc
    return {"field": ".".join(loc) or None, "message": str(err.get("msg", ""))}


async def library_error(request: Request, exc: BrdfFitError) -> JSONResponse:
    """A library error: 422, under the field the library names."""
    return error_response(422, error_body(str(exc), exc.field, type(exc).__name__))


async def request_invalid(request: Request, exc: RequestValidationError | ValidationError):
    """A body, query or form that does not match its schema: 422 naming every field."""
    items = [_validation_item(err) for err in exc.errors()]
    first = items[0] if items else {"field": None, "message": "the request is not valid"}
    message = f"{first['field']}: {first['message']}" if first["field"] else first["message"]
    return error_response(422, error_body(message, first["field"], "ValidationError", items))


async def http_error(request: Request, exc: HTTPException) -> JSONResponse:
    """An :class:`ApiError` of a route, or Starlette's own (404, 405, unreadable body)."""
    if exc.status_code == 400 and exc.detail == UNREADABLE:
        message = "the body cannot be read: JSON must be UTF-8 text, a form must be well-formed"
        return error_response(400, error_body(message, "body", "HTTPError"))
    field = getattr(exc, "field", None)
    kind = getattr(exc, "kind", None) or KINDS.get(exc.status_code, "HTTPError")
    body = error_body(str(exc.detail), field, kind)
    return error_response(exc.status_code, body, getattr(exc, "headers", None))


async def bug(request: Request, exc: Exception) -> JSONResponse:
    """Anything else: a bug of the service, logged with its traceback, never shown."""
    log.exception("internal error on %s %s", request.method, request.url.path)
    message = "internal error: this is a bug of the service; it has been logged"
    return error_response(500, error_body(message, None, "InternalError"))


def install_handlers(app: FastAPI) -> None:
    """Route every error of ``app`` through the handlers above."""
    app.add_exception_handler(BrdfFitError, library_error)
    app.add_exception_handler(RequestValidationError, request_invalid)
    app.add_exception_handler(ValidationError, request_invalid)
    app.add_exception_handler(HTTPException, http_error)
    app.add_exception_handler(Exception, bug)
