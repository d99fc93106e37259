"""Pictures of a job: the fit plot, drawn on request, and the corner plot, drawn by the worker.

- ``plot.png``: :func:`brdffit.plot.fit.plot_fit` (the planes of incidence,
  measured and fitted, and the residuals) of any job that is done, drawn from
  the job's stored data and result the first time it is asked for, then kept.
- ``corner.png``: :func:`brdffit.plot.corner.corner_plot` of the posterior. It needs
  the posterior's samples, which the job's JSON result does not carry, so the
  job's worker draws it when its fit is done, but only for jobs whose
  submitter asked for pictures (:func:`want`; ``POST /comparisons/file``, the
  page's route, does). Drawing it costs seconds of CPU (``corner`` smooths
  every pair of parameters), which jobs of other clients do not pay.

The PNGs live in the table ``artifacts`` of the job's SQLite file, beside
``jobs``; ``GET /jobs/{id}/plot.png`` and ``GET /jobs/{id}/corner.png``
(:mod:`service.routes.plots`) answer them. A plot that cannot be drawn is
logged and left out; it never fails the fit.
"""

from __future__ import annotations

import logging
import sqlite3
import tempfile
import threading
from pathlib import Path

from .store import connect, data_from_bytes

__all__ = ["NAMES", "fit_plot", "forget", "load", "render", "want"]

log = logging.getLogger("brdffit.service")

#: The plots a job may have: file name -> what it shows.
NAMES = {
    "plot.png": "the fit: planes of incidence (measured and fitted) and the residuals",
    "corner.png": "the corner plot of the posterior samples",
}
SCHEMA = """
CREATE TABLE IF NOT EXISTS artifacts (
    job_id TEXT NOT NULL,
    name TEXT NOT NULL,
    png BLOB NOT NULL,
    PRIMARY KEY (job_id, name)
);
CREATE TABLE IF NOT EXISTS artifact_requests (job_id TEXT PRIMARY KEY);
"""
#: Resolution of the corner plot: 7 parameters make a 15-inch figure.
CORNER_DPI = 60
#: plot_fit draws through pyplot, whose state is global: one drawing at a time.
_PYPLOT = threading.Lock()


def _connect(store_path):
    db = connect(store_path)
    db.thing.executescript(SCHEMA)
    return db


def _png(draw) -> bytes | None:
    """The bytes ``draw(path)`` writes, or None (logged) when it fails."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "plot.png"
        try:
            draw(path)
            return path.read_bytes()
        except Exception:  # a picture must never fail a fit, nor answer a 500
            log.exception("could not draw a plot")
            return None


def _store(store_path, job_id: str, name: str, png: bytes) -> None:
    with _connect(store_path) as db:
        db.execute("INSERT OR REPLACE INTO artifacts VALUES (?, ?, ?)",
                   (job_id, name, sqlite3.Binary(png)))  # fmt: skip


def want(store_path, job_id: str) -> None:
    """Ask the worker of ``job_id`` to draw its corner plot (call before submitting it)."""
    with _connect(store_path) as db:
        db.execute("INSERT OR IGNORE INTO artifact_requests VALUES (?)", (job_id,))


def render(store_path, job_id: str, result) -> list[str]:
    """In the worker, after the fit: draw the corner plot of ``result.posterior`` if the
    job asked for pictures; return the names drawn."""
    if result.posterior is None:
        return []
    with _connect(store_path) as db:
        row = db.execute("SELECT 1 FROM artifact_requests WHERE job_id = ?", (job_id,))
        if row.fetchone() is None:
            return []
    from brdffit.plot.corner import corner_plot  # the library's plotting, imported only here

    png = _png(lambda path: corner_plot(result.posterior, path, dpi=CORNER_DPI))
    if png is None:
        return []
    _store(store_path, job_id, "corner.png", png)
    return ["corner.png"]


def fit_plot(store_path, job: dict) -> bytes | None:
    """The fit plot of a job that is done: drawn from its stored data and result the
    first time, then kept."""
    png = load(store_path, job["id"], "plot.png")
    if png is not None or not job.get("result"):
        return png
    with _connect(store_path) as db:
        row = db.execute("SELECT data FROM jobs WHERE id = ?", (job["id"],)).fetchone()
    if row is None:
        return None
    from brdffit.fitting import FitResult
    from brdffit.plot.fit import plot_fit

    data, out = data_from_bytes(bytes(row[0])), job["result"]
    result = FitResult.from_dict(out)
    with _PYPLOT:
        png = _png(lambda path: plot_fit(data, result, path))
    if png is not None:
        _store(store_path, job["id"], "plot.png", png)
    return png


def load(store_path, job_id: str, name: str) -> bytes | None:
    """The PNG ``name`` of a job, or None."""
    with _connect(store_path) as db:
        row = db.execute(
            "SELECT png FROM artifacts WHERE job_id = ? AND name = ?", (job_id, name)
        ).fetchone()
    return None if row is None else bytes(row[0])


def forget(store_path, job_id: str) -> None:
    """Drop the plots of a job that no longer exists."""
    with _connect(store_path) as db:
        db.execute("DELETE FROM artifacts WHERE job_id = ?", (job_id,))
        db.execute("DELETE FROM artifact_requests WHERE job_id = ?", (job_id,))
