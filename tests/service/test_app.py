"""The app as a whole: health, OpenAPI, unknown routes, body limits, JSON errors, bugs."""

from __future__ import annotations

import json

from fastapi.testclient import TestClient
from service_helpers import BODY_LIMIT, assert_error

import brdffit
from brdffit_service import Settings, create_app
from brdffit_service.schemas import EXAMPLE_DATA


def test_health_counts_jobs_by_status(client):
    body = client.get("/health").json()
    assert body["status"] == "ok" and body["version"] == brdffit.__version__
    assert body["workers"] == 1
    assert set(body["jobs"]) == {"queued", "running", "done", "failed", "interrupted", "cancelled"}


def test_openapi_lists_every_route_with_examples(client):
    spec = client.get("/openapi.json").json()
    paths = set(spec["paths"])
    assert paths >= {
        "/health",
        "/models",
        "/models/{name}",
        "/evaluate",
        "/fit",
        "/fit/file",
        "/jobs",
        "/jobs/file",
        "/jobs/{job_id}",
        "/jobs/{job_id}/resubmit",
    }
    fit_in = spec["components"]["schemas"]["FitIn"]
    assert fit_in["examples"][0]["model"] == "blinn"
    assert client.get("/docs").status_code == 200


def test_unknown_route_and_method_answer_json(client):
    assert_error(client.get("/nowhere"), 404)
    assert_error(client.delete("/health"), 405)


def test_oversized_bodies_get_413_with_or_without_a_length(client):
    big = json.dumps({"model": "lambert", "data": EXAMPLE_DATA | {"source": "x" * BODY_LIMIT}})
    headers = {"content-type": "application/json"}
    assert_error(client.post("/fit", content=big, headers=headers), 413, "body", "larger")

    def chunks():
        for _ in range(BODY_LIMIT // 10_000 + 2):
            yield b" " * 10_000

    assert_error(client.post("/fit", content=chunks(), headers=headers), 413, "body")


def test_malformed_json_is_a_422_naming_the_body(client):
    answer = client.post("/fit", content=b"{oops", headers={"content-type": "application/json"})
    assert_error(answer, 422, "body", "not valid JSON")


def test_a_bug_answers_a_json_500(store_path):
    app = create_app(Settings(store_path=store_path, workers=1, fit_workers=0))

    def broken():
        raise RuntimeError("secret detail 42")

    app.add_api_route("/broken", broken)
    with TestClient(app, raise_server_exceptions=False) as c:
        body = assert_error(c.get("/broken"), 500, None, "internal error")
        assert body["kind"] == "InternalError" and "secret detail" not in body["message"]
