"""``fit_many``: every source x every model on Dask distributed.

The engine is Dask's, not ours: a ``LocalCluster`` of worker processes with
one thread each is the default (no setup), a scheduler address points at a
real cluster (``dask scheduler`` / ``dask worker``, dask-jobqueue,
dask-kubernetes). A worker that dies mid-fit is handled by the scheduler: its
tasks go back to the queue and run on another worker, at most
``distributed.scheduler.allowed-failures`` times (Dask's configuration,
default 3) before the pair ends as a ``KilledWorker`` error row. Each future
is yielded once by ``distributed.as_completed``, so a rerun pair still gives
exactly one row. See the Dask distributed documentation, "Resilience" and
"Futures" (https://distributed.dask.org).
"""

from __future__ import annotations

import inspect
import os
import uuid
from collections.abc import Iterable, Iterator
from contextlib import contextmanager

import brdffit
from brdffit.errors import FitError

from ..extras import require
from .rows import BatchRow, RowError, pair_key
from .task import run_pair, unwire

__all__ = ["connect", "fit_many", "sources_of"]

#: Options of brdffit.fit that make no sense across processes or are set by fit_many.
_NOT_OPTIONS = {"data", "model", "uncertainty", "progress"}


def _distributed():
    return require("distributed", "batch")  # the batch extra is optional


def _workers(workers) -> int:
    if workers is None:
        return os.cpu_count() or 1
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise FitError(f"workers={workers!r} must be a whole number >= 1", "workers")
    return workers


@contextmanager
def connect(client=None, workers=None):
    """A ``distributed.Client`` for a batch; what it creates it closes on exit.

    Parameters
    ----------
    client : distributed.Client, str or None
        A client (used as it is, left open), a scheduler address
        (``tcp://host:8786``), or None: the address in the environment
        variable ``DASK_SCHEDULER_ADDRESS`` when set, else a new
        ``LocalCluster`` of ``workers`` processes with one thread each,
        listening on 127.0.0.1 only.
    workers : int, optional
        Processes of the local cluster (default: the number of CPUs); only
        for the local cluster.
    """
    distributed = _distributed()
    if isinstance(client, distributed.Client):
        if workers is not None:
            raise FitError("workers applies to a local cluster, not to a given client", "workers")
        yield client
        return
    if client is not None and not isinstance(client, str):
        raise FitError(
            f"client={client!r} must be a distributed.Client, a scheduler address or None",
            "client",
        )
    address = client or os.environ.get("DASK_SCHEDULER_ADDRESS") or None
    if address:
        if workers is not None:
            raise FitError(f"workers applies to a local cluster, not to {address}", "workers")
        with distributed.Client(address) as own:
            yield own
        return
    n = _workers(workers)
    with (
        distributed.LocalCluster(
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address="127.0.0.1:0",
        ) as cluster,
        distributed.Client(cluster) as own,
    ):
        yield own


def sources_of(sources) -> list:
    """``(label, source)`` pairs: paths as strings, Measurements with a unique label."""
    if isinstance(sources, (str, os.PathLike, brdffit.Measurements)):
        sources = [sources]
    out, seen = [], set()
    for i, source in enumerate(sources):
        if isinstance(source, brdffit.Measurements):
            label = source.source or f"<measurements {i}>"
            if label in seen:
                label = f"{label} #{i}"
        elif isinstance(source, (str, os.PathLike)):
            source = label = os.fspath(source)
            if label in seen:
                continue  # the same file twice is one file
        else:
            raise FitError(
                f"sources[{i}] is a {type(source).__name__}; a path or Measurements is needed",
                "sources",
            )
        seen.add(label)
        out.append((label, source))
    return out


def _check(uncertainty, test_fraction, fit_options: dict) -> None:
    if not isinstance(uncertainty, bool):
        raise FitError(f"uncertainty={uncertainty!r} must be True or False", "uncertainty")
    if test_fraction is not None and (
        isinstance(test_fraction, bool)
        or not isinstance(test_fraction, (int, float))
        or not 0 < test_fraction <= 0.9
    ):
        raise FitError(f"test_fraction={test_fraction!r} must be None or in (0, 0.9]",
                       "test_fraction")  # fmt: skip
    known = set(inspect.signature(brdffit.fit).parameters) - _NOT_OPTIONS
    for name in fit_options:
        if name not in known:
            raise FitError(
                f"{name!r} is not an option of brdffit.fit here; "
                f"known: {', '.join(sorted(known))}",
                name,
            )


def _models(models) -> list:
    if isinstance(models, str):
        models = [models]
    names = []
    for m in models:
        name = m if isinstance(m, str) else getattr(m, "name", None)
        if not isinstance(name, str):
            raise FitError(f"models holds {m!r}; model names are needed", "models")
        brdffit.get_model(name)  # an unknown name fails now, listing the close ones
        if name not in names:
            names.append(name)
    if not names:
        raise FitError("fit_many needs at least one model", "models")
    return names


def fit_many(
    sources: Iterable,
    models: Iterable,
    *,
    client=None,
    workers: int | None = None,
    uncertainty: bool = False,
    test_fraction: float | None = None,
    skip: Iterable[tuple] = (),
    **fit_options,
) -> Iterator[BatchRow]:
    """Fit every model to every source on Dask; yield a row per pair as it finishes.

    Parameters
    ----------
    sources : path, Measurements, or an iterable of them
        Paths are read on the worker that fits them (they must be readable
        there: a shared file system on a cluster); Measurements are scattered
        to the cluster once each.
    models : str or iterable of str
        Model names (sums of lobes allowed); unknown names raise at once.
    client : distributed.Client, str or None
        See :func:`connect`.
    workers : int, optional
        Processes of the local cluster made when no client is given.
    uncertainty : bool
        Also sample each fit's posterior (``posterior_options`` in ``fit_options``).
    test_fraction : float, optional
        Also score each model on held-out samples with :func:`brdffit.compare`
        (one more fit per pair, on the training part).
    skip : iterable of (source label, model)
        Pairs not to submit (a resumed batch).
    **fit_options
        Passed to :func:`brdffit.fit` on the worker (``seed``, ``loss``,
        budgets...). The same seed gives the same rows on whichever worker.

    Yields
    ------
    BatchRow
        In order of completion; each pair exactly once. A pair that fails
        (unreadable file, a fit error, a worker lost too often) is a row with
        its ``error``; the rest go on.
    """
    _check(uncertainty, test_fraction, fit_options)
    names, pairs = _models(models), sources_of(sources)
    done = {pair_key(s, m) for s, m in skip}
    todo = [(lab, src, m) for lab, src in pairs for m in names if (lab, m) not in done]
    if not todo:
        return
    yield from _run(todo, client, workers, (uncertainty, test_fraction, fit_options))


def _run(todo, client, workers, task_args) -> Iterator[BatchRow]:
    distributed = _distributed()
    batch = uuid.uuid4().hex[:12]
    with connect(client, workers) as c:
        shipped = {}
        futures = {}
        for i, (label, source, model) in enumerate(todo):
            if isinstance(source, brdffit.Measurements) and label not in shipped:
                shipped[label] = c.scatter(source, hash=False)
            arg = shipped.get(label, source)
            key = f"brdffit-fit-{batch}-{i}"
            future = c.submit(run_pair, arg, model, *task_args, key=key, pure=False)
            futures[future] = (label, model)
        try:
            for future in distributed.as_completed(futures):
                label, model = futures.pop(future)
                yield _row(future, label, model)
        finally:
            for future in futures:  # a caller that stops early: stop the rest too
                future.cancel()


def _row(future, label: str, model: str) -> BatchRow:
    if future.status != "finished":
        exc = future.exception() if future.status == "error" else None
        error = (
            RowError.of(exc)
            if exc is not None
            else RowError(f"the pair was {future.status} before it finished", "CancelledError")
        )
        return BatchRow(label, model, error=error)
    out = future.result()
    error = RowError(*out["error"]) if out["error"] else None
    return BatchRow(
        label,
        model,
        result=unwire(out["result"]),
        error=error,
        seconds=out["seconds"],
        worker=out["worker"],
        heldout_rmse=out.get("heldout_rmse"),
        heldout_loss=out.get("heldout_loss"),
    )
