"""The service's jobs on a Dask LocalCluster started by the test (service/dask_runner.py)."""

from __future__ import annotations

import os
import signal
import time

import pytest
from service_helpers import WARD_CSV

distributed = pytest.importorskip(
    "distributed", reason="Dask distributed is absent: pip install 'brdffit[batch]'"
)

import brdffit  # noqa: E402
from brdffit_service.dask_runner import DaskJobRunner, runner_for  # noqa: E402
from brdffit_service.store import JobStore, data_to_bytes  # noqa: E402

LONG = {"seed": 1, "global_evals": 3000}  # about a second on 20 000 samples


@pytest.fixture(scope="module")
def cluster():
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
        dashboard_address="127.0.0.1:0",
    ) as c:  # fmt: skip
        yield c


@pytest.fixture(scope="module")
def big():
    return brdffit.synthesize("ggx", geometry="hemisphere", n=20_000, noise=0.01, seed=3)


def _wait(store, ids, statuses, seconds=60):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        jobs = [store.get(i) for i in ids]
        if all(j is not None and j["status"] in statuses for j in jobs):
            return jobs
        time.sleep(0.05)
    pytest.fail(f"jobs did not reach {statuses}: {[store.get(i) for i in ids]}")


def test_jobs_run_on_the_cluster_and_equal_a_plain_fit(cluster, tmp_path):
    store = JobStore(tmp_path / "jobs.sqlite3")
    data = brdffit.read(WARD_CSV)
    runner = runner_for(store, 2, cluster.scheduler_address)
    assert isinstance(runner, DaskJobRunner)
    try:
        with distributed.get_task_stream(runner.client) as stream:
            jobs = [store.create(m, {"seed": 2}, data_to_bytes(data)) for m in ("ward", "blinn")]
            for job in jobs:
                runner.submit(job["id"], job["attempt"])
            done = _wait(store, [j["id"] for j in jobs], {"done", "failed"})
            time.sleep(0.5)  # the task stream learns of a task after the store does
    finally:
        runner.close()
    assert [j["status"] for j in done] == ["done", "done"]
    ran = [t for t in stream.data if t["key"].startswith("run_job_on_dask")]
    assert len(ran) == 2 and {t["worker"] for t in ran} <= set(cluster.scheduler.workers)
    for job in done:
        plain = brdffit.fit(data, job["model"], seed=2)
        assert job["result"]["loss"] == plain.loss
        assert job["result"]["n_evals"] == plain.n_evals


def test_a_restart_of_the_service_loses_no_job(cluster, big, tmp_path):
    store = JobStore(tmp_path / "jobs.sqlite3")
    address = cluster.scheduler_address
    runner = runner_for(store, 2, address)
    ids = []
    for _ in range(3):  # two run when the service stops, one waits
        job = store.create("ggx", {"seed": 1, "global_evals": 1500}, data_to_bytes(big))
        ids.append(job["id"])
        runner.submit(job["id"], job["attempt"])
    _wait(store, ids[:1], {"running"})
    runner.close()  # the service stops with jobs running and queued
    # The next start, as service/app.py's lifespan does it:
    queued = store.recover()
    assert queued and {i for i, _ in queued} < set(ids)
    runner = runner_for(store, 2, address)
    try:
        for job_id, attempt in queued:
            runner.submit(job_id, attempt)
        jobs = _wait(store, ids, {"done", "interrupted"})
        assert {j["status"] for j in jobs if j["id"] in dict(queued)} == {"done"}
        for job in jobs:  # cut short: resubmitted, as POST /jobs/{id}/resubmit does
            if job["status"] == "interrupted":
                runner.submit(job["id"], store.requeue(job["id"]))
        jobs = _wait(store, ids, {"done"})
    finally:
        runner.close()
    losses = {j["result"]["loss"] for j in jobs}
    assert len(losses) == 1  # the same data and seed on whichever worker


def test_a_worker_lost_mid_job_runs_it_again(cluster, big, tmp_path):
    store = JobStore(tmp_path / "jobs.sqlite3")
    runner = DaskJobRunner(store, cluster.scheduler_address)
    try:
        job = store.create("ggx", LONG, data_to_bytes(big))
        runner.submit(job["id"], job["attempt"])
        _wait(store, [job["id"]], {"running"})
        busy = [w for w, keys in runner.client.processing().items() if keys]
        pid = runner.client.run(os.getpid, workers=busy)[busy[0]]
        os.kill(pid, signal.SIGKILL)
        # (interrupted for a moment, between the takeover's two steps)
        (done,) = _wait(store, [job["id"]], {"done", "failed"})
    finally:
        runner.close()
    assert done["status"] == "done" and done["attempt"] == 2


def test_a_cancelled_job_stops_and_writes_nothing(cluster, big, tmp_path):
    store = JobStore(tmp_path / "jobs.sqlite3")
    runner = DaskJobRunner(store, cluster.scheduler_address)
    try:
        job = store.create("ggx", {"seed": 1, "global_evals": 30_000}, data_to_bytes(big))
        runner.submit(job["id"], job["attempt"])
        _wait(store, [job["id"]], {"running"})
        store.delete(job["id"])  # what DELETE /jobs/{id} does
        runner.cancel(job["id"])
        deadline = time.monotonic() + 5  # the fit alone would take over 10 s
        while any(runner.client.processing().values()) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not any(runner.client.processing().values()), "the cancelled fit goes on"
    finally:
        runner.close()
    assert store.get(job["id"]) is None


def test_without_a_scheduler_the_service_keeps_its_own_pool(tmp_path):
    store = JobStore(tmp_path / "jobs.sqlite3")
    runner = runner_for(store, 1, None)
    try:
        assert not isinstance(runner, DaskJobRunner)
    finally:
        runner.close()


def test_the_scheduler_setting_comes_from_brdffit_scheduler():
    from brdffit_service import Settings

    assert Settings.from_env({"BRDFFIT_SCHEDULER": "tcp://127.0.0.1:8786"}).scheduler == (
        "tcp://127.0.0.1:8786"
    )
    assert Settings.from_env({}).scheduler is None
