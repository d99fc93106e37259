"""Measured properties of a model: directional albedo and reciprocity.

MODELS.md asks that reciprocity ``f(L, V) = f(V, L)`` and energy conservation
(albedo ``a(L) = integral f(L, V) cos(theta_o) dw_o <= 1``) be measured, not
typed by hand; this module measures them through the public contract only.

Albedo quadrature. Lobes are centred on the mirror direction R and may be very
narrow (Beckmann at alpha = 0.001: 2e-4 rad across at grazing incidence), so
``V = cos(psi) R + sin(psi) (cos(chi) e1 + sin(chi) e2)``, ``e1`` in the plane of
incidence, ``e2`` horizontal, ``dw_o = sin(psi) dpsi dchi``. Each ray ends on the
horizon at ``psi_max = pi/2 + atan2(sin(theta_i) cos(chi), cos(theta_i))``, which
bounds the domain instead of cutting the integrand. In ``psi``: Clenshaw-Curtis
panels graded geometrically from R (1e-5 rad, then by factors of 4: accurate for
a lobe of any width above 1e-5 rad without knowing it), breaks at pi/2 (Phong's
kink) and at ``psi_max (1 - 2^-j)``, j = 1..3; the last panel is mapped by
``psi = psi_max - h s^2``, smoothing the ``sqrt(cos(theta_o))`` of Ward's lobe.
In ``chi``: the trapezoidal rule in ``u``, ``chi = u - (c/4) sin(4u)``,
``c = 1 - sqrt(cos(theta_i))``, which puts nodes near ``chi = 0, +-pi/2, pi``,
where at grazing incidence the horizon and the lobe (narrowed by
``cos(theta_i)``) vary fastest (the exponent 1/2 did best of those tried).

Each rule embeds one with half the azimuths and one with half the radial
intervals. Per incidence both dimensions are refined once, then each while its
embedded estimate or the change its last refinement made exceeds half the
tolerance (16 to 1024 azimuths, 4 to 32 intervals per panel, doubling). The
estimate is the larger of the embedded ones' sum and twice the last change,
plus 1e-12 of the sum of the terms for rounding: halving the spacing removes at
least half the error wherever the rule converges (a kink gives O(h^2)), and a
rule agreeing by accident with its half rule, common where convergence is
erratic, cannot stop the refinement alone.

Accuracy established by ``tests/test_properties.py`` at ``rtol = 1e-6``, the
true error below the estimate every time, within 1e-6: Lambert (0 to 89.9
degrees); normalised Phong at normal incidence (n = 1 to 1e4) and at 30 and 60
degrees (n >= 1e3); Blinn at normal incidence; normalised Beckmann (alpha =
0.001 to 0.03, up to 85 degrees); Ward (0.001 to 0.3) and a Cook-Torrance-like
lobe (0.001 to 0.1) against an adaptive integration over the half vector. The
V-cavity ``min`` puts kinks inside panels: at alpha = 0.3 the rule stops 1e-5
from the truth, unconverged, and says so. Limits: in a stress run (1300 albedos
of the 26 registered models at random parameters, rtol 1e-3 and 1e-5, against
rtol 1e-10) the estimate fell short twice, at rtol 1e-3: a lobe elongated 50 to
1 (``ggx_anisotropic``; its ridge in ``chi`` needs about 1000 azimuths) and, by
2 %, Blake's piecewise lobe. Narrow features away from R (sharp retro-reflective
Lafortune lobes, Fournier's tilted lobes at large n) are likewise found only as
the azimuths refine.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cache

import numpy as np

from ..data.geometry import Geometry, directions_from_angles
from ..errors import DataError, ParameterError
from . import get_model
from .base import Model

__all__ = ["Albedo", "ReciprocityError", "albedo", "reciprocity_error", "model_properties"]

#: 0, 1e-5 (below the narrowest lobe of MODELS.md's ranges) times powers of 4 up to
#: past pi (powers of 2 cost a third more for the same accuracy), and pi/2.
RADIAL_BREAKS = np.concatenate([[0.0], 1e-5 * 4.0 ** np.arange(10), [math.pi / 2]])
HORIZON_FRACTIONS = 1.0 - 2.0 ** -np.arange(1, 4)
#: Azimuths and intervals per radial panel of the levels; the last bounds memory.
AZIMUTHS = (16, 32, 64, 128, 256, 512, 1024)
RADIAL_INTERVALS = (4, 8, 16, 32)
#: Relative allowance for rounding: sums of up to 1e7 non-negative terms, each
#: computed to a few ulps, stay well inside it.
ROUNDING_FLOOR = 1e-12
#: Direction pairs evaluated at once, to bound memory (geometry caches included).
CHUNK_PAIRS = 1 << 19
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
    value, error, n_evals, stopped = _adapt(
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


class _Late(Exception):
    """The deadline passed during a level of the refinement."""


def _adapt(model, params, theta, phi, rtol, max_level, deadline=None):
    """Refine each incidence until its estimate is within ``rtol`` (module docstring),
    or until the ``deadline`` (``perf_counter`` time) after the first level."""
    value = error = changes = None
    level = np.zeros((theta.size, 2), dtype=int)  # azimuthal and radial level
    last_step = np.zeros((theta.size, 2), dtype=bool)
    active, n_evals = np.arange(theta.size), 0
    while active.size:
        groups, which = np.unique(level[active], axis=0, return_inverse=True)
        refined = []
        for g, (ia, ir) in enumerate(groups):
            idx = active[which.ravel() == g]
            late = None if value is None else deadline
            try:
                v, e_az, e_rad, floor, count = _rule(
                    model, params, theta[idx], phi[idx], AZIMUTHS[ia], RADIAL_INTERVALS[ir], late
                )
            except _Late:
                return value, error, n_evals, True
            n_evals += count
            if value is None:
                shape = (theta.size, *v.shape[1:])
                value, error = np.zeros(shape), np.zeros(shape)
                changes = np.full((2, *shape), np.inf)  # last change made in each dimension
            moved = last_step[idx] if ia + ir else np.zeros((idx.size, 2), dtype=bool)
            for d in (0, 1):
                rows = idx[moved[:, d]]
                changes[d, rows] = np.abs(v[moved[:, d]] - value[rows])
            value[idx] = v
            change = 2.0 * np.fmax(changes[0, idx], changes[1, idx])
            error[idx] = np.fmax(e_az + e_rad, change) + floor
            tol = 0.5 * rtol * np.abs(v)
            want = [np.fmax(e_az, changes[0, idx]) > tol, np.fmax(e_rad, changes[1, idx]) > tol]
            want = np.stack([w.reshape(idx.size, -1).any(axis=1) for w in want], axis=1)
            failing = (error[idx] > 2 * tol).reshape(idx.size, -1).any(axis=1)
            top = np.minimum(max_level, [len(AZIMUTHS) - 1, len(RADIAL_INTERVALS) - 1])
            step = want & failing[:, None] & (level[idx] < top)
            level[idx] += step
            last_step[idx] = step
            refined.append(idx[step.any(axis=1)])
        active = np.concatenate(refined)
    return value, error, n_evals, False


def _rule(model, params, theta, phi, n_azimuth, n_radial, deadline=None):
    """Value, azimuthal and radial estimates, rounding allowance and evaluations;
    raises _Late when the ``deadline`` passes between chunks."""
    per_angle = n_azimuth * (RADIAL_BREAKS.size + HORIZON_FRACTIONS.size) * (n_radial + 1)
    step = max(1, CHUNK_PAIRS // per_angle)
    parts = []
    for i in range(0, theta.size, step):
        if deadline is not None and time.perf_counter() > deadline:
            raise _Late
        parts.append(
            _rule_chunk(model, params, theta[i : i + step], phi[i : i + step], n_azimuth, n_radial)
        )
    return (*(np.concatenate(a) for a in zip(*parts)), per_angle * theta.size)


def quadrature_nodes(theta, phi, n_azimuth: int, n_radial: int):
    """Nodes and weights of the albedo rule for incidences ``theta``, ``phi`` (radians).

    Returns ``wi``, ``wo`` of shape (T * P, 3) and the weights of the full rule,
    of the rule with half the azimuths and of the rule with half the radial
    intervals, each (T, P): ``a(theta_t) = sum_p weight[t, p] f(wi, wo)[t * P + p]``.
    Nodes below the horizon carry weight 0 (and a harmless direction).
    """
    theta, phi = np.atleast_1d(theta), np.atleast_1d(phi)
    st, ct, sp, cp = (g(a)[:, None] for a in (theta, phi) for g in (np.sin, np.cos))
    u = (2.0 * math.pi / n_azimuth) * np.arange(n_azimuth)
    c = 1.0 - np.sqrt(ct)
    chi = u - 0.25 * c * np.sin(4.0 * u)
    w_chi = (2.0 * math.pi / n_azimuth) * (1.0 - c * np.cos(4.0 * u))
    w_chi_half = np.where(np.arange(n_azimuth) % 2 == 0, 2.0 * w_chi, 0.0)
    psi, w_psi, w_psi_half = _radial_nodes(np.pi / 2 + np.arctan2(st * np.cos(chi), ct), n_radial)
    zero = np.zeros_like(st)
    mirror = np.stack([-st * cp, -st * sp, ct], axis=-1)[:, :, None, None]
    e1, e2 = np.stack([ct * cp, ct * sp, st], -1), np.stack([-sp, cp, zero], -1)
    side = np.cos(chi)[..., None] * e1 + np.sin(chi)[..., None] * e2
    wo = np.cos(psi)[..., None] * mirror + np.sin(psi)[..., None] * side[:, :, None, None]
    below = wo[..., 2] <= 0.0
    jacobian = np.where(below, 0.0, np.sin(psi) * wo[..., 2])
    wo[below] = (0.0, 0.0, 1.0)  # weight 0; valid pairs spare the geometry masked copies
    wi = np.repeat(np.hstack([st * cp, st * sp, ct]), psi[0].size, axis=0)

    def weights(w_psi_, w_chi_):
        return (jacobian * w_psi_ * w_chi_[..., None, None]).reshape(theta.size, -1)

    return (
        wi,
        wo.reshape(-1, 3),
        weights(w_psi, w_chi),
        weights(w_psi, w_chi_half),
        weights(w_psi_half, w_chi),
    )


def _rule_chunk(model, params, theta, phi, n_azimuth, n_radial):
    wi, wo, w_full, w_chi_half, w_psi_half = quadrature_nodes(theta, phi, n_azimuth, n_radial)
    f = model.evaluate_prepared(Geometry(wi, wo, check=False), params, check=False)
    f = f.reshape((theta.size, -1, *f.shape[1:]))
    shape = (theta.size, -1) + (1,) * (f.ndim - 2)

    def total(values, w):
        return (values * w.reshape(shape)).sum(1)

    value = total(f, w_full)
    return (
        value,
        np.abs(value - total(f, w_chi_half)),
        np.abs(value - total(f, w_psi_half)),
        ROUNDING_FLOOR * total(np.abs(f), w_full),
    )


def _radial_nodes(psi_max: np.ndarray, n_radial: int):
    """Nodes in psi on [0, psi_max] per ray, and the weights of the full and half rules."""
    top = psi_max[..., None]
    fixed = np.broadcast_to(RADIAL_BREAKS, top.shape[:-1] + RADIAL_BREAKS.shape)
    breaks = np.concatenate([fixed, top * HORIZON_FRACTIONS, top], axis=-1)
    breaks = np.sort(np.minimum(breaks, top), axis=-1)
    lo, hi = breaks[..., :-1, None], breaks[..., 1:, None]
    width = hi - lo
    x, w, w_half = _clenshaw_curtis_01(n_radial)
    last = (hi == top[..., None]) & (width > 0.0)  # mapped by psi = psi_max - h s^2
    psi = np.where(last, hi - width * x * x, lo + width * x)
    scale = np.where(last, 2.0 * width * x, width)
    return psi, scale * w, scale * w_half


@cache
def _clenshaw_curtis_01(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Clenshaw-Curtis nodes and weights of ``n + 1`` points on [0, 1] (``n`` even),
    and the weights of the embedded ``n/2 + 1``-point rule (zero off its nodes).

    Weights by the cosine series of L. N. Trefethen, Spectral Methods in MATLAB
    (SIAM, 2000), program ``clencurt``.
    """

    def weights(m: int) -> np.ndarray:
        theta = np.pi * np.arange(1, m) / m
        v = np.ones(m - 1)
        for k in range(1, m // 2 + 1):
            v -= (1.0 if 2 * k == m else 2.0) * np.cos(2 * k * theta) / (4 * k * k - 1)
        end = 1.0 / (m * m - 1) if m % 2 == 0 else 1.0 / (m * m)
        return 0.5 * np.concatenate([[end], 2.0 * v / m, [end]])

    x = 0.5 * (1.0 - np.cos(np.pi * np.arange(n + 1) / n))
    half = np.zeros(n + 1)
    half[::2] = weights(n // 2)
    return x, weights(n), half


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
