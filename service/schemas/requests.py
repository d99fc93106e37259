"""Bodies of the HTTP service, one to one with the library's calls.

- :class:`DataIn` is :meth:`brdffit.Measurements.from_angles` (angles in degrees);
- :class:`FitOptions` holds the keyword options of :func:`brdffit.fit`, and
  :class:`PosteriorOptions` those of :func:`brdffit.sample_posterior`;
- :class:`FitIn` and :class:`EvaluateIn` are the bodies of ``POST /fit`` and
  ``POST /evaluate``.
"""

from __future__ import annotations

import inspect
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

import brdffit
from brdffit.fitting.losses import LOSSES
from brdffit.fitting.options import MIN_COARSE_SAMPLES

__all__ = [
    "EXAMPLE_DATA",
    "DataIn",
    "EvaluateIn",
    "ExportTarget",
    "FitIn",
    "FitOptions",
    "JobStatus",
    "PosteriorOptions",
]

LossName = Literal[tuple(LOSSES)]  # type: ignore[valid-type]
Number = float
PerChannel = float | list[float]
#: Seeds go to numpy and nlopt, which take unsigned 32-bit integers.
SEED_MAX = 2**32 - 1
#: The renderers of :func:`brdffit.export_targets`.
ExportTarget = Literal[tuple(brdffit.export_targets())]  # type: ignore[valid-type]
JobStatus = Literal["queued", "running", "done", "failed", "interrupted", "cancelled"]


def _defaults(function) -> dict:
    """The library's defaults, so that a field left out means what it means in Python."""
    return {
        name: p.default
        for name, p in inspect.signature(function).parameters.items()
        if p.default is not inspect.Parameter.empty
    }


FIT = _defaults(brdffit.fit)
POSTERIOR = _defaults(brdffit.sample_posterior)


def _example_data() -> dict:
    """A small blinn dataset (in the plane of incidence), made by the library itself."""
    angles = ([30.0] * 6 + [60.0] * 6, [0.0] * 12, [0, 20, 30, 40, 60, 75] * 2, [180.0] * 12)
    params = {"kd": [0.4, 0.3, 0.2], "ks": 0.6, "n": 60.0}
    data = brdffit.synthesize("blinn", params, geometry=angles, noise=0.01, seed=1)
    out = data.to_dict(include_data=True)
    return {
        "theta_i": out["theta_i"],
        "phi_i": out["phi_i"],
        "theta_o": out["theta_o"],
        "phi_o": out["phi_o"],
        "values": [[round(v, 6) for v in row] for row in out["values"]],
        "channels": list(data.channels),
    }


EXAMPLE_DATA = _example_data()


class DataIn(BaseModel):
    """Measured reflectance as arrays: :meth:`brdffit.Measurements.from_angles`.

    Angles in degrees (MODELS.md): ``theta`` from the normal in [0, 180] (past 90
    is below the horizon), ``phi`` any finite number. ``values`` holds one number
    per sample, or one row of C numbers (one per channel) per sample.
    """

    model_config = ConfigDict(extra="forbid", json_schema_extra={"examples": [EXAMPLE_DATA]})

    theta_i: list[Number] = Field(min_length=1, description="Incidence polar angles, degrees.")
    phi_i: list[Number] = Field(min_length=1, description="Incidence azimuths, degrees.")
    theta_o: list[Number] = Field(min_length=1, description="Outgoing polar angles, degrees.")
    phi_o: list[Number] = Field(min_length=1, description="Outgoing azimuths, degrees.")
    values: list[Number] | list[list[Number]] = Field(
        min_length=1, description="BRDF values, (N,) or (N, C), in `units`."
    )
    channels: list[str] | None = Field(None, description="One name per column of `values`.")
    sigma: list[Number] | list[list[Number]] | None = Field(
        None, description="Standard deviation of each value: (N,) or (N, C), positive."
    )
    source: str = Field("request", max_length=500, description="Where the data came from.")
    units: str = Field("1/sr", max_length=50, description="Units of the values.")


class PosteriorOptions(BaseModel):
    """Options of :func:`brdffit.posterior.sample.sample_posterior`."""

    model_config = ConfigDict(extra="forbid")

    walkers: int = Field(POSTERIOR["walkers"], ge=1, le=1024, description="emcee walkers.")
    steps: int | Literal["auto"] = Field(
        POSTERIOR["steps"],
        description='"auto" (until converged) or an exact number of steps (>= 1).',
    )
    max_steps: int = Field(
        POSTERIOR["max_steps"], ge=1, le=1_000_000, description='Cap of steps="auto".'
    )
    max_seconds: float | None = Field(
        POSTERIOR["max_seconds"],
        gt=0,
        le=1e6,
        allow_inf_nan=False,
        description="Wall-clock budget (capped by the server's limit).",
    )
    seed: int | None = Field(
        POSTERIOR["seed"], ge=0, le=SEED_MAX, description="Default: the fit's seed."
    )
    noise: Literal["given", "absolute", "relative", "mixed"] | None = Field(
        POSTERIOR["noise"],
        description='Noise model; default the fit\'s: "mixed" after a mixed fit (the default '
        'without sigma), "given" when the data have sigma.',
    )


class FitOptions(BaseModel):
    """Keyword options of :func:`brdffit.fit`."""

    model_config = ConfigDict(extra="forbid")

    loss: LossName | None = Field(
        FIT["loss"],
        description="The loss minimised (brdffit.fitting.losses); default: the library's.",
    )
    fixed: dict[str, PerChannel] | None = Field(None, description="Parameters held fixed.")
    free: list[str] = Field(
        default_factory=list, max_length=50, description="Parameters a model holds by default "
        "(he's eta, k, aperture) that the fit should search."
    )  # fmt: skip
    weights: list[Number] | None = Field(None, description="One weight per sample (>= 0).")
    start: dict[str, Number] | None = Field(None, description="Initial guess of shape params.")
    seed: int = Field(FIT["seed"], ge=0, le=SEED_MAX, description="Same seed, same result.")
    timeout: float | None = Field(
        None, gt=0, le=1e6, allow_inf_nan=False, description="Seconds (capped by the server's "
        "limit)."
    )  # fmt: skip
    max_evals: int | None = Field(None, ge=1, le=10**8, description="Cap on evaluations.")
    global_evals: int | None = Field(None, ge=1, le=10**7, description="Global-stage budget.")
    local_evals: int | None = Field(None, ge=1, le=10**7, description="Budget of each polish.")
    restarts: int = Field(
        FIT["restarts"], ge=0, le=50, description="Further polishes from distinct points."
    )
    global_algorithm: str | None = Field(
        FIT["global_algorithm"],
        max_length=40,
        description="nlopt global algorithm; null skips it.",
    )
    local_algorithm: str = Field(
        FIT["local_algorithm"], max_length=40, description="nlopt local (LN_)."
    )
    coarse_above: int = Field(
        FIT["coarse_above"],
        ge=0,
        le=10**9,
        description="Samples above which the search runs coarse to fine (a stratified "
        "subsample, then one polish on all the samples).",
    )
    coarse_samples: int = Field(
        FIT["coarse_samples"],
        ge=MIN_COARSE_SAMPLES,
        le=10**8,
        description="Samples of the coarse-to-fine subsample.",
    )
    energy_conserving: bool = Field(
        FIT["energy_conserving"], description="Albedo at most 1 at every incidence."
    )
    uncertainty: bool = Field(False, description="Also sample the posterior.")
    posterior_options: PosteriorOptions | None = Field(
        None, description="Options of the posterior, when `uncertainty` is true."
    )
    export: list[ExportTarget] = Field(
        default_factory=list,
        max_length=20,
        description="Renderers to export the fitted material to after the fit (GET "
        "/export/targets lists them), as POST /export with the data: the answer's "
        "`exports`. They run within the fit's time limit.",
    )

    @field_validator("export")
    @classmethod
    def _once_each(cls, targets: list) -> list:
        return list(dict.fromkeys(targets))


class FitIn(FitOptions):
    """``brdffit.fit(data, model, **options)``."""

    model_config = ConfigDict(
        extra="forbid",
        json_schema_extra={
            "examples": [
                {"model": "blinn", "data": EXAMPLE_DATA},
                {"model": "blinn", "data": EXAMPLE_DATA, "loss": "log", "seed": 3},
                {"model": "blinn", "data": EXAMPLE_DATA, "fixed": {"n": 60.0}},
            ]
        },
    )

    model: str = Field(
        max_length=500, description='A model name, or a sum such as "lambert+blinn".'
    )
    data: DataIn


class EvaluateIn(BaseModel):
    """``Model.evaluate(wi, wo, params)`` at direction pairs given as angles (degrees)."""

    model_config = ConfigDict(
        extra="forbid",
        json_schema_extra={
            "examples": [
                {
                    "model": "ward",
                    "params": {"kd": [0.3, 0.2, 0.1], "ks": 0.08, "alpha": 0.12},
                    "theta_i": [30, 30],
                    "phi_i": [0, 0],
                    "theta_o": [30, 10],
                    "phi_o": [180, 180],
                }
            ]
        },
    )

    model: str = Field(max_length=500, description="A model name or a sum of lobes.")
    params: dict[str, PerChannel] = Field(
        default_factory=dict, description="Parameter values; missing ones take the defaults."
    )
    theta_i: list[Number] = Field(min_length=1)
    phi_i: list[Number] = Field(min_length=1)
    theta_o: list[Number] = Field(min_length=1)
    phi_o: list[Number] = Field(min_length=1)
