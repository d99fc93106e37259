"""``POST /evaluate``, ``POST /fit`` and ``POST /fit/file``: synchronous work."""

from __future__ import annotations

import numpy as np
from fastapi import APIRouter

import brdffit
from brdffit.jsonable import jsonable

from ..convert import fit_kwargs, located, measurements, read_upload, sample_limit
from ..deps import FitsDep, SettingsDep
from ..schemas import EvaluateIn, EvaluateOut, FitIn, FitResultOut
from .common import (
    ERRORS,
    ChannelsField,
    FileField,
    FormatField,
    ModelField,
    OptionsField,
    SubsampleField,
    form_options,
)

__all__ = ["router"]

router = APIRouter(tags=["fit"], responses=ERRORS)


@router.post("/evaluate", response_model=EvaluateOut)
def evaluate(body: EvaluateIn, settings: SettingsDep):
    """``Model.evaluate`` at direction pairs given as angles in degrees."""
    sample_limit(len(body.theta_i), settings.max_samples, "theta_i")
    model = brdffit.get_model(body.model)
    pairs = brdffit.Measurements.from_angles(
        body.theta_i, body.phi_i, body.theta_o, body.phi_o, np.zeros(len(body.theta_i))
    )
    with located("params", set(body.params) | set(model.param_names)):
        params = model.check_params({**model.defaults(), **body.params})
    values = model.evaluate(pairs.wi, pairs.wo, params)
    return {"model": model.name, "params": jsonable(params), "values": jsonable(values)}


@router.post("/fit", response_model=FitResultOut)
def fit(body: FitIn, settings: SettingsDep, fits: FitsDep):
    """``brdffit.fit(data, model, **options)``, within the server's limits of samples
    (``fit_max_samples``) and seconds (``fit_timeout``, for the fit and for the
    posterior); longer work belongs to ``POST /jobs``."""
    data, notes = measurements(body.data, settings.fit_max_samples)
    with located("data"):  # a fault the fit finds in the data (values too large...)
        result = fits.run(data, body.model, fit_kwargs(body, settings.fit_timeout), body.export)
    return {**result, "data_notes": notes}


@router.post("/fit/file", response_model=FitResultOut)
def fit_file(
    settings: SettingsDep,
    fits: FitsDep,
    file: FileField,
    model: ModelField,
    format: FormatField = None,
    subsample: SubsampleField = None,
    channels: ChannelsField = None,
    options: OptionsField = "{}",
):
    """``brdffit.fit(brdffit.read(file), model, **options)``, as ``POST /fit``."""
    options_in = form_options(options)
    kwargs = fit_kwargs(options_in, settings.fit_timeout)
    data, notes = read_upload(file.file.read(), file.filename, format, subsample, channels,
                              settings.fit_max_samples)  # fmt: skip
    return {**fits.run(data, model, kwargs, options_in.export), "data_notes": notes}
