"""``POST /batches``: uploaded files x models as jobs, accepted whole or refused whole."""

from __future__ import annotations

from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from service_helpers import wait_for

import brdffit
from brdffit_service.app import create_app
from brdffit_service.settings import Settings

SYNTHETIC = Path(__file__).resolve().parents[2] / "data_synthetic"


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    settings = Settings(store_path=tmp_path_factory.mktemp("batches") / "jobs.sqlite3",
                        workers=1, fit_workers=0, job_timeout=30.0)  # fmt: skip
    with TestClient(create_app(settings), raise_server_exceptions=False) as c:
        yield c


def _files(*names):
    return [("files", (n, (SYNTHETIC / n).read_bytes(), "text/csv")) for n in names]


def test_every_file_x_model_is_a_job_with_the_plain_fit(client):
    answer = client.post("/batches", files=_files("ward.csv", "blinn.csv"),
                         data={"models": "ward,blinn", "options": '{"seed": 3}'})  # fmt: skip
    assert answer.status_code == 202, answer.text
    jobs = answer.json()["jobs"]
    assert [(j["file"], j["model"]) for j in jobs] == [
        ("ward.csv", "ward"), ("ward.csv", "blinn"), ("blinn.csv", "ward"), ("blinn.csv", "blinn")
    ]  # fmt: skip
    for j in jobs:
        done = wait_for(client, j["job"]["id"])
        assert done["status"] == "done"
        plain = brdffit.fit(brdffit.read(SYNTHETIC / j["file"]), j["model"], seed=3)
        assert done["result"]["n_evals"] == plain.n_evals
        assert done["result"]["loss"] == plain.loss


def test_a_corrupt_file_refuses_the_batch_and_stores_nothing(client):
    before = client.get("/health").json()["jobs"]
    files = [*_files("ward.csv"), ("files", ("bad.csv", b"theta_i,phi_i\n1,2\n", "text/csv"))]
    answer = client.post("/batches", files=files, data={"models": "ward"})
    assert answer.status_code == 422
    assert answer.json()["field"] == "files[1].header" and "bad.csv" in answer.json()["message"]
    assert client.get("/health").json()["jobs"] == before


def test_an_unknown_model_refuses_the_batch(client):
    answer = client.post("/batches", files=_files("ward.csv"), data={"models": "ward,wardd"})
    assert answer.status_code == 422 and "wardd" in answer.json()["message"]
    answer = client.post("/batches", files=_files("ward.csv"), data={"models": " , "})
    assert answer.status_code == 422 and answer.json()["field"] == "models"


def test_a_batch_job_makes_the_exports_its_options_ask_for(client):
    answer = client.post("/batches", files=_files("ward.csv"),
                         data={"models": "ward", "options": '{"export": ["gltf"]}'})  # fmt: skip
    assert answer.status_code == 202, answer.text
    done = wait_for(client, answer.json()["jobs"][0]["job"]["id"])
    assert done["status"] == "done", done
    assert [e["target"] for e in done["result"]["exports"]] == ["gltf"]
