"""One conversion to strict JSON for every answer the project gives.

JSON has no NaN and no infinity, and :func:`json.dumps` writes them unless told
``allow_nan=False``. Every ``to_dict()``, the command line's ``--json`` and the
service's answers pass through :func:`jsonable`, so a non-finite number becomes
``null`` in one place, and numpy scalars and arrays become plain Python.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping

import numpy as np

__all__ = ["dumps", "jsonable"]


def jsonable(value):
    """``value`` as plain, strictly JSON-serialisable Python.

    Mappings become dicts (keys as given), sequences and arrays lists (an array
    keeps its shape as nested lists), numpy scalars Python scalars, and every
    non-finite float ``None``.
    """
    if isinstance(value, Mapping):
        return {k: jsonable(v) for k, v in value.items()}
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def dumps(value, **kwargs) -> str:
    """:func:`json.dumps` of :func:`jsonable` ``(value)``, refusing NaN (a bug if one
    got through)."""
    return json.dumps(jsonable(value), allow_nan=False, **kwargs)
