"""``brdffit batch``: every file x every model on Dask, resumable, with a report.

One JSON line per finished pair is appended to ``--out`` and flushed as it
arrives (strict JSON: ``BatchRow.to_dict()``), so a killed run loses at most
the pairs in flight; ``--resume`` reads the file back (dropping a truncated
last line), skips the pairs it holds and appends the rest. At the end: the
table of the best model per file (by BIC and by held-out error) and, with
``--report``, a markdown report with the table and a fit plot per file.
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import sys
import threading
import time

from ..batch import BatchRow, connect, fit_many
from ..batch.summary import best_per_source, best_table, write_report
from ..errors import BrdfFitError
from ..jsonable import dumps
from ..models import get_model
from .text import table

__all__ = ["add_parser", "run", "read_rows"]


class BatchCliError(BrdfFitError):
    """A ``brdffit batch`` argument the command cannot use."""


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``batch`` command to the ``brdffit`` sub-command parsers."""
    from ..fitting.losses import LOSSES

    p = subparsers.add_parser("batch", help="fit many files x models on Dask, resumable")
    p.add_argument("files", nargs="+", metavar="FILE_OR_GLOB", help="data files or globs")
    p.add_argument("--models", required=True, help="comma-separated model names")
    p.add_argument("--uncertainty", action="store_true", help="also sample each posterior")
    p.add_argument("--max-seconds", type=float, help="time budget of each posterior (60)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, help="processes of the local cluster (CPUs)")
    where.add_argument("--scheduler", metavar="ADDRESS", help="a Dask scheduler, tcp://host:8786")
    p.add_argument("--out", required=True, help="results, one JSON line per pair")
    p.add_argument("--resume", action="store_true", help="skip the pairs already in --out")
    p.add_argument("--report", metavar="MD", help="write a markdown report with plots")
    p.add_argument("--loss", choices=list(LOSSES), help="the loss (default as brdffit fit)")
    p.add_argument("--seed", type=int, default=0, help="seed of every fit and split (0)")
    p.add_argument("--timeout", type=float, help="seconds allowed to each fit")
    p.add_argument("--max-evals", type=int, help="cap on evaluations of each fit")
    p.add_argument(
        "--test-fraction",
        type=float,
        default=0.2,
        help="held-out share for the held-out error (0.2; 0: no held-out score)",
    )
    p.set_defaults(run=run)
    return p


def _expand(patterns) -> list[str]:
    files = []
    for pattern in patterns:
        if glob.has_magic(pattern):
            found = sorted(glob.glob(pattern, recursive=True))
            if not found:
                raise BatchCliError(f"{pattern!r} matches no file", "files")
            files += found
        else:
            files.append(pattern)  # read on the worker: a cluster may see other files
    return files


def read_rows(path) -> list[BatchRow]:
    """The rows of a results file; a truncated last line (a killed run) is cut off the file."""
    if not os.path.exists(path):
        return []
    with open(path, "rb") as f:
        lines = f.read().split(b"\n")
    rows, offset = [], 0
    for i, line in enumerate(lines):
        try:
            if line.strip():
                rows.append(BatchRow.from_dict(json.loads(line)))
        except (ValueError, KeyError, TypeError) as exc:
            if any(rest.strip() for rest in lines[i + 1 :]):
                raise BatchCliError(
                    f"{path}: line {i + 1} is not a batch row ({exc}); only the last line "
                    "of a killed run may be cut short",
                    "out",
                ) from None
            with open(path, "r+b") as f:
                f.truncate(offset)
            break
        offset += len(line) + 1
    return rows


class _Progress:
    """``batch: done/total, running, failed, elapsed, left`` on stderr, redrawn each second."""

    def __init__(self, client, total: int, tty: bool):
        self.client, self.total, self.tty = client, total, tty
        self.done = self.failed = 0
        # Every worker thread is busy while pairs wait; the ticker asks the scheduler.
        self.threads = client.nthreads() if tty else {}
        self.slots = sum(self.threads.values())
        self.running = min(self.slots, total)
        self.t0 = time.monotonic()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._tick, daemon=True) if tty else None
        if self._thread:
            self._thread.start()

    def _tick(self):
        while not self._stop.wait(1.0):
            try:
                # processing() also lists pairs waiting on a worker: one runs per thread.
                busy = self.client.processing().items()
                self.running = sum(min(len(k), self.threads.get(w, 1)) for w, k in busy)
            except Exception:  # the scheduler went away; the main loop will say why
                pass
            self.draw()

    def add(self, row: BatchRow) -> None:
        self.done += 1
        self.failed += not row.ok
        self.running = min(self.slots, self.total - self.done)
        self.draw()

    def line(self) -> str:
        elapsed = time.monotonic() - self.t0
        left = elapsed / self.done * (self.total - self.done) if self.done else None
        eta = "?" if left is None else _clock(left)
        return (
            f"batch: {self.done}/{self.total} done, {self.running} running, "
            f"{self.failed} failed, {_clock(elapsed)} elapsed, ~{eta} left"
        )

    def draw(self) -> None:
        if self.tty:
            sys.stderr.write("\r" + self.line() + "\033[K")
            sys.stderr.flush()

    def close(self) -> None:
        self._stop.set()
        if self._thread:
            self._thread.join()
        sys.stderr.write(("\r" + self.line() + "\033[K\n") if self.tty else self.line() + "\n")


def _clock(seconds: float) -> str:
    m, s = divmod(round(seconds), 60)
    h, m = divmod(m, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m:02d}:{s:02d}"


def _options(args) -> dict:
    options = {"seed": args.seed, "loss": args.loss, "timeout": args.timeout}
    options["max_evals"] = args.max_evals
    if args.max_seconds is not None:
        options["posterior_options"] = {"max_seconds": args.max_seconds}
    return {k: v for k, v in options.items() if v is not None}


def run(args) -> int:
    """Run ``brdffit batch``; exit code 0 when every pair has a result, 1 when some failed."""
    models = list(dict.fromkeys(m.strip() for m in args.models.split(",") if m.strip()))
    for model in models:
        get_model(model)  # an unknown name fails before a cluster starts
    files = list(dict.fromkeys(_expand(args.files)))
    if not args.resume and os.path.exists(args.out) and os.path.getsize(args.out):
        raise BatchCliError(f"{args.out} exists: --resume continues it, or remove it", "out")
    if not 0 <= args.test_fraction <= 0.9:
        raise BatchCliError(
            f"--test-fraction {args.test_fraction} must be in [0, 0.9]", "test_fraction"
        )
    rows = read_rows(args.out) if args.resume else []
    done = {r.key for r in rows}
    total = sum((f, m) not in done for f in files for m in models)
    with connect(args.scheduler, args.workers) as client, open(args.out, "a") as out:
        progress = _Progress(client, total, sys.stderr.isatty())
        try:
            for row in fit_many(
                files, models, client=client, uncertainty=args.uncertainty,
                test_fraction=args.test_fraction or None, skip=done, **_options(args),
            ):  # fmt: skip
                out.write(dumps(row.to_dict()) + "\n")
                out.flush()
                rows.append(row)
                progress.add(row)
        finally:
            progress.close()
    print(table(*best_table(best_per_source(rows))))
    if args.report:
        path = write_report(args.report, rows, title=f"brdffit batch: {len(files)} files")
        print(f"wrote {path}", file=sys.stderr)
    return 0 if all(r.ok for r in rows) else 1
