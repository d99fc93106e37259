"""Notes about data: what a reader or :class:`~brdffit.Measurements` noticed.

Values below zero kept, pairs a reader dropped: the library says these with a
``UserWarning`` through :func:`note`. Inside :func:`collecting` the same
sentences are also gathered in a list, so that a caller that is not a terminal
(the HTTP service) can hand them on. The list lives in a ``ContextVar``: each
thread and each task collects its own, which ``warnings.catch_warnings`` could
not do (it swaps state shared by every thread of the process).
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar

__all__ = ["collecting", "note"]

_notes: ContextVar[list[str] | None] = ContextVar("brdffit_notes", default=None)


def note(message: str, stacklevel: int = 1) -> None:
    """Warn with ``message`` (a ``UserWarning``), and collect it where collected.

    ``stacklevel`` counts as for ``warnings.warn`` from the caller of this function.
    """
    collected = _notes.get()
    if collected is not None:
        collected.append(message)
    warnings.warn(message, UserWarning, stacklevel=stacklevel + 1)


@contextmanager
def collecting() -> Iterator[list[str]]:
    """The notes made inside the block, in order (nested blocks collect their own)."""
    collected: list[str] = []
    token = _notes.set(collected)
    try:
        yield collected
    finally:
        _notes.reset(token)
