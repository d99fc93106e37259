"""FitResult: the frozen answer of a fit, with every metric and a JSON form."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Any

import numpy as np

from ..jsonable import jsonable
from ..words import plural
from .losses import LOSSES, LossContext
from .sums import loss_sums

__all__ = ["FAR", "TYPICAL", "FitResult", "beyond_reach", "metrics_of", "noise_failed"]


@dataclass(frozen=True)
class FitResult:
    """The result of :func:`brdffit.fit`.

    Attributes
    ----------
    model : str
        Name of the fitted model (a sum of lobes is ``a+b+c``).
    params : mapping
        Name -> float, or a per-channel array for linear params.
    loss : float
        The value of the minimised loss.
    loss_name : str
    metrics : mapping
        Every named loss of :data:`brdffit.fitting.losses.LOSSES` at the fitted params
        (``chi2`` only when the data give sigma), ``rmse``, ``aic``, ``bic``.
    n_samples, n_channels, n_values : int
        Samples, channels, and their product (the observations).
    n_params : int
        Fitted parameters: free shape params + free linear coefficients x channels.
    n_evals : int
        Objective evaluations (global + local).
    seconds : float
    converged : bool
        The local polish ended on its tolerance (not on a budget, a timeout or an error).
    message : str
        What happened, in words (why it stopped; parameters at a bound).
    channels : tuple of str
    fixed : mapping
        Parameters held fixed.
    options : mapping
        The options of the fit (loss, algorithms, budgets, seed...), for reproducing
        it; ``options["weights"]`` summarises the per-sample weights (``count``,
        ``min``, ``max``, ``zeros``) or is None.
    at_bounds : tuple of str
        Free parameters that ended at a bound of their range: shape parameters, and
        linear ones (``kd``, ``ks``...) at a bound in any channel.
    unidentified : mapping
        Free parameters that the data do not constrain, name -> why in words
        (:mod:`brdffit.fitting.identifiability`: an anisotropy the geometry cannot
        show, a singular Fisher information, a relative width above 1). Their
        values are the fit's, not the material's.
    posterior : Posterior or None
        The posterior, when the fit was asked for ``uncertainty``.
    weights : ndarray (N,) or None
        The per-sample weights the fit used, as given (read-only; not in
        :meth:`to_dict`, whose ``options`` summarise them).
    noise : mapping or None
        The noise model of the likelihood: ``model`` (``mixed``: ``sigma^2 = a^2 +
        (b f)^2`` estimated with the fit, :mod:`brdffit.fitting.noise`; ``given``:
        the data's sigma; ``loss``: constant on the loss's transformed values),
        ``a``, ``b`` (None unless estimated) and its ``meaning``.
    misfit : mapping or None
        Whether the residuals are systematic (:mod:`brdffit.fitting.misfit`):
        ``detected``, the test statistics and a ``message``.
    """

    model: str
    params: Mapping[str, Any]
    loss: float
    loss_name: str
    metrics: Mapping[str, float]
    n_samples: int
    n_channels: int
    n_values: int
    n_params: int
    n_evals: int
    seconds: float
    converged: bool
    message: str
    channels: tuple
    fixed: Mapping[str, Any] = field(default_factory=dict)
    options: Mapping[str, Any] = field(default_factory=dict)
    at_bounds: tuple = ()
    posterior: Any = None
    weights: np.ndarray | None = field(default=None, repr=False, compare=False)
    unidentified: Mapping[str, str] = field(default_factory=dict)
    noise: Mapping[str, Any] | None = None
    misfit: Mapping[str, Any] | None = None

    def __post_init__(self):
        for name in ("params", "metrics", "fixed", "options", "unidentified"):
            object.__setattr__(self, name, MappingProxyType(dict(getattr(self, name))))
        if self.weights is not None:
            weights = np.array(self.weights, dtype=float)
            weights.setflags(write=False)
            object.__setattr__(self, "weights", weights)

    def to_dict(self) -> dict:
        out = {
            "model": self.model,
            "params": jsonable(dict(self.params)),
            "loss": jsonable(self.loss),
            "loss_name": self.loss_name,
            "metrics": jsonable(dict(self.metrics)),
            "n_samples": self.n_samples,
            "n_channels": self.n_channels,
            "n_values": self.n_values,
            "n_params": self.n_params,
            "n_evals": self.n_evals,
            "seconds": self.seconds,
            "converged": self.converged,
            "message": self.message,
            "channels": list(self.channels),
            "fixed": jsonable(dict(self.fixed)),
            "options": jsonable(dict(self.options)),
            "at_bounds": list(self.at_bounds),
            "unidentified": dict(self.unidentified),
            "noise": jsonable(dict(self.noise)) if self.noise is not None else None,
            "misfit": jsonable(dict(self.misfit)) if self.misfit is not None else None,
        }
        if self.posterior is not None:
            out["posterior"] = self.posterior.to_dict()
        return out

    @classmethod
    def from_dict(cls, d: Mapping) -> FitResult:
        """A FitResult from its :meth:`to_dict` (a JSON line, a job's stored result):
        ``null`` numbers are NaN again and per-channel lists arrays; the posterior stays
        the plain dict it was (its samples are not in the JSON), and the per-sample
        weights are not carried (``options`` keeps their summary)."""

        def number(v):
            return math.nan if v is None else v

        params = {k: np.asarray(v, dtype=float) if isinstance(v, list) else number(v)
                  for k, v in d["params"].items()}  # fmt: skip
        return cls(
            model=d["model"], params=params, loss=number(d["loss"]), loss_name=d["loss_name"],
            metrics={k: number(v) for k, v in d["metrics"].items()},
            n_samples=d["n_samples"], n_channels=d["n_channels"], n_values=d["n_values"],
            n_params=d["n_params"], n_evals=d["n_evals"], seconds=d["seconds"],
            converged=d["converged"], message=d["message"], channels=tuple(d["channels"]),
            fixed=d["fixed"], options=d["options"], at_bounds=tuple(d["at_bounds"]),
            posterior=d.get("posterior"), unidentified=d.get("unidentified") or {},
            noise=d.get("noise"), misfit=d.get("misfit"),
        )  # fmt: skip

    def __str__(self) -> str:
        lines = [
            f"{self.model}: {self.loss_name} loss {self.loss:.6g}, rmse {self.metrics['rmse']:.6g}"
        ]
        for name, value in self.params.items():
            lines.append(f"  {name} = {_fmt(value)}")
        evals = plural(self.n_evals, "evaluation")
        lines.append(f"  {evals}, {self.seconds:.3g} s; {self.message}")
        if self.noise is not None and self.noise.get("model") == "mixed":
            lines.append(
                f"  noise model: sigma^2 = a^2 + (b f)^2, a = {self.noise['a']:.3g}, "
                f"b = {self.noise['b']:.3g} (estimated with the fit)"
            )
        return "\n".join(lines)


def _fmt(value) -> str:
    if np.ndim(value) == 0:
        return f"{float(value):.6g}"
    return "[" + ", ".join(f"{v:.4g}" for v in np.ravel(value)) + "]"


def metrics_of(pred: np.ndarray, y: np.ndarray, ctx: LossContext, n_params: int) -> dict:
    """Every loss, RMSE, AIC and BIC of predictions ``pred`` (N, C) against ``y``
    (``ctx.y``), from the sums of :func:`brdffit.fitting.sums.loss_sums` (one pass
    over cache-sized blocks; the RMSE is the root of the unweighted mean square).

    AIC and BIC use the Gaussian likelihood: with per-sample sigma,
    ``-2 ln L = chi2 + const``, so ``AIC = chi2 + 2k``, ``BIC = chi2 + k ln n``;
    without sigma, an unknown common variance is profiled out:
    ``AIC = n ln(RSS/n) + 2k``, ``BIC = n ln(RSS/n) + k ln n`` (n observations,
    k fitted parameters; Burnham and Anderson 2002, "Model Selection and
    Multimodel Inference", Springer, sec. 2.2). Only differences between models
    on the same data mean anything.
    """
    sums = loss_sums(pred, ctx if ctx.y is y else replace(ctx, y=y))
    n = np.size(y)
    rss = sums.pop("rss")
    out = {name: total if LOSSES[name].is_sum else total / n for name, total in sums.items()}
    out["rmse"] = math.sqrt(rss / n)
    if ctx.sigma is not None:
        base = out["chi2"]
    else:
        base = n * math.log(max(rss, 1e-300) / n)
    out["aic"] = base + 2 * n_params
    out["bic"] = base + n_params * math.log(n)
    return out


#: The data are "far above" the fit when their largest value is over FAR times the
#: largest prediction, or their median over TYPICAL times the prediction's median
#: (values in percent: 9 times a ward fit's, whose kd and ks sit at their upper
#: bounds; Cornell's garnet_red, kd at 0 not at 1: 3.1) (:func:`beyond_reach`).
FAR = 100.0
TYPICAL = 3.0


def beyond_reach(model, params: Mapping, at_bounds, y, pred) -> str:
    """A note for the result's message when the data lie far beyond what ``model``
    reaches within its bounds, else ``""``: a linear coefficient at its upper bound
    and the data far above the prediction (:data:`FAR`, :data:`TYPICAL`), or any at
    a bound and a prediction of 0 everywhere under positive data.

    Such data are most often in other units (percent, radiance not divided by the
    irradiance): the fit then reports coefficients at their bounds and a prediction
    that does not meet the data, which is said here in words with what to do."""
    from .problem import linear_at_bounds  # (problem imports this module)

    linear = [p for p in model.linear_params if p.name in params and p.name in at_bounds]
    if not linear:
        return ""
    y, pred = np.asarray(y, dtype=float), np.abs(np.asarray(pred, dtype=float))
    top = float(y[np.isfinite(y)].max(initial=0.0))
    reach = float(pred.max(initial=0.0))
    if not top > 0.0:
        return ""
    if reach > 0.0:
        if not any(linear_at_bounds(p, params[p.name])[1].any() for p in linear):
            return ""
        typical = float(np.median(y)) > TYPICAL * float(np.median(pred))
        if not (top > FAR * reach or typical):
            return ""
    limits = ", ".join(f"{p.name} <= {p.upper:g}" for p in model.linear_params
                       if math.isfinite(p.upper))  # fmt: skip
    return (
        f"; the data lie far beyond what {model.name} can reach within its bounds"
        f"{f' ({limits})' if limits else ''}: their largest value is {top:.3g}, the "
        f"fit's largest prediction "
        f"{reach:.3g}; the data may be in other units (percent, or radiance not divided "
        "by the irradiance): rescale them to a BRDF in 1/sr, or choose a model whose "
        "coefficients reach them"
    )


def noise_failed(model: str, top: float) -> str:
    """The error of a fit whose noise model (the ``mixed`` loss's, estimated from the
    residuals of ``model``) gave a sigma that is not finite and positive: what went
    wrong is most often in the data's values (largest ``top``), which the user can
    change, or the loss."""
    return (
        f"the noise model estimated from the residuals of {model} (sigma^2 = a^2 + "
        "(b f)^2, the mixed loss) is not finite and positive everywhere; the data's "
        f"largest value is {top:.3g}: if they are not a BRDF in 1/sr (percent, radiance "
        "not divided by the irradiance), rescale them, or fit with another loss "
        "(loss='l2')"
    )
