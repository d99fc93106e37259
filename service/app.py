"""The FastAPI application: ``create_app(settings)``.

Run it with ``brdffit serve`` (or ``uvicorn service.app:app``, which reads the
settings from the environment). The routes are in :mod:`service.routes`; this
module wires the store of jobs, the executor, the body-size limit and the
error handlers. Every error answers with :class:`~service.schemas.ErrorOut`:

- a library error (:class:`brdffit.BrdfFitError`) -> 422, naming its ``field``;
- a body that does not match its schema -> 422, naming every field;
- a body larger than ``max_body_bytes`` -> 413; an unknown route or job -> 404;
- anything else is a bug: logged with its traceback, answered with a JSON 500.
"""

from __future__ import annotations

import logging
from contextlib import asynccontextmanager

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from pydantic import ValidationError
from starlette.exceptions import HTTPException

import brdffit
from brdffit.errors import BrdfFitError

from .batches import router as batches_router
from .errors import KINDS, ApiError
from .jobs import FitPool, JobRunner
from .routes import router
from .settings import Settings
from .store import JobStore

__all__ = ["ApiError", "BodyLimit", "create_app"]

log = logging.getLogger("brdffit.service")

DESCRIPTION = """
Fit analytic BRDF models to measured reflectance, with uncertainties.

Angles are in degrees (theta from the normal, phi the azimuth). Short fits run
synchronously on `POST /fit`, within the server's limits of samples and
seconds; long fits and posteriors run as jobs (`POST /jobs`), stored in SQLite:
a restart keeps every result, and marks the jobs it cut short `interrupted`
(`POST /jobs/{id}/resubmit` runs them again). Files (CSV, ASTM, MERL, pbrt,
MBSDF, NPZ) are uploaded to `POST /fit/file` and `POST /jobs/file`.
"""


def error_body(message: str, field: str | None, kind: str, errors=None) -> dict:
    items = errors if errors is not None else [{"field": field, "message": message}]
    return {"field": field, "message": message, "kind": kind, "errors": items}


def _json(status: int, body: dict, headers=None) -> JSONResponse:
    return JSONResponse(status_code=status, content=body, headers=headers)


def _validation_items(errors) -> list[dict]:
    items = []
    for err in errors:
        if err.get("type") == "json_invalid":
            where = err.get("loc", ("body", "?"))[-1]
            reason = (err.get("ctx") or {}).get("error", "malformed")
            items.append({"field": "body", "message": f"the body is not valid JSON: {reason} "
                          f"at character {where}"})  # fmt: skip
            continue
        loc = [str(part) for part in err.get("loc", ())]
        if loc and loc[0] in ("body", "query", "path", "form"):
            loc = loc[1:] or loc
        items.append({"field": ".".join(loc) or None, "message": str(err.get("msg", ""))})
    return items


async def _library_error(request: Request, exc: BrdfFitError):
    return _json(422, error_body(str(exc), exc.field, type(exc).__name__))


async def _request_invalid(request: Request, exc: RequestValidationError | ValidationError):
    items = _validation_items(exc.errors())
    first = items[0] if items else {"field": None, "message": "the request is not valid"}
    message = f"{first['field']}: {first['message']}" if first["field"] else first["message"]
    return _json(422, error_body(message, first["field"], "ValidationError", items))


async def _http_error(request: Request, exc: HTTPException):
    field = getattr(exc, "field", None)
    if exc.status_code == 400 and exc.detail == "There was an error parsing the body":
        message = "the body cannot be read: JSON must be UTF-8 text, a form must be well-formed"
        return _json(400, error_body(message, "body", "HTTPError"))
    kind = getattr(exc, "kind", None) or KINDS.get(exc.status_code, "HTTPError")
    return _json(
        exc.status_code, error_body(str(exc.detail), field, kind), getattr(exc, "headers", None)
    )


async def _bug(request: Request, exc: Exception):
    log.exception("internal error on %s %s", request.method, request.url.path)
    message = "internal error: this is a bug of the service; it has been logged"
    return _json(500, error_body(message, None, "InternalError"))


class _TooLarge(ApiError):
    def __init__(self, limit: int):
        super().__init__(413, f"the request body is larger than {limit} bytes, this server's "
                         "limit (BRDFFIT_MAX_BODY_BYTES)", "body")  # fmt: skip


class BodyLimit:
    """ASGI middleware: refuse bodies above ``max_bytes`` with 413, whether they
    announce their length or stream it (the count stops reading at the limit)."""

    def __init__(self, app, max_bytes: int):
        self.app, self.max_bytes = app, max_bytes

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        headers = dict(scope.get("headers") or ())
        length = headers.get(b"content-length")
        if length is not None:
            if not length.isdigit():
                body = error_body("the Content-Length header is not a number", "content-length",
                                  "HTTPError")  # fmt: skip
                return await _json(400, body)(scope, receive, send)
            if int(length) > self.max_bytes:
                exc = _TooLarge(self.max_bytes)
                return await _json(413, error_body(exc.detail, "body", exc.kind))(
                    scope, receive, send
                )
        received = 0

        async def counted():
            nonlocal received
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > self.max_bytes:
                    raise _TooLarge(self.max_bytes)
            return message

        started = False

        async def watched(message):
            nonlocal started
            started = started or message["type"] == "http.response.start"
            await send(message)

        try:
            await self.app(scope, counted, watched)
        except _TooLarge as exc:
            if started:
                raise
            await _json(413, error_body(exc.detail, "body", exc.kind))(scope, receive, send)


def create_app(settings: Settings | None = None) -> FastAPI:
    """The service, with its store of jobs at ``settings.store_path``."""
    settings = settings or Settings.from_env()

    @asynccontextmanager
    async def lifespan(app: FastAPI):
        store = JobStore(settings.store_path)
        runner = JobRunner(store, settings.workers)
        app.state.store, app.state.runner = store, runner
        app.state.fits = FitPool(settings.fit_workers)
        for job_id, attempt in store.recover():
            runner.submit(job_id, attempt)
        try:
            yield
        finally:
            runner.close()
            app.state.fits.close()

    app = FastAPI(
        title="brdffit",
        version=brdffit.__version__,
        description=DESCRIPTION,
        lifespan=lifespan,
        openapi_tags=[
            {"name": "models", "description": "The registry of reflectance models."},
            {"name": "fit", "description": "Evaluate models and fit them, synchronously."},
            {"name": "jobs", "description": "Long fits and posteriors, stored durably."},
            {"name": "service", "description": "Health of the service."},
        ],
    )
    app.state.settings = settings
    app.include_router(router)
    app.include_router(batches_router)
    app.add_exception_handler(BrdfFitError, _library_error)
    app.add_exception_handler(RequestValidationError, _request_invalid)
    app.add_exception_handler(ValidationError, _request_invalid)
    app.add_exception_handler(HTTPException, _http_error)
    app.add_exception_handler(Exception, _bug)
    app.add_middleware(BodyLimit, max_bytes=settings.max_body_bytes)
    return app


def __getattr__(name: str):
    # ``uvicorn service.app:app`` builds the app from the environment when asked.
    if name == "app":
        return create_app()
    raise AttributeError(name)
