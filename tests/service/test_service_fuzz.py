"""Property-based fuzzing of the HTTP API from its own OpenAPI schema: no 5xx, ever.

schemathesis generates requests for every operation of ``/openapi.json``, both
valid ones and ones that break the schema (wrong types, missing fields, huge
numbers...), and checks that the service never answers a server error and that
its answers match the documented status codes and schemas. Bounded: a few
dozen examples per operation, fits limited to a fraction of a second.
"""

from __future__ import annotations

import pytest

schemathesis = pytest.importorskip(
    "schemathesis", reason="schemathesis is in the test extra: pip install -e '.[test]'"
)
from fastapi.testclient import TestClient  # noqa: E402
from hypothesis import HealthCheck, settings  # noqa: E402
from schemathesis.checks import (  # noqa: E402
    not_a_server_error,
    response_schema_conformance,
    status_code_conformance,
)

from brdffit_service import Settings, create_app  # noqa: E402

EXAMPLES = 15


@pytest.fixture(scope="module")
def api_schema(tmp_path_factory):
    settings_ = Settings(
        store_path=tmp_path_factory.mktemp("fuzz") / "jobs.sqlite3",
        workers=1,
        fit_workers=0,
        fit_timeout=0.3,
        job_timeout=1.0,
        max_samples=2000,
        fit_max_samples=500,
        max_body_bytes=200_000,
    )
    app = create_app(settings_)
    # Entering the client runs the lifespan (store, workers) that the routes need.
    with TestClient(app):
        yield schemathesis.openapi.from_asgi("/openapi.json", app)


schema = schemathesis.pytest.from_fixture("api_schema")


@schema.parametrize()
@settings(
    max_examples=EXAMPLES, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck)
)
def test_no_request_makes_a_server_error(case):
    case.call_and_validate(
        checks=[not_a_server_error, status_code_conformance, response_schema_conformance]
    )
