"""POST /evaluate, /fit and /fit/file: answers equal to the library called directly."""

from __future__ import annotations

import json
import logging
import struct
import tempfile

import numpy as np
import pytest
from service_helpers import (
    FIT_LIMIT,
    FIT_TIMEOUT,
    WARD_CSV,
    assert_error,
    direction,
    example_measurements,
)

import brdffit
from brdffit.fitting.options import COARSE_ABOVE
from brdffit_service.schemas import EXAMPLE_DATA


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


def test_fit_matches_the_library(client):
    answer = client.post("/fit", json={"model": "blinn", "data": EXAMPLE_DATA, "seed": 3})
    assert answer.status_code == 200, answer.text
    expected = brdffit.fit(example_measurements(), "blinn", seed=3, timeout=FIT_TIMEOUT).to_dict()
    got = answer.json()
    assert got["params"] == expected["params"]
    assert got["n_evals"] == expected["n_evals"]
    assert got["loss"] == expected["loss"]


def test_fit_caps_the_timeout_at_the_server_limit(client):
    body = {"model": "blinn", "data": EXAMPLE_DATA, "timeout": 1000}
    assert client.post("/fit", json=body).json()["options"]["timeout"] == FIT_TIMEOUT


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
        (
            {"model": "blinn", "data": EXAMPLE_DATA, "fixed": {"n": 0}},
            "fixed.n",
            "fixed: n=0.0 is outside",
        ),
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


def test_fit_file_matches_the_library(client):
    with open(WARD_CSV, "rb") as f:
        answer = client.post(
            "/fit/file", files={"file": ("ward.csv", f)}, data={"model": "ward", "channels": "g"}
        )
    assert answer.status_code == 200, answer.text
    data = brdffit.read(WARD_CSV).select_channels(["g"])
    expected = brdffit.fit(data, "ward", timeout=FIT_TIMEOUT).to_dict()
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


def test_fit_file_errors_name_the_uploaded_file(client):
    answer = client.post(
        "/fit/file", files={"file": ("mine.csv", b"a,b\n1,2\n")}, data={"model": "ward"}
    )
    body = assert_error(answer, 422, "file.header", "mine.csv")
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


@pytest.mark.parametrize(
    ("name", "content", "words"),
    [
        ("mine.npz", b"PK\x03\x04garbage", "mine.npz is not a readable .npz"),
        ("m.binary", struct.pack("<3i", 90, 90, 90) + bytes(16), "m.binary: the dimensions"),
        ("t.astm", b"\xff\xfe\x00bad", "t.astm is not a UTF-8 text file"),
    ],
    ids=["npz", "merl", "astm"],
)
@pytest.mark.parametrize("route", ["/fit/file", "/jobs/file"])
def test_uploads_are_read_in_memory_and_errors_name_the_upload(
    client, monkeypatch, route, name, content, words
):
    """No temporary file: the bytes go to brdffit.read named by the upload's file name,
    so a fault of the file is under the form field ``file`` and names the client's
    file, never a server path (the old code wrote a temporary file and rewrote it)."""

    def no_temporary_files(*args, **kwargs):
        raise AssertionError("an upload was written to a temporary file")

    monkeypatch.setattr(tempfile, "mkstemp", no_temporary_files)
    answer = client.post(route, files={"file": (name, content)}, data={"model": "ward"})
    body = assert_error(answer, 422, "file", words)
    assert "/tmp" not in body["message"] and tempfile.gettempdir() not in body["message"]
    with open(WARD_CSV, "rb") as f:
        good = client.post(route, files={"file": ("ward.csv", f)}, data={"model": "ward"})
    assert good.status_code in (200, 202), good.text


@pytest.mark.parametrize("route", ["/fit/file", "/jobs/file"])
def test_the_server_log_names_the_clients_file(client, caplog, route):
    """The log once named the temporary file an upload was written to; uploads are read
    in memory now, and the log says which of the client's files it read, refused or
    noted something about (issue 17)."""
    rows = WARD_CSV.read_text().splitlines()
    last = rows[-1].split(",")
    last[4] = "-0.05"  # the red value of the last sample (header: r,g,b,sigma_r...)
    negative = "\n".join([*rows[:-1], ",".join(last)]).encode()
    caplog.set_level(logging.DEBUG)
    name = "my lab data.csv"
    answer = client.post(route, files={"file": (name, negative)}, data={"model": "ward"})
    assert answer.status_code in (200, 202), answer.text
    refused = client.post(route, files={"file": ("broken scan.csv", b"nothing,here\n1,2\n")},
                          data={"model": "ward"})  # fmt: skip
    assert refused.status_code == 422
    logged = [r.getMessage() for r in caplog.records if r.name == "brdffit.service"]
    read = [m for m in logged if m.startswith(f"upload '{name}'")]
    assert any("samples" in m for m in read), logged
    assert any("negative" in m or "below zero" in m for m in read), logged
    assert any(m.startswith("upload 'broken scan.csv'") and "refused" in m for m in logged)
    everything = " ".join(r.getMessage() for r in caplog.records)
    assert tempfile.gettempdir() not in everything and "/tmp/" not in everything


def test_fit_takes_the_coarse_to_fine_options(tmp_path):
    """``coarse_above`` and ``coarse_samples`` reach the library: a fit of 3,000
    samples (on a server that takes them) runs coarse to fine on 1,000 of them when
    asked (the library's default starts above 50,000), records both, and a subsample
    below the least is refused under its field."""
    from fastapi.testclient import TestClient

    from brdffit_service import Settings, create_app

    settings = Settings(
        store_path=tmp_path / "jobs.sqlite3",
        workers=1,
        fit_workers=0,
        fit_max_samples=3000,
        max_body_bytes=10**7,
        fit_timeout=FIT_TIMEOUT,
    )
    rng = np.random.default_rng(5)
    n = 3000
    geometry = (rng.uniform(0.0, 80.0, n), np.zeros(n), rng.uniform(0.0, 80.0, n),
                rng.uniform(0.0, 360.0, n))  # fmt: skip
    truth = {"kd": 0.1, "ks": 0.4, "n": 60.0}
    measured = brdffit.synthesize("blinn", truth, geometry=geometry, noise=0.01, seed=5)
    data = dict(zip(("theta_i", "phi_i", "theta_o", "phi_o"),
                    (a.tolist() for a in measured.angles())))  # fmt: skip
    data["values"] = measured.values[:, 0].tolist()
    body = {"model": "blinn", "data": data, "loss": "l2"}
    with TestClient(create_app(settings), raise_server_exceptions=False) as client:
        _coarse_fits(client, body, truth)


def _coarse_fits(client, body, truth):
    staged = client.post("/fit", json=body | {"coarse_above": 1000, "coarse_samples": 1000})
    assert staged.status_code == 200, staged.text
    got = staged.json()
    assert "coarse to fine" in got["message"] and "1,000 of the 3,000" in got["message"]
    assert got["options"]["coarse_above"] == 1000 and got["options"]["coarse_samples"] == 1000
    assert got["params"]["n"] == pytest.approx(truth["n"], rel=0.05)
    plain = client.post("/fit", json=body).json()
    assert "coarse to fine" not in plain["message"]
    assert plain["options"]["coarse_above"] == COARSE_ABOVE
    answer = client.post("/fit", json=body | {"coarse_samples": 10})
    assert_error(answer, 422, "coarse_samples")
