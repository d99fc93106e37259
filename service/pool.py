"""A pool of worker processes in which a dying worker takes only its own call.

:class:`~concurrent.futures.ProcessPoolExecutor` marks itself broken when one of
its workers dies, fails every pending future and terminates the other workers:
one fit killed by the kernel's out-of-memory killer took every running job with
it (issue 18). :class:`IsolatedPool` gives each worker process its own pipe
and its own thread in the web process: a worker that dies fails the one call
it was running (:class:`WorkerDied`, with its exit code) and is started anew
for the next call; the other workers go on.

Calls are handed to a worker only when it is free, so nothing waits inside a
worker's pipe: when the web process dies, no worker takes another call, and an
idle worker leaves at once (its pipe's other end is closed by the kernel).
"""

from __future__ import annotations

import logging
import queue
import threading
from concurrent.futures import Executor, Future
from multiprocessing import get_context
from multiprocessing.connection import wait

__all__ = ["IsolatedPool", "WorkerDied"]

log = logging.getLogger("brdffit.service")


class WorkerDied(Exception):
    """The worker process running a call ended before answering."""


def _worker_main(conn, initializer, initargs) -> None:
    """A worker: run each call received on ``conn``, answer ``(ok, value)``; leave when
    the pipe closes (the pool shut down or the web process is gone)."""
    if initializer is not None:
        initializer(*initargs)
    while True:
        try:
            fn, args, kwargs = conn.recv()
        except (EOFError, OSError):
            return
        try:
            answer = (True, fn(*args, **kwargs))
        except BaseException as exc:
            answer = (False, exc)
        try:
            conn.send(answer)
        except Exception as exc:  # an answer that does not pickle
            conn.send((False, RuntimeError(f"the worker's answer cannot be sent: {exc!r}")))


class _Worker:
    """One worker process and the thread of the web process that feeds it."""

    def __init__(self, pool: IsolatedPool, index: int):
        self.pool, self.index = pool, index
        self.process = None
        self.conn = None
        self.thread = threading.Thread(target=self.serve, name=f"pool-worker-{index}",
                                       daemon=True)  # fmt: skip
        self.thread.start()

    def start(self) -> None:
        parent, child = self.pool.context.Pipe()
        self.process = self.pool.context.Process(
            target=_worker_main, args=(child, self.pool.initializer, self.pool.initargs),
            name=f"brdffit-worker-{self.index}", daemon=True,
        )  # fmt: skip
        self.process.start()
        child.close()
        self.conn = parent

    def serve(self) -> None:
        while True:
            item = self.pool.calls.get()
            if item is None:
                return
            future, fn, args, kwargs = item
            if not future.set_running_or_notify_cancel():
                continue
            try:
                self.run(future, fn, args, kwargs)
            except BaseException as exc:
                if not future.done():
                    future.set_exception(exc)

    def run(self, future: Future, fn, args, kwargs) -> None:
        if self.process is None or not self.process.is_alive():
            self.start()
        try:
            self.conn.send((fn, args, kwargs))
            wait([self.conn, self.process.sentinel])
            ok, value = self.conn.recv()
        except (EOFError, OSError):
            self.process.join(timeout=5)
            code = self.process.exitcode
            self.conn.close()
            self.process = None
            if not self.pool.closing:
                log.error("worker process %d died (exit code %s)", self.index, code)
            future.set_exception(WorkerDied(f"the worker process ended with exit code {code}"))
            return
        if ok:
            future.set_result(value)
        else:
            future.set_exception(value)

    def stop(self) -> None:
        process = self.process
        if process is not None and process.is_alive():
            process.terminate()
            process.join(timeout=5)


class IsolatedPool(Executor):
    """``workers`` processes (spawned, not forked: the web process has threads);
    ``initializer(*initargs)`` runs once in each."""

    def __init__(self, workers: int, initializer=None, initargs=(), context=None):
        self.context = context or get_context("spawn")
        self.initializer, self.initargs = initializer, initargs
        self.calls: queue.SimpleQueue = queue.SimpleQueue()
        self.closing = False
        self._lock = threading.Lock()
        self._workers = [_Worker(self, i) for i in range(workers)]

    def submit(self, fn, /, *args, **kwargs) -> Future:
        future: Future = Future()
        with self._lock:
            if self.closing:
                raise RuntimeError("cannot submit to a pool that was shut down")
            self.calls.put((future, fn, args, kwargs))
        return future

    def worker_pids(self) -> list[int]:
        """The process ids of the workers running now."""
        return [w.process.pid for w in self._workers if w.process is not None]

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        """Stop: pending calls are cancelled when asked; with ``wait=False`` the running
        ones are ended at once (their futures fail with :class:`WorkerDied`)."""
        with self._lock:
            self.closing = True
        if cancel_futures:
            while True:
                try:
                    item = self.calls.get_nowait()
                except queue.Empty:
                    break
                if item is not None:
                    item[0].cancel()
        for _ in self._workers:
            self.calls.put(None)
        if not wait:
            for worker in self._workers:
                worker.stop()
        for worker in self._workers:
            worker.thread.join(timeout=None if wait else 5)
            if worker.conn is not None:
                worker.conn.close()
            worker.stop()
