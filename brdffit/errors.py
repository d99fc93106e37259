"""The errors brdffit raises for bad input.

Every error is a :class:`BrdfFitError` (a ``ValueError``) whose message is a
sentence saying what is wrong and what is needed. ``field`` names the input that
is wrong (a parameter, a column, an option) so that the command line and the
HTTP service can point at it without parsing the message.

A part of brdffit whose optional dependencies are not installed (plots, the web
service, colour conversion, batch fits, export previews) raises
:class:`MissingExtraError`, an ``ImportError`` whose one-line message names the
extra to install.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

__all__ = [
    "BrdfFitError",
    "ModelError",
    "ParameterError",
    "DataError",
    "FormatError",
    "FitError",
    "MissingExtraError",
    "under_option",
]


class BrdfFitError(ValueError):
    """Base of every error caused by input that brdffit cannot use."""

    def __init__(self, message: str, field: str | None = None):
        super().__init__(message)
        self.field = field


class ModelError(BrdfFitError):
    """An unknown model name or a malformed sum of lobes."""


class ParameterError(BrdfFitError):
    """A model parameter that is unknown, missing, not finite or out of bounds."""


@contextmanager
def under_option(option: str, name: str) -> Iterator[None]:
    """A :class:`ParameterError` of a value given in an option (``fixed``, ``start``)
    names it there: field ``option.name`` (the option's own path in a request) and
    the message led by the option, so that one parameter given in two options says
    which was wrong."""
    try:
        yield
    except ParameterError as exc:
        raise type(exc)(f"{option}: {exc}", f"{option}.{exc.field or name}") from None


class DataError(BrdfFitError):
    """Directions or values that are malformed (shape, NaN, range, length)."""


class FormatError(BrdfFitError):
    """A file that cannot be read; the message names the file and the place."""


class FitError(BrdfFitError):
    """Options or data that a fit or a posterior run cannot work with."""


class MissingExtraError(ImportError):
    """An optional part of brdffit used without its extra installed.

    ``extra`` is the extra that installs it (``pip install 'brdffit[<extra>]'``).
    """

    def __init__(self, message: str, extra: str, module: str | None = None):
        super().__init__(message, name=module)
        self.extra = extra
