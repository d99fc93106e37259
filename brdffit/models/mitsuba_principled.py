"""Mitsuba 3's ``principled`` BSDF, its reflection lobes (no transmission, sheen,
clearcoat, specular tint or flatness), exactly as Mitsuba evaluates them.

With ``eta = 2 / (1 - sqrt(0.08 specular)) - 1``, ``w(c) = (1 - c)^5``,
``c_d = V.H``, GGX with ``alpha = max(0.001, roughness^2)`` (anisotropic:
``alpha_u = max(0.001, roughness^2 / a)``, ``alpha_v = max(0.001, roughness^2 a)``,
``a = sqrt(1 - 0.9 anisotropic)``, ``alpha_u`` along the tangent x) and the
separable Smith ``G``::

    F = (1 - metallic) F_dielectric(c_d; eta) + metallic (base_color + (1 - base_color) w(c_d))
    f = F D G / (4 N.L N.V)
      + (1 - metallic) base_color / pi ((1 - w(N.L)/2)(1 - w(N.V)/2)
                                        + R (w(N.L) + w(N.V) + w(N.L) w(N.V)(R - 1)))

where ``R = 2 roughness c_d^2`` (Burley's retro-reflection). ``f`` is linear in
``base_color`` (a column and an offset), so base_color is solved for.

References: B. Burley, Physically-based shading at Disney, SIGGRAPH 2012 course
notes; Mitsuba 3, src/bsdfs/principled.cpp and principledhelpers.h
(``calc_dist_params``, ``principled_fresnel``, ``schlick_weight``).
"""

from __future__ import annotations

import math

from ..data.geometry import Geometry
from .base import INV_PI, Classification, Design, Model, Param
from .microfacet import _schlick_weight
from .renderers import FLOAT32, anisotropic_lobe, isotropic_lobe
from .shared import fresnel_dielectric, schlick_weight

__all__ = ["MODELS", "principled_alphas", "principled_eta"]


def principled_eta(specular: float) -> float:
    """Mitsuba's relative index from ``specular``: ``2 / (1 - sqrt(0.08 s)) - 1``."""
    return 2.0 / (1.0 - math.sqrt(0.08 * specular)) - 1.0


def principled_alphas(roughness: float, anisotropic: float | None) -> tuple:
    """Mitsuba's ``calc_dist_params``: (alpha_u, alpha_v)."""
    r2 = roughness * roughness
    if anisotropic is None:
        return max(0.001, r2), max(0.001, r2)
    aspect = math.sqrt(1.0 - 0.9 * anisotropic)
    return max(0.001, r2 / aspect), max(0.001, r2 * aspect)


def _burley_terms(geometry: Geometry) -> tuple:
    """The parameter-free parts of Burley's diffuse, with ``w_L = w(N.L)``, ``w_V =
    w(N.V)``: ``(1 - w_L/2)(1 - w_V/2)``, ``w_L + w_V`` and ``w_L w_V``; cached."""

    def compute():
        wi, wo = schlick_weight(geometry.cos_i), schlick_weight(geometry.cos_o)
        return (1.0 - 0.5 * wi) * (1.0 - 0.5 * wo), wi + wo, wi * wo

    return geometry.cached("mitsuba_principled.burley", compute)


def _design(geometry: Geometry, shape, anisotropic: float | None) -> Design:
    metallic, rough = shape["metallic"], shape["roughness"]
    au, av = principled_alphas(rough, anisotropic)
    if anisotropic is None:
        dg = isotropic_lobe(geometry, "ggx", au, 1.0)
    else:
        dg = anisotropic_lobe(geometry, "ggx", au, av, 1.0)
    w = _schlick_weight(geometry)  # (1 - V.H)^5
    f_diff, w_sum, w_product = _burley_terms(geometry)
    retro = 2.0 * rough * geometry.cos_d * geometry.cos_d
    diffuse = f_diff + retro * (w_sum + w_product * (retro - 1.0))
    column = (1.0 - metallic) * INV_PI * diffuse + metallic * (1.0 - w) * dg
    fresnel = (1.0 - metallic) * fresnel_dielectric(
        geometry.cos_d, principled_eta(shape["specular"])
    )
    offset = (fresnel + metallic * w) * dg
    return Design((column,), offset)


def _params() -> tuple:
    return (
        Param("base_color", 0.0, 1.0, 0.5, linear=True, unit="1", doc="base_color"),
        Param("metallic", 0.0, 1.0, 0.0, unit="1", doc="metallic"),
        Param("roughness", 0.04, 1.0, 0.5, log_scale=True, unit="1",
              doc="Mitsuba 3 principled roughness (Disney's): GGX alpha = roughness^2. Renderers: "
                  "the same value is glTF roughnessFactor, Blender Principled Roughness and "
                  "OpenPBR specular_roughness; Mitsuba roughconductor alpha = roughness^2; "
                  "pbrt-v4 roughness = roughness^4 (remaproughness true) or roughness^2 "
                  "(false)"),
        Param("specular", 0.0, 1.0, 0.5, unit="1",
              doc="specular: eta = 2 / (1 - sqrt(0.08 specular)) - 1"),
    )  # fmt: skip


_REFERENCE = (
    "B. Burley, Physically-based shading at Disney, SIGGRAPH 2012 course notes; "
    "Mitsuba 3 (W. Jakob et al., 2022), src/bsdfs/principled.cpp"
)
_DOC = (
    "Mitsuba 3 principled, reflection lobes only (see brdffit.models.mitsuba_principled): "
    "Burley's diffuse with retro-reflection, GGX with separable Smith G, Fresnel mixing the "
    "exact dielectric (eta from specular) and Schlick on base_color by metallic. A fit "
    "holds specular at Mitsuba's default 0.5 unless told to free it.\n"
)

MITSUBA_PRINCIPLED = Model(
    name="mitsuba_principled",
    params=_params(),
    classification=Classification("physical", "isotropic", "cosine", "material"),
    reference=_REFERENCE,
    design=lambda geometry, shape: _design(geometry, shape, None),
    held=("specular",),
    doc="Mitsuba 3 principled (reflection).\n\n" + _DOC + FLOAT32.format(error="3e-7"),
)

MITSUBA_PRINCIPLED_ANISOTROPIC = Model(
    name="mitsuba_principled_anisotropic",
    params=(
        *_params(),
        Param(
            "anisotropic",
            0.0,
            1.0,
            0.5,
            unit="1",
            doc="anisotropic: alpha_u = alpha / a along x, alpha_v = alpha a",
        ),
    ),
    classification=Classification("physical", "anisotropic", "cosine", "material"),
    reference=_REFERENCE,
    design=lambda geometry, shape: _design(geometry, shape, shape["anisotropic"]),
    held=("specular",),
    doc="Mitsuba 3 principled (reflection) with anisotropic.\n\n"
    + _DOC
    + FLOAT32.format(error="4.2e-7"),
)

MODELS = (MITSUBA_PRINCIPLED, MITSUBA_PRINCIPLED_ANISOTROPIC)
