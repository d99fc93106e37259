"""The form field ``models`` of POST /comparisons/file and POST /batches: one reading.

Both split it the same way and refuse it with the same message naming the field,
the value and what is needed. Before, /batches said "models names no model" for
an empty list where /comparisons/file said "give 1 to 12 model names", and an
unknown name in a batch was refused under the field ``model`` (which /batches
does not have) with no mention of the field's value.
"""

from __future__ import annotations

import pytest
from service_helpers import WARD_CSV, assert_error

import brdffit
from brdffit_service.convert import model_names
from brdffit_service.routes.comparisons import MAX_MODELS

ROUTES = ["/comparisons/file", "/batches"]


def _post(client, route: str, models: str):
    part = "file" if route == "/comparisons/file" else "files"
    files = [(part, ("ward.csv", WARD_CSV.read_bytes(), "text/csv"))]
    return client.post(route, files=files, data={"models": models})


@pytest.mark.parametrize(
    ("models", "words"),
    [
        (" , ", "' , ': give 1 to"),
        ("ward, wardd", "models='ward, wardd': unknown model 'wardd' (did you mean ward?)"),
    ],
)
def test_both_routes_refuse_bad_model_names_alike(client, models, words):
    answers = [_post(client, route, models) for route in ROUTES]
    bodies = [assert_error(a, 422, "models", words) for a in answers]
    assert bodies[0]["message"].split(" to ")[0] == bodies[1]["message"].split(" to ")[0]
    assert bodies[0]["kind"] == bodies[1]["kind"]


def test_model_names_are_split_trimmed_and_deduplicated():
    assert model_names(" ward, lambert+ggx ,ward,", most=3) == ["ward", "lambert+ggx"]
    too_many = ",".join(sorted(brdffit.models.REGISTRY)[: MAX_MODELS + 1])
    with pytest.raises(Exception, match=f"give 1 to {MAX_MODELS} model names") as error:
        model_names(too_many, most=MAX_MODELS)
    assert error.value.field == "models" and too_many in str(error.value)
