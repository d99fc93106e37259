"""A real server: ``brdffit serve`` on loopback, killed with SIGKILL mid-job, restarted.

Checks what no in-process client can: that a job's row is on disk before the
202, that a finished result survives the death of the server, that the job it
was running is marked ``interrupted`` at the next start (and stays so: the
orphaned worker must not overwrite it), and that it can be resubmitted.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest
from service_helpers import wait_for

import brdffit

ROOT = Path(__file__).resolve().parents[2]
WARD = ROOT / "data_synthetic" / "ward.csv"

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="uses POSIX signals")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Server:
    """``brdffit serve`` in its own process group (so that its workers can be reaped)."""

    def __init__(self, store: Path, log: Path):
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        script = shutil.which("brdffit")
        command = [script] if script else [sys.executable, "-m", "brdffit.cli.main"]
        self.log = open(log, "ab")
        self.process = subprocess.Popen(
            [
                *command,
                "serve",
                "--host",
                "127.0.0.1",
                "--port",
                str(self.port),
                "--store",
                str(store),
                "--workers",
                "1",
                "--log-level",
                "warning",
            ],
            stdout=self.log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
        self.client = httpx.Client(base_url=self.url, timeout=30.0)
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            assert self.process.poll() is None, log.read_text()
            try:
                if self.client.get("/health").status_code == 200:
                    return
            except httpx.TransportError:
                time.sleep(0.2)
        raise AssertionError(f"the server did not start:\n{log.read_text()}")

    def kill(self) -> None:
        """SIGKILL the server process only, as a crash would."""
        self.process.send_signal(signal.SIGKILL)
        self.process.wait(timeout=10)
        self.client.close()

    def reap(self) -> None:
        """End whatever is left of this server's process group (its own children)."""
        try:
            os.killpg(self.process.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        self.process.wait(timeout=10)
        self.client.close()
        self.log.close()


def live_members(group: int) -> list[int]:
    """Processes of a process group that are not zombies (Linux /proc)."""
    out = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[2]) == group and fields[0] != "Z":
                out.append(int(entry.name))
    return out


def wait_for_posterior(client, job_id: str, seconds: float = 30.0) -> None:
    """Wait until the running job reports progress of its posterior."""
    running = wait_for(client, job_id, ("running",))
    deadline = time.monotonic() + seconds
    while running["progress"] is None or running["progress"]["stage"] != "posterior":
        assert time.monotonic() < deadline, running
        time.sleep(0.2)
        running = client.get(f"/jobs/{job_id}").json()


def test_results_survive_a_crash_and_the_cut_job_is_interrupted(tmp_path):
    store, log = tmp_path / "jobs.sqlite3", tmp_path / "server.log"
    upload = {"file": ("ward.csv", WARD.read_bytes(), "text/csv")}
    expected = brdffit.fit(brdffit.read(WARD), "ward", seed=2).to_dict()
    first = Server(store, log)
    try:
        fitted = first.client.post(
            "/fit/file", files=upload, data={"model": "ward", "options": '{"seed": 2}'}
        )
        assert fitted.status_code == 200, fitted.text
        assert fitted.json()["params"] == expected["params"]

        quick = first.client.post(
            "/jobs/file", files=upload, data={"model": "ward", "options": '{"seed": 2}'}
        )
        assert quick.status_code == 202, quick.text
        quick_id = quick.json()["id"]
        done = wait_for(first.client, quick_id, ("done", "failed"))
        assert done["status"] == "done" and done["result"]["params"] == expected["params"]

        # A million posterior steps: the server dies long before they end.
        slow_options = (
            '{"uncertainty": true, "posterior_options": {"steps": 1000000, '
            '"max_steps": 1000000, "max_seconds": 600}}'
        )
        slow = first.client.post(
            "/jobs/file", files=upload, data={"model": "ward", "options": slow_options}
        )
        slow_id = slow.json()["id"]
        wait_for_posterior(first.client, slow_id)
        first.kill()
        if Path("/proc/self/stat").exists():
            # The orphaned worker notices that its server is gone and leaves by itself.
            deadline = time.monotonic() + 10
            while live_members(first.process.pid) and time.monotonic() < deadline:
                time.sleep(0.2)
            assert live_members(first.process.pid) == []
    finally:
        first.reap()

    second = Server(store, log)
    try:
        kept = second.client.get(f"/jobs/{quick_id}").json()
        assert kept["status"] == "done" and kept["result"] == done["result"]
        cut = second.client.get(f"/jobs/{slow_id}").json()
        assert cut["status"] == "interrupted" and "resubmit" in cut["error"]["message"]
        time.sleep(1.5)  # longer than a worker's progress interval: an orphan would have written
        assert second.client.get(f"/jobs/{slow_id}").json()["status"] == "interrupted"
        assert second.client.get("/health").json()["jobs"]["interrupted"] == 1

        again = second.client.post(f"/jobs/{slow_id}/resubmit")
        assert again.status_code == 202 and again.json()["attempt"] == 2
        assert wait_for(second.client, slow_id, ("running",))["attempt"] == 2
        assert second.client.delete(f"/jobs/{slow_id}").status_code == 204
    finally:
        second.reap()
