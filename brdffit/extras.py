"""The optional parts of brdffit and the extras that install them.

The core (reading, models, fitting, the posterior, the command line) needs
numpy, scipy, nlopt and emcee. Plots, the web service, the conversion of
spectra to colour, batch fits (Dask) and export previews (Mitsuba) import
their packages only when used, through
:func:`require`, which turns a missing package into a one-line
:class:`~brdffit.errors.MissingExtraError` naming the extra to install.
"""

from __future__ import annotations

import importlib

from .errors import MissingExtraError

__all__ = ["EXTRAS", "require"]

#: Each extra and what needs it, as the subject of the error's sentence.
EXTRAS = {
    "plot": "plots need",
    "service": "the service needs",
    "colour": "converting spectra to colour needs",
    "batch": "batch fits need",
    "export": "a preview of an export needs",
}


def require(module: str, extra: str):
    """Import ``module`` and return it, or raise MissingExtraError naming ``extra``.

    Examples
    --------
    >>> require("numpy", "plot").__name__
    'numpy'
    """
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        what = EXTRAS.get(extra, "this needs")
        raise MissingExtraError(
            f"{what} the '{extra}' extra ({module} is not installed): "
            f"pip install 'brdffit[{extra}]'",
            extra,
            module,
        ) from exc
