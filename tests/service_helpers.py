"""Helpers of the service tests (tests/service/): polling jobs, checking error answers.

Imported by name (`from service_helpers import ...`; pytest puts tests/ on the path).
Directions from angles are computed here with the math module (MODELS.md:
``w = (sin t cos p, sin t sin p, cos t)``), not by the service's code path.
"""

from __future__ import annotations

import math
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx

import brdffit
from brdffit_service.schemas import EXAMPLE_DATA

ROOT = Path(__file__).resolve().parents[1]
WARD_CSV = ROOT / "data_synthetic" / "ward.csv"
#: Limits of the shared test client (tests/service/conftest.py).
FIT_LIMIT = 800
BODY_LIMIT = 400_000
FIT_TIMEOUT = 5.0


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


# ------------------------------------------------------------- a real server
def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def serve_command(store: Path, port: int, workers: int = 1, host: str = "127.0.0.1",
                  extra=()) -> list[str]:  # fmt: skip
    """The command line of ``brdffit serve`` on ``host:port`` with its own store."""
    script = shutil.which("brdffit")
    command = [script] if script else [sys.executable, "-m", "brdffit.cli.main"]
    return [*command, "serve", "--host", host, "--port", str(port), "--store", str(store),
            "--workers", str(workers), "--log-level", "warning", *extra]  # fmt: skip


class Server:
    """``brdffit serve`` in its own process group (so that its workers can be reaped),
    on loopback; ``env``: extra environment variables (a job runner, a token)."""

    def __init__(self, store: Path, log: Path, workers: int = 1, env=None, headers=None):
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.log_path = log
        self.log = open(log, "ab")
        self.process = subprocess.Popen(
            serve_command(store, self.port, workers),
            stdout=self.log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
            env={**os.environ, **(env or {})},
        )
        self.client = httpx.Client(base_url=self.url, timeout=30.0, headers=headers)
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


def proc_stat(pid: int) -> list[str] | None:
    """The fields of /proc/<pid>/stat after the command name (state, ppid, pgrp...)."""
    try:
        return (Path("/proc") / str(pid) / "stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return None


def live_members(group: int) -> list[int]:
    """Processes of a process group that are not zombies (Linux /proc)."""
    out = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            fields = proc_stat(int(entry.name))
            if fields and int(fields[2]) == group and fields[0] != "Z":
                out.append(int(entry.name))
    return out


def wait_until_gone(group: int, seconds: float = 10.0) -> None:
    """Wait until no process of ``group`` lives (a killed server's orphaned workers)."""
    deadline = time.monotonic() + seconds
    while live_members(group) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert live_members(group) == [], "orphaned workers of a killed server still run"
