"""The directional albedo's quadrature (used by :func:`brdffit.models.properties.albedo`
and the energy rows of :mod:`brdffit.fitting.energy`).

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

Accuracy established by ``tests/models/test_properties.py`` at ``rtol = 1e-6``, the
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
from functools import cache

import numpy as np

from ..data.geometry import Geometry

__all__ = ["AZIMUTHS", "RADIAL_INTERVALS", "adapt", "quadrature_nodes"]

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


class _Late(Exception):
    """The deadline passed during a level of the refinement."""


def adapt(model, params, theta, phi, rtol, max_level, deadline=None):
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
