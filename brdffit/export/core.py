"""What every export shares: the fitted material, the Export object, the error.

An export starts from a fitted material (a :class:`~brdffit.result.FitResult`
or its ``to_dict()``, which holds the model name, the parameters and the
channels). Where the target has the fitted model the parameters are carried
over exactly; otherwise the target's native model is fitted to the fitted BRDF
(on a gonioreflectometer grid, noise-free) or, when data are given, to the data,
with the ``log`` loss of Löw et al. (2012, ACM TOG 31(1), E2).

The conversion error of every export is the RMS over the measured directions
(or the grid) and channels of ``ln(1 + f cos(theta_i))`` minus the same of the
reference (the data, or the fitted BRDF), for the target's BRDF and, beside it,
for the fit's own; and the directional albedo of both at 0, 30 and 60 degrees
(:func:`brdffit.properties.albedo`).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..fitting import fit
from ..fitting.result import FitResult
from ..jsonable import jsonable
from ..models import get_model
from ..models.properties import albedo
from ..synth import synthesize

__all__ = ["Export", "Material", "conversion_error", "material_of", "rms_log_error", "to_native"]

ALBEDO_ANGLES = (0.0, 30.0, 60.0)


@dataclass(frozen=True)
class Material:
    """A model name, its parameters (per-channel arrays for linear ones), channels."""

    model: str
    params: Mapping[str, Any]
    channels: tuple = ("value",)

    @property
    def anisotropic(self) -> bool:
        """Whether the model depends on the azimuth about the normal (needs a tangent)."""
        return get_model(self.model).classification.symmetry == "anisotropic"

    def evaluate(self, wi, wo) -> np.ndarray:
        """BRDF values, shape (N, C)."""
        f = get_model(self.model).evaluate(wi, wo, dict(self.params))
        return f.reshape(len(wi), -1)


def material_of(result) -> Material:
    """The material of a FitResult or of its ``to_dict()`` (a JSON result file)."""
    if isinstance(result, FitResult):
        return Material(result.model, dict(result.params), tuple(result.channels))
    if isinstance(result, Mapping):
        for key in ("model", "params"):
            if key not in result:
                raise ParameterError(
                    f"a fit result needs a {key!r} entry (the to_dict() of brdffit.fit)", key
                )
        model = get_model(result["model"])
        params = model.check_params(result["params"])
        channels = tuple(result.get("channels") or _channels(params))
        return Material(model.name, params, channels)
    raise ParameterError(
        f"cannot export a {type(result).__name__}; give a FitResult or its to_dict()", "result"
    )


def _channels(params) -> tuple:
    """Channel names when a result does not give them: as many as values per channel."""
    n = max(np.size(v) for v in params.values())
    if n in (1, 3):
        return ("value",) if n == 1 else ("r", "g", "b")
    return tuple(f"c{i}" for i in range(n))


def reference_data(material: Material, data=None):
    """The measurements an approximate export is fitted to, and what they are."""
    if data is not None:
        return data, "data"
    model = get_model(material.model)
    samples = synthesize(model, dict(material.params), geometry="gonio")
    if len(material.channels) == samples.values.reshape(samples.n, -1).shape[1]:
        samples = synthesize(
            model, dict(material.params), geometry="gonio", channels=material.channels
        )
    return samples, "fitted BRDF (gonio grid)"


def to_native(material: Material, native: str, data=None) -> Material:
    """The target's native model fitted to the material (or to the data)."""
    samples, _ = reference_data(material, data)
    result = fit(samples, native, loss="log")
    return Material(result.model, dict(result.params), tuple(samples.channels))


def _rms_log(f: np.ndarray, y: np.ndarray, cos_i: np.ndarray) -> float:
    d = np.log1p(np.maximum(f, 0.0) * cos_i[:, None]) - np.log1p(
        np.maximum(y, 0.0) * cos_i[:, None]
    )
    return float(np.sqrt(np.mean(d * d)))


def rms_log_error(material: Material, target_eval, data=None) -> float:
    """Only the RMS of ln(1 + f cos) of ``target_eval`` (to choose between candidates)."""
    samples, _ = reference_data(material, data)
    y = samples.values.reshape(samples.n, -1)
    f = np.asarray(target_eval(samples.wi, samples.wo)).reshape(samples.n, -1)
    return _rms_log(np.broadcast_to(f[:, : y.shape[1]], y.shape), y, samples.wi[:, 2])


def conversion_error(material: Material, target_eval, target_albedo, data=None) -> dict:
    """The error of an export (module docstring).

    ``target_eval(wi, wo) -> (N, C)`` evaluates the target's BRDF as exported;
    ``target_albedo(theta) -> (C,)`` its directional albedo.
    """
    samples, against = reference_data(material, data)
    y = samples.values.reshape(samples.n, -1)
    cos_i = samples.wi[:, 2]
    f_target = np.asarray(target_eval(samples.wi, samples.wo)).reshape(samples.n, -1)
    if y.shape[1] == 1:  # a grey material written as RGB: its channels are equal
        f_target = f_target[:, :1]
    f_target = np.broadcast_to(f_target, y.shape)
    f_fit = np.broadcast_to(material.evaluate(samples.wi, samples.wo), y.shape)
    fit_albedo = albedo(material.model, dict(material.params), list(ALBEDO_ANGLES), rtol=1e-4)
    return {
        "against": against,
        "n_directions": int(samples.n),
        "rms_log_target": _rms_log(f_target, y, cos_i),
        "rms_log_fit": _rms_log(f_fit, y, cos_i),
        "albedo_theta_i": list(ALBEDO_ANGLES),
        "albedo_target": np.asarray([target_albedo(t) for t in ALBEDO_ANGLES]).tolist(),
        "albedo_fit": np.asarray(fit_albedo.value).reshape(len(ALBEDO_ANGLES), -1).tolist(),
    }


def native_albedo(material: Material):
    """``theta -> albedo`` of a registered model, for :func:`conversion_error`."""

    def at(theta: float):
        a = albedo(material.model, dict(material.params), theta, rtol=1e-4)
        return np.atleast_1d(a.value)

    return at


@dataclass(frozen=True)
class Export:
    """A material for a renderer, and how far it is from the fit (and the data).

    Attributes
    ----------
    document : dict or str
        What the renderer reads: a dict (Mitsuba ``load_dict``, glTF JSON, Blender
        inputs) or text (Mitsuba XML, MaterialX, pbrt).
    target : str
    parameters : mapping
        The target's own parameters, by the target's names.
    conversion_error : mapping
        See :func:`conversion_error`; ``exact`` says whether the parameters were
        carried over without approximation.
    notes : tuple of str
        What could not be carried over, and conventions worth knowing.
    native : Material
        The model (of brdffit's registry) that the exported values evaluate to.
    extension : str
        The document's file name ending, without the dot (``xml``, ``gltf``,
        ``mtlx``, ``pbrt``, ``json``).
    """

    document: Any
    target: str
    parameters: Mapping[str, Any]
    conversion_error: Mapping[str, Any]
    notes: tuple = ()
    native: Material | None = field(default=None, repr=False)
    extension: str = "json"

    def __post_init__(self):
        object.__setattr__(self, "parameters", MappingProxyType(dict(self.parameters)))
        object.__setattr__(self, "conversion_error", MappingProxyType(dict(self.conversion_error)))

    def text(self) -> str:
        """The document as the text written to a file."""
        if isinstance(self.document, str):
            return self.document
        return json.dumps(self.document, indent=2) + "\n"

    def write(self, path) -> Path:
        """Write the document to ``path``; return the path."""
        path = Path(path)
        path.write_text(self.text())
        return path

    def to_dict(self) -> dict:
        return {
            "target": self.target,
            "document": self.document,
            "parameters": jsonable(dict(self.parameters)),
            "conversion_error": jsonable(dict(self.conversion_error)),
            "notes": list(self.notes),
            "extension": self.extension,
        }


def rgb(value, channels) -> list:
    """Three values for a renderer's RGB from one or three channels."""
    v = np.atleast_1d(np.asarray(value, dtype=float))
    if v.size == 1:
        return [float(v[0])] * 3
    if v.size == 3:
        return [float(x) for x in v]
    raise ParameterError(
        f"a renderer needs one or three channels, the fit has {v.size} ({', '.join(channels)})",
        "channels",
    )
