"""From request bodies to library calls, and from results to JSON: nothing else.

The routes call these functions, so that each route stays a few lines: the
service holds no fitting logic (DESIGN.md).
"""

from __future__ import annotations

import io
import logging
from contextlib import contextmanager

import brdffit
from brdffit.errors import BrdfFitError, DataError, ModelError
from brdffit.notes import collecting

from .schemas import DataIn, FitOptions, PosteriorOptions

__all__ = [
    "fit_kwargs",
    "located",
    "measurements",
    "model_names",
    "read_upload",
    "sample_limit",
]

log = logging.getLogger("brdffit.service")

#: Library fields that name a part of the data, to be found under ``data.`` in a body.
DATA_FIELDS = {"theta_i", "phi_i", "theta_o", "phi_o", "values", "channels", "sigma", "index"}
#: Library fields that mean "the file itself": an upload's is its form field (``file``).
FILE_FIELDS = {None, "path", "source"}
#: Library fields of brdffit.read that are form fields of an upload as well.
FORM_FIELDS = {"format", "subsample"}
UNNAMED_UPLOAD = "the uploaded file"


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


def model_names(text: str, most: int, field: str = "models") -> list[str]:
    """The model names of a form field (``ward, ggx,ward`` -> ``["ward", "ggx"]``):
    split at commas, trimmed, each once, 1 to ``most`` of them and each a model
    :func:`brdffit.get_model` knows; else a ModelError naming ``field`` and its value."""
    names = list(dict.fromkeys(n.strip() for n in text.split(",") if n.strip()))
    if not 1 <= len(names) <= most:
        raise ModelError(f"{field}={text!r}: give 1 to {most} model names separated by "
                         "commas, such as ward,ggx,lambert+blinn", field)  # fmt: skip
    for name in names:
        try:
            brdffit.get_model(name)
        except BrdfFitError as exc:
            raise ModelError(f"{field}={text!r}: {exc}", field) from None
    return names


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
    kwargs = options.model_dump(
        exclude={"model", "data", "posterior_options", "export"}, exclude_unset=True
    )
    kwargs["timeout"] = min(options.timeout or seconds, seconds)
    if options.uncertainty:
        post = options.posterior_options or PosteriorOptions()
        kwargs["posterior_options"] = post.model_dump(exclude_unset=True) | {
            "max_seconds": min(post.max_seconds or seconds, seconds)
        }
    return kwargs


def read_upload(content: bytes, filename: str | None, format: str | None, subsample=None,
                channels: str | None = None, limit: int | None = None,
                field: str = "file"):  # fmt: skip
    """``brdffit.read`` of an uploaded file's bytes, and the notes the reading made.

    The bytes are read in memory, named by the upload's file name: the library
    infers the format from its extension (or from the first bytes), and its
    messages and notes name the client's file. An error names the form field at
    fault, as a dotted path (as ``data.theta_i`` in a JSON body): a fault of the
    file's content is under the file's form field ``field`` (``file.header``),
    one that the reader puts under no narrower field is ``field`` itself, and
    ``format`` and ``subsample`` are the form fields of those names.
    """
    upload = io.BytesIO(content)
    upload.name = filename or UNNAMED_UPLOAD
    options = {} if subsample is None else {"subsample": subsample}
    if limit is not None:  # the reader refuses more before allocating (an NPZ zip bomb)
        options["max_samples"] = limit
    try:
        with collecting() as notes:
            data = brdffit.read(upload, format=format, **options)
    except BrdfFitError as exc:
        if exc.field in FILE_FIELDS:
            exc.field = field
        elif exc.field not in FORM_FIELDS:
            exc.field = f"{field}.{exc.field}"
        log.info("upload %r (%d bytes) refused: %s", upload.name, len(content), exc)
        raise
    # The server's log names the client's file, as the answers do (never a temporary path).
    log.info("upload %r (%d bytes): %d samples", upload.name, len(content), data.n)
    for message in notes:
        log.info("upload %r: %s", upload.name, message)
    if channels:
        data = data.select_channels([c.strip() for c in channels.split(",") if c.strip()])
    if limit is not None:
        sample_limit(data.n, limit, field)
    return data, list(notes)
