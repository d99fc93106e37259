"""Bad input the service once answered with a misleading field or message.

Each case answered 4xx before too, but named the wrong field or said the wrong
thing: the form field ``options`` that is not JSON was called "the body"; NaN
for a time limit was "not less than or equal to 1000000"; a multipart body
without a boundary named no field; a file field sent as text answered pydantic's
"Expected UploadFile, received: <class 'str'>"; and data the fit refuses (values
too large to square) were under ``values`` rather than ``data.values``.
"""

from __future__ import annotations

import json

import pytest
from service_helpers import EXAMPLE_DATA, WARD_CSV, assert_error

JSON = {"content-type": "application/json"}
JSON_DATA = json.dumps(EXAMPLE_DATA)


@pytest.mark.parametrize("route", ["/fit/file", "/jobs/file", "/comparisons/file"])
def test_options_that_are_not_json_are_the_options_fields_fault(client, route):
    form = {"models" if route == "/comparisons/file" else "model": "ward", "options": "{seed: 3"}
    answer = client.post(route, files={"file": ("ward.csv", WARD_CSV.read_bytes())}, data=form)
    body = assert_error(answer, 422, "options", "'{seed: 3' is not valid JSON")
    assert "body" not in body["message"]


@pytest.mark.parametrize(
    ("options", "field"),
    [
        ('"timeout": NaN', "timeout"),
        ('"timeout": Infinity', "timeout"),
        ('"uncertainty": true, "posterior_options": {"max_seconds": NaN}',
         "posterior_options.max_seconds"),
    ],
)  # fmt: skip
def test_a_time_limit_that_is_not_a_number_is_called_so(client, options, field):
    text = f'{{"model": "blinn", "data": {JSON_DATA}, {options}}}'
    for route in ("/fit", "/jobs"):
        assert_error(client.post(route, content=text, headers=JSON), 422, field, "finite number")


def test_a_test_fraction_that_is_not_a_number_is_called_so(client):
    answer = client.post("/comparisons/file", files={"file": ("w.csv", WARD_CSV.read_bytes())},
                         data={"models": "ward", "test_fraction": "nan"})  # fmt: skip
    assert_error(answer, 422, "test_fraction", "finite number")


def test_a_multipart_body_without_a_boundary_names_the_body(client):
    answer = client.post("/fit/file", content=b"model=ward",
                         headers={"content-type": "multipart/form-data"})  # fmt: skip
    assert_error(answer, 400, "body", "the upload form cannot be read: missing boundary")


@pytest.mark.parametrize(("route", "field"), [("/fit/file", "file"), ("/batches", "files.0")])
def test_a_file_sent_as_text_is_told_to_be_a_file(client, route, field):
    name = field.split(".")[0]
    form = {"model": "ward", "models": "ward", name: "theta_i,phi_i"}
    body = assert_error(client.post(route, data=form, files={"x": ("x", b"")}), 422, field)
    assert body["message"].endswith(
        f"must be a file, sent as a multipart part with a file name, not as text "
        f"(curl -F {name}=@data.csv)"
    )


@pytest.mark.parametrize("route", ["/fit", "/jobs"])
def test_data_the_fit_refuses_are_under_data(client, route):
    data = {**EXAMPLE_DATA, "values": [[1e200] * 3] * len(EXAMPLE_DATA["theta_i"])}
    answer = client.post(route, json={"model": "blinn", "data": data})
    assert_error(answer, 422, "data.values", "the largest value is 1e+200")


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ('{"model": "ward", "data": {"theta_i": ' + "[" * 5000 + "]" * 5000 + "}}",
         "nested deeper than this server reads"),
        ('{"model": "ward", "seed": 1' + "0" * 5000 + "}", "has more than 4300 digits"),
    ],
    ids=["nested", "long-integer"],
)  # fmt: skip
def test_json_the_parser_gives_up_on_says_why(client, text, words):
    """Before, both answered "JSON must be UTF-8 text", which they are."""
    body = assert_error(client.post("/fit", content=text, headers=JSON), 400, "body", words)
    assert "UTF-8" not in body["message"]


def test_a_field_path_names_no_pydantic_type(client):
    """Before: ``data.values.list[float].0``, and once per member of the union."""
    data = {**EXAMPLE_DATA, "values": ["a"] * len(EXAMPLE_DATA["theta_i"])}
    body = assert_error(client.post("/fit", json={"model": "ward", "data": data}), 422)
    fields = [item["field"] for item in body["errors"]]
    assert body["field"] == "data.values.0" and len(fields) == len(set(fields)), fields
    assert not any("[" in f or "float" in f for f in fields), fields
