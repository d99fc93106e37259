"""``POST /export`` and ``GET /export/targets``: the library's export, as JSON, and
named 422s for bad input (never a 500)."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient

import brdffit
from brdffit_service import Settings, create_app

GLTF = {"model": "gltf_pbr", "params": {"base_color": [0.6, 0.3, 0.2], "metallic": 0.0,
        "roughness": 0.5}, "channels": ["r", "g", "b"]}  # fmt: skip


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    settings = Settings(store_path=tmp_path_factory.mktemp("export") / "jobs.sqlite3",
                        workers=1, fit_workers=0)  # fmt: skip
    with TestClient(create_app(settings), raise_server_exceptions=False) as c:
        yield c


def test_targets(client):
    r = client.get("/export/targets")
    assert r.status_code == 200 and r.json() == brdffit.export_targets()


def test_export_answers_the_library_export(client):
    r = client.post("/export", json={"result": GLTF, "target": "gltf"})
    assert r.status_code == 200, r.text
    body = r.json()
    expected = brdffit.export(GLTF, "gltf").to_dict()
    assert body["document"] == expected["document"]
    assert body["conversion_error"]["exact"] is True
    assert body["conversion_error"]["rms_log_target"] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("target", ["mitsuba-xml", "gltf"])
def test_the_answer_names_the_library_file_ending(client, target):
    """The page names a download by the answer's ending, not by a table of its own. (The
    route passes any target's answer through; the library's endings, every target's,
    are held in tests/export/test_export.py.)"""
    r = client.post("/export", json={"result": GLTF, "target": target})
    assert r.status_code == 200, r.text
    assert r.json()["extension"] == brdffit.export(GLTF, target).extension


def test_a_fit_answer_is_a_result_and_data_are_used(client):
    data = brdffit.synthesize("gltf_pbr", GLTF["params"], noise=0.01, seed=2)
    angles = [a.tolist() for a in data.angles()]
    payload = dict(zip(("theta_i", "phi_i", "theta_o", "phi_o"), angles))
    payload |= {"values": data.values.tolist(), "channels": list(data.channels)}
    fitted = client.post("/fit", json={"data": payload, "model": "gltf_pbr"})
    assert fitted.status_code == 200, fitted.text
    r = client.post("/export", json={"result": fitted.json(), "target": "mitsuba-xml",
                                     "data": payload})  # fmt: skip
    assert r.status_code == 200, r.text
    err = r.json()["conversion_error"]
    assert err["against"] == "data" and err["n_directions"] == data.n
    assert r.json()["document"].startswith("<bsdf")


@pytest.mark.parametrize(
    "body, field",
    [
        ({"result": GLTF, "target": "maya"}, "target"),
        ({"result": {**GLTF, "model": "gltf"}, "target": "gltf"}, "result.model"),
        ({"result": {**GLTF, "params": {**GLTF["params"], "roughness": 7}}, "target": "gltf"},
         "result.params.roughness"),
        ({"result": {"model": "gltf_pbr", "params": {"metallic": 0.1}}, "target": "gltf"},
         "result.params.base_color"),
        ({"result": GLTF}, "target"),
    ],
)  # fmt: skip
def test_bad_bodies_are_named(client, body, field):
    r = client.post("/export", json=body)
    assert r.status_code == 422, r.text
    assert r.json()["field"] == field or field in {e["field"] for e in r.json()["errors"]}
