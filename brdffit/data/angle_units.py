"""Angles said to be degrees that look like radians: the test and the note.

A file or an array of angles read as degrees whose polar angles all lie within
[0, pi/2] and azimuths within [-2 pi, 2 pi] would, in degrees, put every
direction within 1.6 degrees of the normal: no goniometer measures that, while
radians fill exactly those ranges. Such data are read as degrees, as told, with
a note (:mod:`brdffit.notes`) saying how to state the unit. A stated unit
(``degrees=True`` of :meth:`~brdffit.Measurements.from_angles`, ``angle_unit=``
of :func:`brdffit.read`) skips the test.
"""

from __future__ import annotations

import numpy as np

__all__ = ["radians_note", "radians_suspected"]


def radians_suspected(theta_i, phi_i, theta_o, phi_o) -> bool:
    """True when angles said to be degrees look like radians: some polar angle is
    above zero, every one is within [0, pi/2] and every azimuth within [-2 pi, 2 pi]
    (in degrees such data would all lie within 1.6 degrees of the normal)."""
    thetas = np.concatenate([np.ravel(theta_i), np.ravel(theta_o)]).astype(float)
    phis = np.concatenate([np.ravel(phi_i), np.ravel(phi_o)]).astype(float)
    return bool(
        thetas.size
        and thetas.max() > 0
        and thetas.min() >= 0
        and thetas.max() <= np.pi / 2
        and np.abs(phis).max() <= 2 * np.pi
    )


def radians_note(where: str, largest: float, how: str) -> str:
    """The note that angles read as degrees look like radians; ``how`` says how to
    state the unit."""
    return (
        f"{where}: the angles are read as degrees, but they look like radians: every "
        "theta is within [0, pi/2] and every phi within [-2 pi, 2 pi] (the largest theta "
        f"is {largest:g}, which as degrees puts every direction within 1.6 degrees of the "
        f"normal); if they are radians, say so ({how}); stating degrees silences this note"
    )
