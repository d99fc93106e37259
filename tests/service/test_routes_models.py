"""GET /models and /models/{name}: the registry, as the library lists it."""

from __future__ import annotations

import pytest
from service_helpers import assert_error

import brdffit
from brdffit.models.properties import model_properties


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
