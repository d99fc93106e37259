"""Every upload route names a fault of an uploaded file alike: by the form field, as a
dotted path (``file.header``), as a JSON body's faults are (``data.theta_i``).

Before, POST /comparisons/file said ``file.header`` where /fit/file and /jobs/file
said ``header`` (no field of their form) and /batches ``files[0]`` (not saying
what in the file was wrong).
"""

from __future__ import annotations

import pytest
from service_helpers import assert_error

ROUTES = ["/fit/file", "/jobs/file", "/comparisons/file", "/batches"]
BAD_HEADER = ("mine.csv", b"a,b\n1,2\n")
TRUNCATED = ("cut.bsdf", b"tensor_file\x00\x01\x00")
UNKNOWN = ("blob", bytes(range(256)) * 4)


def _post(client, route: str, upload, **form):
    if route == "/batches":
        return client.post(route, files=[("files", upload)], data={"models": "ward", **form})
    data = {"models" if route == "/comparisons/file" else "model": "ward", **form}
    return client.post(route, files={"file": upload}, data=data)


@pytest.mark.parametrize("route", ROUTES)
@pytest.mark.parametrize(
    ("upload", "form", "part", "words"),
    [
        (BAD_HEADER, {}, ".header", "mine.csv, line 1: bad header"),
        (TRUNCATED, {}, "", "cut.bsdf is truncated"),
        (UNKNOWN, {}, None, "cannot tell the format"),
        (BAD_HEADER, {"format": "nope"}, None, "unknown format 'nope'"),
    ],
    ids=["content", "whole-file", "format-unknown", "format-field"],
)
def test_upload_faults_name_the_form_field(client, route, upload, form, part, words):
    file_field = "files[0]" if route == "/batches" else "file"
    field = "format" if part is None else file_field + part
    assert_error(_post(client, route, upload, **form), 422, field, words)
