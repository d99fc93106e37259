"""Closing the job runner with a job still queued returns (it deadlocked: close() held
the runner's lock while cancelling the queued future, whose callback takes it too)."""

from __future__ import annotations

import threading
from concurrent.futures import ThreadPoolExecutor

from service_helpers import example_measurements

from brdffit_service.jobs import JobRunner
from brdffit_service.store import JobStore, data_to_bytes


def test_close_with_a_queued_job_returns(tmp_path):
    store = JobStore(tmp_path / "jobs.sqlite3")
    blob = data_to_bytes(example_measurements())
    # A posterior stopped by its 3 s budget keeps the one thread busy; the second waits.
    busy = {"timeout": 3.0, "uncertainty": True,
            "posterior_options": {"steps": 1_000_000, "max_seconds": 3.0}}  # fmt: skip
    executor = ThreadPoolExecutor(1)
    runner = JobRunner(store, executor_factory=lambda: executor)
    running, queued = (store.create("blinn", busy, blob) for _ in range(2))
    runner.submit(running["id"], 1)
    runner.submit(queued["id"], 1)
    closing = threading.Thread(target=runner.close, daemon=True)
    closing.start()
    closing.join(timeout=10)
    assert not closing.is_alive(), "JobRunner.close() hangs with a job queued"
    assert store.get(queued["id"])["status"] == "queued"  # the next server runs it
    executor.shutdown(wait=True)
