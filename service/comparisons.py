"""Comparisons of several models on one dataset, as jobs: the held-out part kept.

:func:`brdffit.compare` splits the data once (seeded), fits every model to the
training part and ranks the models by BIC and by the error on the held-out
part. A comparison here does the same with jobs, so that each fit runs in a
worker with its own progress: the training part goes into one ordinary job
per model (``GET /jobs/{id}`` follows each), and the held-out part is kept in
the table ``comparisons`` of the job store. When a job's fit is done its worker
evaluates the model with the job's parameters on the held-out samples, once
(:func:`score`), and stores that RMSE in the table ``comparison_jobs`` beside the
attempt it scored; ``GET /comparisons/{id}`` serves it. The ranks are those of
:func:`brdffit.compare` (1 = best), among the jobs done.
"""

from __future__ import annotations

import json
import logging
import math
import sqlite3
import time
import uuid

import numpy as np

import brdffit

from .store import connect, data_from_bytes, data_to_bytes, iso

__all__ = ["ComparisonStore", "heldout_rmse", "ranks", "score"]

log = logging.getLogger("brdffit.service")

SCHEMA = """
CREATE TABLE IF NOT EXISTS comparisons (
    id TEXT PRIMARY KEY,
    created REAL NOT NULL,
    source TEXT NOT NULL,
    models TEXT NOT NULL,
    jobs TEXT NOT NULL,
    test BLOB NOT NULL,
    test_fraction REAL NOT NULL,
    seed INTEGER NOT NULL,
    n_train INTEGER NOT NULL,
    n_test INTEGER NOT NULL
);
CREATE TABLE IF NOT EXISTS comparison_jobs (
    job_id TEXT PRIMARY KEY,
    comparison_id TEXT NOT NULL,
    attempt INTEGER,
    heldout_rmse REAL
);
"""


def heldout_rmse(model_name: str, params: dict, test) -> float | None:
    """RMSE of ``model_name`` with ``params`` (a job result's JSON) on the samples ``test``,
    over every channel, as in :func:`brdffit.compare`; None when not finite."""
    model = brdffit.get_model(model_name)
    values = {k: np.asarray(v, dtype=float) for k, v in params.items()}
    pred = np.asarray(model.evaluate(test.wi, test.wo, values), dtype=float)
    y = np.asarray(test.values, dtype=float)
    pred = np.broadcast_to(pred.reshape(test.n, -1), y.shape)
    rmse = math.sqrt(float(np.mean((pred - y) ** 2)))
    return rmse if math.isfinite(rmse) else None


def ranks(values: list) -> list:
    """1-based ranks of ``values`` (smallest first, ties in order); None stays None."""
    known = sorted((v, i) for i, v in enumerate(values) if v is not None)
    out: list = [None] * len(values)
    for rank, (_, i) in enumerate(known, start=1):
        out[i] = rank
    return out


class ComparisonStore:
    """The table ``comparisons`` in the SQLite file of the jobs."""

    def __init__(self, path):
        self.path = path
        with self._connect() as db:
            db.executescript(SCHEMA)

    def _connect(self):
        return connect(self.path)

    def create(self, source: str, models: list, jobs: list, test, test_fraction: float,
               seed: int, n_train: int) -> str:  # fmt: skip
        """Store a comparison of ``jobs`` (stored, not yet submitted: their workers look
        their comparison up when done)."""
        comparison_id = uuid.uuid4().hex
        with self._connect() as db:
            db.execute(
                "INSERT INTO comparisons VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (comparison_id, time.time(), source, json.dumps(models), json.dumps(jobs),
                 sqlite3.Binary(data_to_bytes(test)), test_fraction, seed, n_train, test.n),
            )  # fmt: skip
            db.executemany(
                "INSERT OR REPLACE INTO comparison_jobs VALUES (?, ?, NULL, NULL)",
                [(job_id, comparison_id) for job_id in jobs],
            )
        return comparison_id

    def get(self, comparison_id: str):
        """The row as a dict (without its held-out data), with ``scores``: job id ->
        (attempt scored, held-out RMSE) of its jobs scored so far; or None."""
        with self._connect() as db:
            row = db.execute("SELECT * FROM comparisons WHERE id = ?", (comparison_id,)).fetchone()
            scored = db.execute(
                "SELECT job_id, attempt, heldout_rmse FROM comparison_jobs "
                "WHERE comparison_id = ? AND attempt IS NOT NULL",
                (comparison_id,),
            ).fetchall()
        if row is None:
            return None
        scores = {r["job_id"]: (r["attempt"], r["heldout_rmse"]) for r in scored}
        return {**_decoded(row), "scores": scores}

    def score(self, job_id: str, attempt: int, model: str, params: dict,
              comparison_id: str | None = None) -> float | None:  # fmt: skip
        """Evaluate attempt ``attempt`` of ``job_id`` (its ``params``) on the held-out
        samples of its comparison (``comparison_id``, or the one the job was stored
        in) and store the RMSE; None when the job is in no comparison, or the RMSE
        is not finite."""
        with self._connect() as db:
            if comparison_id is None:
                found = db.execute(
                    "SELECT comparison_id FROM comparison_jobs WHERE job_id = ?", (job_id,)
                ).fetchone()
                if found is None:
                    return None
                comparison_id = found["comparison_id"]
            row = db.execute(
                "SELECT test FROM comparisons WHERE id = ?", (comparison_id,)
            ).fetchone()
            if row is None:
                return None
            rmse = heldout_rmse(model, params, data_from_bytes(row["test"]))
            db.execute(
                "INSERT OR REPLACE INTO comparison_jobs VALUES (?, ?, ?, ?)",
                (job_id, comparison_id, attempt, rmse),
            )
        return rmse

    def list(self, limit: int = 20) -> list[dict]:
        with self._connect() as db:
            rows = db.execute(
                "SELECT id, created, source, models, jobs FROM comparisons "
                "ORDER BY created DESC LIMIT ?",
                (limit,),
            ).fetchall()
        return [_decoded(row) for row in rows]


def _decoded(row: sqlite3.Row) -> dict:
    """A row as a dict: its JSON lists decoded, its time in ISO 8601."""
    return {**dict(row), "created": iso(row["created"]), "models": json.loads(row["models"]),
            "jobs": json.loads(row["jobs"])}  # fmt: skip


def score(store_path, job_id: str, attempt: int, model: str, result: dict) -> None:
    """In the worker, when the fit of ``job_id`` is done (its JSON ``result``): store
    its held-out RMSE if the job is part of a comparison. Never fails the fit."""
    try:
        ComparisonStore(store_path).score(job_id, attempt, model, result["params"])
    except Exception:  # GET /comparisons/{id} scores it instead (logged: a bug)
        log.exception("could not score job %s on its held-out samples", job_id)
