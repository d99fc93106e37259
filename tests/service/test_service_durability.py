"""Jobs under faults (issue 18), against a real server and each job runner it has.

- the server killed with jobs running and queued: after a restart on the same
  store, every queued job runs (a worker of a dead server claims none);
- one worker process killed: only its job is affected (``interrupted``, saying
  why); the other worker's job goes on;
- a second server on the same store is refused, naming the first, and the
  first's running job goes on.

The ``runner`` fixture gives each test the environment that selects a job
runner: the process pool; the Dask runner joins it when ``brdffit_service``
has one (``dask_runner``, selected by ``BRDFFIT_SCHEDULER``).
"""

from __future__ import annotations

import importlib.util
import subprocess
import sys
import time
from pathlib import Path

import pytest
from service_helpers import (
    WARD_CSV,
    Server,
    free_port,
    proc_stat,
    serve_command,
    wait_for,
    wait_until_gone,
)

UPLOAD = {"file": ("ward.csv", WARD_CSV.read_bytes(), "text/csv")}
#: A job that runs until stopped: a million posterior steps.
SLOW = (
    '{"uncertainty": true, "posterior_options": {"steps": 1000000, "max_steps": 1000000, '
    '"max_seconds": 600}}'
)
QUICK = '{"seed": 2}'

RUNNERS = {"process": {}}
if importlib.util.find_spec("brdffit_service.dask_runner") and importlib.util.find_spec(
    "distributed"
):
    RUNNERS["dask"] = {"BRDFFIT_SCHEDULER": "local"}

pytestmark = [
    pytest.mark.skipif(sys.platform == "win32", reason="uses POSIX signals"),
    pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc (Linux)"),
]


@pytest.fixture(params=sorted(RUNNERS))
def runner(request) -> dict:
    """The environment variables that select one job runner of the service."""
    return RUNNERS[request.param]


def submit(server: Server, options: str) -> str:
    answer = server.client.post("/jobs/file", files=UPLOAD,
                                data={"model": "ward", "options": options})  # fmt: skip
    assert answer.status_code == 202, answer.text
    return answer.json()["id"]


def progressing(server: Server, job_id: str, seconds: float = 30.0) -> dict:
    """The job once it runs and has reported progress twice (its worker is alive)."""
    deadline = time.monotonic() + seconds
    first = None
    while time.monotonic() < deadline:
        job = server.client.get(f"/jobs/{job_id}").json()
        assert job["status"] in ("queued", "running"), job
        if job["progress"] is not None:
            if first is None:
                first = job["progress"]
            elif job["progress"] != first:
                return job
        time.sleep(0.2)
    raise AssertionError(f"job {job_id} made no progress in {seconds} s")


def worker_pids(server_pid: int) -> list[int]:
    """The server's worker processes (spawned children running jobs)."""
    out = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit() and (fields := proc_stat(int(entry.name))):
            if int(fields[1]) == server_pid and fields[0] != "Z":
                cmdline = (entry / "cmdline").read_bytes()
                if b"spawn_main" in cmdline:
                    out.append(int(entry.name))
    return out


def test_every_queued_job_runs_after_the_server_is_killed(tmp_path, runner):
    store, log = tmp_path / "jobs.sqlite3", tmp_path / "server.log"
    first = Server(store, log, workers=2, env=runner)
    try:
        slow = [submit(first, SLOW) for _ in range(2)]
        for job_id in slow:
            progressing(first, job_id)
        queued = [submit(first, QUICK) for _ in range(3)]
        jobs = [first.client.get(f"/jobs/{job_id}").json() for job_id in queued]
        assert [job["status"] for job in jobs] == ["queued"] * 3
        first.kill()
        wait_until_gone(first.process.pid)
    finally:
        first.reap()
    second = Server(store, log, workers=2, env=runner)
    try:
        for job_id in slow:
            assert second.client.get(f"/jobs/{job_id}").json()["status"] == "interrupted"
        for job_id in queued:
            job = wait_for(second.client, job_id, seconds=30)
            assert job["status"] == "done" and job["attempt"] == 1, job
    finally:
        second.reap()


def _settled(job: dict) -> bool:
    """Whether a job has left its first attempt for good: interrupted (the process
    pool) or running again (Dask), not caught between Dask's interruption of the lost
    attempt and its rerun (``run_job_on_dask`` interrupts, then requeues)."""
    if job["attempt"] > 1:
        return True
    if job["status"] == "running":
        return False
    message = (job.get("error") or {}).get("message", "")
    return "Dask worker running this job was lost" not in message


def test_a_dead_worker_takes_only_its_own_job(tmp_path, runner):
    store, log = tmp_path / "jobs.sqlite3", tmp_path / "server.log"
    server = Server(store, log, workers=2, env=runner)
    try:
        jobs = [submit(server, SLOW) for _ in range(2)]
        for job_id in jobs:
            progressing(server, job_id)
        workers = worker_pids(server.process.pid)
        assert len(workers) == 2, workers
        subprocess.run(["kill", "-KILL", str(workers[0])], check=True)
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline:
            states = [server.client.get(f"/jobs/{job_id}").json() for job_id in jobs]
            hit = [job for job in states if _settled(job)]
            if hit:
                break
            time.sleep(0.2)
        assert len(hit) == 1, states
        if hit[0]["status"] == "interrupted":  # the process pool: the reason is given
            assert "worker running this job died" in hit[0]["error"]["message"]
            assert "exit code -9" in hit[0]["error"]["message"]
        else:  # a runner that retries: the job runs again as a new attempt
            assert hit[0]["attempt"] == 2, hit[0]
        other = next(job_id for job_id in jobs if job_id != hit[0]["id"])
        assert progressing(server, other)["attempt"] == 1
        assert server.client.post(f"/jobs/{other}/cancel").status_code == 200
    finally:
        server.reap()


def test_a_second_server_on_the_same_store_is_refused(tmp_path, runner):
    store, log = tmp_path / "jobs.sqlite3", tmp_path / "server.log"
    first = Server(store, log, workers=1, env=runner)
    try:
        job_id = submit(first, SLOW)
        progressing(first, job_id)
        second = subprocess.run(serve_command(store, free_port(), 1), capture_output=True,
                                text=True, timeout=30)  # fmt: skip
        assert second.returncode != 0
        assert f"another brdffit server (process {first.process.pid})" in second.stderr
        assert str(store) in second.stderr
        job = progressing(first, job_id)
        assert job["status"] == "running" and job["attempt"] == 1
    finally:
        first.reap()
        wait_until_gone(first.process.pid)
