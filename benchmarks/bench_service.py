"""Latency and throughput of ``POST /fit`` against a real server on loopback.

Starts ``brdffit serve`` on 127.0.0.1 (a free port, a temporary job store), then
for 1, 4 and 16 concurrent clients (threads, one HTTP connection each) sends
``POST /fit`` of a blinn dataset of 1,000 samples (3 channels, 1 % noise) and
reports the median and 99th-percentile latency, the throughput and the errors
(any answer but 200). In the same run, the same fit called in-process
(``brdffit.fit``) gives the floor that HTTP, JSON and validation add to, and the
server runs twice: with synchronous fits on the server's threads (the default,
``--fit-workers 0``) and in two worker processes (``2``), the obvious alternative.

Run from the project root::

    python benchmarks/bench_service.py            # 1, 4, 16 clients; 0 then 2 fit workers
    python benchmarks/bench_service.py --requests 200 --clients 1 4 16 64 --fit-workers 2
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import httpx
import numpy as np

import brdffit


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def body_of(data: brdffit.Measurements) -> bytes:
    d = data.to_dict(include_data=True)
    keys = ("theta_i", "phi_i", "theta_o", "phi_o", "values", "channels")
    payload = {k: d[k] for k in keys if k in d} | {"channels": list(data.channels)}
    return json.dumps({"model": "blinn", "data": payload}).encode()


def start_server(store: Path, workers: int, fit_workers: int) -> tuple[subprocess.Popen, str]:
    port = free_port()
    script = shutil.which("brdffit")
    command = [script] if script else [sys.executable, "-m", "brdffit.cli.main"]
    process = subprocess.Popen(
        [
            *command,
            "serve",
            "--host",
            "127.0.0.1",
            "--port",
            str(port),
            "--store",
            str(store),
            "--workers",
            str(workers),
            "--log-level",
            "warning",
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            if httpx.get(url + "/health", timeout=2).status_code == 200:
                return process, url
        except httpx.TransportError:
            time.sleep(0.2)
    process.kill()
    raise SystemExit("the server did not start")


def run_clients(url: str, body: bytes, clients: int, per_client: int) -> dict:
    latencies: list[float] = []
    errors: list[str] = []
    lock = threading.Lock()
    headers = {"content-type": "application/json"}

    def client():
        with httpx.Client(base_url=url, timeout=120) as session:
            for _ in range(per_client):
                t0 = time.perf_counter()
                try:
                    answer = session.post("/fit", content=body, headers=headers)
                    ok = answer.status_code == 200
                    reason = f"{answer.status_code} {answer.text[:100]}"
                except httpx.HTTPError as exc:
                    ok, reason = False, repr(exc)
                elapsed = time.perf_counter() - t0
                with lock:
                    latencies.append(elapsed)
                    if not ok:
                        errors.append(reason)

    threads = [threading.Thread(target=client) for _ in range(clients)]
    t0 = time.perf_counter()
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    wall = time.perf_counter() - t0
    ms = np.array(latencies) * 1000
    return {
        "clients": clients,
        "requests": len(latencies),
        "p50_ms": float(np.percentile(ms, 50)),
        "p99_ms": float(np.percentile(ms, 99)),
        "throughput": len(latencies) / wall,
        "errors": len(errors),
        "first_error": errors[0] if errors else "",
    }


def in_process(data, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        brdffit.fit(data, "blinn")
        times.append(time.perf_counter() - t0)
    return float(np.median(times) * 1000)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--clients", type=int, nargs="+", default=[1, 4, 16])
    parser.add_argument("--requests", type=int, default=96, help="requests per level (96)")
    parser.add_argument("--workers", type=int, default=1, help="job workers of the server")
    parser.add_argument(
        "--fit-workers",
        type=int,
        nargs="+",
        default=[0, 2],
        help="processes for POST /fit; 0 runs fits on the server's threads",
    )
    args = parser.parse_args()

    truth = {"kd": [0.3, 0.2, 0.1], "ks": 0.6, "n": 80.0}
    data = brdffit.synthesize("blinn", truth, geometry="hemisphere", n=1000, noise=0.01, seed=0)
    body = body_of(data)
    before = in_process(data, 20)
    rows = []
    for fit_workers in args.fit_workers:
        with tempfile.TemporaryDirectory() as tmp:
            process, url = start_server(Path(tmp) / "jobs.sqlite3", args.workers, fit_workers)
            try:
                run_clients(url, body, 2, 4)  # warm up (both fit workers when there are two)
                for c in args.clients:
                    row = run_clients(url, body, c, max(args.requests // c, 1))
                    rows.append(row | {"fit_workers": fit_workers})
            finally:
                os.killpg(process.pid, signal.SIGTERM)
                process.wait(timeout=30)
    # Measured before and after, as the shared machine's load drifts during the run.
    after = in_process(data, 20)
    print(
        f"machine: {platform.machine()}, {os.cpu_count()} cores, {platform.system()} "
        f"{platform.release()}, Python {platform.python_version()}"
    )
    print(f"load average (1, 5, 15 min): {', '.join(f'{x:.1f}' for x in os.getloadavg())}")
    print(
        f"body: {len(body)} bytes; brdffit.fit in-process, median of 20: {before:.0f} ms "
        f"before the run, {after:.0f} ms after\n"
    )
    print(
        "| fit workers | clients | requests | p50 (ms) | p99 (ms) | throughput (req/s) | errors |"
    )
    print("|--:|--:|--:|--:|--:|--:|--:|")
    for r in rows:
        print(
            f"| {r['fit_workers']} | {r['clients']} | {r['requests']} | {r['p50_ms']:.0f} | "
            f"{r['p99_ms']:.0f} | {r['throughput']:.1f} | {r['errors']} |"
        )
    failed = [r for r in rows if r["errors"]]
    if failed:
        raise SystemExit(f"errors: {failed[0]['first_error']}")


if __name__ == "__main__":
    main()
