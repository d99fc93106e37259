"""The ``export`` option of ``POST /fit``, ``/fit/file``, ``/jobs`` and ``/jobs/file``:
the answer (or the job's result) carries each renderer export, as ``POST /export``
with the fit's data would make it, within the fit's time limit; a bad target is a
422 naming ``export`` (``options.export`` in a form)."""

from __future__ import annotations

import json
import time

import pytest
from service_helpers import WARD_CSV, example_measurements, wait_for

import brdffit
from brdffit_service.exports import with_exports
from brdffit_service.schemas import EXAMPLE_DATA, FitResultOut
from brdffit_service.schemas.results import ExportOut

#: An export's fields, as its schema declares them (test_schemas holds the library's
#: Export.to_dict() to the same).
EXPORT_KEYS = set(ExportOut.model_fields)


def _library_export(answer: dict, target: str, data) -> dict:
    fitted = {k: v for k, v in answer.items() if k not in ("exports", "export_errors")}
    return brdffit.export(fitted, target, data=data).to_dict()


def test_a_fit_answers_each_export_once_as_the_library_makes_it(client):
    body = {"model": "blinn", "data": EXAMPLE_DATA, "export": ["gltf", "pbrt", "gltf"]}
    answer = client.post("/fit", json=body)
    assert answer.status_code == 200, answer.text
    got = answer.json()
    assert [e["target"] for e in got["exports"]] == ["gltf", "pbrt"]
    assert got["export_errors"] is None
    data = example_measurements()
    for export in got["exports"]:
        assert set(export) == EXPORT_KEYS
        expected = _library_export(got, export["target"], data)
        assert export["document"] == expected["document"]
        assert export["extension"] == expected["extension"]
        assert export["conversion_error"]["against"] == "data"
        assert export["conversion_error"]["n_directions"] == data.n
    assert got["exports"][0]["document"]["materials"][0]["pbrMetallicRoughness"]
    FitResultOut.model_validate(got)


def test_a_fit_without_the_option_answers_no_exports(client):
    got = client.post("/fit", json={"model": "blinn", "data": EXAMPLE_DATA}).json()
    assert got["exports"] is None and got["export_errors"] is None


def test_an_uploaded_fit_exports_with_its_options(client):
    with open(WARD_CSV, "rb") as f:
        answer = client.post(
            "/fit/file",
            files={"file": ("ward.csv", f)},
            data={"model": "ward", "options": json.dumps({"export": ["mitsuba-xml"]})},
        )
    assert answer.status_code == 200, answer.text
    (export,) = answer.json()["exports"]
    assert export["target"] == "mitsuba-xml" and export["document"].startswith("<bsdf")
    assert export["conversion_error"]["n_directions"] == brdffit.read(WARD_CSV).n


def test_a_job_exports_in_its_worker_after_the_fit(client):
    body = {"model": "blinn", "data": EXAMPLE_DATA, "export": ["gltf"]}
    answer = client.post("/jobs", json=body)
    assert answer.status_code == 202, answer.text
    job = wait_for(client, answer.json()["id"])
    assert job["status"] == "done", job
    (export,) = job["result"]["exports"]
    expected = _library_export(job["result"], "gltf", example_measurements())
    assert export["document"] == expected["document"]
    assert export["document"]["materials"][0]["pbrMetallicRoughness"]


def test_an_uploaded_job_exports(client):
    with open(WARD_CSV, "rb") as f:
        answer = client.post(
            "/jobs/file",
            files={"file": ("ward.csv", f)},
            data={"model": "ward", "options": json.dumps({"export": ["blender"]})},
        )
    assert answer.status_code == 202, answer.text
    job = wait_for(client, answer.json()["id"])
    assert [e["target"] for e in job["result"]["exports"]] == ["blender"]


def test_exports_past_the_time_limit_are_not_made_and_the_fit_is_kept():
    data = example_measurements()
    result = brdffit.fit(data, "blinn").to_dict()
    out = with_exports(result, data, ["gltf"], time.monotonic() - 10.0, 5.0)
    assert out["exports"] == [] and "time limit of 5 s" in out["export_errors"]["gltf"]
    assert out["params"] == result["params"]


def test_a_job_out_of_time_keeps_its_fit_and_says_why_it_did_not_export(client):
    # The posterior samples until its budget, the job's 2 s: none is left to export.
    # (With 0.3 s, a machine running seven processes on two cores spent it all on
    # the fit, which takes 0.05 s when quiet, and sampled no posterior.)
    body = {"model": "blinn", "data": EXAMPLE_DATA, "export": ["gltf"], "timeout": 2.0,
            "uncertainty": True, "posterior_options": {"steps": 100_000}}  # fmt: skip
    job = wait_for(client, client.post("/jobs", json=body).json()["id"])
    assert job["status"] == "done", job
    assert job["result"]["posterior"] is not None
    assert job["result"]["exports"] == []
    assert "time limit" in job["result"]["export_errors"]["gltf"]


@pytest.mark.parametrize("route", ["/fit", "/jobs"])
def test_a_bad_target_in_a_body_is_named(client, route):
    answer = client.post(route, json={"model": "blinn", "data": EXAMPLE_DATA,
                                      "export": ["gltf", "maya"]})  # fmt: skip
    assert answer.status_code == 422, answer.text
    assert answer.json()["field"] == "export.1"
    assert "mitsuba" in answer.json()["message"]


@pytest.mark.parametrize("route", ["/fit/file", "/jobs/file"])
def test_a_bad_target_in_a_form_is_named(client, route):
    with open(WARD_CSV, "rb") as f:
        answer = client.post(
            route,
            files={"file": ("ward.csv", f)},
            data={"model": "ward", "options": json.dumps({"export": "gltf"})},
        )
    assert answer.status_code == 422, answer.text
    assert answer.json()["field"] == "options.export"
