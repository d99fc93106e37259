"""Which fitted parameters the data do not constrain.

A fit always returns numbers; some of them the data cannot have decided. Two
checks, run on every fit, name those parameters with the reason
(:attr:`brdffit.fitting.result.FitResult.unidentified`):

1. **Azimuth coverage (anisotropic models).** A BRDF is anisotropic when it
   changes as the surface turns about its normal with the relative geometry
   held, i.e. with the incidence azimuth ``phi_i`` at fixed ``theta_i``,
   ``theta_o`` and ``phi_o - phi_i``. Data measured at one incidence azimuth
   (every ``phi_i`` the same, up to the mirror symmetries ``phi -> -phi`` and
   ``phi -> pi - phi`` of the anisotropic lobes here) never turn the surface:
   an isotropic material and an anisotropic one agree on all of them once the
   lobe's in-plane and cross-plane widths are fitted. The anisotropy parameters
   then describe the lobe's shape in the plane of incidence, not the material,
   and are reported unidentified. (Samples within 1 degree of the normal carry
   no incidence azimuth and do not count.)
2. **Fisher information.** At the optimum, the Jacobian ``J`` of the weighted
   residuals (the Gauss-Newton linearisation of the fit's loss,
   :meth:`brdffit.fitting.losses.Loss.linearised`) with respect to every free
   parameter (shape parameters in the search space, log10 for log-scale ones;
   each channel's linear coefficients; coefficients at a bound of their range
   are held there by it and left out) gives the Fisher information
   ``F = J^T W J / s^2`` (``s^2 = 1`` for ``chi2``, else the residual variance
   ``RSS / (n - p)``), whose inverse is the covariance of the estimate to
   first order (Bates and Watts, *Nonlinear Regression Analysis and Its
   Applications*, Wiley 1988, sections 2.2 and 3.5). ``F`` is scaled to unit
   diagonal; a direction whose eigenvalue is below :data:`RANK_RTOL` of the
   largest is one along which the data change the fit by nothing
   (rank-deficient ``F``), and every parameter with weight in it is
   unidentified. For the other shape parameters, the relative 1-sigma width
   (``ln 10 sd(log10 p)`` for log-scale ones, ``sd / |p|`` otherwise) above
   :data:`MAX_RELATIVE_WIDTH` means the data do not fix even the parameter's
   order of magnitude.

A shape parameter's column is a central difference (one-sided at a bound) of the
model's own evaluation, in the parameters as reported; a linear parameter's is the
model's design column (a difference where the parameters are mapped to the
coefficients). The information is formed channel by channel
(:mod:`brdffit.fitting.information`). Above :data:`MAX_ENTRIES`
it is formed on a seeded subset of the samples, the model evaluated on those
pairs alone, and the information scaled back to all of them.
"""

from __future__ import annotations

import math
import time
from dataclasses import fields, replace

import numpy as np

from .information import (
    channel_information,
    coefficient_diagonal,
    judge,
    linearised,
    residual_variance,
)
from .problem import linear_at_bounds
from .schedule import seeded_rows

__all__ = ["ANISOTROPY", "MAX_RELATIVE_WIDTH", "RANK_RTOL", "unidentified"]

#: The parameters that make each anisotropic model anisotropic (its isotropic
#: reduced form has them equal, or at zero). Anisotropic models not listed here
#: are anisotropic by construction: all their shape parameters count.
ANISOTROPY = {
    "ggx_anisotropic": ("alpha_u", "alpha_v"),
    "beckmann_anisotropic": ("alpha_u", "alpha_v"),
    "ward_anisotropic": ("alpha_x", "alpha_y"),
    "ashikhmin_shirley": ("nu", "nv"),
    "ashikhmin_phong": ("nu", "nv"),
    "mitsuba_roughconductor_anisotropic": ("alpha_u", "alpha_v"),
    "mitsuba_principled_anisotropic": ("anisotropic",),
    "gltf_pbr_anisotropic": ("anisotropy_strength", "anisotropy_rotation"),
}
#: Eigenvalue of the unit-diagonal Fisher information, relative to its largest, below
#: which a direction counts as unconstrained (a singular value 1e-6 of the largest:
#: far above the round-off of the differences, far below any real effect).
RANK_RTOL = 1e-12
#: Relative 1-sigma width above which a shape parameter counts as unconstrained.
MAX_RELATIVE_WIDTH = 1.0
#: Step of the central differences, in the search space (log10 or a share of the range).
STEP = 1e-4
EXACT_COEFFICIENTS = True  #: Coefficients' columns from the design, not by differences.
#: Incidence angles (degrees) below this carry no azimuth.
NORMAL_INCIDENCE = 1.0
#: Folded incidence azimuths within this many degrees count as one.
SAME_AZIMUTH = 1.0


def unidentified(problem, params, deadline=None, pred=None) -> dict:
    """Name -> reason for every free parameter of a fit that the data do not constrain.

    Parameters
    ----------
    problem : Problem
        The fit's problem (its data, model, loss, weights and fixed parameters).
    params : mapping
        The fitted parameters, as reported.
    deadline : float, optional
        A ``time.perf_counter()`` time (the fit's timeout): the Fisher check stops
        there (plus :data:`GRACE` seconds) and names nothing.
    pred : ndarray (N, C), optional
        The fit's prediction at ``params`` (:meth:`Problem.predict`): not evaluated again.

    Returns
    -------
    dict
        Parameter name -> the reason in words; empty when the data constrain every one.
    """
    out: dict[str, list] = {}
    try:
        fisher = _fisher(problem, dict(params), deadline, pred)
    except _Late:
        fisher = {}
    for name, why in [*_azimuth_coverage(problem).items(), *fisher.items()]:
        out.setdefault(name, []).append(why)
    return {name: "; ".join(reasons) for name, reasons in out.items()}


def _anisotropy_params(problem) -> list:
    """The free parameters that carry the anisotropy of the model (or of its lobes)."""
    model = problem.model
    if model.classification.symmetry != "anisotropic":
        return []
    free = [p.name for p in problem.free_shape]
    names = []
    for name in free:
        label, _, own = name.rpartition(".")
        component = _component_model(label or model.name)
        if component is None or component.classification.symmetry != "anisotropic":
            continue
        if own in ANISOTROPY.get(component.name, tuple(p.name for p in component.shape_params)):
            names.append(name)
    return names


def _component_model(label: str):
    """The registered model of a component label (``ggx_anisotropic_2`` -> ggx_anisotropic)."""
    from ..models import REGISTRY

    if label in REGISTRY:
        return REGISTRY[label]
    base, _, number = label.rpartition("_")
    return REGISTRY.get(base) if number.isdigit() else None


def _azimuth_coverage(problem) -> dict:
    names = _anisotropy_params(problem)
    if not names:
        return {}
    theta_i, phi_i, _, _ = problem.data.angles()
    tilted = np.asarray(theta_i) >= NORMAL_INCIDENCE
    if not tilted.any():
        return {}
    folded = np.mod(np.asarray(phi_i)[tilted], 180.0)
    folded = np.minimum(folded, 180.0 - folded)  # the lobes' mirror symmetries
    if np.ptp(folded) > SAME_AZIMUTH:
        return {}
    why = (
        f"every sample has the incidence azimuth phi_i = {float(np.median(folded)):.3g} deg "
        "(up to mirror symmetry): the surface is never turned, so anisotropy (a change "
        "with phi_i) cannot show in these data"
    )
    return {name: why for name in names}


#: Seconds the Fisher check may run past the fit's deadline.
GRACE = 0.5


class _Late(Exception):
    """The fit's deadline passed during the Fisher check."""


#: At most this many Jacobian entries (rows x columns) are formed (memory), and at most
#: MAX_ROWS samples used (time: the information of 50,000 samples fixes its eigenvalues
#: to about 0.5 %); above either a seeded subset of the samples is used and the
#: information scaled back to all of them.
MAX_ENTRIES = 4_000_000
MAX_ROWS = 50_000


def _fisher(problem, params: dict, deadline=None, pred=None) -> dict:
    """Unidentified parameters by the rank of the Fisher information and the widths
    (``pred``, the fit's values at ``params``, where they are the check's own)."""
    quick = _coefficients_only(problem, params, pred)
    if quick is not None:
        return quick
    if deadline is not None:
        deadline = max(deadline, time.perf_counter()) + GRACE
    snapped = _at_their_bounds(problem, params)
    rows = _rows(problem)
    geometry = _geometry(problem, rows)
    whole = len(rows) == problem.geometry.m and problem.geometry.all_valid
    same = pred is not None and whole and all(v is params[k] for k, v in snapped.items())
    base = pred if same else _predict(problem, snapped, geometry) if _reads(problem) else None
    params, ctx = snapped, _context(problem, rows)
    unit = problem.loss.name == "l2" and ctx.weights is None  # weights of ones: none
    ref = ctx.y if base is None else base  # a linear loss's weights read only its shape
    w, target = linearised(problem.loss, ref, ctx, unit)
    names, kinds, sources, layout = _jacobian(problem, params, geometry, base, deadline)
    if not layout:
        return {}
    sqrt_w = None if unit else np.sqrt(w)  # the information, (P,) where it is diagonal:
    info = coefficient_diagonal(sources, layout, sqrt_w)
    info = channel_information(sources, layout, sqrt_w) if info is None else info
    info *= problem.geometry.m / len(rows)
    dof = max(ref.size * problem.geometry.m / len(rows) - len(names), 1.0)
    s2 = residual_variance(problem.loss, target, base, w, dof)
    return _judge(names, kinds, info / max(s2, 1e-300), params)


def _coefficients_only(problem, params: dict, pred) -> dict | None:
    """:func:`_fisher`'s operations for one linear parameter's coefficients alone (lambert's
    kd; its design column, every sample, none at a bound, a linear loss, residuals from
    ``pred``) on the same arrays, without the general steps' copies; else None."""
    model, loss, m, c = problem.model, problem.loss, problem.geometry.m, problem.n_channels
    free = [p for p in model.linear_params if p.name not in problem.fixed]
    exact = EXACT_COEFFICIENTS and model.to_coefficients is None
    if problem.dim or len(free) != 1 or not (exact and loss.linear) or len(_rows(problem)) != m:
        return None
    p, ctx = free[0], problem.ctx
    low, high = linear_at_bounds(p, params[p.name])
    whole = pred is not None and problem.geometry.all_valid  # pred: the check's own values
    if low.any() or high.any() or not (loss.needs_sigma or whole):
        return None  # held at a bound, or values to evaluate: _fisher's steps
    value = np.asarray(params[p.name], dtype=float)
    values = (value if value.shape == (c,) else np.broadcast_to(value, (c,))).tolist()
    inside = [i for i, v in enumerate(values) if p.lower < v < p.upper]
    if not inside:
        return {}
    names = [p.name if c == 1 else f"{p.name}[{problem.data.channels[i]}]" for i in inside]
    unit = loss.name == "l2" and ctx.weights is None
    w, target = linearised(loss, ctx.y, ctx, unit)  # a linear loss's: reads its shape
    column = _design(problem, params, problem.geometry).columns[model.coefficients.index(p.name)]
    column = np.asarray(column, float)
    column = column if column.ndim == 2 else column[..., None]  # times sqrt_w: its values
    source = np.broadcast_to(column, (m, c)) if unit else column  # (a broadcast: 5 us)
    info = coefficient_diagonal([source], [(0, i) for i in inside], None if unit else np.sqrt(w))
    if info is None:
        return None
    s2 = residual_variance(loss, target, pred, w, max(float(ctx.y.size - len(names)), 1.0))
    return _judge(names, ["coef"] * len(names), info / max(s2, 1e-300), params)


def _reads(problem) -> bool:
    """Whether the check reads the model's values at the fit (differences, a loss
    linearised there, the residual variance without sigma)."""
    loss, exact = problem.loss, EXACT_COEFFICIENTS and problem.model.to_coefficients is None
    return bool(problem.dim) or not exact or not loss.linear or not loss.needs_sigma


def _rows(problem) -> np.ndarray:
    """The valid samples used (all, or a seeded subset of them for very large data)."""
    m = problem.geometry.m
    n_cols = len(problem.free_shape) + len(problem.free_coefs) * problem.n_channels
    keep = min(max(int(MAX_ENTRIES / max(n_cols * problem.n_channels, 1)), 1000), MAX_ROWS)
    return np.arange(m) if m <= keep else seeded_rows(m, keep, seed=0)


def _context(problem, rows):
    """The loss context of the samples ``rows`` (every per-sample field subset)."""
    ctx = problem.ctx
    if len(rows) == problem.geometry.m:
        return ctx
    m = problem.geometry.m
    subset = {}
    for f in fields(ctx):
        value = getattr(ctx, f.name)
        if isinstance(value, np.ndarray) and value.shape[:1] == (m,):
            subset[f.name] = np.take(value, rows, axis=0)  # faster than value[rows]
    return replace(ctx, **subset)


def _geometry(problem, rows: np.ndarray):
    """The geometry of the valid samples ``rows`` alone: the problem's own when they are
    all of them, else a new one of those pairs, so that each evaluation of the check
    costs ``len(rows)`` pairs, not ``M``."""
    from ..data.geometry import Geometry

    geometry = problem.geometry
    if len(rows) == geometry.m:
        return geometry
    wi, wo = (np.take(w, rows, axis=0) for w in (geometry.wi, geometry.wo))  # 2x w[rows]
    return Geometry(wi, wo, check=False)


def _predict(problem, params: dict, geometry, deadline=None) -> np.ndarray:
    """The model on ``geometry`` (:func:`_geometry`), (M, C); _Late past the deadline."""
    if deadline is not None and time.perf_counter() > deadline:
        raise _Late
    values = np.asarray(problem.model.evaluate_prepared(geometry, params, check=False))
    if not geometry.all_valid:
        values = values[geometry.valid]
    if values.ndim == 1:
        values = np.repeat(values[:, None], problem.n_channels, axis=1)
    return values


def _jacobian(problem, params: dict, geometry, base, deadline=None) -> tuple:
    """Names, kinds (``log``, ``linear`` shape; ``coef``), the Jacobian's sources (M, C)
    and its columns' layout (:func:`~brdffit.fitting.information.channel_information`):
    a shape parameter's column is its source in every channel (channel -1), a
    coefficient's is channel ``c`` of its linear parameter's source."""
    names, kinds, sources, layout = [], [], [], []
    for p in problem.free_shape:
        lo, hi = (math.log10(p.lower), math.log10(p.upper)) if p.log_scale else (p.lower, p.upper)
        x = math.log10(params[p.name]) if p.log_scale else float(params[p.name])
        h = STEP * (1.0 if p.log_scale else hi - lo)
        up, down = min(x + h, hi), max(x - h, lo)
        values = [10.0**v if p.log_scale else v for v in (up, down)]
        diff = _predict(problem, {**params, p.name: values[0]}, geometry, deadline)
        diff = diff if diff.flags.writeable else diff.copy()  # written in place below
        diff -= _predict(problem, {**params, p.name: values[1]}, geometry, deadline)
        diff /= up - down
        names.append(p.name)
        kinds.append("log" if p.log_scale else "linear")
        layout.append((len(sources), -1))
        sources.append(diff)
    design = _design(problem, params, geometry)
    for p in problem.model.linear_params:
        if p.name not in problem.fixed:
            labels = _coefficient_columns(problem, params, geometry, base, p, deadline, design)
            if labels:
                source, labels = labels
                for label, c in labels:
                    names.append(label)
                    kinds.append("coef")
                    layout.append((len(sources), c))
                sources.append(source)
    return names, kinds, sources, layout


def _design(problem, params: dict, geometry):
    """The model's design at the fitted shape where its linear parameters are its
    coefficients (None where they are mapped to them, or not :data:`EXACT_COEFFICIENTS`)."""
    model, shape = problem.model, {p.name: params[p.name] for p in problem.model.shape_params}
    exact = EXACT_COEFFICIENTS and model.to_coefficients is None
    return model.design(geometry, shape) if exact else None


def _coefficient_columns(problem, params, geometry, base, p, deadline, design=None):
    """The derivatives (M, C) of the prediction by linear parameter ``p`` (each channel by
    its own value: one evaluation serves every channel), and (label, channel) of each
    channel where it is inside its range (at a bound, the bound decides it) or None."""
    value, shape = np.asarray(params[p.name], dtype=float), (problem.n_channels,)
    value = value if value.shape == shape else np.broadcast_to(value, shape)  # 3 us less
    span = (p.upper if math.isfinite(p.upper) else 1.0) - p.lower
    inside = (value > p.lower) & (value < p.upper)  # those at a bound were set to it
    if not inside.any():
        return None
    if design is not None:  # the model is linear in it: its column is the derivative
        column = np.asarray(design.columns[problem.model.coefficients.index(p.name)], float)
        shape = (geometry.m, problem.n_channels)  # base's: None where not read (_reads)
        diff = np.broadcast_to(column if column.ndim == 2 else column[..., None], shape)
    else:
        h = np.where(value + 1e-3 * span < p.upper, 1e-3 * span, -1e-3 * span) * inside
        shifted = value + h
        shifted = float(shifted[0]) if shifted.size == 1 else shifted
        diff = _predict(problem, {**params, p.name: shifted}, geometry, deadline)
        diff = diff if diff.flags.writeable else diff.copy()
        diff -= base
        diff /= np.where(inside, h, 1.0)  # the channels at a bound are not read
    channels = problem.data.channels
    labels = [(p.name if problem.n_channels == 1 else f"{p.name}[{channels[c]}]", int(c))
              for c in np.flatnonzero(inside)]  # fmt: skip
    return diff, labels


def _at_their_bounds(problem, params: dict) -> dict:
    """``params`` with each linear parameter's channels that are at a bound (the fit's
    rule, :func:`~brdffit.fitting.problem.linear_at_bounds`) set to it: held there,
    they decide the derivatives of the others as the bound does. (A lobe fitted to
    data without one keeps ks of 1e-13 from round-off: its shape then looked seen.)"""
    out = dict(params)
    for p in problem.model.linear_params:
        if p.name in problem.fixed:
            continue
        low, high = linear_at_bounds(p, params[p.name])
        if low.any() or high.any():  # else the value itself (np.where's values)
            snapped = np.where(low, p.lower, np.where(high, p.upper, params[p.name]))
            out[p.name] = float(snapped) if snapped.ndim == 0 else snapped
    return out


def _judge(names, kinds, info, params) -> dict:
    """:func:`~brdffit.fitting.information.judge` at :data:`RANK_RTOL` and
    :data:`MAX_RELATIVE_WIDTH`."""
    return judge(names, kinds, info, params, RANK_RTOL, MAX_RELATIVE_WIDTH)
