"""Synthetic measurements with known truth: a model, its parameters, a geometry, noise.

``synthesize(model, params, geometry=...)`` evaluates the model on a set of
direction pairs and adds seeded Gaussian noise, so that a fit can be checked
against the parameters that made the data. Geometries:

- ``"gonio"``: a gonioreflectometer grid like the Cornell one. Incidence at the
  polar angles ``theta_i`` and azimuths ``azimuths``; outgoing directions on the
  grid ``theta_o`` x (``phi_i`` + multiples of ``phi_step``), plus a cross of
  finer steps around the mirror direction (``phi_o = phi_i + 180``) so that
  narrow lobes are seen. Anisotropic models get three incidence azimuths by
  default, so that the anisotropy is seen.
- ``"merl"``: the cell centres of the MERL table (:func:`brdffit.io.merl.grid_directions`,
  option ``step``).
- ``"hemisphere"``: ``n`` pairs drawn uniformly in solid angle over the upper
  hemisphere (``cos theta`` uniform, ``phi`` uniform), seeded.
- explicit ``(wi, wo)`` arrays, four angle arrays ``(theta_i, phi_i, theta_o,
  phi_o)`` in degrees (checked as by :meth:`Measurements.from_angles`), or the
  directions of a :class:`Measurements`.

With any geometry, ``n`` keeps a seeded random subset of ``n`` pairs.
"""

from __future__ import annotations

import numpy as np

from .data.geometry import Geometry, check_directions, directions_from_angles
from .data.measurements import Measurements
from .errors import DataError
from .models import get_model

__all__ = ["GEOMETRIES", "gonio_angles", "hemisphere_angles", "synthesize"]

GEOMETRIES = ("gonio", "merl", "hemisphere")
GEOMETRY_OPTIONS = {
    "gonio": {"theta_i", "azimuths", "theta_o", "phi_step", "peak"},
    "merl": {"step"},
    "hemisphere": set(),
}

#: Defaults of the gonio grid, in degrees.
GONIO_DEFAULTS = {
    "isotropic": {"theta_i": (15, 30, 45, 60, 75), "azimuths": (0,)},
    "anisotropic": {"theta_i": (20, 45, 70), "azimuths": (0, 45, 90)},
}
THETA_O = tuple(range(0, 81, 10))
PEAK_STEPS = (1.0, 2.0, 4.0, 8.0)


def gonio_angles(theta_i, azimuths=(0,), theta_o=THETA_O, phi_step=30.0, peak=True):
    """Angles (degrees) of a gonioreflectometer grid: ``(theta_i, phi_i, theta_o, phi_o)``.

    Every incidence ``(theta_i, azimuth)`` sees the outgoing grid ``theta_o`` x
    ``azimuth + k phi_step`` (one direction at theta_o = 0) and, with ``peak``,
    the mirror direction with in-plane steps of 1, 2, 4, 8 degrees in theta_o
    (kept within [0, 89]) and out-of-plane steps of 1, 2, 4, 8 degrees in phi_o.
    Duplicates are dropped; azimuths are wrapped into [0, 360).
    """
    if not phi_step > 0:
        raise DataError(f"phi_step={phi_step!r} must be positive", "phi_step")
    offsets = np.arange(0.0, 360.0, float(phi_step))
    rows = []
    for ti in np.atleast_1d(np.asarray(theta_i, dtype=float)):
        for pi_ in np.atleast_1d(np.asarray(azimuths, dtype=float)):
            for to in np.atleast_1d(np.asarray(theta_o, dtype=float)):
                rows += [(ti, pi_, to, pi_ + off) for off in (offsets[:1] if to == 0 else offsets)]
            if peak:
                mirror = pi_ + 180.0
                steps = np.concatenate([-np.asarray(PEAK_STEPS), [0.0], PEAK_STEPS])
                rows += [(ti, pi_, ti + d, mirror) for d in steps if 0 <= ti + d <= 89]
                rows += [(ti, pi_, ti, mirror + d) for d in steps if d != 0]
    table = np.array(rows, dtype=float)
    table[:, [1, 3]] = np.mod(table[:, [1, 3]], 360.0)
    _, first = np.unique(np.round(table, 9), axis=0, return_index=True)
    table = table[np.sort(first)]
    return tuple(table[:, j] for j in range(4))


def hemisphere_angles(n: int, rng: np.random.Generator):
    """``n`` pairs uniform in solid angle over the upper hemisphere (degrees)."""
    # 1 - u lies in (0, 1], so no direction falls exactly on the horizon.
    cos_theta = 1.0 - rng.uniform(0.0, 1.0, (2, n))
    theta = np.degrees(np.arccos(cos_theta))
    phi = rng.uniform(0.0, 360.0, (2, n))
    return theta[0], phi[0], theta[1], phi[1]


def _pairs(geometry, model, n, rng, options):
    """``(angles or None, wi, wo)`` of the requested geometry."""
    if isinstance(geometry, Measurements):
        return None, geometry.wi, geometry.wo
    if not isinstance(geometry, str):
        parts = tuple(geometry) if isinstance(geometry, (tuple, list)) else ()
        if len(parts) == 4:
            return Measurements.from_angles(*parts, np.zeros(len(parts[0]))).angles(), None, None
        if len(parts) != 2:
            raise DataError(
                f"geometry must be one of {', '.join(GEOMETRIES)}, a pair (wi, wo), four "
                f"angle arrays in degrees or Measurements, not {type(geometry).__name__}",
                "geometry",
            )
        return None, *parts
    allowed = GEOMETRY_OPTIONS.get(geometry, set())
    unknown = sorted(set(options) - allowed)
    if unknown and geometry in GEOMETRY_OPTIONS:
        raise DataError(
            f"the {geometry} geometry does not take the option(s) {', '.join(unknown)}; "
            f"it takes {', '.join(sorted(allowed)) or 'none'}",
            unknown[0],
        )
    if geometry == "gonio":
        symmetry = getattr(getattr(model, "classification", None), "symmetry", "isotropic")
        return gonio_angles(**{**GONIO_DEFAULTS[symmetry], **options}), None, None
    if geometry == "hemisphere":
        return hemisphere_angles(1000 if n is None else int(n), rng), None, None
    if geometry == "merl":
        from .io.merl import grid_directions

        return None, *grid_directions(**options)
    raise DataError(
        f"unknown geometry {geometry!r}; it must be one of {', '.join(GEOMETRIES)}, "
        "or a pair (wi, wo)",
        "geometry",
    )


def _directions(angles) -> tuple:
    """Directions of degree angles; z = 0 exactly at 90 degrees, as Measurements.from_angles."""
    wi = directions_from_angles(angles[0], angles[1])
    wo = directions_from_angles(angles[2], angles[3])
    wi[angles[0] == 90.0, 2] = 0.0
    wo[angles[2] == 90.0, 2] = 0.0
    return wi, wo


def _noise_sigma(f: np.ndarray, noise: float, noise_kind: str) -> np.ndarray:
    if noise_kind == "absolute":
        return np.full(f.shape, float(noise))
    # sigma = noise |f|, floored far below every non-zero value so that it stays
    # positive where the model is exactly zero.
    floor = 1e-12 * max(float(np.abs(f).max()), 1e-300)
    return noise * np.maximum(np.abs(f), floor)


def _check_noise(noise, noise_kind) -> float:
    if noise_kind not in ("relative", "absolute"):
        raise DataError(
            f"noise_kind={noise_kind!r} is not known; it must be 'relative' or 'absolute'",
            "noise_kind",
        )
    try:
        noise = float(noise)
    except (TypeError, ValueError):
        raise DataError(f"noise={noise!r} must be a number", "noise") from None
    if not (np.isfinite(noise) and noise >= 0):
        raise DataError(f"noise={noise!r} must be a finite number >= 0", "noise")
    return noise


def synthesize(model, params=None, geometry="gonio", noise=0.0, noise_kind="relative", seed=0,
               n=None, channels=None, **geometry_options) -> Measurements:  # fmt: skip
    """Measurements of ``model`` with ``params``, on a geometry, with seeded Gaussian noise.

    Parameters
    ----------
    model : str or Model
        A registered model name or a Model.
    params : mapping, optional
        Parameter values; missing ones take the model's defaults. Linear
        parameters given per channel (length C) make C channels.
    geometry : str, (wi, wo), (theta_i, phi_i, theta_o, phi_o) or Measurements
        ``"gonio"``, ``"merl"``, ``"hemisphere"`` (module docstring), or
        explicit direction pairs or angles (degrees).
    noise : float
        Standard deviation of the Gaussian noise: relative,
        ``sigma = noise * |f|``, or absolute, ``sigma = noise``
        (``noise_kind``). The returned ``sigma`` is this sigma (None if 0).
    seed : int
        Seed of ``numpy.random.default_rng``: the hemisphere draw, the subset
        and the noise, in that order.
    n : int, optional
        Number of pairs of the hemisphere geometry (default 1000); with other
        geometries, a seeded random subset of ``n`` pairs.
    channels : sequence of str, optional
        Channel names; default ``("value",)`` for one channel, ``("r", "g", "b")``
        for three, ``("c0", ...)`` otherwise.
    **geometry_options
        ``theta_i``, ``azimuths``, ``theta_o``, ``phi_step``, ``peak`` (gonio);
        ``step`` (merl).
    """
    model = get_model(model)
    noise = _check_noise(noise, noise_kind)
    values = model.check_params({**model.defaults(), **dict(params or {})})
    rng = np.random.default_rng(seed)
    angles, wi, wo = _subset(*_pairs(geometry, model, n, rng, geometry_options), geometry, n, rng)
    f = model.evaluate_prepared(Geometry(wi, wo, check=False), values, check=False)
    f = f.reshape(len(wi), -1)
    sigma = _noise_sigma(f, noise, noise_kind) if noise > 0 else None
    noisy = f if sigma is None else f + sigma * rng.standard_normal(f.shape)
    channels = _channel_names(model, values, f.shape[1]) if channels is None else channels
    source = f"synthetic {model.name}, {noise:g} {noise_kind} noise, seed {seed}"
    if angles is not None:
        return Measurements.from_angles(*angles, noisy, channels=channels, sigma=sigma,
                                        source=source)  # fmt: skip
    return Measurements(wi, wo, noisy, channels, sigma, source)


def _subset(angles, wi, wo, geometry, n, rng) -> tuple:
    """Unit directions of the pairs, and a seeded subset of ``n`` of them (but for the
    hemisphere geometry, which draws ``n`` pairs in the first place)."""
    if angles is None:
        wi, wo = check_directions(wi, wo)
    else:
        wi, wo = _directions(angles)
    if n is not None and geometry != "hemisphere":
        if not 1 <= int(n) <= len(wi):
            raise DataError(f"n={n!r} must be in [1, {len(wi)}] for this geometry", "n")
        keep = np.sort(rng.choice(len(wi), size=int(n), replace=False))
        angles = None if angles is None else tuple(a[keep] for a in angles)
        wi, wo = wi[keep], wo[keep]
    return angles, wi, wo


def _channel_names(model, values, n_channels: int):
    """Channels of a wave-optics model are named by their wavelength, so that a fit of
    the data finds them (``550nm``); one channel is ``value``, three ``r, g, b``."""
    wavelength = next((p.name for p in model.params if p.per_channel), None)
    if wavelength is not None:
        nm = np.broadcast_to(np.asarray(values[wavelength], dtype=float), (n_channels,))
        return tuple(f"{w:g}nm" for w in nm)
    if n_channels in (1, 3):
        return ("value",) if n_channels == 1 else ("r", "g", "b")
    return None
