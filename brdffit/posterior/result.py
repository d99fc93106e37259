"""The Posterior: samples of a fit's posterior, their summary and diagnostics.

Built by :func:`brdffit.sample_posterior`; frozen like
:class:`~brdffit.fitting.result.FitResult`: every array is read-only and every
mapping a read-only view, so a Posterior can be shared and cached.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from ..errors import FitError
from ..jsonable import jsonable

__all__ = ["Posterior", "NOISE_MEANING"]

NOISE_MEANING = {
    "given": "the data's per-sample sigma",
    "absolute": "estimated: one standard deviation, constant on the loss's transformed values "
    "(units of the data for l2 and cosine, a multiple of sigma for chi2)",
    "relative": "estimated: a standard deviation proportional to each measured value "
    "(noise is the fraction)",
    "mixed": "the fit's noise model sigma^2 = a^2 + (b f)^2 (a, b estimated with the fit); "
    "noise is the sampled multiple of it",
}


@dataclass(frozen=True, eq=False)
class Posterior:
    """Samples of the posterior of a fit, with their summary and diagnostics.

    Attributes
    ----------
    model, loss : str
        The fitted model and the loss whose residuals the likelihood is Gaussian on.
    noise : str
        ``given``, ``absolute`` or ``relative`` (:data:`NOISE_MEANING`).
    names : tuple of str
        Parameter names, the columns of ``samples``.
    samples : (S, P) read-only array
        Kept samples in natural units (after burn-in, thinned by ``thin``).
    sampled : tuple of str
        The coordinates emcee sampled (free shape parameters, then ``noise``);
        ``chain`` holds them in the search space (log10 for log-scale ones).
    sampled_log : tuple of bool
        Which sampled coordinates are log10 in ``chain``.
    chain : (steps, walkers, len(sampled)) read-only array
    burn, thin, n_walkers, n_steps : int
    autocorr_time : mapping
        Integrated autocorrelation time in steps of each sampled coordinate.
    effective_samples : int
        The smallest effective sample size of the sampled coordinates.
    acceptance_fraction : float
        Mean over walkers.
    converged : bool
        At least 50 autocorrelation times of sampling after burn-in.
    message : str
    seconds : float
    seed : int
    channels : tuple of str
    summary : mapping
        Name -> ``median``, ``p16``, ``p84``, ``mean``, ``std``.
    covariance, correlation : (P, P) read-only arrays, rows and columns in ``names`` order.
    """

    model: str
    loss: str
    noise: str
    names: tuple
    samples: np.ndarray
    sampled: tuple
    sampled_log: tuple
    chain: np.ndarray
    burn: int
    thin: int
    n_walkers: int
    n_steps: int
    autocorr_time: Mapping[str, float]
    effective_samples: int
    acceptance_fraction: float
    converged: bool
    message: str
    seconds: float
    seed: int
    channels: tuple
    summary: Mapping[str, Mapping[str, float]] = field(init=False)
    covariance: np.ndarray = field(init=False)
    correlation: np.ndarray = field(init=False)

    def __post_init__(self):
        samples = _readonly(self.samples)
        object.__setattr__(self, "samples", samples)
        object.__setattr__(self, "chain", _readonly(self.chain))
        object.__setattr__(self, "autocorr_time", MappingProxyType(dict(self.autocorr_time)))
        q16, q50, q84 = np.percentile(samples, [16, 50, 84], axis=0)
        mean, std = samples.mean(axis=0), samples.std(axis=0, ddof=1)
        summary = {
            name: MappingProxyType(
                {
                    "median": float(q50[i]),
                    "p16": float(q16[i]),
                    "p84": float(q84[i]),
                    "mean": float(mean[i]),
                    "std": float(std[i]),
                }
            )
            for i, name in enumerate(self.names)
        }
        object.__setattr__(self, "summary", MappingProxyType(summary))
        cov = np.atleast_2d(np.cov(samples, rowvar=False))
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = cov / np.sqrt(np.outer(np.diag(cov), np.diag(cov)))
        object.__setattr__(self, "covariance", _readonly(cov))
        object.__setattr__(self, "correlation", _readonly(corr))

    @property
    def noise_meaning(self) -> str:
        return NOISE_MEANING[self.noise]

    def index(self, name: str) -> int:
        """Column of ``name`` in ``samples``; an unknown name lists the names."""
        try:
            return self.names.index(name)
        except ValueError:
            raise FitError(
                f"{name!r} is not a parameter of this posterior; they are {', '.join(self.names)}",
                "name",
            ) from None

    def to_dict(self, include_samples: bool = False) -> dict:
        """A dict ready for strict JSON (:func:`brdffit.jsonable.jsonable`: a NaN or an
        infinity, e.g. the correlation of a parameter that did not move, is None;
        matrices are lists of rows); ``include_samples`` adds the samples (rows of
        ``names``)."""
        out = {
            "model": self.model,
            "loss": self.loss,
            "noise": self.noise,
            "noise_meaning": self.noise_meaning,
            "names": list(self.names),
            "summary": {k: dict(v) for k, v in self.summary.items()},
            "covariance": self.covariance,
            "correlation": self.correlation,
            "sampled": list(self.sampled),
            "sampled_log": list(self.sampled_log),
            "autocorr_time": dict(self.autocorr_time),
            "effective_samples": self.effective_samples,
            "acceptance_fraction": self.acceptance_fraction,
            "converged": self.converged,
            "message": self.message,
            "n_samples": int(self.samples.shape[0]),
            "n_walkers": self.n_walkers,
            "n_steps": self.n_steps,
            "burn": self.burn,
            "thin": self.thin,
            "seconds": self.seconds,
            "seed": self.seed,
            "channels": list(self.channels),
        }
        if include_samples:
            out["samples"] = self.samples
        return jsonable(out)

    def __str__(self) -> str:
        lines = [
            f"posterior of {self.model} ({self.loss} loss, noise {self.noise}): {self.message}"
        ]
        for name, s in self.summary.items():
            lines.append(
                f"  {name} = {s['median']:.6g} -{s['median'] - s['p16']:.3g} "
                f"+{s['p84'] - s['median']:.3g}"
            )
        return "\n".join(lines)


def _readonly(a) -> np.ndarray:
    a = np.array(a, dtype=float, copy=True)
    a.setflags(write=False)
    return a
