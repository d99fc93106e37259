"""Comparisons of several models on one dataset, as jobs: the held-out part kept.

:func:`brdffit.compare` splits the data once (seeded), fits every model to the
training part and ranks the models by BIC and by the error on the held-out
part. A comparison here does the same with jobs, so that each fit runs in a
worker with its own progress: the training part goes into one ordinary job
per model (``GET /jobs/{id}`` follows each), and the held-out part is kept in
the table ``comparisons`` of the job store. Once a job is done its held-out
RMSE is the model with the job's parameters evaluated on the held-out samples;
the ranks are those of :func:`brdffit.compare` (1 = best), among the jobs done.
"""

from __future__ import annotations

import json
import math
import sqlite3
import time
import uuid
from contextlib import closing

import numpy as np

import brdffit

from .store import data_from_bytes, data_to_bytes, iso

__all__ = ["ComparisonStore", "heldout_rmse", "ranks"]

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
        db = sqlite3.connect(self.path, timeout=30.0, isolation_level=None)
        db.row_factory = sqlite3.Row
        db.execute("PRAGMA busy_timeout=30000")
        return closing(db)

    def create(self, source: str, models: list, jobs: list, test, test_fraction: float,
               seed: int, n_train: int) -> str:  # fmt: skip
        comparison_id = uuid.uuid4().hex
        with self._connect() as db:
            db.execute(
                "INSERT INTO comparisons VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (comparison_id, time.time(), source, json.dumps(models), json.dumps(jobs),
                 sqlite3.Binary(data_to_bytes(test)), test_fraction, seed, n_train, test.n),
            )  # fmt: skip
        return comparison_id

    def get(self, comparison_id: str):
        """The row as a dict with its held-out data loaded (``test``), or None."""
        with self._connect() as db:
            row = db.execute("SELECT * FROM comparisons WHERE id = ?", (comparison_id,)).fetchone()
        if row is None:
            return None
        return {**_decoded(row), "test": data_from_bytes(row["test"])}

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
