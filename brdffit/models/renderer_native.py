"""Renderer-native reflection models: exactly what glTF viewers and Mitsuba 3 evaluate.

A material fitted with one of these models is exported without approximation
(:mod:`brdffit.export`): its parameters are the renderer's own.

``gltf_pbr`` is the core glTF 2.0 metallic-roughness BRDF (glTF 2.0
specification, appendix B): with ``alpha = roughness^2``, GGX ``D``, the
height-correlated Smith visibility ``V = G2 / (4 N.L N.V)``,
``G2 = 1 / (1 + Lambda(L) + Lambda(V))``, ``Lambda = (sqrt(1 + alpha^2 tan^2) - 1) / 2``,
and Schlick's weight ``w = (1 - V.H)^5``::

    dielectric = (1 - Fd) base_color / pi + Fd D V,   Fd = 0.04 + 0.96 w   (ior 1.5)
    metal      = (base_color + (1 - base_color) w) D V
    f          = (1 - metallic) dielectric + metallic metal

``f`` is linear in ``base_color`` (one column and an offset, both functions of
``metallic`` and ``roughness``), so base_color is solved for, per channel.
``gltf_pbr_anisotropic`` adds ``KHR_materials_anisotropy``: along the
anisotropy direction (the tangent T = x rotated counter-clockwise by
``anisotropy_rotation``) ``alpha_t = alpha + (1 - alpha) strength^2``, across it
``alpha_b = alpha``.

``mitsuba_roughconductor`` is Mitsuba 3's ``roughconductor`` with the GGX
distribution: ``f = specular_reflectance F(V.H; eta + i k) D G1(L) G1(V) /
(4 N.L N.V)`` with the separable Smith ``G`` and the exact conductor Fresnel;
``eta = 0, k = 1`` is Mitsuba's ``material = "none"`` (``F = 1``). Mitsuba's
``BSDF.eval`` returns this BRDF times ``cos(theta_o)``.

References: glTF 2.0 specification, appendix B "BRDF implementation"
(Khronos, registry.khronos.org/glTF/specs/2.0); KHR_materials_anisotropy
(github.com/KhronosGroup/glTF, extensions/2.0/Khronos); Mitsuba 3,
src/bsdfs/roughconductor.cpp and include/mitsuba/render/microfacet.h;
E. Heitz, Understanding the masking-shadowing function in microfacet-based
BRDFs, JCGT 3(2), 2014 (height-correlated Smith).
"""

from __future__ import annotations

import math

import numpy as np

from ..data.geometry import MIN_COSINE, Geometry
from .base import INV_PI, Classification, Design, Model, Param
from .microfacet import _schlick_weight, inv_4_cos, schlick_fresnel
from .params import roughness
from .renderers import FLOAT32, _tan2, anisotropic_lobe, isotropic_lobe
from .shared import fresnel_conductor, ggx_d

__all__ = ["MODELS", "GLTF_F0", "gltf_specular", "conductor_fresnel", "perfect_conductor"]

ISOTROPIC = Classification("physical", "isotropic", "cosine", "material")
ANISOTROPIC = Classification("physical", "anisotropic", "cosine", "material")

#: glTF's dielectric reflectance at normal incidence, ``((1.5 - 1)/(1.5 + 1))^2``.
GLTF_F0 = 0.04

_GLTF_REFERENCE = (
    "glTF 2.0 specification, appendix B (BRDF implementation), Khronos Group, 2021; "
    "E. Heitz, JCGT 3(2), 2014 (height-correlated Smith G2)"
)
_MITSUBA_REFERENCE = (
    "Mitsuba 3 (W. Jakob et al., 2022), src/bsdfs/roughconductor.cpp and "
    "include/mitsuba/render/microfacet.h; B. Walter et al., EGSR 2007 (GGX)"
)


# --------------------------------------------------------------- glTF pieces
def _lambda_ggx(v: np.ndarray, alpha_t: float, alpha_b: float, rotation: float):
    """Smith ``Lambda`` of GGX along directions ``v`` (M, 3): ``(sqrt(1 + (alpha_t^2
    v_t^2 + alpha_b^2 v_b^2) / v_z^2) - 1) / 2`` with ``t`` the rotated tangent, ``v_z``
    clamped as every model's cosines (:data:`~brdffit.data.geometry.MIN_COSINE`), so
    that no anisotropy is the isotropic model at grazing angles too."""
    c, s = math.cos(rotation), math.sin(rotation)
    vt = v[:, 0] * c + v[:, 1] * s
    vb = v[:, 1] * c - v[:, 0] * s
    vz = np.maximum(v[:, 2], MIN_COSINE)
    x = ((alpha_t * vt) ** 2 + (alpha_b * vb) ** 2) / (vz * vz)
    return 0.5 * (np.sqrt(1.0 + x) - 1.0)


def _ggx_d_rotated(h: np.ndarray, alpha_t: float, alpha_b: float, rotation: float):
    """``1 / (pi alpha_t alpha_b (h_t^2/alpha_t^2 + h_b^2/alpha_b^2 + h_z^2)^2)``."""
    c, s = math.cos(rotation), math.sin(rotation)
    ht = h[:, 0] * c + h[:, 1] * s
    hb = h[:, 1] * c - h[:, 0] * s
    q = (ht / alpha_t) ** 2 + (hb / alpha_b) ** 2 + h[:, 2] ** 2
    return 1.0 / (math.pi * alpha_t * alpha_b * q * q)


def gltf_specular(geometry: Geometry, alpha_t: float, alpha_b: float, rotation: float = 0.0):
    """``D V`` of glTF: GGX ``D`` times the height-correlated visibility
    ``G2 / (4 N.L N.V)``; isotropic when ``alpha_t = alpha_b``."""
    d = _ggx_d_rotated(geometry.half, alpha_t, alpha_b, rotation)
    lam = _lambda_ggx(geometry.wi, alpha_t, alpha_b, rotation)
    lam += _lambda_ggx(geometry.wo, alpha_t, alpha_b, rotation)
    lam += 1.0
    d /= lam
    d *= inv_4_cos(geometry)
    return d


def _gltf_specular_isotropic(geometry: Geometry, alpha) -> np.ndarray:
    """:func:`gltf_specular` with ``alpha_t = alpha_b = alpha``, from the geometry's
    cached ``tan^2`` of H, L and V: ``G2 = 2 / (sqrt(1 + alpha^2 tan^2 theta_L) +
    sqrt(1 + alpha^2 tan^2 theta_V))``. ``alpha`` may be a (W, 1) batch."""
    a2 = alpha * alpha
    d = ggx_d(geometry.tan2_h, geometry.cos_h, a2)
    s = np.sqrt(1.0 + a2 * _tan2(geometry, "i"))
    s += np.sqrt(1.0 + a2 * _tan2(geometry, "o"))
    d *= 2.0 / s
    d *= inv_4_cos(geometry)
    return d


def _gltf_design(geometry: Geometry, metallic: float, spec: np.ndarray) -> Design:
    """Column of ``base_color`` and the offset, from ``S = D V`` (module docstring)."""
    w = _schlick_weight(geometry)
    fd = schlick_fresnel(geometry, GLTF_F0)  # from the same cached weight
    column = (1.0 - metallic) * INV_PI * (1.0 - fd) + metallic * (1.0 - w) * spec
    offset = ((1.0 - metallic) * fd + metallic * w) * spec
    return Design((column,), offset)


#: What Mitsuba's alpha is, and the other renderers' names for it (issue 17).
_MITSUBA_ALPHA = (
    "Mitsuba 3 alpha: the GGX width alpha, not squared, not an rms slope (GGX slopes have no "
    "finite variance). Renderers: glTF roughnessFactor, Disney/Blender Principled Roughness "
    "and OpenPBR specular_roughness = sqrt(alpha); pbrt-v4 roughness = alpha with "
    "remaproughness false, alpha^2 with true (its default)"
)


def _gltf_params() -> tuple:
    return (
        Param("base_color", 0.0, 1.0, 0.5, linear=True, unit="1", doc="baseColorFactor"),
        Param("metallic", 0.0, 1.0, 0.0, unit="1", doc="metallicFactor"),
        Param(
            "roughness", 0.03, 1.0, 0.5, log_scale=True, unit="1",
            doc="glTF roughnessFactor (perceptual): GGX alpha = roughness^2. Renderers: the same "
            "value is Disney/Blender Principled Roughness and OpenPBR specular_roughness; "
            "Mitsuba 3 alpha = roughness^2; pbrt-v4 roughness = roughness^4 with "
            "remaproughness true (its default), roughness^2 with false",
        ),
    )  # fmt: skip


def _gltf_iso_design(geometry: Geometry, shape) -> Design:
    alpha = shape["roughness"] ** 2
    return _gltf_design(geometry, shape["metallic"], _gltf_specular_isotropic(geometry, alpha))


def _gltf_aniso_design(geometry: Geometry, shape) -> Design:
    alpha = shape["roughness"] ** 2
    strength = shape["anisotropy_strength"]
    alpha_t = alpha + (1.0 - alpha) * strength * strength
    spec = gltf_specular(geometry, alpha_t, alpha, shape["anisotropy_rotation"])
    return _gltf_design(geometry, shape["metallic"], spec)


GLTF_PBR = Model(
    name="gltf_pbr",
    params=_gltf_params(),
    classification=ISOTROPIC,
    reference=_GLTF_REFERENCE,
    design=_gltf_iso_design,
    doc="glTF 2.0 core metallic-roughness BRDF (see brdffit.models.renderer_native).\n\n"
    "``f = (1 - metallic)((1 - Fd) base_color/pi + Fd D V) + metallic (base_color + "
    "(1 - base_color)(1 - V.H)^5) D V``, ``Fd = 0.04 + 0.96 (1 - V.H)^5``, GGX ``D`` "
    "with ``alpha = roughness^2``, height-correlated Smith ``V``.\n",
)

GLTF_PBR_ANISOTROPIC = Model(
    name="gltf_pbr_anisotropic",
    params=(
        *_gltf_params(),
        Param("anisotropy_strength", 0.0, 1.0, 0.5, unit="1", doc="anisotropyStrength"),
        Param(
            "anisotropy_rotation",
            -math.pi / 2,
            math.pi / 2,
            0.0,
            unit="rad",
            doc="anisotropyRotation: counter-clockwise from the tangent T = x",
        ),
    ),
    classification=ANISOTROPIC,
    reference=_GLTF_REFERENCE + "; KHR_materials_anisotropy (Khronos, 2023)",
    design=_gltf_aniso_design,
    doc="glTF 2.0 metallic-roughness with KHR_materials_anisotropy.\n\n"
    "As ``gltf_pbr`` with ``alpha_t = alpha + (1 - alpha) anisotropy_strength^2`` along "
    "the tangent rotated by ``anisotropy_rotation`` and ``alpha_b = alpha`` across it.\n",
)


# ------------------------------------------------------------ Mitsuba pieces
def conductor_fresnel(geometry: Geometry, eta: float, k: float) -> np.ndarray:
    """Exact conductor Fresnel at ``V.H``, as Mitsuba's ``fresnel_conductor``."""
    return fresnel_conductor(geometry.cos_d, eta, k)


def _conductor_params(*alphas: Param) -> tuple:
    return (
        Param(
            "specular_reflectance", 0.0, 10.0, 1.0, linear=True, unit="1",
            doc="Mitsuba specular_reflectance (a scale of the lobe)",
        ),
        *alphas,
        Param("eta", 0.0, 10.0, 0.0, unit="1", doc="real part of the conductor's index"),
        Param("k", 0.0, 10.0, 1.0, unit="1", doc="imaginary part (eta=0, k=1: F = 1)"),
    )  # fmt: skip


#: The smallest ``k`` at which ``eta = 0`` makes the conductor Fresnel exactly 1.
PERFECT_K_MIN = 1e-70


def perfect_conductor(eta, k) -> bool:
    """Whether :func:`conductor_fresnel` is exactly 1 at every ``V.H`` in [0, 1]: at
    ``eta = 0`` (Mitsuba's ``material = "none"`` is ``eta = 0, k = 1``) its ``t0 = -k^2
    - s^2 <= 0`` and ``sqrt(t0^2) = |t0|`` give ``a = 0``, so ``Rs = t1/t1`` and ``Rp =
    Rs t3/t3``; ``k >=`` :data:`PERFECT_K_MIN` keeps ``t0^2`` and ``t3`` normal numbers
    (at ``k = 1e-100`` and ``V.H = 1`` the formula gives 1/2). The models then skip the
    factor: it cost three quarters of the numpy evaluation (measured, 47 of 65 ms on
    1 M pairs)."""
    return bool(np.all(np.asarray(eta) == 0.0) and np.all(np.asarray(k) >= PERFECT_K_MIN))


def _times_fresnel(geometry: Geometry, lobe: np.ndarray, shape) -> np.ndarray:
    if not perfect_conductor(shape["eta"], shape["k"]):
        lobe *= conductor_fresnel(geometry, shape["eta"], shape["k"])
    return lobe


def _conductor_iso_design(geometry: Geometry, shape) -> Design:
    lobe = isotropic_lobe(geometry, "ggx", shape["alpha"], 1.0)
    return Design((_times_fresnel(geometry, lobe, shape),))


def _conductor_aniso_design(geometry: Geometry, shape) -> Design:
    lobe = anisotropic_lobe(geometry, "ggx", shape["alpha_u"], shape["alpha_v"], 1.0)
    return Design((_times_fresnel(geometry, lobe, shape),))


_MITSUBA_DOC = (
    "``f = specular_reflectance F(V.H; eta + i k) D G1(L) G1(V) / (4 N.L N.V)``, GGX, "
    "separable Smith G, exact conductor Fresnel. Mitsuba's eval returns f cos(theta_o). "
    "A fit holds eta and k at Mitsuba's material 'none' (F = 1) unless told to free them.\n"
)

MITSUBA_ROUGHCONDUCTOR = Model(
    name="mitsuba_roughconductor",
    params=_conductor_params(roughness("alpha", doc=_MITSUBA_ALPHA)),
    classification=ISOTROPIC,
    reference=_MITSUBA_REFERENCE,
    design=_conductor_iso_design,
    held=("eta", "k"),
    doc="Mitsuba 3 roughconductor (GGX).\n\n" + _MITSUBA_DOC,
)

MITSUBA_ROUGHCONDUCTOR_ANISOTROPIC = Model(
    name="mitsuba_roughconductor_anisotropic",
    params=_conductor_params(
        roughness(
            "alpha_u",
            doc="Mitsuba 3 alpha_u: GGX width along the tangent T = x, not "
            "squared, not an rms slope. Renderers: pbrt-v4 uroughness = alpha_u "
            "(remaproughness false) or alpha_u^2 (true); Disney/Blender Principled: "
            "roughness^2 = sqrt(alpha_u alpha_v)",
        ),
        roughness(
            "alpha_v",
            0.3,
            doc="Mitsuba 3 alpha_v: GGX width along the bitangent, not "
            "squared, not an rms slope. Renderers: pbrt-v4 vroughness = alpha_v "
            "(remaproughness false) or alpha_v^2 (true); Disney/Blender Principled: "
            "roughness^2 = sqrt(alpha_u alpha_v)",
        ),
    ),
    classification=ANISOTROPIC,
    reference=_MITSUBA_REFERENCE,
    design=_conductor_aniso_design,
    held=("eta", "k"),
    doc="Mitsuba 3 roughconductor (GGX) with alpha_u, alpha_v.\n\n"
    + _MITSUBA_DOC
    + FLOAT32.format(error="1.3e-7"),
)

MODELS = (
    GLTF_PBR,
    GLTF_PBR_ANISOTROPIC,
    MITSUBA_ROUGHCONDUCTOR,
    MITSUBA_ROUGHCONDUCTOR_ANISOTROPIC,
)
