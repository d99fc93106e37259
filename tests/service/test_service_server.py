"""A real server: ``brdffit serve`` on loopback, killed with SIGKILL mid-job, restarted.

Checks what no in-process client can: that a job's row is on disk before the
202, that a finished result survives the death of the server, that the job it
was running is marked ``interrupted`` at the next start (and stays so: the
orphaned worker must not overwrite it), and that it can be resubmitted.
"""

from __future__ import annotations

import json
import socket
import sys
import time
from pathlib import Path

import pytest
from service_helpers import WARD_CSV as WARD
from service_helpers import Server, wait_for, wait_until_gone

import brdffit

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="uses POSIX signals")


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
            wait_until_gone(first.process.pid)
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


def raw_request(port: int, head: bytes) -> tuple[int, dict, dict]:
    """Send ``head`` on a socket of its own; the status, headers and JSON body answered."""
    with socket.create_connection(("127.0.0.1", port), timeout=10) as sock:
        sock.sendall(head)
        chunks = []
        while chunk := sock.recv(65536):
            chunks.append(chunk)
    status_line, _, rest = b"".join(chunks).partition(b"\r\n")
    header_block, _, body = rest.partition(b"\r\n\r\n")
    headers = dict(
        line.decode().lower().split(": ", 1) for line in header_block.split(b"\r\n") if line
    )
    return int(status_line.split()[1]), headers, json.loads(body)


def test_a_malformed_content_length_answers_json_naming_the_header(tmp_path):
    """uvicorn's parser refuses these before the app sees them; its 400 was plain text."""
    server = Server(tmp_path / "jobs.sqlite3", tmp_path / "server.log")
    try:
        for length in ("abc", "-1", "1" * 30):
            head = (f"POST /fit HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json"
                    f"\r\nContent-Length: {length}\r\n\r\n{{}}").encode()  # fmt: skip
            status, headers, body = raw_request(server.port, head)
            assert status == 400 and headers["content-type"] == "application/json", length
            assert body["field"] == "content-length" and body["kind"] == "HTTPError"
            assert "Content-Length" in body["message"]
            assert body["errors"][0]["field"] == body["field"]
        assert server.client.get("/health").status_code == 200  # the server goes on
        # A 5,000-character file name: the multipart parser's limit on a part's headers.
        upload = {"file": ("n" * 5000 + ".csv", WARD.read_bytes(), "text/csv")}
        named = server.client.post("/fit/file", files=upload, data={"model": "ward"})
        assert named.status_code == 400 and named.json()["field"] == "file"
        assert "file name" in named.json()["message"]
    finally:
        server.reap()
