"""What handlers share, handed to them by FastAPI's ``Depends``.

The app's lifespan (:func:`brdffit_service.app.create_app`) makes one store, one job
runner and one pool of synchronous fits, and keeps them on the app; these
functions are the only place that looks them up, so a handler declares what it
needs by type (``store: StoreDep``) and a test can swap any of them through
``app.dependency_overrides``.
"""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Request

from .jobs import FitPool, JobRunner
from .settings import Settings
from .store import JobStore

__all__ = ["FitsDep", "RunnerDep", "SettingsDep", "StoreDep"]


def get_settings(request: Request) -> Settings:
    """The settings the app was built with."""
    return request.app.state.settings


def get_store(request: Request) -> JobStore:
    """The SQLite store of jobs."""
    return request.app.state.store


def get_runner(request: Request) -> JobRunner:
    """The runner that hands jobs to worker processes."""
    return request.app.state.runner


def get_fits(request: Request) -> FitPool:
    """The pool running synchronous fits (``POST /fit``)."""
    return request.app.state.fits


SettingsDep = Annotated[Settings, Depends(get_settings)]
StoreDep = Annotated[JobStore, Depends(get_store)]
RunnerDep = Annotated[JobRunner, Depends(get_runner)]
FitsDep = Annotated[FitPool, Depends(get_fits)]
