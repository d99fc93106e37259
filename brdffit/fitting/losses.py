"""Loss functions of BRDF fitting, as a named registry.

Every loss compares the model ``f`` with the data ``y`` through a transform
``t`` applied to both:

    loss = (1 / norm) * sum_m sum_c w_m (t(f_mc) - t(y_mc))^2

where ``w_m`` are the user's sample weights (scaled to mean 1) and ``norm`` is
the number of values ``M * C`` (a mean), except for ``chi2``, which is a sum.

- ``l2``: ``t(f) = f``; plain least squares.
- ``cosine``: ``t(f) = f cos(theta_i)``; Löw, Kronander, Ynnerman and Unger
  2012, "BRDF models for accurate and efficient rendering of glossy surfaces",
  ACM TOG 31(1), error E1.
- ``log``: ``t(f) = ln(1 + f cos(theta_i))``; Löw et al. 2012, error E2.
- ``cbrt``: ``t(f) = (f cos(theta_i))^(1/3)``; Forés, Ferwerda and Gu 2012,
  "Toward a perceptually based metric for BRDF modeling", IS&T Color and
  Imaging Conference 20 (the cube-root metric).
- ``relative``: ``t(f) = f / max(|y|, eps)``, ``eps`` 1e-3 of the channel's
  largest ``|y|`` (guards zeros).
- ``chi2``: ``t(f) = f / sigma`` with the data's per-sample sigma (a sum, not
  a mean; needs sigma).
- ``mixed``: ``t(f) = f / s`` with ``s^2 = a^2 + (b f_hat)^2``, a noise model
  with an absolute floor ``a`` and a relative part ``b`` estimated together
  with the fit, ``f_hat`` the model's prediction (:mod:`brdffit.fitting.noise`:
  iteratively reweighted least squares with the variance function estimated
  by maximum likelihood, Carroll and Ruppert 1988, "Transformation and
  Weighting in Regression", ch. 2-3). A sum, like chi2. The default for data
  without sigma.

The fitting engine solves the linear coefficients by weighted least squares
in the Gauss-Newton linearisation of ``t`` (exact in one step for the losses
whose transform is linear in ``f``: l2, cosine, relative, chi2, mixed; iterated for
log and cbrt), and always reports the exact loss.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..errors import FitError
from .channels import abs_max_by_channel, einsum

__all__ = ["LOSSES", "Loss", "LossContext", "get_loss"]


@dataclass(frozen=True)
class LossContext:
    """What the transforms need besides the values: cos(theta_i) (M,), the data's
    sigma (M, C) or None, the target y (M, C) and the per-channel scale of y."""

    cos_i: np.ndarray
    y: np.ndarray
    sigma: np.ndarray | None
    weights: np.ndarray | None
    #: The standard deviations (M, C) of the fitted noise model (the ``mixed`` loss).
    noise_sigma: np.ndarray | None = None

    @property
    def y_scale(self) -> np.ndarray:
        return np.maximum(abs_max_by_channel(self.y), 1e-300)


@dataclass(frozen=True)
class Loss:
    """A named loss: transform t, its derivative dt, whether t is linear in f."""

    name: str
    transform: Callable[[np.ndarray, LossContext], np.ndarray]
    derivative: Callable[[np.ndarray, LossContext], np.ndarray]
    linear: bool
    doc: str
    reference: str
    needs_sigma: bool = False
    is_sum: bool = False
    #: Weighted by a noise model estimated with the fit (``LossContext.noise_sigma``).
    needs_noise: bool = False

    #: ``(t(f), dt(f))`` at once, where they share work (the log loss); None: apart.
    both: Callable[[np.ndarray, LossContext], tuple] | None = None

    def target(self, ctx: LossContext) -> np.ndarray:
        """``t(y)``: computed once per context (the fit evaluates it at every step)."""
        cache = ctx.__dict__.setdefault("_targets", {})  # a frozen dataclass's own dict
        if self.name not in cache:
            cache[self.name] = self.transform(ctx.y, ctx)
        return cache[self.name]

    def value(self, pred: np.ndarray, ctx: LossContext) -> float:
        """The exact loss of predictions ``pred`` (M, C) against ``ctx.y``."""
        d = self.transform(pred, ctx) - self.target(ctx)
        if ctx.weights is None:
            d = d.reshape(len(d), -1)
            total = float(einsum("mc,mc->", d, d))  # no squared copy (26 MB on MERL)
        else:
            d2 = d * d
            d2 *= ctx.weights[:, None]
            total = float(d2.sum())
        return total if self.is_sum else total / d.size

    def norm(self, ctx: LossContext) -> float:
        return 1.0 if self.is_sum else float(ctx.y.size)

    def linearised(self, ref: np.ndarray, ctx: LossContext) -> tuple[np.ndarray, np.ndarray]:
        """Weights (M, C) and targets (M, C) of the least-squares problem in f that
        is the Gauss-Newton linearisation of this loss at the values ``ref``."""
        if self.linear or ref is ctx.y:
            # At the data itself the step's target ref - (t(y) - t(y)) / dt is y.
            t, dt = None, self.derivative(ref, ctx)
        elif self.both is not None:
            t, dt = self.both(ref, ctx)
        else:
            t, dt = self.transform(ref, ctx), self.derivative(ref, ctx)
        # ref - (t - t(y)) / dt in t's array, dt^2 in dt's, where the transform made
        # them (the same values; at a MERL file's prediction the log loss formed eight
        # arrays of 26 MB here, now the two it returns).
        z = ctx.y if t is None else _step_target(ref, _own(t), self.target(ctx), dt)
        w = _own(dt)
        np.multiply(w, w, out=w)
        if ctx.weights is not None:
            w *= ctx.weights[:, None]
        return w, z


def _own(a) -> np.ndarray:
    """``a`` itself where it is a writable float array of its own (a transform's or a
    derivative's new result), else a float copy (a view, a broadcast, a scalar)."""
    if isinstance(a, np.ndarray) and a.flags.owndata and a.flags.writeable and a.dtype == float:
        return a
    return np.array(a, dtype=float)


def _step_target(ref, t: np.ndarray, target, dt) -> np.ndarray:
    """``ref - (t - target) / dt`` in ``t``'s array."""
    t -= target
    t /= dt
    return np.subtract(ref, t, out=t)


def _cos(ctx: LossContext) -> np.ndarray:
    return ctx.cos_i[:, None]


def _log_arg(f, ctx):
    """``max(1 + f cos, 1e-12)``, formed in one new array (the same values: a MERL
    file's 3.3 M values made three arrays of 26 MB)."""
    arg = np.multiply(f, _cos(ctx))
    if not isinstance(arg, np.ndarray):  # scalars: the expression as written
        return np.maximum(1.0 + arg, 1e-12)
    arg += 1.0
    return np.maximum(arg, 1e-12, out=arg)


def _log(f, ctx):
    arg = _log_arg(f, ctx)
    return np.log(arg, out=arg) if isinstance(arg, np.ndarray) else np.log(arg)


def _log_both(f, ctx):
    arg = _log_arg(f, ctx)
    dt = _cos(ctx) / arg
    return (np.log(arg, out=arg) if isinstance(arg, np.ndarray) else np.log(arg)), dt


def _cbrt_floor(ctx):
    """|f cos| below this is treated as this in the derivative (1e-6 of the data scale)."""
    return 1e-6 * np.maximum(abs_max_by_channel(ctx.y * _cos(ctx)), 1e-300)


def _relative_scale(ctx):
    return np.maximum(np.abs(ctx.y), 1e-3 * ctx.y_scale)


def _noise_sigma(ctx):
    if ctx.noise_sigma is None:
        raise FitError("the mixed loss needs the fitted noise model's sigma", "loss")
    return ctx.noise_sigma


def _sigma(ctx):
    if ctx.sigma is None:
        raise FitError("the chi2 loss needs per-sample sigma in the data", "loss")
    return ctx.sigma


def _divided_by(scale: Callable[[LossContext], np.ndarray]):
    """The transform ``t(f) = f / s`` and its derivative ``1 / s``, ``s = scale(ctx)``
    (the losses that weight each value by a fixed scale: relative, chi2, mixed)."""
    return (lambda f, ctx: f / scale(ctx), lambda f, ctx: _inverse(scale(ctx), f))


def _inverse(s: np.ndarray, f) -> np.ndarray:
    """``1 / s`` in the shape of ``ones_like(f) / s``, without the array of ones (a
    MERL file's mixed loss forms this for 3.3 M values at every reweighting)."""
    inverse = 1.0 / s
    mine = isinstance(inverse, np.ndarray)
    if mine and inverse.shape == np.shape(f):  # s's shape is f's: their broadcast (3 us)
        return inverse
    shape = np.broadcast_shapes(np.shape(f), np.shape(s))
    if mine and inverse.shape == shape:
        return inverse  # already that shape: a new array of its own (broadcast_to: 3 us)
    return np.broadcast_to(inverse, shape)


LOSSES: dict[str, Loss] = {
    loss.name: loss
    for loss in (
        Loss(
            "l2",
            lambda f, ctx: f,
            lambda f, ctx: np.ones_like(f),
            True,
            "mean of (f - y)^2",
            "least squares",
        ),
        Loss(
            "cosine",
            lambda f, ctx: f * _cos(ctx),
            lambda f, ctx: np.broadcast_to(_cos(ctx), f.shape),
            True,
            "mean of ((f - y) cos(theta_i))^2",
            "Löw, Kronander, Ynnerman and Unger 2012, ACM TOG 31(1), E1",
        ),
        Loss(
            "log",
            _log,
            lambda f, ctx: _cos(ctx) / _log_arg(f, ctx),
            False,
            "mean of (ln(1 + f cos(theta_i)) - ln(1 + y cos(theta_i)))^2",
            "Löw, Kronander, Ynnerman and Unger 2012, ACM TOG 31(1), E2",
            both=_log_both,
        ),
        Loss(
            "cbrt",
            lambda f, ctx: np.cbrt(f * _cos(ctx)),
            lambda f, ctx: (
                _cos(ctx)
                / (3.0 * np.cbrt(np.maximum(np.abs(f * _cos(ctx)), _cbrt_floor(ctx))) ** 2)
            ),
            False,
            "mean of (cbrt(f cos(theta_i)) - cbrt(y cos(theta_i)))^2",
            "Forés, Ferwerda and Gu 2012, IS&T Color and Imaging Conference 20, 142-148",
        ),
        Loss(
            "relative",
            *_divided_by(_relative_scale),
            True,
            "mean of ((f - y) / max(|y|, 1e-3 max|y|))^2",
            "relative least squares",
        ),
        Loss(
            "chi2",
            *_divided_by(_sigma),
            True,
            "sum of ((f - y) / sigma)^2",
            "chi-square with the data's sigma",
            needs_sigma=True,
            is_sum=True,
        ),
        Loss(
            "mixed",
            *_divided_by(_noise_sigma),
            True,
            "sum of ((f - y) / s)^2, s^2 = a^2 + (b f)^2 estimated with the fit",
            "Carroll and Ruppert 1988, Transformation and Weighting in Regression, ch. 2-3",
            is_sum=True,
            needs_noise=True,
        ),
    )
}


def get_loss(name: str) -> Loss:
    try:
        return LOSSES[name]
    except (KeyError, TypeError):
        raise FitError(
            f"loss={name!r} is not a known loss; choose one of {', '.join(LOSSES)}", "loss"
        ) from None
