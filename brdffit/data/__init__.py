"""The ground floor: measured reflectance and its directions, with no model and no format.

:class:`Measurements` holds directions, values per channel, sigma and units;
:class:`Geometry` the parameter-free terms of a set of direction pairs;
:mod:`~brdffit.data.colour` converts spectra and RGB.
"""

from .geometry import Geometry
from .measurements import Measurements

__all__ = ["Geometry", "Measurements"]
