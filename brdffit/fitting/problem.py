"""A model bound to a dataset: the search space and the variable-projection objective.

:class:`Problem` is what the fitting engine and the posterior sampler share.
It holds the geometry of the data (prepared once), the search space of the
free shape parameters (log10 for log-scale ones, bounds from the registry),
and for any point of that space it solves the linear coefficients (kd, ks...
per channel) by bounded least squares (:mod:`brdffit.fitting.solve`, over
:mod:`brdffit.fitting.linear`) and returns the exact loss. The optimiser therefore
searches only the few shape parameters, shared by all channels.
"""

from __future__ import annotations

import copy
import weakref
from collections.abc import Mapping

import numpy as np

from ..errors import FitError, ParameterError, under_option
from ..models import get_model
from ..words import plural
from .linear import weighted_target
from .losses import LossContext, get_loss
from .result import noise_failed
from .solve import (
    BAD_LOSS,
    Solution,
    as_2d,
    compiled_normal,
    linear_terms,
    solve_linear,
    solve_log,
    solve_normal,
    stack_columns,
)

__all__ = ["Problem", "Solution", "linear_at_bounds"]


class Problem:
    """Bind a model to measurements for fitting.

    What a Problem answers does not change after it is made: :meth:`solve` keeps
    everything of one call (the shape, its constraint rows) in local variables and
    builds what it reuses (the linearised targets) once, in one assignment, so
    threads may share one Problem (not across :meth:`let_go`).

    Parameters
    ----------
    data : Measurements
    model : str or Model
    loss : str
        A name of :data:`brdffit.fitting.losses.LOSSES`.
    weights : array_like (N,), optional
        Non-negative per-sample weights (scaled to mean 1).
    fixed : mapping, optional
        Parameters held at given values (linear ones may be per channel).
    noise_sigma : array_like (N, C), optional
        The standard deviations of the fitted noise model, for the ``mixed`` loss
        (:mod:`brdffit.fitting.noise`); without them it starts with ones (plain
        least squares), and :meth:`reweighted` sets them.
    """

    def __init__(
        self,
        data,
        model,
        loss: str = "l2",
        weights=None,
        fixed: Mapping | None = None,
        energy_conserving: bool = False,
        noise_sigma=None,
    ):
        self.data = data
        self._last_prediction = None
        self.model = get_model(model)
        self.loss = get_loss(loss)
        self.geometry = data.geometry()
        self.n_channels = data.values.shape[1]
        self.fixed = self._check_fixed(fixed or {})
        self._set_per_channel()
        self.free_shape = [
            p for p in self.model.shape_params if p.name not in self.fixed and not p.per_channel
        ]
        self.lower = np.array(
            [np.log10(p.lower) if p.log_scale else p.lower for p in self.free_shape]
        )
        self.upper = np.array(
            [np.log10(p.upper) if p.log_scale else p.upper for p in self.free_shape]
        )
        self._set_coefficients()
        self._set_targets(weights, noise_sigma)
        self._check_size()
        self.energy = None
        if energy_conserving:
            from .energy import EnergyRows

            self.energy = EnergyRows(self)

    # ----------------------------------------------------------- construction
    def _check_fixed(self, fixed: Mapping) -> dict:
        if not isinstance(fixed, Mapping):
            raise FitError("fixed must be a mapping of parameter name to value", "fixed")
        out = {}
        for name, value in fixed.items():
            with under_option("fixed", name):
                value = self.model.param(name).check(value)
                if np.ndim(value) == 1 and np.size(value) not in (1, self.n_channels):
                    raise ParameterError(
                        f"{name} has {plural(np.size(value), 'value')} but the data have "
                        f"{plural(self.n_channels, 'channel')}",
                        name,
                    )
            out[name] = value
        return out

    def _set_per_channel(self):
        """Per-channel non-linear params (wavelengths) come from the data unless fixed."""
        for p in self.model.shape_params:
            if not p.per_channel or p.name in self.fixed:
                continue
            wl = self.data.wavelengths()
            if wl is None:
                raise FitError(
                    f"{self.model.name} needs {p.name} per channel: give channels named by "
                    f"wavelength (such as 550nm) or fix {p.name}",
                    p.name,
                )
            self.fixed[p.name] = p.check(np.asarray(wl, dtype=float))

    def _set_coefficients(self):
        names = list(self.model.coefficients)
        fixed_linear = [p.name for p in self.model.linear_params if p.name in self.fixed]
        if fixed_linear and self.model.to_coefficients is not None:
            raise FitError(
                f"{self.model.name} maps its linear parameters to coefficients; holding "
                f"{', '.join(fixed_linear)} fixed is not supported for it",
                fixed_linear[0],
            )
        self.fixed_coefs = [n for n in names if n in self.fixed]
        self.free_coefs = [n for n in names if n not in self.fixed]
        self.coef_index = [names.index(n) for n in self.free_coefs]
        self.fixed_index = [names.index(n) for n in self.fixed_coefs]
        ranges = [self.model.coefficient_ranges[i] for i in self.coef_index]
        self.coef_lower = np.array([max(lo, 0.0) for lo, _ in ranges], dtype=float)
        self.coef_upper = np.array([hi for _, hi in ranges], dtype=float)
        self.coef_constraints = None
        if self.model.coefficient_constraints:
            rows = np.array([row for row, _ in self.model.coefficient_constraints], dtype=float)
            bounds = np.array([b for _, b in self.model.coefficient_constraints], dtype=float)
            self.coef_constraints = (rows[:, self.coef_index], bounds)

    def reweighted(self, noise_sigma) -> Problem:
        """A copy of this problem (same geometry, model, bounds) whose ``mixed`` loss
        uses the noise model's standard deviations ``noise_sigma`` (N, C)."""
        out = copy.copy(self)
        out._set_targets(self.user_weights, noise_sigma)
        return out

    def _set_targets(self, weights, noise_sigma=None):
        g = self.geometry
        self.user_weights = weights
        y_all = np.asarray(self.data.values, dtype=float)
        sigma = self.data.sigma
        if self.loss.needs_sigma and sigma is None:
            raise FitError(f"loss={self.loss.name!r} needs per-sample sigma in the data", "loss")
        w = None
        if weights is not None:
            w = np.asarray(weights, dtype=float)
            if w.shape != (self.data.n,):
                raise FitError(
                    f"weights has shape {w.shape}; it must be ({self.data.n},)", "weights"
                )
            if not np.isfinite(w).all() or (w < 0).any() or not (w > 0).any():
                raise FitError("weights must be finite, non-negative and not all zero", "weights")
            w = w / w.mean()
        valid = g.valid
        noise = self._noise_sigma(noise_sigma, y_all.shape)
        self.noise_sigma = noise
        self.y = y_all[valid] if not g.all_valid else y_all
        self.invalid_y = None if g.all_valid else y_all[~valid]
        self.ctx = LossContext(
            cos_i=g.cos_i,
            y=self.y,
            sigma=None if sigma is None else (sigma if g.all_valid else sigma[valid]),
            weights=None if w is None else (w if g.all_valid else w[valid]),
            noise_sigma=None if noise is None else (noise if g.all_valid else noise[valid]),
        )
        # Below the horizon every model is 0: those samples add a constant to the loss.
        self.invalid_loss = 0.0
        if self.invalid_y is not None and self.invalid_y.size:
            self.invalid_loss = self._invalid_contribution(y_all, sigma, w, valid, noise)
        self.let_go()

    def let_go(self) -> None:
        """Forget what the solve builds from the data for the search (the linearised
        weights and targets and their copies for the compiled passes: up to 100 MB on
        a MERL file), once the search is done; a later :meth:`solve` builds them
        again. Not while other threads solve."""
        self._linearised = None
        self._prepared = None
        self.log_inputs = None  # the compiled log passes' inputs (solve.solve_log)

    def linearisation(self) -> tuple:
        """The loss's linearisation at the data: weights (M,), (M, C) or None (all
        ones), targets (M, C), and for a quadratic loss ``W y`` and ``y'Wy``, reused by
        every solve of a model without an offset (its target never changes; else
        None). Made at the first call and kept until :meth:`let_go`."""
        state = self._linearised
        if state is None:
            w, z = linear_terms(self)
            weighted = weighted_target(z, w) if self.loss.linear else None
            state = self._linearised = (w, z, weighted)  # one assignment: thread-safe
        return state

    def _noise_sigma(self, noise_sigma, shape):
        """The noise model's sigma (N, C) for a loss that needs one (ones to start), else None."""
        if not self.loss.needs_noise:
            return None
        if noise_sigma is None:
            return np.ones(shape)
        noise = np.broadcast_to(np.asarray(noise_sigma, dtype=float), shape)
        if not (np.isfinite(noise).all() and (noise > 0).all()):
            top = float(np.max(np.abs(self.data.values), initial=0.0))
            raise FitError(noise_failed(self.model.name, top), "noise")
        return noise

    def _invalid_contribution(self, y_all, sigma, w, valid, noise=None) -> float:
        ctx = LossContext(
            cos_i=np.maximum(self.data.wi[~valid, 2], 0.0),
            y=y_all[~valid],
            sigma=None if sigma is None else sigma[~valid],
            weights=None if w is None else w[~valid],
            noise_sigma=None if noise is None else noise[~valid],
        )
        total = self.loss.value(np.zeros_like(ctx.y), ctx) * self.loss.norm(ctx)
        return total

    def _check_size(self):
        n_free = len(self.free_coefs) + len(self.free_shape)
        if self.geometry.m <= n_free:
            raise FitError(
                f"the data have {plural(self.geometry.m, 'sample')} above the horizon but "
                f"{self.model.name} has {plural(n_free, 'free parameter')} per channel; "
                "it needs more samples than parameters",
                "data",
            )

    # ----------------------------------------------------------------- search
    @property
    def dim(self) -> int:
        """The number of free shape parameters: the dimension of the search space."""
        return len(self.free_shape)

    @property
    def norm(self) -> float:
        """What the summed loss is divided by: 1 for sums, the number of values for means."""
        return 1.0 if self.loss.is_sum else float(self.data.values.size)

    def x_from_params(self, params: Mapping) -> np.ndarray:
        """The search-space point (log10 for log-scale parameters) of ``params``."""
        out = []
        for p in self.free_shape:
            v = p.check(params[p.name])
            out.append(np.log10(v) if p.log_scale else v)
        return np.array(out)

    def shape_from_x(self, x) -> dict:
        """Shape parameter values (the held ones too) at a search-space point."""
        shape = {}
        for p, v in zip(self.free_shape, x):
            v = 10.0**v if p.log_scale else float(v)
            shape[p.name] = float(min(max(v, p.lower), p.upper))  # np.clip's value, faster
        for p in self.model.shape_params:
            if p.name in self.fixed:
                shape[p.name] = self.fixed[p.name]
        return shape

    # -------------------------------------------------------------- objective
    def solve(self, x) -> Solution:
        """Shape params from ``x``, coefficients by least squares, the exact loss."""
        shape = self.shape_from_x(x)
        design = self.model.design(self.geometry, shape)
        m, c = self.y.shape
        cols = [self._full(col) for col in design.columns]
        offset = None if design.offset is None else as_2d(design.offset)
        for i, name in zip(self.fixed_index, self.fixed_coefs):
            term = as_2d(cols[i]) * np.asarray(self.fixed[name], dtype=float)
            offset = term if offset is None else offset + term
        free = [cols[i] for i in self.coef_index]
        constraints = self._constraints_for(shape)
        raw = [design.columns[i] for i in self.coef_index]
        normal = compiled_normal(self, raw, offset)
        try:
            if normal is not None:
                return solve_normal(self, shape, normal, constraints)
            compiled = solve_log(self, shape, raw, offset, constraints)
            if compiled is not None:
                return compiled
            return solve_linear(self, shape, stack_columns(free, m, c), offset, constraints)
        except np.linalg.LinAlgError:
            # No coefficients satisfy the constraints at this shape (energy
            # conservation with a too bright offset): infeasible, never NaN.
            return Solution(shape, np.zeros((c, len(self.coef_index))), BAD_LOSS)

    def _constraints_for(self, shape):
        """The model's coefficient constraints, plus the albedo rows in energy mode."""
        if self.energy is None:
            return self.coef_constraints
        rows, bound = self.energy.rows(shape)
        if self.coef_constraints is None:
            return rows, bound
        a0, b0 = self.coef_constraints
        c = self.n_channels
        b = np.concatenate(
            [np.broadcast_to(b0, (c, len(b0))), np.broadcast_to(bound, (c, rows.shape[0]))], axis=1
        )
        return np.vstack([a0, rows]), b

    def _full(self, col):
        """A column as an (M,) array; constant columns are cached per value."""
        if np.ndim(col):
            return col
        key = ("constant_column", float(col))
        return self.geometry.cached(key, lambda: np.full(self.geometry.m, float(col)))

    def exact_loss(self, params: Mapping, pred=None) -> float:
        """The loss at full params from the formed residuals (no normal-equation
        round-off), with the user's weights, as the objective defines it (``pred``:
        :meth:`predict` at them, where the caller holds it)."""
        pred = self.predict(params) if pred is None else pred
        if not self.geometry.all_valid:
            pred = pred[self.geometry.valid]
        total = self.loss.value(pred, self.ctx) * self.loss.norm(self.ctx) + self.invalid_loss
        return total / self.norm

    # ---------------------------------------------------------------- results
    def params_of(self, sol: Solution) -> dict:
        """Full parameter mapping (shape, per-channel linear values) of a solution."""
        coefs = {}
        for j, name in enumerate(self.free_coefs):
            coefs[name] = _squeeze(sol.coefs[:, j])
        for name in self.fixed_coefs:
            coefs[name] = self.fixed[name]
        params = dict(sol.shape)
        params.update(self.model.params_from_coefficients(coefs))
        for name, value in self.fixed.items():
            params.setdefault(name, value)
        params = {p.name: params[p.name] for p in self.model.params}
        if self.model.canonical is not None:
            params = self.model.canonical(params)
        return params

    def predict(self, params: Mapping) -> np.ndarray:
        """Model values (N, C) at the data's directions for full params (read-only).

        The last prediction is remembered while a caller still holds it (a weak
        reference: the problem itself never keeps 26 MB of a MERL file's prediction
        alive): the metrics, exact loss and noise estimate of a fit, which ask for
        the prediction at the same params, then share one."""
        key = _fingerprint(params)
        last = self._last_prediction
        if last is not None and last[0] == key:
            values = last[1]()
            if values is not None:
                return values
        values = self.model.evaluate_prepared(self.geometry, params)
        values = np.asarray(values)
        if values.ndim == 1:
            values = np.repeat(values[:, None], self.n_channels, axis=1)
        values.setflags(write=False)
        self._last_prediction = (key, weakref.ref(values))  # one assignment: thread-safe
        return values


def linear_at_bounds(p, value) -> tuple[np.ndarray, np.ndarray]:
    """Where a linear parameter's ``value`` (a channel's, or all channels') is at its
    lower and its upper bound: within 1e-6 of its range (of 1 for a wider one). The
    polish stops at 1e-7 relative in the shape parameters, and a coefficient the data
    put at a bound comes out up to 7e-8 from it (measured: kd of 18 noiseless blinn
    fits with kd = 0; at 1e-9 of its range 10 of them were not at it). The fit's
    ``at_bounds`` and the identifiability check (which holds such coefficients there)
    use this one rule."""
    tol = 1e-6 * min((p.upper if np.isfinite(p.upper) else 1.0) - p.lower, 1.0)
    value = np.asarray(value, dtype=float)
    return value <= p.lower + tol, value >= p.upper - tol


def _fingerprint(params: Mapping) -> tuple:
    """The exact values of ``params`` (names, dtypes, bytes): equal only for equal params."""
    out = []
    for name in sorted(params):
        value = np.asarray(params[name])
        out.append((name, value.dtype.str, value.shape, value.tobytes()))
    return tuple(out)


def _squeeze(v: np.ndarray):
    return float(v[0]) if v.size == 1 else np.asarray(v, dtype=float)
