"""Which model describes this material best: fit several, rank them.

``compare(data, models)`` splits the data once (seeded) into a training part
and a held-out part, fits every model to the training part with the same
options, and ranks the models two ways:

- by BIC of the training fit (penalises parameters: ``k ln n``), with the
  likelihood the fits used (the fitted noise model ``sigma^2 = a^2 + (b f)^2``
  of the default ``mixed`` loss, its two parameters counted; the data's sigma
  for ``chi2``; one profiled variance on the loss's transformed residuals for
  the others), and
- by the error on the held-out samples in the fit's own loss (for ``mixed``,
  the mean negative log-likelihood per value under each model's own noise
  model, so that a model cannot win by calling its misfit noise), which no
  parameter count can game. The RMSE is shown beside it.

When the two rankings disagree the table shows it; neither is hidden.

A fit with parameters the data cannot identify
(:attr:`~brdffit.fitting.result.FitResult.unidentified`, e.g. an anisotropic
model on data measured at one incidence azimuth) is ranked, in both rankings,
after every fit without such parameters, and marked ``*`` in the table: its
better numbers come from parameters the data do not decide.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import FitError
from ..jsonable import jsonable
from ..models import get_model
from ..words import plural
from .core import fit
from .losses import LossContext, get_loss
from .noise import NoiseModel
from .result import FitResult

__all__ = ["Comparison", "ComparisonEntry", "compare"]


@dataclass(frozen=True)
class ComparisonEntry:
    """One model of a comparison."""

    model: str
    fit: FitResult
    bic: float
    aic: float
    heldout_rmse: float
    heldout_loss: float
    rank_bic: int
    rank_heldout: int

    def to_dict(self) -> dict:
        return {
            "model": self.model,
            **jsonable(
                {
                    "bic": self.bic,
                    "aic": self.aic,
                    "heldout_rmse": self.heldout_rmse,
                    "heldout_loss": self.heldout_loss,
                }
            ),
            "rank_bic": self.rank_bic,
            "rank_heldout": self.rank_heldout,
            "fit": self.fit.to_dict(),
        }


@dataclass(frozen=True)
class Comparison:
    """The ranked result of :func:`compare`; entries are in order of held-out error."""

    entries: tuple
    loss_name: str
    test_fraction: float
    n_train: int
    n_test: int
    seed: int

    @property
    def best_by_bic(self) -> str:
        return min(self.entries, key=lambda e: e.rank_bic).model

    @property
    def best_by_heldout(self) -> str:
        return min(self.entries, key=lambda e: e.rank_heldout).model

    def to_dict(self) -> dict:
        return {
            "loss_name": self.loss_name,
            "test_fraction": self.test_fraction,
            "n_train": self.n_train,
            "n_test": self.n_test,
            "seed": self.seed,
            "best_by_bic": self.best_by_bic,
            "best_by_heldout": self.best_by_heldout,
            "entries": [e.to_dict() for e in self.entries],
        }

    def __str__(self) -> str:
        held = "held-out nll" if self.loss_name == "mixed" else f"held-out {self.loss_name}"
        head = (
            f"{'model':<40} {'BIC':>14} {held:>14} {'held-out rmse':>14} {'rank BIC':>9} "
            f"{'rank held-out':>14}"
        )
        rows = [head, "-" * len(head)]
        for e in self.entries:
            name = e.model + (" *" if e.fit.unidentified else "")
            rows.append(
                f"{name:<40} {e.bic:>14.6g} {e.heldout_loss:>14.6g} {e.heldout_rmse:>14.6g} "
                f"{e.rank_bic:>9d} {e.rank_heldout:>14d}"
            )
        if any(e.fit.unidentified for e in self.entries):
            rows.append(
                "* has parameters the data do not identify (FitResult.unidentified): "
                "ranked after the models without"
            )
        rows.append(
            f"trained on {plural(self.n_train, 'sample')}, held out {self.n_test} "
            f"({self.test_fraction:.0%}, seed {self.seed})"
        )
        return "\n".join(rows)


def _ranks(values, demoted) -> list:
    """Ranks by ``values``, the ``demoted`` entries after all the others."""
    order = np.lexsort((np.asarray(values, dtype=float), np.asarray(demoted, dtype=bool)))
    ranks = np.empty(len(values), dtype=int)
    ranks[order] = np.arange(1, len(values) + 1)
    return [int(r) for r in ranks]


def heldout_loss(loss, result: FitResult, pred: np.ndarray, ctx: LossContext) -> float:
    """The held-out error of a fit in its own loss: for ``mixed``, the mean Gaussian
    negative log-likelihood per value, ``mean(ln(2 pi s^2) + r^2 / s^2) / 2``, with the
    fit's noise model ``s`` at its prediction; else the loss's value."""
    if not loss.needs_noise:
        return loss.value(pred, ctx)
    noise = result.noise
    s2 = NoiseModel(noise["a"], noise["b"]).sigma(pred) ** 2
    return 0.5 * float(np.mean(np.log(2 * np.pi * s2) + (pred - ctx.y) ** 2 / s2))


def compare(
    data, models, *, test_fraction: float = 0.2, seed: int = 0, **fit_options
) -> Comparison:
    """Fit each of ``models`` to the same training split and rank them.

    Parameters
    ----------
    data : Measurements
    models : sequence of str or Model
    test_fraction : float
        Share of the samples held out, in (0, 0.9].
    seed : int
        Seeds the split and every fit.
    **fit_options
        Passed to :func:`brdffit.fit` (``loss``, budgets, ``timeout``...).
    """
    if isinstance(models, str):
        models = [models]
    models = [get_model(m) for m in models]
    if not models:
        raise FitError("compare needs at least one model", "models")
    if not isinstance(test_fraction, (int, float)) or not 0 < test_fraction <= 0.9:
        raise FitError(f"test_fraction={test_fraction!r} must be in (0, 0.9]", "test_fraction")
    train, test = data.split(test_fraction, seed=seed)
    if fit_options.get("loss") is None and data.sigma is None:
        # One likelihood for every model: the noise model of each, never the refit
        # that a lone default fit makes on misfit (a misfit is what ranks it lower).
        fit_options = {**fit_options, "loss": "mixed"}
    fits = [fit(train, m, seed=seed, **fit_options) for m in models]
    loss = get_loss(fits[0].loss_name)
    ctx = LossContext(
        cos_i=np.maximum(test.wi[:, 2], 0.0),
        y=np.asarray(test.values),
        sigma=test.sigma,
        weights=None,
    )
    rmse, held = [], []
    for model, result in zip(models, fits):
        pred = np.asarray(model.evaluate(test.wi, test.wo, dict(result.params)))
        if pred.ndim == 1:
            pred = np.repeat(pred[:, None], test.n_channels, axis=1)
        rmse.append(math.sqrt(float(np.mean((pred - ctx.y) ** 2))))
        held.append(heldout_loss(loss, result, pred, ctx))
    bic = [r.metrics["bic"] for r in fits]
    demoted = [bool(r.unidentified) for r in fits]
    rank_bic, rank_held = _ranks(bic, demoted), _ranks(held, demoted)
    entries = [
        ComparisonEntry(m.name, r, b, r.metrics["aic"], e, h, rb, rh)
        for m, r, b, e, h, rb, rh in zip(models, fits, bic, rmse, held, rank_bic, rank_held)
    ]
    entries.sort(key=lambda e: e.rank_heldout)
    return Comparison(tuple(entries), loss.name, float(test_fraction), train.n, test.n, int(seed))
