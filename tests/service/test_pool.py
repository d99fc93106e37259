"""IsolatedPool: a worker that dies fails its own call only, and is started anew."""

from __future__ import annotations

import os
import signal
import sys
import time

import pytest

from brdffit_service.pool import IsolatedPool, WorkerDied

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="uses POSIX signals")


def test_a_dead_worker_fails_only_its_call_and_is_replaced():
    pool = IsolatedPool(2)
    try:
        sleeping = [pool.submit(time.sleep, 30) for _ in range(2)]
        deadline = time.monotonic() + 30
        while len(pool.worker_pids()) < 2 or not all(f.running() for f in sleeping):
            assert time.monotonic() < deadline, "the workers did not start"
            time.sleep(0.05)
        victim = pool.worker_pids()[0]
        os.kill(victim, signal.SIGKILL)
        deadline = time.monotonic() + 10
        while not any(f.done() for f in sleeping):
            assert time.monotonic() < deadline, "the dead worker's call did not fail"
            time.sleep(0.05)
        time.sleep(0.5)
        hit = [f for f in sleeping if f.done()]
        assert len(hit) == 1  # the other worker's call goes on
        failed = hit[0].exception()
        assert isinstance(failed, WorkerDied) and "exit code -9" in str(failed)
        assert pool.submit(os.getpid).result(timeout=30) not in (victim, os.getpid())
        assert pool.submit(divmod, 7, 2).result(timeout=30) == (3, 1)
        with pytest.raises(ZeroDivisionError):
            pool.submit(divmod, 1, 0).result(timeout=30)
    finally:
        pool.shutdown(wait=False, cancel_futures=True)
    with pytest.raises(RuntimeError, match="shut down"):
        pool.submit(os.getpid)
