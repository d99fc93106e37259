"""From request bodies to library calls, and from results to JSON: nothing else.

The routes call these functions, so that each route stays a few lines: the
service holds no fitting logic (DESIGN.md).
"""

from __future__ import annotations

import math
import os
import re
import tempfile
from collections.abc import Mapping
from contextlib import contextmanager

import numpy as np

import brdffit
from brdffit.errors import BrdfFitError, DataError
from brdffit.notes import collecting

from .schemas import DataIn, FitOptions, PosteriorOptions

__all__ = [
    "finite",
    "fit_kwargs",
    "located",
    "measurements",
    "read_upload",
    "sample_limit",
]

#: Library fields that name a part of the data, to be found under ``data.`` in a body.
DATA_FIELDS = {"theta_i", "phi_i", "theta_o", "phi_o", "values", "channels", "sigma", "index"}
_SAFE_SUFFIX = re.compile(r"^\.[A-Za-z0-9]{1,10}$")


def finite(value):
    """``value`` with every non-finite float replaced by None (JSON has no NaN)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, Mapping):
        return {k: finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite(v) for v in value]
    if isinstance(value, np.ndarray):
        return finite(value.tolist())
    if isinstance(value, np.generic):
        return finite(value.item())
    return value


@contextmanager
def located(prefix: str, fields=DATA_FIELDS):
    """Re-raise a library error with its field under ``prefix`` (``theta_i`` ->
    ``data.theta_i``), when the field is one of ``fields``."""
    try:
        yield
    except BrdfFitError as exc:
        if exc.field in fields:
            exc.field = f"{prefix}.{exc.field}"
        raise


def sample_limit(n: int, limit: int, where: str, hint: str = "") -> None:
    """A DataError when ``n`` samples exceed a limit of the server."""
    if n > limit:
        raise DataError(
            f"{where} has {n} samples; this server takes at most {limit} here{hint}",
            where,
        )


def measurements(data: DataIn, limit: int, prefix: str = "data") -> tuple:
    """``Measurements.from_angles`` of a body, within a sample limit, and the notes
    made on the way (values below zero...: :mod:`brdffit.notes`)."""
    sample_limit(len(data.theta_i), limit, f"{prefix}.theta_i")
    with located(prefix), collecting() as notes:
        out = brdffit.Measurements.from_angles(
            data.theta_i,
            data.phi_i,
            data.theta_o,
            data.phi_o,
            data.values,
            channels=data.channels,
            sigma=data.sigma,
            source=data.source,
            units=data.units,
        )
    return out, notes


def fit_kwargs(options: FitOptions, seconds: float) -> dict:
    """Keyword arguments of ``brdffit.fit``: the options the client set (the library's
    defaults stand for the others), with the time limits capped at ``seconds``."""
    kwargs = options.model_dump(exclude={"model", "data", "posterior_options"}, exclude_unset=True)
    kwargs["timeout"] = min(options.timeout or seconds, seconds)
    if options.uncertainty:
        post = options.posterior_options or PosteriorOptions()
        kwargs["posterior_options"] = post.model_dump(exclude_unset=True) | {
            "max_seconds": min(post.max_seconds or seconds, seconds)
        }
    return kwargs


def read_upload(content: bytes, filename: str | None, format: str | None, subsample=None,
                channels: str | None = None, limit: int | None = None):  # fmt: skip
    """``brdffit.read`` of an uploaded file, through a temporary file that keeps its
    extension (the library infers the format from it, or from the first bytes), and
    the notes the reading made, naming the uploaded file."""
    suffix = os.path.splitext(filename or "")[1]
    suffix = suffix if _SAFE_SUFFIX.match(suffix) else ""
    fd, path = tempfile.mkstemp(suffix=suffix)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(content)
        options = {} if subsample is None else {"subsample": subsample}
        try:
            with collecting() as notes:
                data = brdffit.read(path, format=format, **options)
        except BrdfFitError as exc:
            # Name the uploaded file, not the temporary one, in the message; a fault
            # in the file's content is the field "file"'s.
            raise type(exc)(_named(str(exc), path, filename), exc.field or "file") from None
    finally:
        os.unlink(path)
    if channels:
        data = data.select_channels([c.strip() for c in channels.split(",") if c.strip()])
    if limit is not None:
        sample_limit(data.n, limit, "file")
    return data, [_named(text, path, filename) for text in notes]


def _named(text: str, path: str, filename: str | None) -> str:
    """``text`` naming the uploaded file where it names the temporary one (by its path
    or by its base name, as readers do)."""
    shown = filename or "the uploaded file"
    return text.replace(path, shown).replace(os.path.basename(path), shown)
