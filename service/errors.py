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
import re
import sys

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
#: The member of a union type that pydantic puts in an error's location
#: (``data.values.list[float].0``): the type, not a field of the request.
UNION_TAG = re.compile(r"(float|int|str|bool|(list|dict|literal|function-\w+)\[.*\])")
#: Starts of the details of Starlette's 400s for a multipart form it cannot parse.
FORM_FAULTS = ("Invalid multipart", "Part exceeded", "Too many", "Missing boundary")
#: About the longest file name a multipart part header takes (python-multipart's
#: limit on a header line, 4,224 bytes, less the rest of Content-Disposition).
MAX_NAME = 4000


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
    loc = [str(part) for part in err.get("loc", ()) if not UNION_TAG.fullmatch(str(part))]
    if loc and loc[0] in ("body", "query", "path", "form"):
        loc = loc[1:] or loc
    message = str(err.get("msg", ""))
    if "Expected UploadFile" in message:  # a form field sent as text, not as a file
        message = (f"must be a file, sent as a multipart part with a file name, not as text "
                   f"(curl -F {loc[0] if loc else 'file'}=@data.csv)")  # fmt: skip
    return {"field": ".".join(loc) or None, "message": message}


async def library_error(request: Request, exc: BrdfFitError) -> JSONResponse:
    """A library error: 422, under the field the library names."""
    return error_response(422, error_body(str(exc), exc.field, type(exc).__name__))


async def request_invalid(request: Request, exc: RequestValidationError | ValidationError):
    """A body, query or form that does not match its schema: 422 naming every field."""
    by_field: dict = {}  # per field the first problem (a union's members each add one)
    for item in map(_validation_item, exc.errors()):
        by_field.setdefault(item["field"], item)
    items = list(by_field.values())
    first = items[0] if items else {"field": None, "message": "the request is not valid"}
    message = f"{first['field']}: {first['message']}" if first["field"] else first["message"]
    return error_response(422, error_body(message, first["field"], "ValidationError", items))


async def http_error(request: Request, exc: HTTPException) -> JSONResponse:
    """An :class:`ApiError` of a route, or Starlette's own (404, 405, unreadable body)."""
    if exc.status_code == 400 and exc.detail == UNREADABLE:
        return error_response(400, error_body(_unreadable(exc), "body", "HTTPError"))
    form_fault = _form_fault(exc)
    if exc.status_code == 400 and form_fault is not None:
        return error_response(400, error_body(*form_fault, "HTTPError"))
    field = getattr(exc, "field", None)
    kind = getattr(exc, "kind", None) or KINDS.get(exc.status_code, "HTTPError")
    body = error_body(str(exc.detail), field, kind)
    return error_response(exc.status_code, body, getattr(exc, "headers", None))


def _unreadable(exc: HTTPException) -> str:
    """Why FastAPI could not parse a body (its 400 says only "There was an error
    parsing the body"; the parser's own error is the exception's cause)."""
    cause = exc.__cause__ or exc.__context__
    if isinstance(cause, RecursionError):
        return ("the body cannot be read: its JSON is nested deeper than this server "
                "reads (about 1,000 levels); send flat arrays of numbers")  # fmt: skip
    if isinstance(cause, ValueError) and "integer string conversion" in str(cause):
        digits = sys.get_int_max_str_digits()
        return (f"the body cannot be read: a whole number in its JSON has more than {digits} "
                "digits; no field takes one that large")  # fmt: skip
    return "the body cannot be read: JSON must be UTF-8 text, a form must be well-formed"


def _form_fault(exc: HTTPException) -> tuple[str, str] | None:
    """(message, field) of a multipart form the parser refused (Starlette answers a bare
    "Invalid multipart data."; the parser's own error is in the exception's context)."""
    cause, seen = exc.__context__, 0
    while cause is not None and seen < 5:
        if type(cause).__module__.split(".")[0] in ("python_multipart", "multipart"):
            reason = str(cause)
            if "header" in reason.lower():
                return (f"the upload form cannot be read: {reason} in a part's headers, "
                        f"most likely a file name too long (at most {MAX_NAME} characters): "
                        "send the file under a shorter name", "file")  # fmt: skip
            return f"the upload form cannot be read: {reason}", "body"
        cause, seen = cause.__cause__ or cause.__context__, seen + 1
    if str(exc.detail).startswith(FORM_FAULTS):
        return f"the upload form cannot be read: {exc.detail}", "body"
    return None


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
