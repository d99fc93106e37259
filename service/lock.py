"""One server per job store: an operating-system lock on a file beside the store.

A server marks the jobs it finds ``running`` at start-up as ``interrupted``
(:meth:`~brdffit_service.store.JobStore.recover`): their server died. A second
server on the same store would so cut the first one's live jobs (issue 18).
The server therefore holds an exclusive ``flock`` on ``<store>.lock`` for its
whole life; a second one is refused, naming the process that holds it. The
kernel releases the lock when its holder dies, however it dies (SIGKILL
included), so a crashed server never blocks the next one.

``flock`` locks are advisory and local: they hold between processes of one
machine (on a network file system they may not; the README says to keep the
store on a local disk). On systems without ``fcntl`` (Windows), no lock is
taken.
"""

from __future__ import annotations

import os
import threading
from pathlib import Path

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None

__all__ = ["StoreInUse", "StoreLock"]

#: Locks this process holds: path -> [open file, users].
_HELD: dict[str, list] = {}
_GUARD = threading.Lock()


class StoreInUse(RuntimeError):
    """Another live server holds the store's lock."""


class StoreLock:
    """The exclusive lock of the store at ``store_path`` (``acquire``, ``release``)."""

    def __init__(self, store_path):
        self.store = Path(store_path)
        self.path = self.store.with_name(self.store.name + ".lock")
        self._file = None

    def acquire(self) -> StoreLock:
        """Take the lock, or raise :class:`StoreInUse` saying who holds it. Within one
        process the lock is shared (two apps of one test process on one store)."""
        if fcntl is None or self._file is not None:
            return self
        key = str(self.path.resolve())
        with _GUARD:
            held = _HELD.get(key)
            if held is None:
                held = _HELD[key] = [self._lock_file(), 0]
            held[1] += 1
        self._file = held[0]
        return self

    def _lock_file(self):
        self.path.parent.mkdir(parents=True, exist_ok=True)
        handle = open(self.path, "a+")  # held for the server's life
        try:
            fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.seek(0)
            holder = handle.read().strip() or "unknown"
            handle.close()
            raise StoreInUse(
                f"another brdffit server (process {holder}) is using the job store "
                f"{self.store}; one server per store: stop that one, or give this one "
                f"its own store (--store or BRDFFIT_STORE_PATH)"
            ) from None
        handle.seek(0)
        handle.truncate()
        handle.write(f"{os.getpid()}\n")
        handle.flush()
        return handle

    def release(self) -> None:
        if self._file is None:
            return
        key = str(self.path.resolve())
        self._file = None
        with _GUARD:
            held = _HELD.get(key)
            if held is not None:
                held[1] -= 1
                if held[1] <= 0:
                    del _HELD[key]
                    fcntl.flock(held[0].fileno(), fcntl.LOCK_UN)
                    held[0].close()
