"""Plots (matplotlib, the ``plot`` extra): :mod:`.fit` for a fit against its data,
:mod:`.corner` for a posterior."""
