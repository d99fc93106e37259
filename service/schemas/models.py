"""Answers of the model routes: ``Model.to_dict()``, its properties, evaluations."""

from __future__ import annotations

from pydantic import BaseModel, Field

from .results import ANSWER, MaybeFloat, PerChannelOut

__all__ = [
    "ClassificationOut",
    "EvaluateOut",
    "ModelOut",
    "ParamOut",
    "PropertiesOut",
]


class ParamOut(BaseModel):
    """``Param.to_dict()``: one parameter of a model."""

    model_config = ANSWER

    name: str = Field(description="The parameter's name (kd, ks, alpha...).")
    lower: float = Field(description="Lower bound of its range.")
    upper: float = Field(description="Upper bound of its range.")
    default: float = Field(description="Its default value (and a fit's usual start).")
    log_scale: bool = Field(description="Searched in log space (it spans decades).")
    linear: bool = Field(description="A linear coefficient, solved, not searched.")
    unit: str = Field(description="Its unit, empty when dimensionless.")
    doc: str = Field(description="What it means.")
    per_channel: bool = Field(description="Takes one value per channel of the data.")


class ClassificationOut(BaseModel):
    """``Classification.to_dict()``: the axes of the classification paper (MODELS.md)."""

    model_config = ANSWER

    origin: str = Field(description="empirical or physical.")
    symmetry: str = Field(description="isotropic or anisotropic.")
    operand: str = Field(description="cosine or angle: what the lobe is a function of.")
    highlight: str = Field(description="light or material: what sets the highlight.")
    wave_optics: bool = Field(description="Accounts for wave optics (diffraction...).")


class PropertiesOut(BaseModel):
    """``brdffit.models.properties.model_properties``: albedo and reciprocity, measured."""

    model_config = ANSWER

    params: dict[str, PerChannelOut] = Field(description="The parameter values used.")
    max_albedo: PerChannelOut = Field(
        description="Largest directional albedo over the incidences tried."
    )
    max_albedo_theta_i: float = Field(description="Incidence polar angle of it, degrees.")
    max_albedo_phi_i: float = Field(description="Incidence azimuth of it, degrees.")
    albedo: dict[str, PerChannelOut] = Field(
        description='Incidence polar angle in degrees ("0", "30"...) -> directional albedo.'
    )
    albedo_error: float = Field(description="The largest error estimate of the albedos.")
    energy_conserving: bool = Field(description="max_albedo <= 1 within that error.")
    reciprocity_max: MaybeFloat = Field(description="Largest relative |f(L,V) - f(V,L)|.")
    reciprocity_rms: MaybeFloat = Field(description="Its root mean square over the pairs.")
    reciprocal: bool = Field(description="reciprocity_max below 1e-6.")


class ModelOut(BaseModel):
    """``Model.to_dict()``, and ``properties`` when asked for."""

    model_config = ANSWER

    name: str = Field(description="The model's name (a sum of lobes: a+b).")
    params: list[ParamOut] = Field(description="Its parameters, in order.")
    classification: ClassificationOut = Field(description="Where it sits in MODELS.md.")
    reference: str = Field(description="The primary source of its formula.")
    reciprocal: bool = Field(description="Reciprocal by construction.")
    doc: str = Field(description="What the model is, in words.")
    properties: PropertiesOut | None = Field(
        None, description="Measured albedo and reciprocity (with ?properties=true)."
    )


class EvaluateOut(BaseModel):
    """BRDF values (1/sr), (N,) or (N, C) when linear params are given per channel."""

    model_config = ANSWER

    model: str = Field(description="The model evaluated.")
    params: dict[str, PerChannelOut] = Field(description="The values used, defaults filled.")
    values: list[MaybeFloat] | list[list[MaybeFloat]] = Field(
        description="BRDF values, one per direction pair (a row per pair with channels)."
    )
    units: str = Field("1/sr", description="Units of the values.")
