"""Jobs off the request path: a worker function and the executor that runs it.

:func:`run_job` is all a worker needs: the path of the store, a job id and an
attempt number. It claims the job, reads its inputs from the store, runs
:func:`brdffit.fit` (with the posterior when asked), writes progress as it
goes and the result or the error at the end. Because the call carries only
ids, any ``concurrent.futures``-style executor can run it: the default is an
:class:`~brdffit_service.pool.IsolatedPool` of spawned processes (a worker that
dies takes only its own job: that job becomes ``interrupted``, saying why), and a
distributed executor that can open the store can take its place
(``JobRunner(store, executor_factory=...)``) without touching the routes.

A running job stops early, at its next progress report, when its row is
cancelled (``POST /jobs/{id}/cancel``), deleted, resubmitted, or when the server
process that owns the worker is gone (an orphan must not keep computing, nor
write). A worker whose server is gone claims no job: the job stays ``queued``
and the next server runs it.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import threading
import time
from collections.abc import Callable
from concurrent.futures import Executor, Future

import brdffit
from brdffit.errors import BrdfFitError
from brdffit.jsonable import jsonable

from . import artifacts, comparisons
from .errors import ApiError
from .exports import with_exports
from .pool import IsolatedPool, WorkerDied
from .store import JobStore, data_from_bytes

__all__ = ["Cancelled", "FitPool", "JobRunner", "fit_to_dict", "run_job"]

log = logging.getLogger("brdffit.service")

#: Seconds between progress writes of a worker: often enough to watch, rare
#: enough that SQLite commits cost nothing next to the fit.
PROGRESS_EVERY = 0.5


class Cancelled(Exception):
    """The job was cancelled, deleted or resubmitted, or its server is gone: stop.

    Not a :class:`brdffit.StopFit`, which would end the fit with a result to store:
    this abandons the job, and the fitting engine lets it through to :func:`run_job`.
    """


class _Reporter:
    """The ``progress`` callback of a job's fit and posterior."""

    def __init__(self, store: JobStore, job_id: str, attempt: int, parent_pid: int | None):
        self.store, self.job_id, self.attempt = store, job_id, attempt
        self.parent_pid = parent_pid
        self.last = 0.0

    def __call__(self, progress) -> None:
        self._check_server()
        now = time.monotonic()
        if now - self.last < PROGRESS_EVERY:
            return
        self.last = now
        report = dataclasses.asdict(progress)
        report.setdefault("stage", "posterior")
        self._write(jsonable(report))

    def exporting(self, target: str) -> None:
        """The progress of an export (``export`` option), made after the fit."""
        self._check_server()
        self._write({"stage": f"export {target}", "seconds": 0.0})

    def _check_server(self) -> None:
        if _orphan(self.parent_pid):
            raise Cancelled("the server process that started this job is gone")

    def _write(self, report: dict) -> None:
        if not self.store.progress(self.job_id, self.attempt, report):
            raise Cancelled("the job was cancelled, deleted or resubmitted")


def _orphan(parent_pid: int | None) -> bool:
    """True when the server process that handed out the work is gone."""
    return parent_pid is not None and os.getppid() != parent_pid


def run_job(store_path: str, job_id: str, attempt: int, parent_pid: int | None = None) -> str:
    """Run one attempt of a job; return its final status (``done``, ``failed``, or
    ``gone`` when the job was cancelled, deleted or taken over before or while it ran,
    or when its server is gone: then a queued job is left queued for the next one)."""
    if _orphan(parent_pid):
        return "gone"
    store = JobStore(store_path)
    claimed = store.start(job_id, attempt)
    if claimed is None:
        return "gone"
    if _orphan(parent_pid):  # the server died while claiming: give the job back
        store.release(job_id, attempt)
        return "gone"
    model, options, blob = claimed
    started = time.monotonic()
    targets = options.pop("export", ())
    reporter = _Reporter(store, job_id, attempt, parent_pid)
    try:
        data = data_from_bytes(blob)
        if options.get("uncertainty"):
            posterior = dict(options.get("posterior_options") or {})
            options = {**options, "posterior_options": {**posterior, "progress": reporter}}
        result = brdffit.fit(data, model, progress=reporter, **options)
        artifacts.render(store_path, job_id, result)  # a corner plot, if asked (issue 16)
        answer = with_exports(jsonable(result.to_dict()), data, targets, started,
                              options.get("timeout"), reporter.exporting)  # fmt: skip
        comparisons.score(store_path, job_id, attempt, model, answer)  # if in one (issue 16)
    except Cancelled:
        return "gone"
    except BrdfFitError as exc:
        error = {"field": exc.field, "message": str(exc), "kind": type(exc).__name__}
        store.finish(job_id, attempt, error=error)
        return "failed"
    except Exception as exc:  # a bug: say so in the job, keep the worker alive
        log.exception("job %s failed", job_id)
        error = {"field": None, "message": f"internal error: {exc!r}", "kind": "InternalError"}
        store.finish(job_id, attempt, error=error)
        return "failed"
    return "done" if store.finish(job_id, attempt, result=answer) else "gone"


def _exit_with_parent(parent_pid: int, every: float = 1.0) -> None:
    """Initializer of pool workers: leave when the server is gone. An idle worker of a
    killed server would otherwise wait forever on its task queue, whose write end it
    holds itself."""

    def watch():
        while os.getppid() == parent_pid:
            time.sleep(every)
        os._exit(0)

    threading.Thread(target=watch, name="exit-with-parent", daemon=True).start()


def _process_pool(workers: int) -> Executor:
    # Spawned processes (pool.py), each leaving when the server is gone.
    return IsolatedPool(workers, initializer=_exit_with_parent, initargs=(os.getpid(),))


def _stop(executor: Executor) -> None:
    """Shut an executor down without waiting for the work it is doing (a process
    pool's running workers are ended: they are this process's own children)."""
    executor.shutdown(wait=False, cancel_futures=True)


class JobRunner:
    """Submits jobs of a store to an executor and watches for workers that die."""

    def __init__(self, store: JobStore, workers: int = 2,
                 executor_factory: Callable[[], Executor] | None = None):  # fmt: skip
        self.store = store
        self._factory = executor_factory or (lambda: _process_pool(workers))
        self._executor = self._factory()
        self._futures: dict[str, Future] = {}
        self._lock = threading.Lock()
        self._closing = False
        self._retries: dict[str, int] = {}
        # Workers compare their parent's pid with this: a process pool's workers are
        # children of this process. Another executor may set it to None.
        self.parent_pid: int | None = os.getpid() if executor_factory is None else None

    def submit(self, job_id: str, attempt: int) -> None:
        args = (run_job, str(self.store.path), job_id, attempt, self.parent_pid)
        with self._lock:
            try:
                future = self._executor.submit(*args)
            except RuntimeError:  # an executor that was shut down (or broke): a new one
                self._executor = self._factory()
                future = self._executor.submit(*args)
            self._futures[job_id] = future
        future.add_done_callback(lambda f: self._done(job_id, attempt, f))

    def _done(self, job_id: str, attempt: int, future: Future) -> None:
        with self._lock:
            if self._futures.get(job_id) is future:
                del self._futures[job_id]
        if future.cancelled() or self._closing:
            return
        exc = future.exception()
        if exc is None:
            self._retries.pop(job_id, None)
            return
        job = self.store.get(job_id)
        retries = self._retries.get(job_id, 0)
        if job and job["status"] == "queued" and job["attempt"] == attempt and retries < 3:
            # It never started (its worker died before claiming it): run it anew.
            self._retries[job_id] = retries + 1
            self.submit(job_id, attempt)
            return
        log.error("the worker of job %s died: %s", job_id, exc)
        self.store.interrupt(
            job_id, attempt, f"the worker running this job died ({exc}); "
            f"POST /jobs/{job_id}/resubmit runs it again",
        )  # fmt: skip

    def cancel(self, job_id: str) -> None:
        """Drop a queued job from the executor (a running one stops by itself)."""
        with self._lock:
            future = self._futures.get(job_id)
        if future is not None:
            future.cancel()

    def close(self) -> None:
        """Stop at once: running jobs stay ``running`` in the store and become
        ``interrupted`` at the next start, where they can be resubmitted."""
        with self._lock:
            self._closing = True
            executor = self._executor
        # Outside the lock: cancelling a queued future runs its callback, _done, which
        # takes the lock (a server stopped with a job queued hung here).
        _stop(executor)


def fit_to_dict(data, model: str, kwargs: dict, export=()) -> dict:
    """``brdffit.fit(data, model, **kwargs).to_dict()``, JSON-ready: a synchronous fit,
    with the renderer exports of ``export`` made within its time limit."""
    started = time.monotonic()
    result = jsonable(brdffit.fit(data, model, **kwargs).to_dict())
    return with_exports(result, data, export, started, kwargs.get("timeout"))


class FitPool:
    """Synchronous fits in worker processes, or with no workers on the calling thread.

    Threads use both cores of the benchmark machine as well as processes do (the
    numpy work of a fit releases the GIL; ``benchmarks/README.md``), so the
    default is none; processes keep a fit's memory and any crash out of the web
    process. Library errors raised in a worker reach the caller unchanged."""

    def __init__(self, workers: int):
        self.workers = workers
        self._executor = _process_pool(workers) if workers else None

    def run(self, data, model: str, kwargs: dict, export=()) -> dict:
        if self._executor is None:
            return fit_to_dict(data, model, kwargs, export)
        executor = self._executor
        try:
            return executor.submit(fit_to_dict, data, model, kwargs, export).result()
        except WorkerDied:  # that worker is started anew; the other fits go on
            raise ApiError(503, "the worker running this fit died; try again", None) from None

    def close(self) -> None:
        if self._executor is not None:
            _stop(self._executor)
