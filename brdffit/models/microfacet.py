"""Isotropic physical models of the paper: Ward, Torrance-Sparrow, Cook-Torrance.

All of them are ``kd / pi + ks * lobe`` and share the pieces of
:mod:`brdffit.models.shared` (Fresnel, D, shadowing). Every parameter-free factor
(V-cavity shadowing, ``1/(4 N.L N.V)``, Ward's ``1/sqrt(N.L N.V)``,
``theta_h^2``, Schlick's ``(1 - V.H)^5``) is cached on the geometry, so an
evaluation does only the parameter-dependent work, in place.

The microfacet models of today's renderers (GGX, Beckmann with Smith shadowing)
are in :mod:`brdffit.models.renderers`.
"""

from __future__ import annotations

import math

import numpy as np

from ..data.geometry import Geometry
from .base import INV_PI, Classification, Design, Model
from .params import diffuse_params, eta_param, f0_param, roughness
from .shared import fresnel_dielectric, schlick_weight, vcavity_g

__all__ = [
    "MODELS",
    "cook_torrance_lobe",
    "inv_4_cos",
    "schlick_fresnel",
    "torrance_sparrow_lobe",
    "ward_lobe",
]

PHYSICAL_COSINE = Classification("physical", "isotropic", "cosine", "material")
PHYSICAL_ANGLE = Classification("physical", "isotropic", "angle", "material")
WARD_CLASS = Classification("physical", "isotropic", "cosine", "light")


# ------------------------------------------------- cached parameter-free terms
def inv_4_cos(geometry: Geometry) -> np.ndarray:
    """``1 / (4 (N.L)(N.V))``, the microfacet Jacobian factor; cached."""

    def compute():
        out = np.multiply(geometry.cos_i, geometry.cos_o)
        out *= 4.0
        return np.divide(1.0, out, out=out)

    return geometry.cached("microfacet.inv_4_cos", compute)


def _vcavity_over_4(geometry: Geometry) -> np.ndarray:
    """``G / (4 (N.L)(N.V))`` with the V-cavity ``G``; cached."""
    return geometry.cached(
        "microfacet.vcavity_over_4",
        lambda: (
            vcavity_g(geometry.cos_h, geometry.cos_i, geometry.cos_o, geometry.cos_d)
            * inv_4_cos(geometry)
        ),
    )


def _cook_torrance_d_factor(geometry: Geometry) -> np.ndarray:
    """``G / (4 (N.L)(N.V) pi cos^4 theta_h)``: all of Cook-Torrance but
    ``exp(-tan^2/m^2) / m^2`` and ``F``; cached."""

    def compute():
        c2 = geometry.cos_h**2
        return _vcavity_over_4(geometry) * (INV_PI / (c2 * c2))

    return geometry.cached("microfacet.cook_torrance_d_factor", compute)


def _ward_factor(geometry: Geometry) -> np.ndarray:
    """``1 / (4 pi sqrt((N.L)(N.V)))``; cached."""

    def compute():
        out = np.multiply(geometry.cos_i, geometry.cos_o)
        np.sqrt(out, out=out)
        out *= 4.0 * math.pi
        return np.divide(1.0, out, out=out)

    return geometry.cached("microfacet.ward_factor", compute)


def _schlick_weight(geometry: Geometry) -> np.ndarray:
    """``(1 - V.H)^5``; cached, so Schlick's Fresnel costs two operations."""
    return geometry.cached("microfacet.schlick_weight", lambda: schlick_weight(geometry.cos_d))


def schlick_fresnel(geometry: Geometry, f0: float) -> np.ndarray:
    """Schlick's ``F = f0 + (1 - f0)(1 - V.H)^5`` from the cached weight."""
    fresnel = np.multiply(_schlick_weight(geometry), 1.0 - f0)
    fresnel += f0
    return fresnel


# ------------------------------------------------------------------- Ward
def ward_lobe(geometry: Geometry, alpha: float) -> np.ndarray:
    """``exp(-tan^2(theta_h)/alpha^2) / (4 pi alpha^2 sqrt((N.L)(N.V)))``."""
    inv_a2 = 1.0 / (alpha * alpha)
    lobe = np.multiply(geometry.tan2_h, -inv_a2)
    np.exp(lobe, out=lobe)
    lobe *= _ward_factor(geometry)
    lobe *= inv_a2
    return lobe


def _ward_design(geometry: Geometry, shape) -> Design:
    return Design((INV_PI, ward_lobe(geometry, shape["alpha"])))


#: The renderers' names for a Beckmann-type width (parameter docs, issue 17).
_BECKMANN_RENDERERS = (
    "Renderers: Mitsuba 3 roughconductor/roughplastic with distribution 'beckmann' take "
    "this alpha (same D); glTF, Disney/Blender Principled, OpenPBR and pbrt-v4 use GGX, "
    "whose alpha is another width: no exact mapping (fit ggx for them)"
)
_BECKMANN_M = (
    "Beckmann width m of D = exp(-tan^2/m^2) / (pi m^2 cos^4) (Cook-Torrance's m): the rms "
    "slope magnitude, sqrt(2) x the rms slope along any one direction. " + _BECKMANN_RENDERERS
)

WARD = Model(
    name="ward",
    params=(
        *diffuse_params(),
        roughness(
            "alpha",
            doc="Ward 1992 width alpha of exp(-tan^2(theta_h)/alpha^2): the slope "
            "Gaussian of a Beckmann alpha (rms slope magnitude alpha, sqrt(2) x the "
            "rms slope along one direction). " + _BECKMANN_RENDERERS,
        ),
    ),
    classification=WARD_CLASS,
    reference="G. J. Ward, Measuring and modeling anisotropic reflection, SIGGRAPH 1992 "
    "(Computer Graphics 26(2), 265-272)",
    design=_ward_design,
    doc="""Ward's isotropic Gaussian lobe.

``f = kd/pi + ks exp(-tan^2(theta_h)/alpha^2) / (4 pi alpha^2 sqrt((N.L)(N.V)))``.

Classification. ``origin = physical``: MODELS.md separates models "fitted to look
right" from models "derived from a surface model (microfacets ...)". Ward's
exponential is the Beckmann distribution of facet slopes with rms slope alpha,
and the classification paper presents the model that way ("if the mean deviation
of the facets' orientation is m, the BRDF of such a surface is ...", grouping it
with Torrance-Sparrow and Cook-Torrance). The rest is not derived: the Fresnel
and shadowing-masking factors of a microfacet model are replaced by the
normalisation ``1/sqrt((N.L)(N.V))``, chosen to fit Ward's measurements and to
integrate in closed form, which is why later authors call the model empirical
(Dür 2006, "An improved normalization for the Ward reflectance model"). The
surface model decides; ``ward_anisotropic`` is classified the same way. That it
is reciprocal and nearly energy conserving is a measured property, not its
origin (MODELS.md). ``highlight = light``: without a Fresnel factor nothing makes
the highlight's colour depend on the material or the angle; as in Phong and
Blinn it is the colour of ks. ``operand = cosine``: ``tan^2(theta_h)`` comes from dot
products, no arccos.
""",
)


# ------------------------------------------------------- Torrance-Sparrow
def _theta_h2(geometry: Geometry) -> np.ndarray:
    return geometry.cached("microfacet.theta_h2", lambda: geometry.theta_h**2)


def torrance_sparrow_lobe(geometry: Geometry, m: float, fresnel: np.ndarray) -> np.ndarray:
    """``F D G / (4 (N.L)(N.V))`` with ``D = exp(-(theta_h/m)^2)``, given ``F``."""
    lobe = np.multiply(_theta_h2(geometry), -1.0 / (m * m))
    np.exp(lobe, out=lobe)
    lobe *= _vcavity_over_4(geometry)
    lobe *= fresnel
    return lobe


def _torrance_sparrow_design(geometry: Geometry, shape) -> Design:
    fresnel = fresnel_dielectric(geometry.cos_d, shape["eta"])
    return Design((INV_PI, torrance_sparrow_lobe(geometry, shape["m"], fresnel)))


TORRANCE_SPARROW = Model(
    name="torrance_sparrow",
    params=(
        # D is unnormalised: its integral (about pi m^2 for small m) goes into ks,
        # so ks reaches 1/(pi m^2) = 3e5 for an albedo of 1 at m = 0.001.
        *diffuse_params(ks_upper=1e7, ks_unit="1/sr"),
        roughness(
            "m",
            doc="Torrance-Sparrow width m (radians) of exp(-(theta_h/m)^2): an angle, "
            "not a slope; near a Beckmann alpha for small m (tan theta_h ~ theta_h). "
            "Renderers: no renderer parameter is this width; the nearest is a Beckmann "
            "alpha (Mitsuba 3 distribution 'beckmann'); fit beckmann or ggx for them",
        ),
        eta_param(),
    ),
    classification=PHYSICAL_ANGLE,
    reference="K. E. Torrance and E. M. Sparrow, Theory for off-specular reflection from "
    "roughened surfaces, JOSA 57(9), 1105-1114, 1967",
    design=_torrance_sparrow_design,
    doc="""Torrance-Sparrow: V-groove microfacets with a Gaussian in the angle theta_h.

``f = kd/pi + ks F(V.H) D G / (4 (N.L)(N.V))``, ``D = exp(-(theta_h/m)^2)``,
exact dielectric Fresnel at ``c = V.H``, V-cavity ``G``.

D is unnormalised (MODELS.md): Torrance and Sparrow write ``D = b exp(-c^2 a^2)``
with ``a`` the facet angle and ``b`` a constant; ``b`` is absorbed in ks, which
therefore has units of 1/sr and spans large values for small m. The paper writes
``c_1 exp(-gamma/m)^2``: the square belongs to the ratio, ``exp(-(gamma/m)^2)``.
``operand = angle``: D needs ``theta_h = acos(N.H)`` as an angle.
""",
)


# ----------------------------------------------------------- Cook-Torrance
def cook_torrance_lobe(geometry: Geometry, m: float, fresnel: np.ndarray) -> np.ndarray:
    """``F D G / (4 N.L N.V)`` with Beckmann ``D`` and V-cavity ``G``, given ``F``."""
    inv_m2 = 1.0 / (m * m)
    lobe = np.multiply(geometry.tan2_h, -inv_m2)
    np.exp(lobe, out=lobe)
    lobe *= _cook_torrance_d_factor(geometry)
    lobe *= fresnel
    lobe *= inv_m2
    return lobe


def _cook_torrance_design(geometry: Geometry, shape) -> Design:
    fresnel = fresnel_dielectric(geometry.cos_d, shape["eta"])
    return Design((INV_PI, cook_torrance_lobe(geometry, shape["m"], fresnel)))


def _cook_torrance_schlick_design(geometry: Geometry, shape) -> Design:
    fresnel = schlick_fresnel(geometry, shape["f0"])
    return Design((INV_PI, cook_torrance_lobe(geometry, shape["m"], fresnel)))


_COOK_TORRANCE_REFERENCE = (
    "R. L. Cook and K. E. Torrance, A reflectance model for computer graphics, "
    "SIGGRAPH 1981 / ACM TOG 1(1), 7-24, 1982"
)
_COOK_TORRANCE_DOC = """

``f = kd/pi + ks F(V.H) D G / (4 (N.L)(N.V))``,
``D = exp(-tan^2(theta_h)/m^2) / (pi m^2 cos^4(theta_h))`` (Beckmann), V-cavity
``G``. The paper writes ``F/pi D G / ((N.L)(N.V))`` with D lacking its 1/pi;
that differs by a constant absorbed in ks. The normalised form is used so that
a white conductor has ks near 1 (MODELS.md). ``operand = cosine``:
``tan^2(theta_h)`` and ``cos^4(theta_h)`` come from ``N.H``, no arccos.
"""

COOK_TORRANCE = Model(
    name="cook_torrance",
    params=(*diffuse_params(), roughness("m", doc=_BECKMANN_M), eta_param()),
    classification=PHYSICAL_COSINE,
    reference=_COOK_TORRANCE_REFERENCE,
    design=_cook_torrance_design,
    doc="Cook-Torrance with Beckmann D and exact dielectric Fresnel of index eta."
    + _COOK_TORRANCE_DOC,
)

COOK_TORRANCE_SCHLICK = Model(
    name="cook_torrance_schlick",
    params=(*diffuse_params(), roughness("m", doc=_BECKMANN_M), f0_param()),
    classification=PHYSICAL_COSINE,
    reference=_COOK_TORRANCE_REFERENCE + "; C. Schlick, An inexpensive BRDF model for "
    "physically-based rendering, Computer Graphics Forum 13(3), 1994",
    design=_cook_torrance_schlick_design,
    doc="Cook-Torrance with Beckmann D and Schlick's Fresnel "
    "``F = f0 + (1 - f0)(1 - V.H)^5``." + _COOK_TORRANCE_DOC,
)

MODELS = (WARD, TORRANCE_SPARROW, COOK_TORRANCE, COOK_TORRANCE_SCHLICK)
