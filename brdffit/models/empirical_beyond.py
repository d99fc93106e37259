"""Isotropic models MODELS.md lists beyond the classification paper: one isotropic
Lafortune generalised cosine lobe and the qualitative Oren-Nayar rough diffuse model.

Each lobe is a plain vectorised function of a prepared
:class:`~brdffit.data.geometry.Geometry` and its shape parameters (MODELS.md);
what depends on the directions only is cached on the geometry. Both formulas are
symmetric in ``L`` and ``V``, so both models are flagged reciprocal;
``tests/models/test_model_invariants.py`` measures it. The paper's own isotropic
empirical lobes live in :mod:`brdffit.models.empirical`.
"""

from __future__ import annotations

import math

import numpy as np

from ..data.geometry import Geometry
from .base import INV_PI, Classification, Design, Model, Param, diffuse_plus_lobe
from .empirical import EMPIRICAL_COSINE
from .params import KD, exponent

__all__ = ["MODELS"]

PHYSICAL_COSINE_LIGHT = Classification("physical", "isotropic", "cosine", "light")


def _dot_xy(geometry: Geometry) -> np.ndarray:
    """``Lx Vx + Ly Vy``, the tangential part of ``L.V``."""
    return geometry.cached(
        "dot_xy",
        lambda: geometry.wi[:, 0] * geometry.wo[:, 0] + geometry.wi[:, 1] * geometry.wo[:, 1],
    )


# ---------------------------------------------------------------- Lafortune
def lafortune_lobe(geometry: Geometry, cxy: float, n: float) -> np.ndarray:
    """``max(0, cxy (Lx Vx + Ly Vy) + Lz Vz)^n``."""
    dot_z = geometry.cached("dot_z", lambda: geometry.wi[:, 2] * geometry.wo[:, 2])
    base = np.multiply(_dot_xy(geometry), cxy)
    base += dot_z
    # np.power beats exp(n ln x) here: ln x is not reusable, cxy changes the base.
    np.maximum(base, 0.0, out=base)
    return np.power(base, n, out=base)


LAFORTUNE = diffuse_plus_lobe(
    "lafortune",
    lafortune_lobe,
    (
        Param("cxy", -1.0, 1.0, -1.0, unit="1", doc="Cx = Cy over Cz: -1 Phong, +1 retro"),
        exponent(doc="exponent of the generalised cosine"),
    ),
    EMPIRICAL_COSINE,
    "E. P. F. Lafortune, S.-C. Foo, K. E. Torrance, D. P. Greenberg, Non-linear "
    "approximation of reflectance functions, SIGGRAPH 1997",
    """One isotropic generalised cosine lobe:
``f = kd / pi + ks max(0, cxy (Lx Vx + Ly Vy) + Lz Vz)^n``.

Lafortune's lobe is ``(Cx Lx Vx + Cy Ly Vy + Cz Lz Vz)^n``; isotropy needs
``Cx = Cy``. Scaling the vector C by s scales the lobe by ``s^n``, which ks
absorbs exactly, so only the ratio ``cxy = Cx / Cz`` is identifiable: Cz is
fixed to 1. ``cxy = -1`` gives ``-(Lx Vx + Ly Vy) + Lz Vz = R.V`` (the mirror
of L is ``(-Lx, -Ly, Lz)``), i.e. Phong; ``cxy = 0`` a lobe about the normal;
``cxy > 0`` retro-reflection. With ``|cxy| <= 1`` the base is at most 1
(Cauchy-Schwarz), so the peak is 1 and ``base^n`` cannot overflow.

Limitation: lobes with ``|Cx| > Cz`` (off-specular, brighter towards grazing)
are out of range. The three-lobe fit of light-blue house paint published by
Cornell with its data (MDL chunk ``blLfrtn``) has ``Cx/Cz`` = 1.13, -1.46 and
-19.5, all outside [-1, 1]; wider bounds would need the base rescaled by
``max(1, |cxy|)`` (a constant that ks absorbs) to keep the peak at 1.
""",
)


# ---------------------------------------------------------------- Oren-Nayar
def oren_nayar_term(geometry: Geometry) -> np.ndarray:
    """``max(0, cos(phi_i - phi_o)) sin(alpha) tan(beta)`` from dot products.

    With ``alpha = max(theta_i, theta_o)``, ``beta = min``:
    ``sin(alpha) sin(beta) = sin(theta_i) sin(theta_o)`` and
    ``cos(phi_i - phi_o) sin(theta_i) sin(theta_o) = Lx Vx + Ly Vy``, so the term is
    ``max(0, Lx Vx + Ly Vy) / max(N.L, N.V)``: no angle, no square root, and no
    0/0 at normal incidence, where the azimuth is undefined.
    """
    return geometry.cached(
        "oren_nayar_term",
        lambda: np.maximum(_dot_xy(geometry), 0.0) / np.maximum(geometry.cos_i, geometry.cos_o),
    )


def _oren_nayar_design(geometry: Geometry, shape) -> Design:
    s2 = shape["sigma"] ** 2
    a = 1.0 - 0.5 * s2 / (s2 + 0.33)
    b = 0.45 * s2 / (s2 + 0.09)
    column = oren_nayar_term(geometry) * (b * INV_PI)
    column += a * INV_PI
    return Design((column,))


OREN_NAYAR = Model(
    name="oren_nayar",
    params=(
        KD,
        Param(
            "sigma",
            0.0,
            math.pi / 2,
            0.3,
            unit="rad",
            doc="Oren-Nayar 1994 sigma: standard deviation (radians) "
            "of the facet slope angle, 0 is Lambert; not a microfacet alpha and not glTF/Disney "
            "roughness. Renderers: their Oren-Nayar roughness inputs (Blender Diffuse BSDF, "
            "Mitsuba) are other variants: no exact mapping",
        ),
    ),
    classification=PHYSICAL_COSINE_LIGHT,
    reference="M. Oren and S. K. Nayar, Generalization of Lambert's reflectance model, "
    "SIGGRAPH 1994 (the qualitative model)",
    design=_oren_nayar_design,
    doc="""Qualitative Oren-Nayar:
``f = kd/pi (A + B max(0, cos(phi_i - phi_o)) sin(alpha) tan(beta))``,
``A = 1 - 0.5 s^2/(s^2 + 0.33)``, ``B = 0.45 s^2/(s^2 + 0.09)``, ``s = sigma`` (radians),
``alpha = max(theta_i, theta_o)``, ``beta = min(theta_i, theta_o)``.

Checked against the form of Oren and Nayar 1994 as implemented by pbrt-v3
(``OrenNayar``, sigma converted to radians) and Mitsuba 0.6 (``roughdiffuse``,
fast approximation), which agree with this formula; it drops the full model's
``tan((alpha + beta)/2)`` term and the ``rho^2`` interreflection term.
sigma = 0 gives Lambert. Evaluated as ``max(0, Lx Vx + Ly Vy)/max(N.L, N.V)``
(see :func:`oren_nayar_term`); it grows without bound when both directions
graze, but ``f cos(theta_i)`` stays below ``kd/pi (A + B)``.

Classification: ``physical``, although it lives with the empirical models: it
is derived from a surface of Lambertian V-cavities with Gaussian slopes
(Torrance-Sparrow geometry, masking and shadowing); only the constants of A and B
were fitted to that physical model, not to measurements. ``cosine``: the
angles appear only through sines, tangents and cosines, all algebraic in dot
products (no arccos; see above). ``light``: there is no Fresnel term; the
wavelength enters only through kd, as for Lambert.
""",
)


MODELS = (
    LAFORTUNE,
    OREN_NAYAR,
)
