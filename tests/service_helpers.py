"""Helpers of the service tests (tests/service/): polling jobs, checking error answers.

Imported by name (`from service_helpers import ...`; pytest puts tests/ on the path).
Directions from angles are computed here with the math module (MODELS.md:
``w = (sin t cos p, sin t sin p, cos t)``), not by the service's code path.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import brdffit
from brdffit_service.schemas import EXAMPLE_DATA

ROOT = Path(__file__).resolve().parents[1]
WARD_CSV = ROOT / "data_synthetic" / "ward.csv"
#: Limits of the shared test client (tests/service/conftest.py).
FIT_LIMIT = 800
BODY_LIMIT = 400_000


def wait_for(client, job_id: str, statuses=("done", "failed", "interrupted"), seconds=60.0):
    """The job's JSON once its status is one of ``statuses``; fails after ``seconds``.

    ``client`` is anything with ``get(url).json()``: the test client or httpx.
    """
    deadline = time.monotonic() + seconds
    job = None
    while time.monotonic() < deadline:
        job = client.get(f"/jobs/{job_id}").json()
        if job["status"] in statuses:
            return job
        time.sleep(0.1)
    raise AssertionError(f"job {job_id} is still {job and job['status']} after {seconds} s")


def example_measurements() -> brdffit.Measurements:
    d = EXAMPLE_DATA
    return brdffit.Measurements.from_angles(
        d["theta_i"], d["phi_i"], d["theta_o"], d["phi_o"], d["values"], channels=d["channels"]
    )


def direction(theta_deg: float, phi_deg: float) -> list[float]:
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return [math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)]


def without_seconds(d):
    if isinstance(d, dict):
        return {k: without_seconds(v) for k, v in d.items() if k != "seconds"}
    return d


def assert_error(response, status: int, field: str | None = None, words: str = ""):
    assert response.status_code == status, response.text
    body = response.json()
    assert set(body) >= {"field", "message", "kind", "errors"}
    if field is not None:
        assert body["field"] == field, body
    assert words.lower() in body["message"].lower(), body
    return body
