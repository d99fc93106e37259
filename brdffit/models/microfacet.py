"""Isotropic physical models: Ward and the microfacet models.

All of them share the pieces of :mod:`brdffit.models.shared` (Fresnel, D,
shadowing). Parameter-free factors (V-cavity shadowing, 1/(4 N.L N.V)) are
cached on the geometry, so an evaluation does only the parameter-dependent work.
"""

from __future__ import annotations

import numpy as np

from ..geometry import Geometry
from .base import INV_PI, Classification, Design, Model, Param
from .shared import fresnel_dielectric, vcavity_g

__all__ = ["MODELS"]

PHYSICAL_ANGLE_MATERIAL = Classification("physical", "isotropic", "angle", "material")


def diffuse_params(ks_upper: float = 10.0) -> tuple:
    return (
        Param("kd", 0.0, 1.0, 0.5, linear=True, unit="1", doc="diffuse albedo"),
        Param("ks", 0.0, ks_upper, 1.0, linear=True, unit="1", doc="specular albedo scale"),
    )


def roughness(name: str, default: float = 0.1, doc: str = "") -> Param:
    return Param(name, 1e-3, 1.0, default, log_scale=True, unit="1", doc=doc or "roughness")


def eta_param() -> Param:
    return Param("eta", 1.0, 3.0, 1.5, unit="1", doc="real refractive index (Fresnel)")


def _vcavity_over_4(geometry: Geometry) -> np.ndarray:
    """G / (4 (N.L)(N.V)) with the V-cavity G: parameter-free, cached."""
    return geometry.cached(
        "vcavity_over_4",
        lambda: vcavity_g(geometry.cos_h, geometry.cos_i, geometry.cos_o, geometry.cos_d)
        / (4.0 * geometry.cos_i * geometry.cos_o),
    )


def _cook_torrance_d_factor(geometry: Geometry) -> np.ndarray:
    """G / (4 N.L N.V pi cos^4 theta_h): everything but exp(...)/m^2 and F."""
    def compute():
        c2 = geometry.cos_h**2
        return _vcavity_over_4(geometry) * (INV_PI / (c2 * c2))

    return geometry.cached("cook_torrance_d_factor", compute)


def cook_torrance_lobe(geometry: Geometry, m: float, fresnel: np.ndarray) -> np.ndarray:
    """``F D G / (4 N.L N.V)`` with Beckmann ``D``, given the Fresnel factor."""
    m2 = m * m
    lobe = np.exp(geometry.tan2_h * (-1.0 / m2))
    lobe *= _cook_torrance_d_factor(geometry)
    lobe *= fresnel
    lobe *= 1.0 / m2
    return lobe


def _cook_torrance_design(geometry: Geometry, shape) -> Design:
    fresnel = fresnel_dielectric(geometry.cos_d, shape["eta"])
    return Design((INV_PI, cook_torrance_lobe(geometry, shape["m"], fresnel)))


COOK_TORRANCE = Model(
    name="cook_torrance",
    params=(*diffuse_params(), roughness("m", doc="Beckmann rms slope"), eta_param()),
    classification=PHYSICAL_ANGLE_MATERIAL,
    reference="R. L. Cook and K. E. Torrance, A reflectance model for computer graphics, "
    "SIGGRAPH 1981 / ACM TOG 1(1) 1982",
    design=_cook_torrance_design,
    doc="""Cook-Torrance with Beckmann D and exact dielectric Fresnel.

``f = kd/pi + ks F(V.H) D G / (4 (N.L)(N.V))``,
``D = exp(-tan^2(theta_h)/m^2) / (pi m^2 cos^4(theta_h))``, V-cavity ``G``.
The paper writes ``F/pi D G / ((N.L)(N.V))`` with D lacking its 1/pi; that
differs by a constant absorbed in ks. The normalised form is used so that a
white conductor has ks near 1 (MODELS.md).
""",
)

MODELS = (COOK_TORRANCE,)
