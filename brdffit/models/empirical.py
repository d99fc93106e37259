"""Isotropic empirical models: Lambert and the cosine-power family of the paper.

Each lobe is a plain vectorised function of a prepared
:class:`~brdffit.geometry.Geometry` and its shape parameters; the model is
``kd / pi + ks * lobe`` (MODELS.md).
"""

from __future__ import annotations

import numpy as np

from ..geometry import Geometry
from .base import INV_PI, Classification, Design, Model, Param, diffuse_plus_lobe

__all__ = ["MODELS"]

EMPIRICAL_COSINE = Classification("empirical", "isotropic", "cosine", "light")
EMPIRICAL_ANGLE = Classification("empirical", "isotropic", "angle", "light")


def exponent(name: str = "n", upper: float = 1e4, default: float = 50.0, doc: str = "") -> Param:
    """A specular exponent, searched in log space."""
    return Param(name, 1.0, upper, default, log_scale=True, unit="1", doc=doc or "exponent")


def _lambert_design(geometry: Geometry, shape) -> Design:
    return Design((INV_PI,))


LAMBERT = Model(
    name="lambert",
    params=(Param("kd", 0.0, 1.0, 0.5, linear=True, unit="1", doc="diffuse albedo"),),
    classification=EMPIRICAL_COSINE,
    reference="J. H. Lambert, Photometria, 1760",
    design=_lambert_design,
    doc="""Lambert: ``f = kd / pi``.

The paper's ambient term ``Ia ka`` and distance attenuation ``1/(d + k)`` are
shading, not reflectance, and have no fit parameter (MODELS.md).
""",
)


def blinn_lobe(geometry: Geometry, n: float) -> np.ndarray:
    """``(N.H)^n``, evaluated as ``exp(n ln(N.H))`` on the prepared logarithm."""
    return np.exp(n * geometry.log_cos_h)


BLINN = diffuse_plus_lobe(
    "blinn",
    blinn_lobe,
    (exponent(doc="Blinn exponent of N.H"),),
    EMPIRICAL_COSINE,
    "J. F. Blinn, Models of light reflection for computer synthesized pictures, "
    "SIGGRAPH 1977",
    """Blinn-Phong: ``f = kd / pi + ks (N.H)^n``.""",
)

MODELS = (LAMBERT, BLINN)
