"""Answers of the fit routes: ``FitResult.to_dict()`` and ``Posterior.to_dict()``.

Every key of those ``to_dict()``s is a field here, typed and described, so that
the OpenAPI document shows clients all of an answer; ``tests/service`` checks
the keys of a real fit and a real posterior against these fields. A number
that is not finite is ``null`` (JSON has no NaN: :mod:`brdffit.jsonable`).
"""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from brdffit.fitting.options import COARSE_ABOVE, COARSE_SAMPLES

from .requests import ExportTarget

__all__ = [
    "ConversionErrorOut",
    "ExportOut",
    "FitResultOut",
    "MisfitOut",
    "NoiseOut",
    "MaybeFloat",
    "OptionsOut",
    "PerChannelOut",
    "PosteriorOut",
    "SummaryOut",
    "WeightsOut",
]

#: Answers say null where a number is not finite (JSON has no NaN).
MaybeFloat = float | None
PerChannelOut = MaybeFloat | list[MaybeFloat]
Matrix = list[list[MaybeFloat]]
ANSWER = ConfigDict(extra="forbid")


class SummaryOut(BaseModel):
    """The marginal posterior of one parameter, in its natural units."""

    model_config = ANSWER

    median: MaybeFloat = Field(description="The 50th percentile of the samples.")
    p16: MaybeFloat = Field(description="The 16th percentile (median - 1 sigma if Gaussian).")
    p84: MaybeFloat = Field(description="The 84th percentile (median + 1 sigma if Gaussian).")
    mean: MaybeFloat = Field(description="The mean of the samples.")
    std: MaybeFloat = Field(description="Their standard deviation (ddof = 1).")


class PosteriorOut(BaseModel):
    """``Posterior.to_dict()``: the summary, the covariance and emcee's diagnostics."""

    model_config = ANSWER

    model: str = Field(description="The fitted model's name.")
    loss: str = Field(description="The loss on whose residuals the likelihood is Gaussian.")
    noise: str = Field(description='The noise model: "given", "absolute", "relative" or "mixed".')
    noise_meaning: str = Field(description="What the noise model means, in words.")
    names: list[str] = Field(
        description="Parameter names: the keys of `summary`, the rows and columns of "
        '`covariance`; per-channel coefficients as "kd[r]", the noise as "noise".'
    )
    summary: dict[str, SummaryOut] = Field(description="Name -> its marginal posterior.")
    covariance: Matrix = Field(description="Covariance of the samples, in `names` order.")
    correlation: Matrix = Field(description="Correlation matrix, in `names` order.")
    sampled: list[str] = Field(
        description="The coordinates emcee sampled: free shape parameters, then noise."
    )
    sampled_log: list[bool] = Field(description="Which sampled coordinates were log10.")
    autocorr_time: dict[str, MaybeFloat] = Field(
        description="Integrated autocorrelation time, in steps, of each sampled coordinate."
    )
    effective_samples: int = Field(
        description="The smallest effective sample size of the sampled coordinates."
    )
    acceptance_fraction: MaybeFloat = Field(description="emcee's acceptance, mean of walkers.")
    converged: bool = Field(
        description="At least 50 autocorrelation times of sampling after burn-in."
    )
    message: str = Field(description="Why sampling stopped, in words.")
    n_samples: int = Field(description="Samples kept (after burn-in, thinned).")
    n_walkers: int = Field(description="emcee walkers.")
    n_steps: int = Field(description="Steps each walker took.")
    burn: int = Field(description="Steps discarded as burn-in.")
    thin: int = Field(description="Every `thin`-th step was kept.")
    seconds: float = Field(description="Wall-clock seconds of sampling.")
    seed: int = Field(description="The seed of the sampler (same seed, same samples).")
    channels: list[str] = Field(description="The data's channels.")


class WeightsOut(BaseModel):
    """What a fit's options say of its per-sample weights (the array stays in Python)."""

    model_config = ANSWER

    count: int = Field(description="How many weights (one per sample).")
    min: float = Field(description="The smallest weight.")
    max: float = Field(description="The largest weight.")
    zeros: int = Field(description="How many weights are 0 (samples left out).")


class OptionsOut(BaseModel):
    """``FitOptions.record()``: the options a fit ran with, defaults resolved."""

    model_config = ANSWER

    loss: str = Field(description="The loss minimised.")
    global_algorithm: str | None = Field(description="nlopt global algorithm; null: none.")
    local_algorithm: str = Field(description="nlopt local algorithm of the polish.")
    global_evals: int = Field(description="Budget of the global stage.")
    local_evals: int = Field(description="Budget of each local polish.")
    restarts: int = Field(description="Further polishes from distinct points.")
    max_evals: int = Field(description="Cap on all evaluations.")
    timeout: MaybeFloat = Field(description="Seconds the fit could run; null: no limit.")
    seed: int = Field(description="The seed (same seed, same result).")
    coarse_above: int = Field(
        COARSE_ABOVE,
        description="Samples above which the search ran coarse to fine (a stratified "
        "subsample, then one polish on all).",
    )
    coarse_samples: int = Field(
        COARSE_SAMPLES, description="Samples of the coarse-to-fine subsample."
    )
    energy_conserving: bool = Field(description="Albedo held at most 1 at every incidence.")
    weights: WeightsOut | None = Field(description="A summary of the weights; null: none.")


class NoiseOut(BaseModel):
    """``FitResult.noise``: the noise model the fit assumed or estimated."""

    model_config = ANSWER

    model: str = Field(
        description='"mixed" (sigma^2 = a^2 + (b f)^2, estimated with the fit), "given" '
        "(the data's sigma) or \"loss\" (constant on the loss's transformed values)."
    )
    a: MaybeFloat = Field(None, description="mixed: the absolute noise floor a.")
    b: MaybeFloat = Field(None, description="mixed: the relative noise b (a fraction of f).")
    meaning: str = Field(description="What the noise model means, in words.")


class MisfitOut(BaseModel):
    """``FitResult.misfit``: whether the residuals say the model does not describe the data."""

    model_config = ANSWER

    detected: bool = Field(description="A misfit was found (runs test or chi2).")
    runs_ratio: MaybeFloat = Field(
        description="Runs of residual signs counted over runs expected of noise, in the "
        "ordering and channel of the largest runs_z (below 1: residuals cluster)."
    )
    runs_z: MaybeFloat = Field(description="The largest runs test z (too few runs).")
    threshold_z: MaybeFloat = Field(description="The z above which it is a misfit.")
    ordered_by: str = Field(description="The angle the residuals were ordered along.")
    reduced_chi2: MaybeFloat = Field(description="Sum of squared residuals per degree of freedom.")
    chi2_tested: bool = Field(description="The reduced chi-square was tested (known sigma).")
    refit_loss: str | None = Field(
        None,
        description="The loss a default fit was refitted with after its noise-model fit "
        "misfit (log); null: not refitted.",
    )
    message: str = Field(description="The verdict, in words.")


class ConversionErrorOut(BaseModel):
    """How far the exported material is from the data (or the fitted BRDF)."""

    model_config = ConfigDict(extra="allow")

    against: str = Field(description="'data', or the fitted BRDF on a gonio grid.")
    n_directions: int = Field(description="Direction pairs the RMS is taken over.")
    rms_log_target: float = Field(description="RMS of ln(1 + f cos theta_i), export vs reference.")
    rms_log_fit: float = Field(description="The same for the fit itself.")
    albedo_theta_i: list[float] = Field(description="Incidence angles of the albedos, degrees.")
    albedo_target: list[list[float]] = Field(description="Directional albedo of the export.")
    albedo_fit: list[list[float]] = Field(description="Directional albedo of the fit.")
    exact: bool = Field(description="Whether the parameters were carried over exactly.")


class ExportOut(BaseModel):
    """``Export.to_dict()``: :func:`brdffit.export`."""

    target: ExportTarget = Field(description="The renderer (GET /export/targets lists them).")
    document: dict[str, Any] | str = Field(description="What the renderer reads.")
    parameters: dict[str, Any] = Field(description="The target's own parameters.")
    conversion_error: ConversionErrorOut = Field(description="The export's error.")
    notes: list[str] = Field(description="What could not be carried over; conventions.")
    extension: str | None = Field(
        None,
        description="The document's file name ending, without the dot (null in the exports "
        "of jobs stored before answers gave it).",
    )


class FitResultOut(BaseModel):
    """``FitResult.to_dict()``, and in answers to ``POST /fit`` the data's notes."""

    model_config = ANSWER

    model: str = Field(description='The fitted model ("a+b" for a sum of lobes).')
    params: dict[str, PerChannelOut] = Field(
        description="Fitted values: a number, or one per channel for linear parameters."
    )
    loss: MaybeFloat = Field(description="The minimised loss at `params`.")
    loss_name: str = Field(description="Which loss was minimised.")
    metrics: dict[str, MaybeFloat] = Field(
        description="Every named loss at `params` (chi2 only with sigma), rmse, aic, bic."
    )
    n_samples: int = Field(description="Direction pairs fitted.")
    n_channels: int = Field(description="Channels (colours or wavelengths) per sample.")
    n_values: int = Field(description="Observations: n_samples x n_channels.")
    n_params: int = Field(
        description="Fitted parameters: free shape ones + free linear ones x channels."
    )
    n_evals: int = Field(description="Evaluations of the objective (global + local).")
    seconds: float = Field(description="Wall-clock seconds of the fit.")
    converged: bool = Field(
        description="The local polish ended on its tolerance (not a budget or a timeout)."
    )
    message: str = Field(description="What happened, in words.")
    channels: list[str] = Field(description="The data's channel names.")
    fixed: dict[str, PerChannelOut] = Field(description="Parameters held fixed.")
    options: OptionsOut = Field(
        description="The options of the fit, defaults resolved: enough to reproduce it."
    )
    at_bounds: list[str] = Field(
        description="Free parameters that ended at a bound: shape ones, and linear ones "
        "(kd, ks...) at a bound in any channel."
    )
    noise: NoiseOut | None = Field(None, description="The noise model of the fit.")
    misfit: MisfitOut | None = Field(
        None, description="The test of the residuals for a model that does not fit."
    )
    unidentified: dict[str, str] = Field(
        default_factory=dict,
        description="Free parameters the data do not constrain, name -> why (an "
        "anisotropy the geometry cannot show, a singular Fisher information, a wide "
        "relative width): their values are the fit's, not the material's.",
    )
    posterior: PosteriorOut | None = Field(
        None, description="The posterior, when `uncertainty` was asked for."
    )
    exports: list[ExportOut] | None = Field(
        None,
        description="With the option `export`: the fitted material as each renderer's "
        "material (as POST /export answers, with the data), made after the fit.",
    )
    export_errors: dict[str, str] | None = Field(
        None,
        description="With the option `export`: target -> why its export was not made "
        "(the fit's time limit ran out first, or the library's error); null: none.",
    )
    data_notes: list[str] | None = Field(
        None,
        description="In the answer to POST /fit and /fit/file: what reading the data "
        "noticed and kept or dropped (values below zero, pairs a reader dropped), "
        "as the library's warnings say it.",
    )
