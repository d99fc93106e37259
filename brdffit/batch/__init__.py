"""Batch fits of whole material databases on Dask distributed.

``fit_many(sources, models)`` fits every model to every source on a Dask
cluster (a local one by default) and yields one :class:`BatchRow` per pair as
it finishes. ``brdffit batch`` is its command line.
"""

from .engine import connect, fit_many, sources_of
from .rows import BatchRow, RowError

__all__ = ["BatchRow", "RowError", "connect", "fit_many", "sources_of"]
