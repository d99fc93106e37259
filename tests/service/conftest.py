"""The app shared by the service tests: one store and one job worker for the session."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient
from service_helpers import BODY_LIMIT, FIT_LIMIT, FIT_TIMEOUT

from brdffit_service import Settings, create_app


@pytest.fixture(scope="session")
def store_path(tmp_path_factory):
    return tmp_path_factory.mktemp("service") / "jobs.sqlite3"


@pytest.fixture(scope="session")
def client(store_path):
    # Synchronous fits on the web process's threads (the default); the worker
    # processes that BRDFFIT_FIT_WORKERS asks for are exercised by test_fit_pool_*.
    settings = Settings(
        store_path=store_path,
        workers=1,
        fit_workers=0,
        fit_max_samples=FIT_LIMIT,
        max_body_bytes=BODY_LIMIT,
        fit_timeout=FIT_TIMEOUT,
        job_timeout=30.0,
    )
    with TestClient(create_app(settings), raise_server_exceptions=False) as c:
        yield c
