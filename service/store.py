"""Jobs and their results in SQLite: durable across restarts and crashes.

One table, ``jobs``; one row per job, written before the service answers 202,
so that nothing a client was told is accepted can be lost. WAL mode lets the
worker processes write progress while the web process reads; ``synchronous=
FULL`` makes every commit survive a crash of the machine, not only of the
process.

Every write of a worker names the job's ``attempt``: a job resubmitted, or
marked ``interrupted`` by a restart, no longer accepts writes from the run it
had before (an orphaned worker of a killed server cannot overwrite it).
"""

from __future__ import annotations

import io
import json
import sqlite3
import time
import uuid
from contextlib import closing
from datetime import datetime, timezone
from pathlib import Path

import brdffit
from brdffit.fitting.options import weights_summary

__all__ = ["JobStore", "data_from_bytes", "data_to_bytes", "iso"]

SCHEMA = """
CREATE TABLE IF NOT EXISTS jobs (
    id TEXT PRIMARY KEY,
    status TEXT NOT NULL,
    model TEXT NOT NULL,
    options TEXT NOT NULL,
    data BLOB NOT NULL,
    created REAL NOT NULL,
    started REAL,
    finished REAL,
    attempt INTEGER NOT NULL,
    progress TEXT,
    result TEXT,
    error TEXT,
    notes TEXT
);
CREATE INDEX IF NOT EXISTS jobs_status ON jobs (status);
"""
STATUSES = ("queued", "running", "done", "failed", "interrupted", "cancelled")
CANCELLED = (
    "cancelled on request; its inputs are kept: POST /jobs/{id}/resubmit runs it again, "
    "DELETE /jobs/{id} deletes it"
)
INTERRUPTED = (
    "the server stopped while this job ran; POST /jobs/{id}/resubmit runs it again "
    "(its inputs are kept)"
)


def iso(seconds: float | None) -> str | None:
    """ISO 8601 time in UTC of a POSIX timestamp."""
    if seconds is None:
        return None
    return datetime.fromtimestamp(seconds, timezone.utc).isoformat(timespec="milliseconds")


def data_to_bytes(data: brdffit.Measurements) -> bytes:
    """Measurements as the bytes of a brdffit ``.npz`` archive (lossless, no pickle)."""
    buffer = io.BytesIO()
    brdffit.write(buffer, data, format="npz")
    return buffer.getvalue()


def data_from_bytes(blob: bytes) -> brdffit.Measurements:
    """The Measurements of :func:`data_to_bytes`."""
    return brdffit.read(blob, format="npz")


def connect(path) -> closing:
    """A short-lived connection to the service's SQLite file (jobs, comparisons and
    plots share it), closed on leaving its ``with``: one per operation, since
    handlers run on several threads and workers in other processes, and opening a
    SQLite file costs microseconds. Rows by name and index; every commit durable;
    a writer waits up to 30 s for another."""
    db = sqlite3.connect(path, timeout=30.0, isolation_level=None)
    db.row_factory = sqlite3.Row
    db.execute("PRAGMA synchronous=FULL")
    db.execute("PRAGMA busy_timeout=30000")
    return closing(db)


class JobStore:
    """The SQLite file of jobs at ``path`` (created with its folder if absent)."""

    def __init__(self, path):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with self._connect() as db:
            db.execute("PRAGMA journal_mode=WAL")
            db.executescript(SCHEMA)
            # A store written before jobs kept their data notes gains the column.
            columns = {row["name"] for row in db.execute("PRAGMA table_info(jobs)")}
            if "notes" not in columns:
                db.execute("ALTER TABLE jobs ADD COLUMN notes TEXT")

    def _connect(self):
        return connect(self.path)

    # ------------------------------------------------------------ web process
    def create(self, model: str, options: dict, data: bytes, notes=()) -> dict:
        """Store a queued job; ``notes``: what reading its data noticed."""
        job_id = uuid.uuid4().hex
        with self._connect() as db:
            db.execute(
                "INSERT INTO jobs (id, status, model, options, data, created, attempt, notes) "
                "VALUES (?, 'queued', ?, ?, ?, ?, 1, ?)",
                (job_id, model, json.dumps(options), sqlite3.Binary(data), time.time(),
                 json.dumps(list(notes))),
            )  # fmt: skip
        return self.get(job_id)

    def get(self, job_id: str) -> dict | None:
        """The job as a dict (without its inputs), or None."""
        with self._connect() as db:
            row = db.execute(
                "SELECT id, status, model, created, started, finished, attempt, progress, "
                "result, error, notes FROM jobs WHERE id = ?",
                (job_id,),
            ).fetchone()
        return None if row is None else _public(row)

    def list(self, status: str | None = None, limit: int = 100) -> list[dict]:
        query = "SELECT id, status, model, created, started, finished, attempt FROM jobs"
        args: tuple = ()
        if status is not None:
            query += " WHERE status = ?"
            args = (status,)
        with self._connect() as db:
            rows = db.execute(query + " ORDER BY created DESC LIMIT ?", (*args, limit))
            return [_public(row) for row in rows.fetchall()]

    def cancel(self, job_id: str) -> bool:
        """Mark a queued or running job ``cancelled``, keeping it (a running one stops at
        its next progress report, its writes refused); False when it is neither."""
        message = CANCELLED.replace("{id}", job_id)
        error = json.dumps({"field": None, "message": message, "kind": "Cancelled"})
        with self._connect() as db:
            return (
                db.execute(
                    "UPDATE jobs SET status = 'cancelled', finished = ?, error = ? "
                    "WHERE id = ? AND status IN ('queued', 'running')",
                    (time.time(), error, job_id),
                ).rowcount
                > 0
            )

    def delete(self, job_id: str) -> bool:
        with self._connect() as db:
            return db.execute("DELETE FROM jobs WHERE id = ?", (job_id,)).rowcount > 0

    def counts(self) -> dict:
        with self._connect() as db:
            rows = db.execute("SELECT status, COUNT(*) FROM jobs GROUP BY status").fetchall()
        return {status: 0 for status in STATUSES} | {row[0]: row[1] for row in rows}

    def recover(self) -> list[tuple[str, int]]:
        """At start-up: running jobs become ``interrupted``; queued ones are returned to
        be submitted again (they never started, so running them is what was promised)."""
        error = json.dumps({"field": None, "message": INTERRUPTED, "kind": "Interrupted"})
        with self._connect() as db:
            db.execute(
                "UPDATE jobs SET status = 'interrupted', finished = ?, error = ? "
                "WHERE status = 'running'",
                (time.time(), error),
            )
            rows = db.execute(
                "SELECT id, attempt FROM jobs WHERE status = 'queued' ORDER BY created"
            ).fetchall()
        return [(row[0], row[1]) for row in rows]

    def requeue(self, job_id: str) -> int | None:
        """Queue an interrupted, failed or cancelled job again; its new attempt, or None."""
        with self._connect() as db:
            changed = db.execute(
                "UPDATE jobs SET status = 'queued', attempt = attempt + 1, started = NULL, "
                "finished = NULL, progress = NULL, result = NULL, error = NULL "
                "WHERE id = ? AND status IN ('interrupted', 'failed', 'cancelled')",
                (job_id,),
            ).rowcount
            if not changed:
                return None
            return db.execute("SELECT attempt FROM jobs WHERE id = ?", (job_id,)).fetchone()[0]

    def interrupt(self, job_id: str, attempt: int, message: str) -> None:
        """Mark a queued or running attempt interrupted (its worker died)."""
        error = json.dumps({"field": None, "message": message, "kind": "Interrupted"})
        with self._connect() as db:
            db.execute(
                "UPDATE jobs SET status = 'interrupted', finished = ?, error = ? "
                "WHERE id = ? AND attempt = ? AND status IN ('queued', 'running')",
                (time.time(), error, job_id, attempt),
            )

    # --------------------------------------------------------- worker process
    def start(self, job_id: str, attempt: int):
        """Claim a queued attempt: ``(model, options, data bytes)``, or None if it is gone."""
        with self._connect() as db:
            claimed = db.execute(
                "UPDATE jobs SET status = 'running', started = ? "
                "WHERE id = ? AND attempt = ? AND status = 'queued'",
                (time.time(), job_id, attempt),
            ).rowcount
            if not claimed:
                return None
            row = db.execute(
                "SELECT model, options, data FROM jobs WHERE id = ?", (job_id,)
            ).fetchone()
        return row["model"], json.loads(row["options"]), bytes(row["data"])

    def release(self, job_id: str, attempt: int) -> None:
        """Give back an attempt claimed by a worker whose server died meanwhile: queued
        again, for the next server (unless its start-up has already marked it)."""
        with self._connect() as db:
            db.execute(
                "UPDATE jobs SET status = 'queued', started = NULL "
                "WHERE id = ? AND attempt = ? AND status = 'running' AND progress IS NULL",
                (job_id, attempt),
            )

    def progress(self, job_id: str, attempt: int, progress: dict) -> bool:
        """Record progress; False when the attempt is no longer running (deleted...)."""
        with self._connect() as db:
            return (
                db.execute(
                    "UPDATE jobs SET progress = ? WHERE id = ? AND attempt = ? "
                    "AND status = 'running'",
                    (json.dumps(progress), job_id, attempt),
                ).rowcount
                > 0
            )

    def finish(self, job_id: str, attempt: int, result=None, error=None) -> bool:
        """Store the result (status done) or the error (status failed) of an attempt."""
        status = "done" if error is None else "failed"
        with self._connect() as db:
            return (
                db.execute(
                    "UPDATE jobs SET status = ?, finished = ?, result = ?, error = ? "
                    "WHERE id = ? AND attempt = ? AND status = 'running'",
                    (
                        status,
                        time.time(),
                        None if result is None else json.dumps(result),
                        None if error is None else json.dumps(error),
                        job_id,
                        attempt,
                    ),
                ).rowcount
                > 0
            )


def _public(row: sqlite3.Row) -> dict:
    out = {key: row[key] for key in row.keys()}
    for key in ("created", "started", "finished"):
        out[key] = iso(out[key])
    for key in ("progress", "result", "error"):
        if key in out:
            out[key] = None if out[key] is None else json.loads(out[key])
    if out.get("result"):
        out["result"] = _upgraded(out["result"])
    if "notes" in out:
        notes = out.pop("notes")
        out["data_notes"] = [] if notes is None else json.loads(notes)
    return out


def _upgraded(result: dict) -> dict:
    """A result stored before results summarised their weights (every weight was in
    ``options.weights``) answers the summary, as a result stored today does."""
    options = result.get("options") or {}
    if isinstance(options.get("weights"), list):
        summary = weights_summary(options["weights"])
        result = {**result, "options": {**options, "weights": summary}}
    return result
