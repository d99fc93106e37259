"""/jobs: jobs run to the library's result, fail saying why, survive restarts."""

from __future__ import annotations

import io
import sqlite3
import time

import numpy as np
import pytest
from fastapi.testclient import TestClient
from service_helpers import WARD_CSV, assert_error, example_measurements, wait_for, without_seconds

import brdffit
from brdffit.jsonable import jsonable
from brdffit_service import Settings, create_app
from brdffit_service.jobs import FitPool
from brdffit_service.schemas import EXAMPLE_DATA, JobOut
from brdffit_service.store import SCHEMA, JobStore, data_to_bytes


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
    assert_error(client.post("/jobs", json=body), 422, "fixed.alpha", "outside")
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


def test_cancelling_a_running_job_keeps_it_and_frees_its_worker(client):
    """Cancel is not delete (issue 17): the job stays, ``cancelled``, saying how to run
    it again; its worker stops at its next report; a finished job cannot be cancelled;
    DELETE still deletes."""
    body = {
        "model": "ward",
        "data": EXAMPLE_DATA,
        "uncertainty": True,
        "posterior_options": {"steps": 1_000_000, "max_steps": 1_000_000, "max_seconds": 60},
    }
    long_id = client.post("/jobs", json=body).json()["id"]
    wait_for(client, long_id, statuses=("running",))
    answer = client.post(f"/jobs/{long_id}/cancel")
    assert answer.status_code == 200, answer.text
    kept = client.get(f"/jobs/{long_id}").json()
    assert kept["status"] == "cancelled" and kept["error"]["kind"] == "Cancelled"
    assert f"/jobs/{long_id}/resubmit" in kept["error"]["message"]
    assert long_id in [j["id"] for j in client.get("/jobs", params={"status": "cancelled"}).json()]
    assert client.get("/health").json()["jobs"]["cancelled"] >= 1
    short = client.post("/jobs", json={"model": "lambert", "data": EXAMPLE_DATA}).json()
    assert wait_for(client, short["id"], seconds=20)["status"] == "done"
    assert client.get(f"/jobs/{long_id}").json()["status"] == "cancelled"  # no late write
    assert_error(client.post(f"/jobs/{short['id']}/cancel"), 409, "id", "done")
    assert_error(client.post(f"/jobs/{long_id}/cancel"), 409, "id", "cancelled")
    assert_error(client.post("/jobs/nope/cancel"), 404, "id")
    assert client.post(f"/jobs/{long_id}/resubmit").json()["attempt"] == 2
    assert client.post(f"/jobs/{long_id}/cancel").status_code == 200
    assert client.delete(f"/jobs/{long_id}").status_code == 204
    assert_error(client.get(f"/jobs/{long_id}"), 404)


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


def test_fit_pool_returns_the_library_result_and_its_errors():
    pool = FitPool(1)
    try:
        data = example_measurements()
        got = pool.run(data, "blinn", {"seed": 1})
        expected = jsonable(brdffit.fit(data, "blinn", seed=1).to_dict())
        assert without_seconds(got) == without_seconds(expected)
        with pytest.raises(brdffit.ModelError) as caught:
            pool.run(data, "blin", {})
        assert caught.value.field == "model" and "did you mean blinn" in str(caught.value)
    finally:
        pool.close()


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


def test_a_50000_sample_upload_is_accepted_as_a_job(tmp_path):
    """Jobs are checked without fitting (brdffit.check_fit): the old check, a fit of one
    evaluation, refused large files, having spent its budget before the fit began."""
    rng = np.random.default_rng(7)
    n = 50_000
    angles = (rng.uniform(0, 80, n), rng.uniform(0, 360, n), rng.uniform(0, 80, n),
              rng.uniform(0, 360, n))  # fmt: skip
    params = {"kd": 0.3, "ks": 0.1, "alpha": 0.2}
    data = brdffit.synthesize("ward", params, geometry=angles, noise=0.01, seed=3)
    upload = io.BytesIO()
    brdffit.write(upload, data, format="npz")
    settings = Settings(store_path=tmp_path / "jobs.sqlite3", workers=1, fit_workers=0,
                        max_body_bytes=64 * 2**20)  # fmt: skip
    with TestClient(create_app(settings)) as c:
        answer = c.post(
            "/jobs/file", files={"file": ("big.npz", upload.getvalue())}, data={"model": "ward"}
        )
        assert answer.status_code == 202, answer.text
        assert c.delete(f"/jobs/{answer.json()['id']}").status_code == 204


def test_a_result_stored_with_every_weight_answers_their_summary(tmp_path):
    """Results stored before FitResult.options summarised the weights carried the whole
    array; such a job still answers, in today's schema."""
    store = JobStore(tmp_path / "jobs.sqlite3")
    job = store.create("blinn", {}, data_to_bytes(example_measurements()))
    store.start(job["id"], 1)
    result = jsonable(brdffit.fit(example_measurements(), "blinn").to_dict())
    old = {**result, "options": {**result["options"], "weights": [1.0, 0.0, 2.5]}}
    store.finish(job["id"], 1, result=old)
    weights = store.get(job["id"])["result"]["options"]["weights"]
    assert weights == {"count": 3, "min": 0.0, "max": 2.5, "zeros": 1}
    JobOut.model_validate(store.get(job["id"]))
