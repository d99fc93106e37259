"""Every route of the HTTP service, with good and bad input, through FastAPI's TestClient.

Expected numbers come from the library called directly on the same inputs, and
directions from angles are computed here with the math module (MODELS.md:
``w = (sin t cos p, sin t sin p, cos t)``), not by the service's code path.
"""

from __future__ import annotations

import json
import math
import sqlite3
import time
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient
from job_polling import wait_for

import brdffit
from brdffit.models.properties import model_properties
from service import Settings, create_app
from service.convert import finite
from service.jobs import FitPool
from service.schemas import EXAMPLE_DATA
from service.store import SCHEMA, JobStore, data_to_bytes

ROOT = Path(__file__).resolve().parents[2]
WARD_CSV = ROOT / "data_synthetic" / "ward.csv"
FIT_LIMIT = 800
BODY_LIMIT = 400_000


@pytest.fixture(scope="module")
def store_path(tmp_path_factory):
    return tmp_path_factory.mktemp("service") / "jobs.sqlite3"


@pytest.fixture(scope="module")
def client(store_path):
    # Synchronous fits on the web process's threads (the default); the worker
    # processes that BRDFFIT_FIT_WORKERS asks for are exercised by test_fit_pool_*.
    settings = Settings(
        store_path=store_path,
        workers=1,
        fit_workers=0,
        fit_max_samples=FIT_LIMIT,
        max_body_bytes=BODY_LIMIT,
        fit_timeout=5.0,
        job_timeout=30.0,
    )
    with TestClient(create_app(settings), raise_server_exceptions=False) as c:
        yield c


def example_measurements() -> brdffit.Measurements:
    d = EXAMPLE_DATA
    return brdffit.Measurements.from_angles(
        d["theta_i"], d["phi_i"], d["theta_o"], d["phi_o"], d["values"], channels=d["channels"]
    )


def direction(theta_deg: float, phi_deg: float) -> list[float]:
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return [math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)]


def without_seconds(d):
    if isinstance(d, dict):
        return {k: without_seconds(v) for k, v in d.items() if k != "seconds"}
    return d


def assert_error(response, status: int, field: str | None = None, words: str = ""):
    assert response.status_code == status, response.text
    body = response.json()
    assert set(body) >= {"field", "message", "kind", "errors"}
    if field is not None:
        assert body["field"] == field, body
    assert words.lower() in body["message"].lower(), body
    return body


# ------------------------------------------------------------------- basics
def test_health_counts_jobs_by_status(client):
    body = client.get("/health").json()
    assert body["status"] == "ok" and body["version"] == brdffit.__version__
    assert body["workers"] == 1
    assert set(body["jobs"]) == {"queued", "running", "done", "failed", "interrupted"}


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


# ------------------------------------------------------------------- models
def test_models_lists_the_registry_and_filters(client):
    names = [m["name"] for m in client.get("/models").json()]
    assert names == list(brdffit.REGISTRY)
    body = client.get("/models", params={"symmetry": "anisotropic", "origin": "physical"}).json()
    expected = brdffit.list_models(symmetry="anisotropic", origin="physical")
    assert body == [m.to_dict() | {"properties": None} for m in expected]


def test_models_with_properties_match_the_library(client):
    body = client.get(
        "/models", params={"symmetry": "anisotropic", "origin": "physical", "properties": True}
    ).json()
    for entry in body:
        measured = model_properties(entry["name"])
        assert entry["properties"]["max_albedo"] == pytest.approx(measured["max_albedo"])
        assert entry["properties"]["reciprocal"] == measured["reciprocal"]


def test_models_bad_filter_names_the_field(client):
    body = assert_error(client.get("/models", params={"origin": "alien"}), 422, "origin")
    assert body["kind"] == "ValidationError"


def test_one_model_and_sums_of_lobes(client):
    assert client.get("/models/ward").json() == brdffit.get_model("ward").to_dict() | {
        "properties": None
    }
    assert client.get("/models/lambert+blinn").json()["name"] == "lambert+blinn"
    assert_error(client.get("/models/blin"), 404, "name", "did you mean blinn")


# ----------------------------------------------------------------- evaluate
def test_evaluate_matches_the_model_at_directions_from_angles(client):
    pairs = [(30, 0, 30, 180), (30, 0, 10, 180), (60, 45, 20, 200), (0, 0, 75, 90)]
    params = {"kd": [0.3, 0.2, 0.1], "ks": 0.08, "alpha": 0.12}
    body = {
        "model": "ward",
        "params": params,
        "theta_i": [p[0] for p in pairs],
        "phi_i": [p[1] for p in pairs],
        "theta_o": [p[2] for p in pairs],
        "phi_o": [p[3] for p in pairs],
    }
    answer = client.post("/evaluate", json=body)
    assert answer.status_code == 200, answer.text
    wi = np.array([direction(p[0], p[1]) for p in pairs])
    wo = np.array([direction(p[2], p[3]) for p in pairs])
    expected = brdffit.get_model("ward").evaluate(wi, wo, params)
    np.testing.assert_allclose(answer.json()["values"], expected, rtol=1e-12)


def test_evaluate_fills_defaults(client):
    body = {"model": "blinn", "theta_i": [20], "phi_i": [0], "theta_o": [20], "phi_o": [180]}
    answer = client.post("/evaluate", json=body).json()
    model = brdffit.get_model("blinn")
    assert answer["params"] == model.defaults()
    wi, wo = np.array([direction(20, 0)]), np.array([direction(20, 180)])
    assert answer["values"][0] == pytest.approx(model.evaluate(wi, wo, model.defaults())[0])


@pytest.mark.parametrize(
    ("change", "field", "words"),
    [
        ({"phi_o": [180]}, "phi_o", "entries"),
        ({"theta_o": [30, 190]}, "theta_o", "outside [0, 180]"),
        ({"params": {"kd": 5}}, "params.kd", "outside its bounds"),
        ({"params": {"nope": 1}}, "params.nope", "no parameter"),
        ({"model": "wardd"}, "model", "did you mean ward"),
        ({"theta_i": []}, "theta_i", ""),
    ],
)
def test_evaluate_bad_input_names_the_field(client, change, field, words):
    body = {
        "model": "ward",
        "theta_i": [30, 30],
        "phi_i": [0, 0],
        "theta_o": [30, 10],
        "phi_o": [180, 180],
    } | change
    assert_error(client.post("/evaluate", json=body), 422, field, words)


def test_nan_in_a_body_is_refused(client):
    body = {"model": "ward", "theta_i": [float("nan")], "phi_i": [0], "theta_o": [1], "phi_o": [0]}
    text = json.dumps(body)  # Python writes NaN, which JSON parsers of the service accept
    answer = client.post("/evaluate", content=text, headers={"content-type": "application/json"})
    assert_error(answer, 422, "theta_i", "not finite")


# ---------------------------------------------------------------------- fit
def test_fit_matches_the_library(client):
    answer = client.post("/fit", json={"model": "blinn", "data": EXAMPLE_DATA, "seed": 3})
    assert answer.status_code == 200, answer.text
    expected = brdffit.fit(example_measurements(), "blinn", seed=3, timeout=5.0).to_dict()
    got = answer.json()
    assert got["params"] == expected["params"]
    assert got["n_evals"] == expected["n_evals"]
    assert got["loss"] == expected["loss"]


def test_fit_caps_the_timeout_at_the_server_limit(client):
    body = {"model": "blinn", "data": EXAMPLE_DATA, "timeout": 1000}
    assert client.post("/fit", json=body).json()["options"]["timeout"] == 5.0


def test_fit_with_uncertainty_returns_the_posterior(client):
    body = {
        "model": "blinn",
        "data": EXAMPLE_DATA,
        "uncertainty": True,
        "posterior_options": {"noise": "relative"},
    }
    got = client.post("/fit", json=body).json()
    post = got["posterior"]
    assert set(post["summary"]) >= {"n", "kd[r]", "ks[b]", "noise"}
    median = post["summary"]["n"]["median"]
    assert post["summary"]["n"]["p16"] < median < post["summary"]["n"]["p84"]


def bad_data(**change):
    return {"model": "blinn", "data": EXAMPLE_DATA | change}


@pytest.mark.parametrize(
    ("body", "field", "words"),
    [
        (bad_data(values=[[1, 2, 3]]), "data.values", "same length"),
        (bad_data(theta_i=[200.0] * 12), "data.theta_i", "outside"),
        (bad_data(phi_o=[0.0] * 3), "data.phi_o", "entries"),
        (bad_data(channels=["r", "g"]), "data.channels", "names 2 channel"),
        (bad_data(sigma=[-1.0] * 12), "data.sigma", "positive"),
        ({"model": "nope", "data": EXAMPLE_DATA}, "model", "unknown model"),
        ({"model": "blinn", "data": EXAMPLE_DATA, "loss": "chi2"}, "loss", "sigma"),
        ({"model": "blinn", "data": EXAMPLE_DATA, "loss": "l3"}, "loss", ""),
        ({"model": "blinn", "data": EXAMPLE_DATA, "fixed": {"n": 0}}, "n", "outside"),
        ({"model": "blinn", "data": EXAMPLE_DATA, "seed": -1}, "seed", ""),
        ({"model": "blinn", "data": EXAMPLE_DATA, "surprise": 1}, "surprise", ""),
        ({"model": "blinn"}, "data", "required"),
        (
            {
                "model": "ward",
                "data": {
                    k: v[:3] if isinstance(v, list) else v
                    for k, v in EXAMPLE_DATA.items()
                    if k != "channels"
                },
            },
            "data",
            "more samples than parameters",
        ),
    ],
)
def test_fit_bad_input_names_the_field(client, body, field, words):
    assert_error(client.post("/fit", json=body), 422, field, words)


def test_fit_refuses_more_samples_than_its_limit(client):
    n = FIT_LIMIT + 1
    data = {
        "theta_i": [30.0] * n,
        "phi_i": [0.0] * n,
        "theta_o": [30.0] * n,
        "phi_o": [180.0] * n,
        "values": [0.1] * n,
    }
    assert_error(
        client.post("/fit", json={"model": "lambert", "data": data}),
        422,
        "data.theta_i",
        f"at most {FIT_LIMIT}",
    )


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


def test_fit_file_matches_the_library(client):
    with open(WARD_CSV, "rb") as f:
        answer = client.post(
            "/fit/file", files={"file": ("ward.csv", f)}, data={"model": "ward", "channels": "g"}
        )
    assert answer.status_code == 200, answer.text
    data = brdffit.read(WARD_CSV).select_channels(["g"])
    expected = brdffit.fit(data, "ward", timeout=5.0).to_dict()
    assert answer.json()["params"] == expected["params"]


def test_fit_file_sniffs_a_csv_without_extension(client):
    content = WARD_CSV.read_bytes()
    answer = client.post(
        "/fit/file",
        files={"file": ("measurements", content)},
        data={"model": "ward", "options": '{"seed": 1}'},
    )
    assert answer.status_code == 200, answer.text
    assert answer.json()["n_samples"] == brdffit.read(WARD_CSV).n


@pytest.mark.filterwarnings("ignore:.*values are negative:UserWarning")
def test_data_notes_reach_the_client(client):
    """What reading the data noticed (here: values below zero, kept) is in the answer of
    POST /fit, /fit/file (naming the uploaded file, not the server's temporary one) and
    /jobs, not only in the server's log; clean data give no notes."""
    values = [list(v) for v in EXAMPLE_DATA["values"]]
    values[0] = [-abs(x) - 0.001 for x in values[0]]
    noisy = EXAMPLE_DATA | {"values": values}
    answer = client.post("/fit", json={"model": "blinn", "data": noisy})
    assert answer.status_code == 200, answer.text
    notes = answer.json()["data_notes"]
    assert len(notes) == 1 and f"{len(values[0])} of " in notes[0] and "negative" in notes[0]
    clean = client.post("/fit", json={"model": "blinn", "data": EXAMPLE_DATA}).json()
    assert clean["data_notes"] == []
    data = example_measurements()
    rows = ["theta_i,phi_i,theta_o,phi_o,v"] + [
        f"{a},{b},{c},{d},{-0.5 if k == 0 else v}"
        for k, (a, b, c, d, v) in enumerate(zip(*data.angles(), data.values[:, 0]))
    ]
    upload = ("mine.csv", ("\n".join(rows) + "\n").encode())
    answer = client.post("/fit/file", files={"file": upload}, data={"model": "blinn"})
    assert answer.status_code == 200, answer.text
    (text,) = answer.json()["data_notes"]
    assert text.startswith("mine.csv: 1 of ") and "/tmp" not in text
    job = client.post("/jobs", json={"model": "blinn", "data": noisy})
    assert job.status_code == 202 and job.json()["data_notes"] == notes
    assert client.get(f"/jobs/{job.json()['id']}").json()["data_notes"] == notes


def test_a_store_from_before_data_notes_gains_them(tmp_path):
    """A job store written by the previous schema (no notes column) opens, keeps its
    jobs, and answers them with no notes; new jobs keep theirs."""
    path = tmp_path / "old.sqlite3"
    old_schema = SCHEMA.replace(",\n    notes TEXT", "")
    assert "notes" not in old_schema
    with sqlite3.connect(path) as db:
        db.executescript(old_schema)
        db.execute(
            "INSERT INTO jobs (id, status, model, options, data, created, attempt) "
            "VALUES ('old', 'done', 'lambert', '{}', x'00', 0, 1)"
        )
    store = JobStore(path)
    assert store.get("old")["data_notes"] == []
    new = store.create("lambert", {}, b"\x00", ["request: 1 of 3 values are negative"])
    assert store.get(new["id"])["data_notes"] == ["request: 1 of 3 values are negative"]


def test_fit_file_errors_name_the_uploaded_file(client):
    answer = client.post(
        "/fit/file", files={"file": ("mine.csv", b"a,b\n1,2\n")}, data={"model": "ward"}
    )
    body = assert_error(answer, 422, "header", "mine.csv")
    assert "/tmp" not in body["message"]
    answer = client.post(
        "/fit/file",
        files={"file": ("cut.bsdf", b"tensor_file\x00\x01\x00")},
        data={"model": "ward"},
    )
    body = assert_error(answer, 422, "file", "cut.bsdf is truncated")
    answer = client.post(
        "/fit/file", files={"file": ("blob", bytes(range(256)) * 4)}, data={"model": "ward"}
    )
    assert_error(answer, 422, "format", "cannot tell the format")


def test_fit_file_options_errors_are_under_options(client):
    with open(WARD_CSV, "rb") as f:
        answer = client.post(
            "/fit/file",
            files={"file": ("ward.csv", f)},
            data={"model": "ward", "options": '{"loss": "l3"}'},
        )
    assert_error(answer, 422, "options.loss")


# --------------------------------------------------------------------- jobs
def test_a_job_runs_to_the_library_result(client):
    answer = client.post("/jobs", json={"model": "blinn", "data": EXAMPLE_DATA, "seed": 5})
    assert answer.status_code == 202, answer.text
    job = answer.json()
    assert job["status"] == "queued" and answer.headers["location"] == f"/jobs/{job['id']}"
    done = wait_for(client, job["id"])
    assert done["status"] == "done", done
    expected = brdffit.fit(example_measurements(), "blinn", seed=5, timeout=30.0).to_dict()
    assert done["result"]["params"] == expected["params"]
    assert done["started"] >= done["created"] and done["finished"] >= done["started"]
    listed = client.get("/jobs", params={"status": "done"}).json()
    assert job["id"] in [j["id"] for j in listed]


def test_a_job_with_uncertainty_carries_the_posterior(client):
    body = {
        "model": "ward",
        "data": EXAMPLE_DATA,
        "uncertainty": True,
        "posterior_options": {"noise": "relative", "seed": 2},
    }
    job = wait_for(client, client.post("/jobs", json=body).json()["id"])
    assert job["status"] == "done", job
    assert "alpha" in job["result"]["posterior"]["summary"]


def test_a_job_failing_at_run_time_says_why_and_can_be_resubmitted(client):
    # noise="given" needs sigma, which these data lack: only the posterior finds out.
    body = {
        "model": "blinn",
        "data": EXAMPLE_DATA,
        "uncertainty": True,
        "posterior_options": {"noise": "given"},
    }
    job_id = client.post("/jobs", json=body).json()["id"]
    failed = wait_for(client, job_id)
    assert failed["status"] == "failed"
    assert failed["error"]["field"] == "noise" and "sigma" in failed["error"]["message"]
    again = client.post(f"/jobs/{job_id}/resubmit")
    assert again.status_code == 202 and again.json()["attempt"] == 2
    assert wait_for(client, job_id)["status"] == "failed"


def test_jobs_validate_before_accepting(client):
    body = {"model": "ward", "data": EXAMPLE_DATA, "fixed": {"alpha": 7}}
    assert_error(client.post("/jobs", json=body), 422, "alpha", "outside")
    with open(WARD_CSV, "rb") as f:
        answer = client.post(
            "/jobs/file", files={"file": ("ward.csv", f)}, data={"model": "ward", "format": "astm"}
        )
    assert_error(answer, 422)


def test_job_file_upload_runs(client):
    with open(WARD_CSV, "rb") as f:
        answer = client.post("/jobs/file", files={"file": ("ward.csv", f)}, data={"model": "ward"})
    assert answer.status_code == 202, answer.text
    job = wait_for(client, answer.json()["id"])
    expected = brdffit.fit(brdffit.read(WARD_CSV), "ward", timeout=30.0).to_dict()
    assert job["result"]["params"] == expected["params"]


def test_unknown_jobs_are_404_and_finished_ones_are_not_resubmitted(client):
    assert_error(client.get("/jobs/nope"), 404, "id")
    assert_error(client.delete("/jobs/nope"), 404, "id")
    assert_error(client.post("/jobs/nope/resubmit"), 404, "id")
    job_id = client.post("/jobs", json={"model": "lambert", "data": EXAMPLE_DATA}).json()["id"]
    wait_for(client, job_id)
    assert_error(client.post(f"/jobs/{job_id}/resubmit"), 409, "id", "done")


def test_deleting_a_running_job_frees_its_worker(client):
    # A posterior of 10^6 steps would hold the only worker for a minute.
    body = {
        "model": "ward",
        "data": EXAMPLE_DATA,
        "uncertainty": True,
        "posterior_options": {
            "steps": 1_000_000,
            "max_steps": 1_000_000,
            "max_seconds": 60,
            "noise": "relative",
        },
    }
    long_id = client.post("/jobs", json=body).json()["id"]
    wait_for(client, long_id, statuses=("running",))
    assert client.delete(f"/jobs/{long_id}").status_code == 204
    assert_error(client.get(f"/jobs/{long_id}"), 404)
    t0 = time.monotonic()
    short = client.post("/jobs", json={"model": "lambert", "data": EXAMPLE_DATA}).json()
    assert wait_for(client, short["id"], seconds=20)["status"] == "done"
    assert time.monotonic() - t0 < 20


def test_restart_interrupts_running_jobs_and_requeues_queued_ones(tmp_path):
    store = JobStore(tmp_path / "jobs.sqlite3")
    blob = data_to_bytes(example_measurements())
    running = store.create("lambert", {"seed": 0}, blob)
    store.start(running["id"], 1)
    queued = store.create("lambert", {"seed": 0}, blob)
    settings = Settings(store_path=tmp_path / "jobs.sqlite3", workers=1, fit_workers=0)
    with TestClient(create_app(settings)) as c:
        cut = c.get(f"/jobs/{running['id']}").json()
        assert cut["status"] == "interrupted" and "resubmit" in cut["error"]["message"]
        assert wait_for(c, queued["id"])["status"] == "done"
        assert c.post(f"/jobs/{running['id']}/resubmit").status_code == 202
        rerun = wait_for(c, running["id"])
        assert rerun["status"] == "done" and rerun["attempt"] == 2
        expected = brdffit.fit(example_measurements(), "lambert", seed=0)
        assert rerun["result"]["params"]["kd"] == list(expected.params["kd"])


def test_a_bug_answers_a_json_500(store_path):
    app = create_app(Settings(store_path=store_path, workers=1, fit_workers=0))

    def broken():
        raise RuntimeError("secret detail 42")

    app.add_api_route("/broken", broken)
    with TestClient(app, raise_server_exceptions=False) as c:
        body = assert_error(c.get("/broken"), 500, None, "internal error")
        assert body["kind"] == "InternalError" and "secret detail" not in body["message"]


def test_fit_pool_returns_the_library_result_and_its_errors():
    pool = FitPool(1)
    try:
        data = example_measurements()
        got = pool.run(data, "blinn", {"seed": 1})
        expected = finite(brdffit.fit(data, "blinn", seed=1).to_dict())
        assert without_seconds(got) == without_seconds(expected)
        with pytest.raises(brdffit.ModelError) as caught:
            pool.run(data, "blin", {})
        assert caught.value.field == "model" and "did you mean blinn" in str(caught.value)
    finally:
        pool.close()
