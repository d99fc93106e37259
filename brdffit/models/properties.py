"""Measured properties of a model: directional albedo and reciprocity.

MODELS.md asks that reciprocity ``f(L, V) = f(V, L)`` and energy conservation
(albedo ``a(L) = integral f(L, V) cos(theta_o) dw_o <= 1``) be measured, not
typed by hand; this module measures them through the public contract only.

The albedo's quadrature, and the accuracy the tests establish for it, are described
in :mod:`brdffit.models.quadrature`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..data.geometry import Geometry, directions_from_angles
from ..errors import DataError, ParameterError
from . import get_model
from .base import Model
from .quadrature import AZIMUTHS, adapt

__all__ = ["Albedo", "ReciprocityError", "albedo", "reciprocity_error", "model_properties"]

#: A model counts as reciprocal when its measured violation is below this. Rounding
#: alone reaches about 1e-9 on grazing pairs with L nearly opposite V, where
#: V.H = (1 + L.V) / |L + V| loses digits; non-reciprocal formulas give 1e-3 to 1.
RECIPROCITY_TOLERANCE = 1e-6
#: Incidence angles (degrees) of model_properties.
PROPERTY_THETA_I = (0, 10, 20, 30, 40, 50, 60, 70, 80, 85)
LISTED_THETA_I = (0, 30, 60, 85)
#: Azimuths of incidence for anisotropic models. Lobes built on (H.T)^2, (H.B)^2
#: or (L.T)(V.T) are unchanged by T -> -T and B -> -B, so 0..90 degrees covers all.
ANISOTROPIC_PHI_I = (0, 45, 90)


@dataclass(frozen=True)
class Albedo:
    """Directional albedo with its error estimate (arrays are read-only).

    ``value`` has the broadcast shape of the incidence angles ``theta_i``,
    ``phi_i`` (degrees), plus a channel axis when the model gives one value per
    channel; ``error`` estimates ``|value - a(L)|`` (module docstring); ``rtol``
    is the accuracy requested and ``n_evals`` the number of BRDF values computed;
    ``stopped`` says that the ``deadline`` ended the refinement.
    """

    value: np.ndarray
    error: np.ndarray
    theta_i: np.ndarray
    phi_i: np.ndarray
    rtol: float
    n_evals: int
    stopped: bool = False

    def __post_init__(self):
        for array in (self.value, self.error, self.theta_i, self.phi_i):
            array.setflags(write=False)

    @property
    def converged(self) -> bool:
        """Whether every error estimate is within ``rtol`` of its value."""
        return bool(np.all(self.error <= self.rtol * np.abs(self.value)))


@dataclass(frozen=True)
class ReciprocityError:
    """``max`` and ``rms`` of ``|f(L, V) - f(V, L)| / max f`` over ``n_pairs`` pairs."""

    max: float
    rms: float
    n_pairs: int

    @property
    def is_reciprocal(self) -> bool:
        """Whether the violation is below what rounding can explain (1e-6)."""
        return self.max < RECIPROCITY_TOLERANCE


def albedo(model, params, theta_i, phi_i=0.0, *, rtol=1e-6, max_level=6, deadline=None) -> Albedo:
    """Directional albedo ``a(L) = integral f(L, V) cos(theta_o) dw_o`` (MODELS.md).

    Parameters
    ----------
    model : Model or str
        A model or a registered name.
    params : mapping or None
        Parameter values; names not given take the model's defaults. Linear
        parameters given per channel give one albedo per channel.
    theta_i, phi_i : float or array_like
        Incidence angles in degrees, ``0 <= theta_i < 90``, broadcast together.
    rtol : float
        Relative accuracy sought.
    max_level : int
        Finest refinement allowed, 0 to 6 (``16 * 2^max_level`` azimuths);
        ``converged`` says whether ``rtol`` was reached.
    deadline : float, optional
        A ``time.perf_counter()`` time after which no finer level is started (the
        first level always completes): the estimates so far are returned, with
        ``stopped`` set.

    Returns
    -------
    Albedo
        Values, error estimates, angles and the number of evaluations. The
        quadrature and the accuracy the tests establish are described in the
        module docstring.
    """
    model, params = _resolve(model, params)
    theta_deg, phi_deg = _check_incidence(theta_i, phi_i)
    if not (isinstance(rtol, (int, float)) and 0.0 < rtol < 1.0):
        raise ParameterError(f"rtol={rtol!r} must be a number between 0 and 1", "rtol")
    if not (isinstance(max_level, int) and 0 <= max_level < len(AZIMUTHS)):
        raise ParameterError(
            f"max_level={max_level!r} must be an integer from 0 to {len(AZIMUTHS) - 1}",
            "max_level",
        )
    theta, phi = np.radians(theta_deg.ravel()), np.radians(phi_deg.ravel())
    value, error, n_evals, stopped = adapt(
        model, params, theta, phi, float(rtol), max_level, deadline
    )
    shape = theta_deg.shape + value.shape[1:]
    return Albedo(
        value.reshape(shape),
        error.reshape(shape),
        theta_deg,
        phi_deg,
        float(rtol),
        n_evals,
        stopped,
    )


def reciprocity_error(model, params=None, n_pairs: int = 20000, seed: int = 0):
    """Measured violation of Helmholtz reciprocity ``f(L, V) = f(V, L)``.

    Parameters
    ----------
    model : Model or str
    params : mapping or None
        Parameter values; names not given take the defaults.
    n_pairs : int
        Number of random pairs. ``L`` is uniform over the upper hemisphere; half
        of the ``V`` are uniform too and half lie near the mirror direction of
        ``L`` (angular distance log-uniform in 1e-4..0.5 rad), so that narrow
        lobes are probed. Pairs that fall below the horizon are dropped.
    seed : int
        Seed of the generator: the same seed gives the same pairs.

    Returns
    -------
    ReciprocityError
        Over all pairs and channels, relative to the largest value either way.
    """
    model, params = _resolve(model, params)
    if not (isinstance(n_pairs, (int, np.integer)) and n_pairs >= 2):
        raise ParameterError(f"n_pairs={n_pairs!r} must be an integer of at least 2", "n_pairs")
    wi, wo = _random_pairs(int(n_pairs), np.random.default_rng(seed))
    forward = model.evaluate_prepared(Geometry(wi, wo, check=False), params, check=False)
    backward = model.evaluate_prepared(Geometry(wo, wi, check=False), params, check=False)
    scale = max(float(np.max(forward)), float(np.max(backward)))
    if scale <= 0.0:
        return ReciprocityError(0.0, 0.0, wi.shape[0])
    rel = np.abs(forward - backward) / scale
    return ReciprocityError(float(rel.max()), float(np.sqrt(np.mean(rel**2))), wi.shape[0])


def model_properties(model, params=None) -> dict:
    """Measured properties of a model for listings, JSON-ready.

    Parameters
    ----------
    model : Model or str
    params : mapping or None
        Parameter values; the model's defaults where not given.

    Returns
    -------
    dict
        ``params`` (the values used); ``max_albedo`` over ``theta_i`` = 0, 10, ...,
        80, 85 degrees (and ``phi_i`` = 0, 45, 90 for anisotropic models), with
        ``max_albedo_theta_i`` and ``max_albedo_phi_i``, the first angles whose
        albedo is within the error of it; ``albedo``, a mapping from ``"0"``,
        ``"30"``, ``"60"``, ``"85"`` (degrees, ``phi_i = 0``) to the albedo there;
        ``albedo_error``, the largest error estimate (``rtol = 1e-3``);
        ``energy_conserving``, ``max_albedo <= 1`` within that error;
        ``reciprocity_max``, ``reciprocity_rms`` (4000 pairs, seed 0) and
        ``reciprocal`` (``reciprocity_max < 1e-6``). Albedos are lists when the
        params give one value per channel.
    """
    model, params = _resolve(model, params)
    theta, phi = list(PROPERTY_THETA_I), [0.0] * len(PROPERTY_THETA_I)
    if model.classification.symmetry == "anisotropic":  # at theta_i = 0, phi_i is moot
        oblique = [t for t in PROPERTY_THETA_I if t > 0]
        for p in ANISOTROPIC_PHI_I[1:]:
            theta, phi = theta + oblique, phi + [p] * len(oblique)
    result = albedo(model, params, theta, phi, rtol=1e-3, max_level=4)
    per_channel = result.value.ndim > 1
    flat = result.value.reshape(len(theta), -1)
    error = float(np.max(result.error))
    max_albedo = flat.max(axis=0)
    best = int(np.argmax(flat.max(axis=1) >= max_albedo.max() - error))
    recip = reciprocity_error(model, params, n_pairs=4000, seed=0)
    return {
        "params": {name: _plain(v) for name, v in params.items()},
        "max_albedo": _plain(max_albedo if per_channel else max_albedo[0]),
        "max_albedo_theta_i": float(theta[best]),
        "max_albedo_phi_i": float(phi[best]),
        "albedo": {str(t): _plain(result.value[theta.index(t)]) for t in LISTED_THETA_I},
        "albedo_error": error,
        "energy_conserving": bool(np.all(max_albedo <= 1.0 + error)),
        "reciprocity_max": recip.max,
        "reciprocity_rms": recip.rms,
        "reciprocal": recip.is_reciprocal,
    }


# ----------------------------------------------------------------- internals
def _resolve(model, params) -> tuple[Model, dict]:
    model = get_model(model)
    if params is not None and not isinstance(params, Mapping):
        raise ParameterError(
            f"params must be a mapping of name to value, not {type(params).__name__}", "params"
        )
    return model, model.check_params({**model.defaults(), **(params or {})})


def _check_incidence(theta_i, phi_i) -> tuple[np.ndarray, np.ndarray]:
    try:
        theta, phi = (np.array(a, dtype=float) for a in np.broadcast_arrays(theta_i, phi_i))
    except (TypeError, ValueError) as exc:
        raise DataError(
            f"theta_i and phi_i must be numbers, or arrays that broadcast together: {exc}",
            "theta_i",
        ) from None
    for name, a in (("theta_i", theta), ("phi_i", phi)):
        if not np.isfinite(a).all():
            raise DataError(f"{name} contains NaN or inf; angles must be finite", name)
    if theta.size == 0:
        raise DataError("theta_i is empty; give at least one incidence angle", "theta_i")
    outside = (theta < 0.0) | (theta >= 90.0)
    if outside.any():
        raise DataError(
            f"theta_i={float(theta[outside].flat[0]):g} is not in [0, 90) degrees; "
            "the light must be above the horizon",
            "theta_i",
        )
    return theta, phi


def _random_pairs(n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    cos_theta = 1.0 - rng.uniform(0.0, 1.0, (2, n))  # uniform in (0, 1]: above the horizon
    wi, wo = directions_from_angles(np.arccos(cos_theta), rng.uniform(0, 2 * np.pi, (2, n)), False)
    near = n // 2
    mirror = wi[:near] * np.array([-1.0, -1.0, 1.0])
    side = np.cross(mirror, rng.normal(size=(near, 3)))  # orthogonal to the mirror direction
    side /= np.linalg.norm(side, axis=1, keepdims=True)
    psi = np.exp(rng.uniform(np.log(1e-4), np.log(0.5), near))[:, None]
    wo[:near] = np.cos(psi) * mirror + np.sin(psi) * side
    keep = wo[:, 2] > 0.0
    return wi[keep], wo[keep]


def _plain(value):
    """A float, or a list of floats, for JSON."""
    array = np.asarray(value, dtype=float)
    return float(array) if array.ndim == 0 else array.tolist()
