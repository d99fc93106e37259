"""The FastAPI application: ``create_app(settings)``.

Run it with ``brdffit serve`` (or ``uvicorn brdffit_service.app:app``, which reads
the settings from the environment; the folder ``service/`` installs as the package
``brdffit_service``). This module only wires the parts: the routes
(:mod:`brdffit_service.routes`, one module per resource), the shared state handed to
them (:mod:`brdffit_service.deps`), the error handlers (:mod:`brdffit_service.errors`) and
the body-size limit (:mod:`brdffit_service.middleware`).
"""

from __future__ import annotations

import json
from contextlib import asynccontextmanager

from fastapi import FastAPI

import brdffit

from .dask_runner import runner_for
from .errors import install_handlers
from .jobs import FitPool
from .lock import StoreLock
from .middleware import BodyLimit
from .routes import router
from .routes.docs import router as docs_router
from .routes.web import routers as web_routers
from .security import TokenAuth
from .settings import Settings
from .store import JobStore

__all__ = ["create_app"]

DESCRIPTION = """
Fit analytic BRDF models to measured reflectance, with uncertainties.

Angles are in degrees (theta from the normal, phi the azimuth). Short fits run
synchronously on `POST /fit`, within the server's limits of samples and
seconds; long fits and posteriors run as jobs (`POST /jobs`), stored in SQLite:
a restart keeps every result, and marks the jobs it cut short `interrupted`
(`POST /jobs/{id}/resubmit` runs them again). `POST /jobs/{id}/cancel` stops a
job and keeps it, `cancelled`; `DELETE /jobs/{id}` deletes it. Files (CSV, ASTM,
MERL, pbrt, MBSDF, RGL, NPZ) are uploaded to `POST /fit/file` and
`POST /jobs/file`. A server with an API token (`BRDFFIT_API_TOKEN`) asks for it
as `Authorization: Bearer <token>` on every route but `/health`.
"""

TAGS = [
    {"name": "models", "description": "The registry of reflectance models."},
    {"name": "fit", "description": "Evaluate models and fit them, synchronously."},
    {"name": "jobs", "description": "Long fits and posteriors, stored durably."},
    {
        "name": "comparisons",
        "description": "Several models fitted to one file and ranked on held-out samples.",
    },
    {"name": "export", "description": "Fitted materials written for renderers."},
    {"name": "examples", "description": "The example measurement files of the web page."},
    {"name": "service", "description": "Health of the service."},
]


def _lifespan(settings: Settings):
    @asynccontextmanager
    async def lifespan(app: FastAPI):
        # One server per store (lock.py): recovery marks running jobs interrupted.
        lock = StoreLock(settings.store_path).acquire()
        try:
            store = JobStore(settings.store_path)
            runner = runner_for(store, settings.workers, settings.scheduler)
            fits = FitPool(settings.fit_workers)
            app.state.store, app.state.runner, app.state.fits = store, runner, fits
            for job_id, attempt in store.recover():
                runner.submit(job_id, attempt)
            try:
                yield
            finally:
                runner.close()
                fits.close()
        finally:
            lock.release()

    return lifespan


def _error_schema_for_422(app: FastAPI) -> None:
    """Document every 422 as what it is, :class:`~brdffit_service.schemas.ErrorOut`.

    FastAPI documents its own ``HTTPValidationError`` for each route with a
    parameter and no 422 of its own (the ``/jobs/{id}`` routes...); the service's
    handler (:mod:`.errors`) answers ErrorOut for every one of them."""
    generate = app.openapi

    def openapi() -> dict:
        if app.openapi_schema is None:
            spec = generate()
            for operations in spec.get("paths", {}).values():
                for operation in operations.values():
                    answer = operation.get("responses", {}).get("422")
                    if answer and "HTTPValidationError" in json.dumps(answer):
                        schema = {"$ref": "#/components/schemas/ErrorOut"}
                        answer["content"] = {"application/json": {"schema": schema}}
                        answer["description"] = "Input that cannot be used; `field` says which."
            schemas = spec.get("components", {}).get("schemas", {})
            for name in ("HTTPValidationError", "ValidationError"):
                schemas.pop(name, None)
            if app.state.settings.api_token is not None:
                _bearer(spec)
            app.openapi_schema = spec
        return app.openapi_schema

    app.openapi = openapi


def _bearer(spec: dict) -> None:
    """Say in the OpenAPI document that the routes want the API token (security.py),
    so that /docs offers to enter it ("Authorize")."""
    scheme = {"type": "http", "scheme": "bearer", "description": "BRDFFIT_API_TOKEN"}
    spec.setdefault("components", {})["securitySchemes"] = {"token": scheme}
    spec["security"] = [{"token": []}]
    for operation in spec.get("paths", {}).get("/health", {}).values():
        operation["security"] = []


def create_app(settings: Settings | None = None) -> FastAPI:
    """The service, with its store of jobs at ``settings.store_path``."""
    settings = settings or Settings.from_env()
    app = FastAPI(
        title="brdffit",
        version=brdffit.__version__,
        description=DESCRIPTION,
        lifespan=_lifespan(settings),
        openapi_tags=TAGS,
        docs_url=None,  # served from the package by routes/docs.py (no CDN)
        redoc_url=None,
    )
    app.state.settings = settings
    app.include_router(router)
    install_handlers(app)
    for web_router in web_routers:  # the page at / and its routes
        app.include_router(web_router)
    app.include_router(docs_router)
    _error_schema_for_422(app)
    app.add_middleware(BodyLimit, max_bytes=settings.max_body_bytes)
    app.add_middleware(TokenAuth, settings=settings)  # outermost: before reading any body
    return app


def __getattr__(name: str):
    # ``uvicorn brdffit_service.app:app`` builds the app from the environment when asked.
    if name == "app":
        return create_app()
    raise AttributeError(name)
