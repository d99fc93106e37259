"""The app as a whole: health, OpenAPI, unknown routes, body limits, JSON errors, bugs."""

from __future__ import annotations

import json
import re

from fastapi.testclient import TestClient
from service_helpers import BODY_LIMIT, assert_error

import brdffit
from brdffit_service import Settings, create_app
from brdffit_service.routes.docs import SWAGGER_UI_VERSION
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


def test_every_422_is_documented_as_the_error_schema(client):
    """The handler answers ErrorOut for every 422; FastAPI documented its own
    HTTPValidationError for the routes with a path parameter (/jobs/{id}...)."""
    spec = client.get("/openapi.json").json()
    documented = 0
    for path, operations in spec["paths"].items():
        for method, operation in operations.items():
            answer = operation["responses"].get("422")
            if answer is not None:
                schema = answer["content"]["application/json"]["schema"]
                assert schema == {"$ref": "#/components/schemas/ErrorOut"}, (method, path)
                documented += 1
    assert documented >= 15
    for route in ("/jobs/{job_id}", "/jobs/{job_id}/resubmit", "/jobs/{job_id}/cancel"):
        assert all("422" in op["responses"] for op in spec["paths"][route].values()), route
    assert "HTTPValidationError" not in json.dumps(spec)
    body = assert_error(client.get("/jobs?limit=0"), 422, "limit")
    assert set(body) == set(spec["components"]["schemas"]["ErrorOut"]["properties"])


def test_the_api_docs_need_nothing_from_elsewhere(client):
    """/docs was blank offline: it loaded Swagger UI from a CDN (issue 17)."""
    page = client.get("/docs")
    assert page.status_code == 200
    urls = re.findall(r"""(?:src|href|url)\s*[=:]\s*['"]([^'"]+)['"]""", page.text)
    assert urls and not [u for u in urls if re.match(r"(https?:)?//", u)], urls
    assets = [u for u in urls if u.startswith("/docs/assets/")]
    assert len(assets) == 3, urls
    for url in assets:
        answer = client.get(url)
        assert answer.status_code == 200 and len(answer.content) > 500, url
    script = client.get("/docs/assets/swagger-ui-bundle.js")
    assert script.headers["content-type"].startswith("text/javascript")
    assert SWAGGER_UI_VERSION.encode() in script.content  # the copy the module names
    assert SWAGGER_UI_VERSION.startswith("5.")  # Swagger UI 5 reads OpenAPI 3.1
    assert b"Apache License" in client.get("/docs/assets/LICENSE").content
    assert_error(client.get("/docs/assets/secret.txt"), 404, "name")
    assert client.get("/redoc").status_code == 404  # ReDoc would need a CDN


def test_every_tag_of_an_operation_is_declared_with_a_description(client):
    """The documentation groups the routes by tag: a tag used by an operation but
    not declared shows without a description (three did: comparisons, export,
    examples)."""
    spec = client.get("/openapi.json").json()
    declared = {t["name"]: t.get("description", "") for t in spec["tags"]}
    used = {t for ops in spec["paths"].values() for op in ops.values() for t in op["tags"]}
    assert used <= set(declared), used - set(declared)
    assert all(declared[t] for t in used)
