"""Measured (or synthetic) reflectance: direction pairs, values per channel, sigma.

A :class:`Measurements` is read-only: its arrays are copies marked non-writeable,
and every method that changes something (``subsample``, ``split``,
``select_channels``, ``to_xyz``) returns a new object. Its
:meth:`~Measurements.geometry` is built once and cached, so that a fit prepares
the direction pairs once per dataset.

Angles follow MODELS.md: ``w = (sin t cos p, sin t sin p, cos t)``, degrees at
the edges of the system. A polar angle may lie anywhere in [0, 180] degrees:
past 90 the direction is below the horizon, where every model is zero; such
pairs are kept and counted (:attr:`Measurements.below_horizon_count`), so that a
file is never silently shortened. Azimuths may be any finite number.
"""

from __future__ import annotations

import re

import numpy as np

from ..errors import DataError
from ..notes import note
from ..words import plural
from .angle_units import radians_note, radians_suspected
from .checks import (
    ANGLE_COLUMNS,  # also imported from here by the readers
    _check_angles,
    _check_channels,
    _readonly,
    _validated,
)
from .geometry import Geometry, angles_from_directions, check_directions, directions_from_angles

__all__ = ["Measurements"]

#: The state of a Measurements, in the order of ``Measurements._derived``.
_FIELDS = ("wi", "wo", "values", "sigma", "channels", "source", "units", "angles")

_WAVELENGTH = re.compile(r"^\s*(\d+(?:\.\d*)?)\s*(?:nm)?\s*$", re.IGNORECASE)


class Measurements:
    """Reflectance samples: direction pairs, values per channel and optional sigma.

    Parameters
    ----------
    wi, wo : array_like, shape (N, 3)
        Unit directions towards the light and the viewer, local frame (MODELS.md).
    values : array_like, shape (N,) or (N, C)
        BRDF values (1/sr by default). Negative values are kept and counted; a
        ``UserWarning`` says how many.
    channels : sequence of str, optional
        One name per column: ``("value",)`` for one column, ``("c0", "c1", ...)``
        otherwise. Names such as ``"550nm"`` or ``"550"`` make the data spectral.
    sigma : array_like, shape (N,) or (N, C), optional
        Standard deviation of each value, positive and finite. An (N,) sigma with
        C > 1 channels applies to every channel.
    source : str
        Where the data came from (a file name, "synthetic ...").
    units : str
        Units of the values.
    """

    __slots__ = ("_angles", "_channels", "_geometry", "_sigma", "_source", "_units", "_values")
    __slots__ += ("_wi", "_wo")

    def __init__(self, wi, wo, values, channels=None, sigma=None, source="", units="1/sr"):
        wi, wo = check_directions(wi, wo)
        values, sigma, channels = _validated(wi.shape[0], values, channels, sigma)
        self._set(wi, wo, values, sigma, channels, str(source), str(units), None)
        self._warn_negative(stacklevel=3)

    def _warn_negative(self, stacklevel: int):
        if self.negative_count:
            where = f"{self._source}: " if self._source else ""
            note(
                f"{where}{self.negative_count} of {self._values.size} values are negative "
                "(measurement noise); they are kept and counted, and no model can reach them",
                stacklevel=stacklevel,
            )

    def _set(self, wi, wo, values, sigma, channels, source, units, angles):
        sigma = None if sigma is None else _readonly(sigma)
        angles = angles and (tuple(_readonly(a) for a in angles[0]), angles[1])
        fields = {"_wi": _readonly(wi), "_wo": _readonly(wo), "_values": _readonly(values)}
        fields.update(_sigma=sigma, _channels=tuple(channels), _source=source, _units=units)
        for name, value in dict(fields, _angles=angles, _geometry=None).items():
            object.__setattr__(self, name, value)

    @classmethod
    def _derived(cls, wi, wo, values, sigma, channels, source, units, angles):
        """A new object from arrays that are already valid (no checks, no warning)."""
        obj = cls.__new__(cls)
        obj._set(wi, wo, values, sigma, channels, source, units, angles)
        return obj

    def _replace(self, **changes) -> Measurements:
        return self._derived(**{k: changes.get(k, getattr(self, "_" + k)) for k in _FIELDS})

    def __setattr__(self, name, value):
        raise AttributeError(f"Measurements are read-only; cannot set {name!r}")

    def __reduce__(self):
        # Pickling (process pools, copy) must not go through the refused __setattr__.
        return (Measurements._derived, tuple(getattr(self, "_" + k) for k in _FIELDS))

    @classmethod
    def from_angles(cls, theta_i, phi_i, theta_o, phi_o, values, channels=None, sigma=None,
                    degrees=None, source="", units="1/sr"):  # fmt: skip
        """Measurements from spherical angles (MODELS.md convention).

        ``theta`` in [0, 180] (degrees, or [0, pi] radians with ``degrees=False``),
        ``phi`` any finite number. The angles are kept as given, so that
        :meth:`angles` returns them exactly and files round-trip byte for byte.
        A polar angle of exactly 90 degrees gives a direction with z = 0 exactly
        (cos(pi/2) evaluates to 6e-17, which would put it above the horizon).

        ``degrees=None`` (the default) reads degrees and notes
        (:func:`brdffit.notes.note`, a ``UserWarning``) when the angles look like
        radians (:func:`radians_suspected`); ``degrees=True`` states degrees and
        ``degrees=False`` radians, without that check.
        """
        stated, degrees = degrees is not None, True if degrees is None else bool(degrees)
        ti = _check_angles("theta_i", theta_i, None, degrees, True)
        n = ti.size
        pi_ = _check_angles("phi_i", phi_i, n, degrees, False)
        to = _check_angles("theta_o", theta_o, n, degrees, True)
        po = _check_angles("phi_o", phi_o, n, degrees, False)
        if not stated and radians_suspected(ti, pi_, to, po):
            largest = max(ti.max(), to.max())
            note(radians_note(source or "the angles", largest, "degrees=False"), stacklevel=2)
        wi = directions_from_angles(ti, pi_, degrees)
        wo = directions_from_angles(to, po, degrees)
        right = 90.0 if degrees else np.pi / 2
        wi[ti == right, 2] = 0.0
        wo[to == right, 2] = 0.0
        values, sigma, channels = _validated(n, values, channels, sigma)
        angles = ((ti, pi_, to, po), bool(degrees))
        obj = cls._derived(wi, wo, values, sigma, channels, str(source), str(units), angles)
        obj._warn_negative(stacklevel=3)
        return obj

    # ------------------------------------------------------------ properties
    wi = property(lambda self: self._wi, doc="(N, 3) unit directions towards the light.")
    wo = property(lambda self: self._wo, doc="(N, 3) unit directions towards the viewer.")
    values = property(lambda self: self._values, doc="(N, C) values, always 2-D.")
    sigma = property(lambda self: self._sigma, doc="(N, C) standard deviations, or None.")
    channels = property(lambda self: self._channels, doc="Channel names, one per column.")
    source = property(lambda self: self._source, doc="Where the data came from.")
    units = property(lambda self: self._units, doc="Units of the values.")

    @property
    def n(self) -> int:
        """Number of samples (direction pairs)."""
        return self._values.shape[0]

    @property
    def n_channels(self) -> int:
        return self._values.shape[1]

    @property
    def negative_count(self) -> int:
        """Number of values (over all channels) below zero."""
        return int((self._values < 0).sum())

    @property
    def below_horizon_count(self) -> int:
        """Pairs with wi or wo at or below the horizon (z <= 0): every model is zero there."""
        return int(((self._wi[:, 2] <= 0) | (self._wo[:, 2] <= 0)).sum())

    def __len__(self) -> int:
        return self.n

    def __repr__(self) -> str:
        return (
            f"Measurements(n={self.n}, channels={list(self._channels)}, "
            f"sigma={'yes' if self._sigma is not None else 'no'}, source={self._source!r})"
        )

    # --------------------------------------------------------------- derived
    def angles(self, degrees: bool = True) -> tuple:
        """``(theta_i, phi_i, theta_o, phi_o)``.

        The angles given to :meth:`from_angles` when the data were built from
        angles (converted if the unit differs), otherwise computed from the
        directions with the azimuth in [0, 360) degrees.
        """
        if self._angles is not None:
            stored, stored_degrees = self._angles
            if stored_degrees == degrees:
                return stored
            convert = np.degrees if degrees else np.radians
            return tuple(convert(a) for a in stored)
        ti, pi_ = angles_from_directions(self._wi, degrees)
        to, po = angles_from_directions(self._wo, degrees)
        return ti, pi_, to, po

    def wavelengths(self) -> np.ndarray | None:
        """Wavelengths in nm when every channel is named like ``"550nm"`` or ``"550"``."""
        found = [_WAVELENGTH.match(c) for c in self._channels]
        if not all(found):
            return None
        return np.array([float(m.group(1)) for m in found])

    def geometry(self) -> Geometry:
        """The :class:`Geometry` of the direction pairs, built once and cached."""
        if self._geometry is None:
            object.__setattr__(self, "_geometry", Geometry(self._wi, self._wo, check=False))
        return self._geometry

    def subset(self, index) -> Measurements:
        """The samples selected by an integer index array or a boolean mask of length N."""
        index = np.asarray(index)
        if index.dtype == bool:
            if index.shape != (self.n,):
                raise DataError(
                    f"a boolean mask must have length {self.n}, not {index.shape}", "index"
                )
            index = np.flatnonzero(index)
        if index.size == 0:
            raise DataError("the selection is empty; at least one sample is needed", "index")
        angles = self._angles and (tuple(a[index] for a in self._angles[0]), self._angles[1])
        sigma = None if self._sigma is None else self._sigma[index]
        return self._replace(wi=self._wi[index], wo=self._wo[index], values=self._values[index],
                             sigma=sigma, angles=angles)  # fmt: skip

    def select_channels(self, names) -> Measurements:
        """The data restricted to (and ordered as) the named channels."""
        names = (names,) if isinstance(names, str) else tuple(names)
        missing = [x for x in names if x not in self._channels]
        if missing or not names:
            raise DataError(
                f"unknown channel(s) {missing or list(names)}; the channels are "
                f"{list(self._channels)}",
                "channels",
            )
        names = _check_channels(names, len(names))
        cols = [self._channels.index(x) for x in names]
        sigma = None if self._sigma is None else self._sigma[:, cols]
        return self._replace(values=self._values[:, cols], sigma=sigma, channels=names)

    def subsample(self, n=None, fraction=None, seed=0) -> Measurements:
        """A random subset of ``n`` samples (or a ``fraction`` of them), in original order."""
        if (n is None) == (fraction is None):
            raise DataError("give exactly one of n and fraction to subsample", "n")
        if fraction is not None:
            if not 0 < fraction <= 1:
                raise DataError(f"fraction={fraction!r} must be in (0, 1]", "fraction")
            n = max(1, round(fraction * self.n))
        if int(n) != n or not 1 <= n <= self.n:
            raise DataError(f"n={n!r} must be a whole number in [1, {self.n}]", "n")
        rng = np.random.default_rng(seed)
        return self.subset(np.sort(rng.choice(self.n, size=int(n), replace=False)))

    def split(self, test_fraction=0.2, seed=0) -> tuple:
        """Disjoint ``(train, test)`` sets, drawn with a seeded permutation."""
        if not 0 < test_fraction < 1:
            raise DataError(f"test_fraction={test_fraction!r} must be in (0, 1)", "test_fraction")
        n_test = round(test_fraction * self.n)
        if not 1 <= n_test <= self.n - 1:
            raise DataError(
                f"test_fraction={test_fraction!r} of {plural(self.n, 'sample')} leaves an empty "
                "train or test set; more samples or another fraction are needed",
                "test_fraction",
            )
        order = np.random.default_rng(seed).permutation(self.n)
        return self.subset(np.sort(order[n_test:])), self.subset(np.sort(order[:n_test]))

    # ---------------------------------------------------------------- colour
    def to_xyz(self) -> Measurements:
        """CIE XYZ channels from spectral channels, through :mod:`brdffit.data.colour`.

        The spectral-to-XYZ map is linear (integration against the colour
        matching functions), ``XYZ = values @ M``; sigma is propagated as for
        independent errors, ``sigma_XYZ^2 = sigma^2 @ M^2`` (the correlations the
        map introduces between X, Y and Z are dropped).
        """
        if self._channels == ("X", "Y", "Z"):
            return self
        wavelengths = self.wavelengths()
        if wavelengths is None:
            raise DataError(
                f"to_xyz needs spectral channels named like '550nm'; these are "
                f"{list(self._channels)}",
                "channels",
            )
        from .colour import tristimulus_weights

        return self._linear_map(tristimulus_weights(wavelengths), ("X", "Y", "Z"))

    def to_srgb(self) -> Measurements:
        """Linear sRGB channels ``("r", "g", "b")`` (no gamma: reflectance stays linear).

        Out-of-gamut colours keep their negative components (not clipped: the map
        stays linear); a note (``UserWarning``) counts them
        (:func:`brdffit.data.colour.gamut_note`).
        """
        if self._channels == ("r", "g", "b"):
            return self
        from .colour import gamut_note, xyz_to_srgb

        xyz = self.to_xyz()
        matrix = np.asarray(xyz_to_srgb(np.eye(3)), dtype=float)
        out = xyz._linear_map(matrix, ("r", "g", "b"))
        gamut_note(out.values, self._source)
        return out

    def _linear_map(self, matrix: np.ndarray, names: tuple) -> Measurements:
        values = self._values @ matrix
        sigma = None
        if self._sigma is not None:
            sigma = np.sqrt(self._sigma**2 @ matrix**2)
            # A channel that no input reaches has zero sigma; sigma must stay positive.
            sigma = np.maximum(sigma, np.finfo(float).tiny)
        return self._replace(values=values, sigma=sigma, channels=names)

    # -------------------------------------------------------------- printing
    def to_dict(self, include_data: bool = False) -> dict:
        """A JSON-ready summary; with ``include_data`` also the angles (degrees) and values."""
        wavelengths, angles = self.wavelengths(), self.angles()
        out = {
            "n": self.n,
            "channels": list(self._channels),
            "source": self._source,
            "units": self._units,
            "has_sigma": self._sigma is not None,
            "negative_count": self.negative_count,
            "below_horizon_count": self.below_horizon_count,
            "wavelengths_nm": None if wavelengths is None else wavelengths.tolist(),
            "min": self._values.min(axis=0).tolist(),
            "max": self._values.max(axis=0).tolist(),
            "theta_i_deg": sorted({round(float(t), 6) for t in angles[0]})[:50],
        }
        if include_data:
            out.update({k: np.asarray(a).tolist() for k, a in zip(ANGLE_COLUMNS, angles)})
            out["values"] = self._values.tolist()
            out["sigma"] = None if self._sigma is None else self._sigma.tolist()
        return out

    def summary(self) -> str:
        """A few lines describing the data, for printing."""
        d = self.to_dict()
        wl = d["wavelengths_nm"]
        channels = (
            f"{len(wl)} wavelengths {wl[0]:g}..{wl[-1]:g} nm" if wl else ", ".join(d["channels"])
        )
        thetas = ", ".join(f"{t:g}" for t in d["theta_i_deg"][:12])
        return (
            f"{plural(self.n, 'sample')} from {self._source or 'arrays'}; channels: {channels}; "
            f"units {self._units}\n"
            f"values {min(d['min']):.6g} .. {max(d['max']):.6g}; {d['negative_count']} negative; "
            f"{plural(d['below_horizon_count'], 'pair')} at or below the horizon; "
            f"sigma {'given' if d['has_sigma'] else 'not given'}\n"
            f"theta_i (deg): {thetas}{' ...' if len(d['theta_i_deg']) > 12 else ''}"
        )
