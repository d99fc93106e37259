"""The ``export`` option of fits and jobs: renderer exports made after the fit.

They run where the fit ran (a worker of the job, or of the synchronous fit),
after it, as ``POST /export`` with the fit's data (:func:`brdffit.export`), and
only while the fit's time limit lasts: a target reached after it is not
exported, and the answer says so in ``export_errors`` (the fit is kept).
"""

from __future__ import annotations

import time
from collections.abc import Callable

import brdffit
from brdffit.errors import BrdfFitError
from brdffit.jsonable import jsonable

__all__ = ["with_exports"]


def with_exports(result: dict, data, targets, started: float, seconds: float | None,
                 before: Callable[[str], None] | None = None) -> dict:  # fmt: skip
    """``result`` (a fit's JSON-ready ``to_dict()``) with ``exports`` and
    ``export_errors`` for ``targets``, made until ``started + seconds``
    (``time.monotonic()`` clock; ``seconds`` None: no limit). ``before(target)``
    is called before each export (a job reports its progress there)."""
    if not targets:
        return result
    exports, errors = [], {}
    for target in targets:
        if seconds is not None and time.monotonic() - started >= seconds:
            errors[target] = (f"not exported: the fit's time limit of {seconds:g} s ran out "
                              "first; POST /export makes it from this result")  # fmt: skip
            continue
        if before is not None:
            before(target)
        try:
            exports.append(jsonable(brdffit.export(result, target, data=data).to_dict()))
        except BrdfFitError as exc:
            errors[target] = str(exc)
    return {**result, "exports": exports, "export_errors": errors or None}
