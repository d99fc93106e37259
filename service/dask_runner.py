"""The service's jobs on a Dask cluster, when ``BRDFFIT_SCHEDULER`` is set.

:class:`~service.jobs.JobRunner` runs :func:`~service.jobs.run_job` (store
path, job id, attempt: nothing else crosses a process) on any
``concurrent.futures`` executor. Dask's ``Client.get_executor()`` is one
(distributed documentation, "Futures", ``ClientExecutor``), so a Dask runner
is a JobRunner with a different executor; the SQLite store stays the one
source of truth:

- a job accepted is in the store before it is submitted, and a restart of
  the service resubmits what was queued (``JobStore.recover``), as today;
- cancelling marks the row ``cancelled`` and deleting removes it; the running
  fit notices at its next progress report, and a late result of a cancelled,
  deleted or resubmitted attempt is dropped by the store (``finish`` only
  writes a *running* row of the same attempt);
- a worker lost mid-job: Dask's scheduler runs the task again on another
  worker (up to ``distributed.scheduler.allowed-failures``). The rerun finds
  its attempt ``running``; it marks it interrupted and requeues it as a new
  attempt before fitting, so a lost worker that still lives (a network
  partition) can no longer write: its attempt is not the job's any more.
  Past the allowed failures, ``KilledWorker`` reaches ``JobRunner`` and the
  job is ``interrupted`` as when a process of the default pool dies.

The workers must open the store: a cluster on the same machine, or a shared
file system (SQLite's locking needs one that honours POSIX locks; not NFS).

The service's lifespan (``service/app.py``) asks :func:`runner_for` for its runner.
"""

from __future__ import annotations

import logging
import os
from concurrent.futures import Executor

from brdffit.extras import require

from .jobs import JobRunner, run_job
from .store import JobStore

__all__ = ["DaskJobRunner", "run_job_on_dask", "runner_for"]

log = logging.getLogger("brdffit.service")


def run_job_on_dask(store_path: str, job_id: str, attempt: int, parent_pid=None) -> str:
    """:func:`~service.jobs.run_job`, taking over an attempt whose Dask worker was lost."""
    status = run_job(store_path, job_id, attempt, None)
    if status != "gone":
        return status
    store = JobStore(store_path)
    job = store.get(job_id)
    if not (job and job["status"] == "running" and job["attempt"] == attempt):
        return status  # deleted or resubmitted: nothing to do
    # Dask reruns a task only when the worker running it is gone.
    store.interrupt(job_id, attempt, "the Dask worker running this job was lost")
    new = store.requeue(job_id)
    if new is None:
        return "gone"
    log.warning("job %s: worker lost, running it again as attempt %d", job_id, new)
    return run_job(store_path, job_id, new, None)


class _DaskExecutor(Executor):
    """A ``ClientExecutor`` that runs :func:`run_job_on_dask` for :func:`run_job`."""

    def __init__(self, client):
        self._inner = client.get_executor(pure=False)
        self._closed = False

    def submit(self, fn, /, *args, **kwargs):
        if self._closed:
            raise RuntimeError("cannot submit jobs after shutdown")
        if fn is run_job:
            fn = run_job_on_dask
            args = (os.path.abspath(args[0]), *args[1:])  # workers may have another cwd
        return self._inner.submit(fn, *args, **kwargs)

    def shutdown(self, wait=True, *, cancel_futures=False):
        # No call into the client here: JobRunner stops its executor holding its
        # lock, and the futures' callbacks take that lock on the client's event
        # loop, so waiting on that loop would deadlock. DaskJobRunner.close()
        # closes the client next, which releases (cancels) what is left.
        self._closed = True


class DaskJobRunner(JobRunner):
    """A :class:`~service.jobs.JobRunner` whose jobs run on a Dask cluster.

    Parameters
    ----------
    store : JobStore
    address : str, optional
        A scheduler address; None or ``"local"``: a LocalCluster of
        ``workers`` processes, one thread each, on 127.0.0.1.
    workers : int
        Processes of the local cluster.
    """

    def __init__(self, store: JobStore, address: str | None = None, workers: int = 2):
        import distributed

        self._cluster = None
        if address in (None, "", "local"):
            self._cluster = distributed.LocalCluster(
                n_workers=workers, threads_per_worker=1, processes=True,
                host="127.0.0.1", dashboard_address="127.0.0.1:0",
            )  # fmt: skip
            address = self._cluster.scheduler_address
        self.client = distributed.Client(address)
        super().__init__(store, workers, executor_factory=lambda: _DaskExecutor(self.client))

    def close(self) -> None:
        """Stop submitting and leave the cluster; running attempts become
        ``interrupted`` at the next start of the service, as with the process pool."""
        super().close()
        self.client.close()
        if self._cluster is not None:
            self._cluster.close()


def runner_for(store: JobStore, workers: int, scheduler: str | None = None) -> JobRunner:
    """The job runner the settings ask for: Dask when ``scheduler`` (``BRDFFIT_SCHEDULER``)
    is set, else the service's own process pool."""
    if scheduler:
        require("distributed", "batch")
        return DaskJobRunner(store, scheduler, workers)
    return JobRunner(store, workers)
