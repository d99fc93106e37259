"""Every answer schema documents every key the library answers, no more, no fewer.

The keys of a real fit, a real posterior, a real model, measured properties, a
stored job, real progress reports and a comparison are compared with the fields of their
schemas, and the answers validated against them (the schemas forbid keys they
do not declare). Before this, the answers accepted any extra key and
documented 5 of a posterior's 23 fields.
"""

from __future__ import annotations

import dataclasses

import pytest
from service_helpers import example_measurements

import brdffit
from brdffit.jsonable import jsonable
from brdffit.models.properties import model_properties
from brdffit_service.comparisons import ComparisonStore
from brdffit_service.routes.comparisons import _comparison
from brdffit_service.schemas import (
    EXAMPLE_DATA,
    ClassificationOut,
    ComparisonBrief,
    ComparisonOut,
    EntryOut,
    ErrorOut,
    FitResultOut,
    JobOut,
    JobProgress,
    ModelOut,
    OptionsOut,
    ParamOut,
    PosteriorOut,
    PropertiesOut,
    SummaryOut,
    WeightsOut,
)
from brdffit_service.schemas.results import ConversionErrorOut, ExportOut
from brdffit_service.store import JobStore, data_to_bytes

#: Fields the service adds to a library answer (not in any to_dict()).
SERVICE_ONLY = {FitResultOut: {"data_notes", "exports", "export_errors"}, ModelOut: {"properties"}}
POSTERIOR = {"steps": 60, "walkers": 16, "noise": "relative", "seed": 1}


def fields(schema) -> set:
    return set(schema.model_fields) - SERVICE_ONLY.get(schema, set())


@pytest.fixture(scope="module")
def fitted():
    """A real fit with its posterior, and every progress report it made."""
    reports = []
    result = brdffit.fit(
        example_measurements(),
        "blinn",
        weights=[1.0] * 11 + [0.0],
        uncertainty=True,
        posterior_options=POSTERIOR | {"progress": reports.append},
        progress=reports.append,
    )
    return result, reports


def test_a_fit_and_its_posterior_have_exactly_the_fields_of_their_schemas(fitted):
    result, _ = fitted
    answer = jsonable(result.to_dict())
    assert set(answer) == fields(FitResultOut)
    assert set(answer["options"]) == fields(OptionsOut)
    assert set(answer["options"]["weights"]) == fields(WeightsOut)
    assert set(answer["posterior"]) == fields(PosteriorOut)
    for summary in answer["posterior"]["summary"].values():
        assert set(summary) == fields(SummaryOut)
    FitResultOut.model_validate(answer)


@pytest.mark.parametrize("name", ["ward", "lambert+blinn", "he"])
def test_a_model_has_exactly_the_fields_of_its_schema(name):
    model = brdffit.get_model(name)
    answer = model.to_dict()
    assert set(answer) == fields(ModelOut)
    assert set(answer["classification"]) == fields(ClassificationOut)
    for param in answer["params"]:
        assert set(param) == fields(ParamOut)
    ModelOut.model_validate(answer)


@pytest.mark.parametrize("target", ["mitsuba-xml", "gltf"])
def test_an_export_has_exactly_the_fields_of_its_schema(target):
    answer = jsonable(brdffit.export({"model": "ward", "params": {"kd": 0.2, "ks": 0.3,
                                      "alpha": 0.2}}, target).to_dict())  # fmt: skip
    assert set(answer) == fields(ExportOut)
    assert fields(ConversionErrorOut) <= set(answer["conversion_error"])  # (it allows more)
    ExportOut.model_validate(answer)


def test_measured_properties_have_exactly_the_fields_of_their_schema():
    answer = jsonable(model_properties("blinn"))
    assert set(answer) == fields(PropertiesOut)
    PropertiesOut.model_validate(answer)


def test_a_stored_job_and_its_progress_have_exactly_the_fields_of_their_schemas(fitted, tmp_path):
    result, reports = fitted
    store = JobStore(tmp_path / "jobs.sqlite3")
    job = store.create("blinn", {}, data_to_bytes(example_measurements()), ["a note"])
    assert set(job) == fields(JobOut)
    store.start(job["id"], 1)
    stages = {"fit": set(), "posterior": set()}
    for report in reports:
        keys = set(dataclasses.asdict(report)) | {"stage"}
        stages["posterior" if hasattr(report, "steps") else "fit"] |= keys
        assert store.progress(job["id"], 1, jsonable(dataclasses.asdict(report) | {"stage": "x"}))
    assert stages["fit"] and stages["posterior"], "both stages report progress"
    assert stages["fit"] | stages["posterior"] == fields(JobProgress)
    store.finish(job["id"], 1, result=jsonable(result.to_dict()))
    done = JobOut.model_validate(store.get(job["id"]))
    assert done.result is not None and done.result.posterior is not None
    assert done.progress is not None


def test_a_failed_job_answers_an_error_of_the_error_schema(tmp_path):
    store = JobStore(tmp_path / "jobs.sqlite3")
    job = store.create("blinn", {}, data_to_bytes(example_measurements()))
    store.start(job["id"], 1)
    store.finish(job["id"], 1, error={"field": "noise", "message": "no", "kind": "FitError"})
    assert JobOut.model_validate(store.get(job["id"])).error == ErrorOut(
        field="noise", message="no", kind="FitError", errors=[]
    )


def test_a_comparison_and_its_entries_have_exactly_the_fields_of_their_schemas(fitted, tmp_path):
    result, _ = fitted
    store = JobStore(tmp_path / "jobs.sqlite3")
    data = data_to_bytes(example_measurements())
    done, queued = (store.create("blinn", {}, data) for _ in range(2))
    comparisons = ComparisonStore(store.path)
    comparison_id = comparisons.create("x.csv", ["blinn", "blinn"], [done["id"], queued["id"]],
                                       example_measurements(), 0.2, 1, 12)  # fmt: skip
    store.start(done["id"], 1)
    store.finish(done["id"], 1, result=jsonable(result.to_dict()))
    answer = _comparison(store, comparison_id)
    assert set(answer) == fields(ComparisonOut)
    for entry in answer["entries"]:
        assert set(entry) == fields(EntryOut)
    assert answer["entries"][0]["heldout_rmse"] is not None
    ComparisonOut.model_validate(answer)
    (brief,) = comparisons.list()
    assert set(brief) == fields(ComparisonBrief)
    ComparisonBrief.model_validate(brief)


@pytest.mark.parametrize(
    "schema",
    [
        ComparisonOut,
        ComparisonBrief,
        EntryOut,
        FitResultOut,
        OptionsOut,
        WeightsOut,
        PosteriorOut,
        SummaryOut,
        ModelOut,
        ParamOut,
        PropertiesOut,
        JobOut,
        JobProgress,
    ],
)
def test_openapi_documents_every_field_of_every_answer(client, schema):
    spec = client.get("/openapi.json").json()["components"]["schemas"][schema.__name__]
    assert set(spec["properties"]) == set(schema.model_fields)
    undocumented = [k for k, v in spec["properties"].items() if not v.get("description")]
    assert not undocumented, f"{schema.__name__}: {undocumented}"
    assert spec.get("additionalProperties") is False


def test_the_fit_answer_over_http_keeps_every_key_of_the_library(client):
    body = {"model": "blinn", "data": EXAMPLE_DATA, "uncertainty": True,
            "posterior_options": POSTERIOR}  # fmt: skip
    answer = client.post("/fit", json=body)
    assert answer.status_code == 200, answer.text
    got = answer.json()
    assert set(got) == set(FitResultOut.model_fields)
    assert set(got["posterior"]) == set(PosteriorOut.model_fields)
