"""The rows of a batch: one frozen record per (source, model) pair.

A row holds either the :class:`~brdffit.fitting.result.FitResult` of the pair or the
error that stopped it (its message and its type), never both, with the time
the pair took on its worker and the worker's address. ``to_dict()`` is strict
JSON (no NaN or infinity), the form ``brdffit batch`` writes one line of.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..fitting.result import FitResult
from ..jsonable import jsonable

__all__ = ["BatchRow", "RowError", "pair_key"]


@dataclass(frozen=True)
class RowError:
    """Why a pair has no result: the exception's message and its class name."""

    message: str
    type: str
    field: str | None = None

    @classmethod
    def of(cls, exc: BaseException) -> RowError:
        return cls(str(exc) or repr(exc), type(exc).__name__, getattr(exc, "field", None))

    def to_dict(self) -> dict:
        return {"message": self.message, "type": self.type, "field": self.field}


@dataclass(frozen=True)
class BatchRow:
    """One finished (source, model) pair of :func:`brdffit.batch.fit_many`.

    Attributes
    ----------
    source : str
        The path as given, or the label of a :class:`~brdffit.Measurements`
        (its ``source``, else ``<measurements i>``).
    model : str
        The model name as given.
    result : FitResult or None
        The fit of the whole data set; None when the pair failed.
    error : RowError or None
        Why the pair failed; None when it has a result.
    seconds : float
        Wall time of the pair on its worker (reading the file included).
    worker : str
        Address of the Dask worker that produced the row ("" when the pair
        never reached one).
    heldout_rmse, heldout_loss : float or None
        Error on the held-out samples of :func:`brdffit.compare` for this
        model, when ``fit_many(..., test_fraction=...)`` asked for them.
    """

    source: str
    model: str
    result: Any = None
    error: RowError | None = None
    seconds: float = 0.0
    worker: str = ""
    heldout_rmse: float | None = None
    heldout_loss: float | None = None

    @property
    def ok(self) -> bool:
        return self.error is None

    @property
    def key(self) -> tuple:
        """``(source, model)``: what identifies the pair in a batch and a resumed one."""
        return pair_key(self.source, self.model)

    @classmethod
    def from_dict(cls, d: dict) -> BatchRow:
        """A row back from its :meth:`to_dict` (a resumed batch); a posterior stays a dict."""
        error = RowError(**d["error"]) if d.get("error") else None
        result = FitResult.from_dict(d["result"]) if d.get("result") else None
        return cls(
            d["source"], d["model"], result, error, float(d.get("seconds") or 0.0),
            d.get("worker") or "", d.get("heldout_rmse"), d.get("heldout_loss"),
        )  # fmt: skip

    def to_dict(self) -> dict:
        """Strict-JSON form: non-finite numbers become ``null``."""
        return jsonable(
            {
                "source": self.source,
                "model": self.model,
                "ok": self.ok,
                "seconds": self.seconds,
                "worker": self.worker,
                "heldout_rmse": self.heldout_rmse,
                "heldout_loss": self.heldout_loss,
                "error": None if self.error is None else self.error.to_dict(),
                "result": None if self.result is None else self.result.to_dict(),
            }
        )


def pair_key(source: str, model: str) -> tuple:
    """The key of a pair, ``(source, model)`` as strings: rows and ``skip`` agree on it."""
    return (str(source), str(model))
