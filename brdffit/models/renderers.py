"""The microfacet models of today's renderers: GGX and Beckmann with Smith shadowing.

``f = kd/pi + ks F(V.H) D(H) G1(L) G1(V) / (4 (N.L)(N.V))`` with the exact
separable Smith shadowing-masking of each distribution (Beckmann's as a rational
function within 2e-8 relative of the exact one, :mod:`brdffit.kernels.smith`) and
Schlick's Fresnel
``F = f0 + (1 - f0)(1 - V.H)^5`` (MODELS.md, "Beyond the paper"). ``alpha_u``
acts along the tangent T, ``alpha_v`` along the bitangent B. With ``f0 = 1`` and
``kd = 0`` the specular term is Mitsuba 3's ``roughconductor`` with a perfect
conductor, whose ``eval`` returns ``F D G / (4 cos(theta_i))``, i.e. the BRDF times
the cosine of the other direction.

Parameter-free terms (``tan^2`` and the azimuth of L and V, ``1/(4 N.L N.V)``,
Schlick's ``(1 - V.H)^5``) are cached on the geometry.

References: B. Walter, S. R. Marschner, H. Li, K. E. Torrance, Microfacet models
for refraction through rough surfaces, EGSR 2007; E. Heitz, Understanding the
masking-shadowing function in microfacet-based BRDFs, JCGT 3(2), 2014.
"""

from __future__ import annotations

import numpy as np

from ..data.geometry import Geometry
from ..kernels import smith
from .base import INV_PI, Classification, Design, Model
from .microfacet import inv_4_cos, schlick_fresnel
from .params import diffuse_params, f0_param, roughness
from .shared import (
    beckmann_d,
    beckmann_d_anisotropic,
    ggx_d,
    ggx_d_anisotropic,
    projected_alpha2,
    smith_g1_ggx,
)

__all__ = ["MODELS", "anisotropic_lobe", "beckmann_lobe", "ggx_lobe", "isotropic_lobe"]

ISOTROPIC = Classification("physical", "isotropic", "cosine", "material")
ANISOTROPIC = Classification("physical", "anisotropic", "cosine", "material")

_DISTRIBUTIONS = {
    "ggx": (ggx_d, ggx_d_anisotropic, smith_g1_ggx),
    # Beckmann's Smith G1 as a rational function within 2e-8 of the exact one, the
    # same as the compiled loops' (brdffit.kernels.smith says why)
    "beckmann": (beckmann_d, beckmann_d_anisotropic, smith.smith_g1),
}


# ------------------------------------------------- cached parameter-free terms
def _tan2(geometry: Geometry, which: str) -> np.ndarray:
    """``tan^2`` of the polar angle of L (``which = "i"``) or V (``"o"``): a row of
    :func:`_tan2_both`."""
    return _tan2_both(geometry)[0 if which == "i" else 1]


def _tan2_both(geometry: Geometry) -> np.ndarray:
    """``tan^2`` of the polar angles of L and V, stacked (2, M) (one array for the
    shadowing of both directions in one numpy call of each operation).

    From the tangential components, ``(x^2 + y^2) / z^2``, which is accurate near
    the normal, with ``z`` clamped like the geometry's cosines."""

    def compute():
        out = np.empty((2, geometry.m))
        for row, w, cos in ((0, geometry.wi, geometry.cos_i), (1, geometry.wo, geometry.cos_o)):
            out[row] = w[:, 0] ** 2
            out[row] += w[:, 1] ** 2
            out[row] /= cos
            out[row] /= cos
        return out

    return geometry.cached("renderers.tan2", compute)


def _cos2_phi(geometry: Geometry, which: str) -> np.ndarray:
    """``cos^2`` of the azimuth of L or V: a row of :func:`_cos2_phi_both`."""
    return _cos2_phi_both(geometry)[0 if which == "i" else 1]


def _cos2_phi_both(geometry: Geometry) -> np.ndarray:
    """``cos^2`` of the azimuths of L and V, stacked (2, M); 1/2 along the normal,
    where ``tan^2 = 0`` makes ``G1 = 1`` whatever the azimuth."""

    def compute():
        out = np.full((2, geometry.m), 0.5)
        for row, w in ((0, geometry.wi), (1, geometry.wo)):
            s2 = w[:, 0] ** 2 + w[:, 1] ** 2
            ok = s2 > 1e-300
            out[row, ok] = w[ok, 0] ** 2 / s2[ok]
        return out

    return geometry.cached("renderers.cos2_phi", compute)


def _tan2_axes_h(geometry: Geometry) -> tuple[np.ndarray, np.ndarray]:
    """``(H.T/N.H)^2`` and ``(H.B/N.H)^2``: ``tan^2(theta_h)`` times ``cos^2`` and
    ``sin^2`` of its azimuth, from H's components (no ``cos^2 - 1`` to cancel)."""

    def compute():
        h, inv_c2 = geometry.half, 1.0 / geometry.cos_h**2
        return h[:, 0] ** 2 * inv_c2, h[:, 1] ** 2 * inv_c2

    return geometry.cached("renderers.tan2_axes_h", compute)


# ----------------------------------------------------------------- lobes
def _d_anisotropic(geometry: Geometry, distribution: str, alpha_u: float, alpha_v: float):
    """The anisotropic ``D`` of :func:`~brdffit.models.shared.beckmann_d_anisotropic`
    and :func:`~brdffit.models.shared.ggx_d_anisotropic` (Heitz 2014, section 5.4),
    its ``tan^2 (cos^2 phi/alpha_u^2 + sin^2 phi/alpha_v^2)`` summed from
    :func:`_tan2_axes_h`: two positive terms. (Those functions' ``cos^2 phi (1/alpha_u^2
    - 1/alpha_v^2) + 1/alpha_v^2`` cancels: measured, exponents of 200-600 wrong by
    3e-11 at alpha_v = 0.003.)"""
    along_t, along_b = _tan2_axes_h(geometry)
    # not in place: alpha_u and alpha_v may be (W, 1) arrays of walkers, or one of them
    e = along_t * (1.0 / (alpha_u * alpha_u)) + along_b * (1.0 / (alpha_v * alpha_v))
    if distribution == "ggx":
        e += 1.0
        e *= geometry.cos_h
        e *= geometry.cos_h
        e *= e
        return np.divide(1.0 / (np.pi * alpha_u * alpha_v), e, out=e)
    np.negative(e, out=e)
    np.exp(e, out=e)
    for _ in range(4):
        e /= geometry.cos_h
    e *= 1.0 / (np.pi * alpha_u * alpha_v)
    return e


def _finish(geometry: Geometry, lobe, g1, alpha2_i, alpha2_o, f0: float) -> np.ndarray:
    """``lobe * G1(L) G1(V) F / (4 N.L N.V)``, in place on ``lobe`` (which holds D).

    ``alpha2_i`` and ``alpha2_o`` (the roughness^2 seen along L and V) may be one
    (2, M) array with ``alpha2_o`` None, or one number for both: then ``G1`` of L and
    V is one call on the stacked ``tan^2`` (:func:`_tan2_both`), the same values in
    half the numpy calls (most of a small fit's evaluation)."""
    if alpha2_o is None or (alpha2_o is alpha2_i and np.ndim(alpha2_i) == 0):
        g_i, g_o = g1(_tan2_both(geometry), alpha2_i)
    else:  # roughness arrays of walkers (W, 1)
        t_i, t_o = _tan2(geometry, "i"), _tan2(geometry, "o")
        if g1 is smith.smith_g1:
            g_i, g_o = _stacked_g1(g1, t_i, t_o, alpha2_i, alpha2_o)
        else:
            g_i, g_o = g1(t_i, alpha2_i), g1(t_o, alpha2_o)
    lobe *= g_i
    lobe *= g_o
    lobe *= inv_4_cos(geometry)
    lobe *= schlick_fresnel(geometry, f0)
    return lobe


def _stacked_g1(g1, t_i, t_o, alpha2_i, alpha2_o):
    """``g1`` of L and of V in one call on both stacked: the same values, half the
    numpy calls. For Beckmann's rational ``G1`` (28 calls, most of a small fit's
    evaluation); GGX's few cost less than the stacking (measured)."""
    tan2 = np.empty((2, *np.broadcast_shapes(t_i.shape, np.shape(alpha2_i))))
    tan2[0], tan2[1] = t_i, t_o
    if alpha2_o is not alpha2_i:
        alpha2_i = np.stack(np.broadcast_arrays(alpha2_i, alpha2_o))
    return g1(tan2, alpha2_i)


def isotropic_lobe(geometry: Geometry, distribution: str, alpha: float, f0: float):
    """``F D G1(L) G1(V) / (4 N.L N.V)`` for ``distribution`` "ggx" or "beckmann"."""
    d_iso, _, g1 = _DISTRIBUTIONS[distribution]
    alpha2 = alpha * alpha
    lobe = d_iso(geometry.tan2_h, geometry.cos_h, alpha2)
    return _finish(geometry, lobe, g1, alpha2, alpha2, f0)


def anisotropic_lobe(
    geometry: Geometry, distribution: str, alpha_u: float, alpha_v: float, f0: float
) -> np.ndarray:
    """As :func:`isotropic_lobe` with ``alpha_u`` along T and ``alpha_v`` along B;
    ``G1`` uses the roughness projected on the azimuth of each direction."""
    g1 = _DISTRIBUTIONS[distribution][2]
    lobe = _d_anisotropic(geometry, distribution, alpha_u, alpha_v)
    if np.ndim(alpha_u) == 0 and np.ndim(alpha_v) == 0:  # both directions at once
        alpha2 = projected_alpha2(_cos2_phi_both(geometry), alpha_u, alpha_v)
        return _finish(geometry, lobe, g1, alpha2, None, f0)
    alpha2_i = projected_alpha2(_cos2_phi(geometry, "i"), alpha_u, alpha_v)
    alpha2_o = projected_alpha2(_cos2_phi(geometry, "o"), alpha_u, alpha_v)
    return _finish(geometry, lobe, g1, alpha2_i, alpha2_o, f0)


def ggx_lobe(geometry: Geometry, alpha: float, f0: float) -> np.ndarray:
    return isotropic_lobe(geometry, "ggx", alpha, f0)


def beckmann_lobe(geometry: Geometry, alpha: float, f0: float) -> np.ndarray:
    return isotropic_lobe(geometry, "beckmann", alpha, f0)


# ----------------------------------------------------------------- models
_GGX_FORMULA = (
    "``D = 1 / (pi alpha^2 cos^4 (1 + tan^2/alpha^2)^2)`` (GGX, Trowbridge-Reitz), "
    "``G1(v) = 2 / (1 + sqrt(1 + alpha^2 tan^2 theta_v))``"
)
_GGX_REFERENCE = (
    "B. Walter, S. R. Marschner, H. Li and K. E. Torrance, Microfacet models for "
    "refraction through rough surfaces, EGSR 2007 (GGX D eq. 33, G1 eq. 34)"
)
_BECKMANN_FORMULA = (
    "``D = exp(-tan^2/alpha^2) / (pi alpha^2 cos^4)``, "
    "``G1(v) = 1 / (1 + Lambda(a))``, ``a = 1/(alpha tan theta_v)``, "
    "``Lambda = (erf(a) - 1)/2 + exp(-a^2)/(2 a sqrt(pi))`` (Smith's exact masking, "
    "evaluated as a rational function of ``a`` within 2e-8 of it, brdffit.kernels.smith; "
    "not the 1e-3 approximation Mitsuba uses)"
)
_BECKMANN_REFERENCE = (
    "P. Beckmann and A. Spizzichino, The scattering of electromagnetic waves from "
    "rough surfaces, 1963; B. Walter et al., Microfacet models for refraction "
    "through rough surfaces, EGSR 2007"
)
_FORMULAS = {
    "ggx": (_GGX_FORMULA, _GGX_REFERENCE),
    "beckmann": (_BECKMANN_FORMULA, _BECKMANN_REFERENCE),
}

#: What each width parameter is, and the renderers' names for it (issue 17).
_GGX_RENDERERS = (
    "Renderers: Mitsuba 3 alpha = alpha; glTF roughnessFactor, Disney/Blender Principled "
    "Roughness and OpenPBR specular_roughness = sqrt(alpha); pbrt-v4 roughness = alpha "
    "with remaproughness false, alpha^2 with true (its default)"
)
_BECKMANN_RENDERERS = (
    "Renderers: Mitsuba 3 roughconductor/roughplastic with distribution 'beckmann' take "
    "this alpha; glTF, Disney/Blender Principled, OpenPBR and pbrt-v4 use GGX, whose alpha "
    "is another width (no exact mapping: fit ggx for them)"
)
_ALPHA_DOC = {
    "ggx": "GGX (Trowbridge-Reitz) width alpha of D (Walter et al. 2007, eq. 33); not an "
    "rms slope: GGX slopes have no finite variance. " + _GGX_RENDERERS,
    "beckmann": "Beckmann width alpha of D = exp(-tan^2/alpha^2) / (pi alpha^2 cos^4): the "
    "rms slope magnitude, sqrt(2) x the rms slope along any one direction. " + _BECKMANN_RENDERERS,
    "ggx_u": "GGX width alpha_u along the tangent T (Heitz 2014, section 5.4); not an rms "
    "slope. Renderers: Mitsuba 3 alpha_u; pbrt-v4 uroughness = alpha_u (remaproughness "
    "false) or alpha_u^2 (true); Disney/Blender Principled: roughness^2 = sqrt(alpha_u "
    "alpha_v), anisotropic sets the ratio; glTF KHR_materials_anisotropy: alpha_v = "
    "roughness^2, alpha_u = alpha_v + (1 - alpha_v) anisotropyStrength^2",
    "ggx_v": "GGX width alpha_v along the bitangent B; not an rms slope. Renderers: "
    "Mitsuba 3 alpha_v; pbrt-v4 vroughness = alpha_v (remaproughness false) or alpha_v^2 "
    "(true); glTF: alpha_v = roughness^2 of roughnessFactor (see alpha_u)",
    "beckmann_u": "Beckmann width along the tangent T: sqrt(2) x the rms slope along T. "
    + _BECKMANN_RENDERERS.replace("this alpha", "it as alpha_u"),
    "beckmann_v": "Beckmann width along the bitangent B: sqrt(2) x the rms slope along B. "
    + _BECKMANN_RENDERERS.replace("this alpha", "it as alpha_v"),
}

_ANISOTROPIC_NOTE = """
Anisotropic: in D, ``tan^2/alpha^2`` becomes ``tan^2 (cos^2 phi_h/alpha_u^2 +
sin^2 phi_h/alpha_v^2)`` and ``alpha^2`` in the normalisation ``alpha_u alpha_v``;
in ``G1(v)``, ``alpha^2`` becomes ``alpha_u^2 cos^2 phi_v + alpha_v^2 sin^2 phi_v``
(Heitz 2014, JCGT 3(2), section 5.4). ``alpha_u`` acts along T, ``alpha_v``
along B; with ``alpha_u = alpha_v`` the model equals its isotropic form.
"""

_COMMON_NOTE = """
``f = kd/pi + ks F(V.H) D G1(L) G1(V) / (4 (N.L)(N.V))``, Schlick's
``F = f0 + (1 - f0)(1 - V.H)^5``. ``physical`` (microfacet theory), ``cosine``
(``tan^2`` and azimuths from dot products, no arccos), ``material`` (Fresnel).
With ``f0 = 1``, ``kd = 0``, ``ks = 1`` it equals Mitsuba 3's ``roughconductor``
with a perfect conductor divided by ``cos(theta_o)``.
"""


def _isotropic_model(distribution: str) -> Model:
    formula, reference = _FORMULAS[distribution]

    def design(geometry: Geometry, shape) -> Design:
        lobe = isotropic_lobe(geometry, distribution, shape["alpha"], shape["f0"])
        return Design((INV_PI, lobe))

    return Model(
        name=distribution,
        params=(*diffuse_params(), roughness("alpha", doc=_ALPHA_DOC[distribution]), f0_param()),
        classification=ISOTROPIC,
        reference=reference,
        design=design,
        doc=f"Isotropic {distribution} microfacet model with {_SHADOWING[distribution]}.\n"
        f"{_COMMON_NOTE}\n{formula}.\n{_FLOAT32_NOTE.get(distribution, '')}",
    )


_SHADOWING = {
    "ggx": "exact Smith shadowing",
    "beckmann": "Smith shadowing (G1 within 2e-8 relative of the exact one)",
}
#: The note of the models whose compiled loop reads some inputs in float32 (their
#: bounds: brdffit.kernels.inputs.F32_ERROR, tested against these notes).
FLOAT32 = (
    "The compiled kernel (numba, 10,000 pairs or more) reads some parameter-free "
    "inputs in float32: within {error} relative of the float64 form "
    "(brdffit.kernels.inputs).\n"
)
_FLOAT32_NOTE = dict.fromkeys(
    ("beckmann", "ggx_anisotropic", "beckmann_anisotropic"), FLOAT32.format(error="2e-7")
)


def _anisotropic_model(distribution: str) -> Model:
    formula, reference = _FORMULAS[distribution]

    def design(geometry: Geometry, shape) -> Design:
        lobe = anisotropic_lobe(
            geometry, distribution, shape["alpha_u"], shape["alpha_v"], shape["f0"]
        )
        return Design((INV_PI, lobe))

    return Model(
        name=f"{distribution}_anisotropic",
        params=(
            *diffuse_params(),
            roughness("alpha_u", doc=_ALPHA_DOC[distribution + "_u"]),
            roughness("alpha_v", 0.3, doc=_ALPHA_DOC[distribution + "_v"]),
            f0_param(),
        ),
        classification=ANISOTROPIC,
        reference=reference + "; E. Heitz, Understanding the masking-shadowing function "
        "in microfacet-based BRDFs, JCGT 3(2), 2014",
        design=design,
        doc=f"Anisotropic {distribution} microfacet model with {_SHADOWING[distribution]}.\n"
        f"{_COMMON_NOTE}\nIsotropic form: {formula}.\n{_ANISOTROPIC_NOTE}"
        f"{_FLOAT32_NOTE.get(distribution + '_anisotropic', '')}",
    )


GGX = _isotropic_model("ggx")
BECKMANN = _isotropic_model("beckmann")
GGX_ANISOTROPIC = _anisotropic_model("ggx")
BECKMANN_ANISOTROPIC = _anisotropic_model("beckmann")

MODELS = (GGX, BECKMANN, GGX_ANISOTROPIC, BECKMANN_ANISOTROPIC)
