"""Plots (matplotlib, the ``plot`` extra): :mod:`.fit` for a fit against its data,
:mod:`.corner` for a posterior. Importing this package without matplotlib raises
:class:`~brdffit.errors.MissingExtraError` naming the extra."""

from ..extras import require

require("matplotlib", "plot")
