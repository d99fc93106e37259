"""Polling a job of the service until it reaches a status, for the service tests."""

from __future__ import annotations

import time


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
