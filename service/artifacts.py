"""Pictures of a finished job, drawn by its worker and kept in the job store.

A job's worker draws, once its fit is done, the fit plot
(:func:`brdffit.plot_fit.plot_fit`: the planes of incidence, measured against
fitted, and the residuals) and, when the posterior was sampled, the corner plot
(:func:`brdffit.plots.corner_plot`). They are drawn there, not on request,
because the corner plot needs the posterior's samples, which the job's JSON
result does not carry, and because drawing takes a second of CPU that belongs
in a worker, not on the web process.

The PNGs live in the table ``artifacts`` of the job's SQLite file, beside
``jobs``; ``GET /jobs/{id}/plot.png`` and ``GET /jobs/{id}/corner.png``
(:mod:`service.routes_plots`) answer them. A plot that cannot be drawn is
logged and left out; it never fails the fit.
"""

from __future__ import annotations

import logging
import sqlite3
import tempfile
from contextlib import closing
from pathlib import Path

__all__ = ["NAMES", "forget", "load", "render"]

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
"""
#: Resolution of the corner plot: 7 parameters make a 15-inch figure.
CORNER_DPI = 60


def _connect(store_path):
    db = sqlite3.connect(store_path, timeout=30.0, isolation_level=None)
    db.execute("PRAGMA busy_timeout=30000")
    db.executescript(SCHEMA)
    return closing(db)


def _draw(data, result, folder: Path) -> dict[str, bytes]:
    # The library's plotting modules, imported only here (and only in workers).
    from brdffit.plot_fit import plot_fit
    from brdffit.plots import corner_plot

    drawn = {}
    steps = [("plot.png", lambda path: plot_fit(data, result, path))]
    if result.posterior is not None:
        steps.append(("corner.png", lambda path: corner_plot(result.posterior, path,
                                                             dpi=CORNER_DPI)))  # fmt: skip
    for name, draw in steps:
        path = folder / name
        try:
            draw(path)
            drawn[name] = path.read_bytes()
        except Exception:  # a picture must never fail a fit that succeeded
            log.exception("could not draw %s of a fit of %s", name, result.model)
    return drawn


def render(store_path, job_id: str, data, result) -> list[str]:
    """Draw the plots of a job's ``result`` on ``data`` and store them; return their names."""
    with tempfile.TemporaryDirectory() as folder:
        drawn = _draw(data, result, Path(folder))
    with _connect(store_path) as db:
        for name, png in drawn.items():
            db.execute("INSERT OR REPLACE INTO artifacts VALUES (?, ?, ?)",
                       (job_id, name, sqlite3.Binary(png)))  # fmt: skip
    return sorted(drawn)


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
