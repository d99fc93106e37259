"""Isotropic empirical models of the classification paper's table (MODELS.md):
Lambert, the cosine-power lobes Phong and Blinn (and their normalised variants),
Schlick's and Romanyuk's rational replacements, and the angle-operand Gaussian and
Blake lobes. Lafortune and Oren-Nayar, which MODELS.md lists beyond the paper,
live in :mod:`brdffit.models.empirical_beyond`.

Each lobe is a plain vectorised function of a prepared
:class:`~brdffit.data.geometry.Geometry` and its shape parameters; the model is
``kd / pi + ks * lobe`` (MODELS.md). What depends on the directions only
(``ln(N.H)``, ``ln(R.V)``, ``1 - N.H``, ``theta_h^2``...) is cached on the geometry,
so an evaluation does only the arithmetic that involves a parameter, in place.

Every formula here is symmetric in ``L`` and ``V``, so every model is flagged
reciprocal; ``tests/models/test_model_invariants.py`` measures it.
"""

from __future__ import annotations

import math

import numpy as np

from ..data.geometry import Geometry
from .base import INV_PI, Classification, Design, Model, Param, diffuse_plus_lobe
from .params import KD, exponent

__all__ = ["MODELS", "blake_bounds", "exponent"]

EMPIRICAL_COSINE = Classification("empirical", "isotropic", "cosine", "light")
EMPIRICAL_ANGLE = Classification("empirical", "isotropic", "angle", "light")


def _power_from_log(log_base: np.ndarray, n: float) -> np.ndarray:
    """``base^n`` as ``exp(n ln base)`` in one new array; ``ln 0 = -inf`` gives 0."""
    out = np.multiply(log_base, n)
    return np.exp(out, out=out)


def _log_of_positive_part(x: np.ndarray) -> np.ndarray:
    """``ln(max(0, x))``; -inf where ``x <= 0``, which every power lobe maps to 0."""
    with np.errstate(divide="ignore"):
        return np.log(np.maximum(x, 0.0))


def _one_minus_cos_h(geometry: Geometry) -> np.ndarray:
    """``1 - N.H`` as ``sin^2(theta_h) / (1 + N.H)``: no cancellation near H = N."""
    return geometry.cached("one_minus_cos_h", lambda: geometry.sin2_h / (1.0 + geometry.cos_h))


# ----------------------------------------------------------------------- Lambert
def _lambert_design(geometry: Geometry, shape) -> Design:
    return Design((INV_PI,))


LAMBERT = Model(
    name="lambert",
    params=(KD,),
    classification=EMPIRICAL_COSINE,
    reference="J. H. Lambert, Photometria, 1760",
    design=_lambert_design,
    doc="""Lambert: ``f = kd / pi``.

The paper's ambient term ``Ia ka`` and distance attenuation ``1/(d + k)`` are
shading, not reflectance, and have no fit parameter (MODELS.md).
""",
)


# ------------------------------------------------------------ Phong and Blinn
def phong_lobe(geometry: Geometry, n: float) -> np.ndarray:
    """``max(0, R.V)^n`` with ``R = 2 (N.L) N - L``, as ``exp(n ln R.V)``."""
    log_cos_r = geometry.cached("log_cos_r", lambda: _log_of_positive_part(geometry.cos_r))
    return _power_from_log(log_cos_r, n)


def blinn_lobe(geometry: Geometry, n: float) -> np.ndarray:
    """``(N.H)^n``, evaluated as ``exp(n ln(N.H))`` on the prepared logarithm."""
    return _power_from_log(geometry.log_cos_h, n)


PHONG_REFERENCE = "B. T. Phong, Illumination for computer generated pictures, CACM 18(6), 1975"
BLINN_REFERENCE = (
    "J. F. Blinn, Models of light reflection for computer synthesized pictures, SIGGRAPH 1977"
)

PHONG = diffuse_plus_lobe(
    "phong",
    phong_lobe,
    (exponent(doc="Phong exponent of R.V"),),
    EMPIRICAL_COSINE,
    PHONG_REFERENCE,
    """Phong: ``f = kd / pi + ks max(0, R.V)^n``, ``R = 2 (N.L) N - L``.

Reciprocity: ``R.V = 2 (N.L)(N.V) - L.V`` is symmetric in L and V, so this
lobe, read as a BRDF, obeys Helmholtz reciprocity exactly (``reciprocal=True``;
the invariant tests find ``f(L, V) = f(V, L)`` bit for bit). The classic
non-reciprocity of "Phong" belongs to Phong's shading formula
``I_s = I ks cos^n(alpha)``, which has no ``cos(theta_i)``: a BRDF is radiance
per unit irradiance ``I cos(theta_i)``, so that formula read as a BRDF is
``ks (R.V)^n / (N.L)``, not symmetric (at n = 20 on random pairs, swapping L and
V changes it by up to 4x its peak). MODELS.md fixes the lobe without the division.
""",
)

BLINN = diffuse_plus_lobe(
    "blinn",
    blinn_lobe,
    (exponent(doc="Blinn exponent of N.H"),),
    EMPIRICAL_COSINE,
    BLINN_REFERENCE,
    """Blinn-Phong: ``f = kd / pi + ks (N.H)^n``.""",
)


NORMALIZED_KS_DOC = "specular albedo (energy of the normalised lobe at normal incidence)"


def _normalized(name, lobe, factor, reference: str, doc: str) -> Model:
    """``kd / pi + ks * factor(n) * lobe(n)``: the lobe scaled to unit energy."""

    def design(geometry: Geometry, shape) -> Design:
        n = shape["n"]
        column = lobe(geometry, n)
        column *= factor(n)
        return Design((INV_PI, column))

    return Model(
        name=name,
        params=(
            KD,
            Param("ks", 0.0, 10.0, 0.5, linear=True, unit="1", doc=NORMALIZED_KS_DOC),
            exponent(doc="exponent of the lobe"),
        ),
        classification=EMPIRICAL_COSINE,
        reference=reference,
        design=design,
        doc=doc,
    )


PHONG_NORMALIZED = _normalized(
    "phong_normalized",
    phong_lobe,
    lambda n: (n + 2.0) / (2.0 * math.pi),
    PHONG_REFERENCE + "; normalisation: R. R. Lewis, Making shaders more physically "
    "plausible, Computer Graphics Forum 13(2), 1994",
    """Energy-normalised Phong: ``f = kd / pi + ks (n + 2)/(2 pi) max(0, R.V)^n``.

The factor makes ``integral (n+2)/(2 pi) (R.V)^n cos(theta_o) dw_o = 1`` at
normal incidence, exactly for every n (there ``R.V = cos(theta_o)``), so ks is
the specular albedo there; away from the normal the horizon cuts the lobe and
the albedo is lower. Same lobe as ``phong``; only the scale of ks differs.
""",
)

BLINN_NORMALIZED = _normalized(
    "blinn_normalized",
    blinn_lobe,
    lambda n: (n + 8.0) / (8.0 * math.pi),
    BLINN_REFERENCE + "; normalisation: T. Akenine-Moller, E. Haines, N. Hoffman, "
    "Real-Time Rendering, 3rd ed., 2008, section 7.6",
    """Energy-normalised Blinn-Phong: ``f = kd / pi + ks (n + 8)/(8 pi) (N.H)^n``.

``(n + 8)/(8 pi)`` is the usual approximate normalisation. At normal incidence
the albedo of the normalised lobe is exactly
``n (n + 8) / ((n + 2)(n + 4))`` up to terms in ``2^(-n/2)``, i.e. about
``1 + 2/n``: ks is the specular albedo to within 2/n.
""",
)


# ------------------------------------------------- rational and angle lobes
def schlick_lobe(geometry: Geometry, n: float) -> np.ndarray:
    """``c / (n - n c + c)`` with ``c = N.H``, i.e. ``c / (n (1 - c) + c)``."""
    c = geometry.cos_h
    out = np.multiply(_one_minus_cos_h(geometry), n)
    out += c
    return np.divide(c, out, out=out)


def romanyuk_lobe(geometry: Geometry, n: float) -> np.ndarray:
    """``max(0, 1 + (7n/16)(c - 1))^2`` with ``c = N.H``, clamped before squaring."""
    out = np.multiply(_one_minus_cos_h(geometry), -7.0 * n / 16.0)
    out += 1.0
    np.maximum(out, 0.0, out=out)
    return np.square(out, out=out)


def gaussian_lobe(geometry: Geometry, n: float) -> np.ndarray:
    """``exp(-n theta_h^2 / 2)``."""
    half_theta2 = geometry.cached("half_theta_h2", lambda: 0.5 * geometry.theta_h**2)
    out = np.multiply(half_theta2, -n)
    return np.exp(out, out=out)


def blake_bounds(n: float) -> tuple[float, float]:
    """Blake's breakpoints ``a = (n + 5.6)/(n (0.09 n + 5.2))``, ``b = (n + 65)/(5 n + 31.7)``.

    ``a < b`` for every n in [1, 1e3] (a ~ 1/(0.09 n) falls below b ~ 0.2).
    """
    return (n + 5.6) / (n * (0.09 * n + 5.2)), (n + 65.0) / (5.0 * n + 31.7)


def blake_lobe(geometry: Geometry, n: float) -> np.ndarray:
    """Blake's piecewise quadratic in ``g = theta_h`` (MODELS.md):
    ``1 - g^2/(a b)`` for ``g <= a``, ``(g - b)^2 / (b (b - a))`` for ``a <= g <= b``,
    0 beyond. The tail is written ``max(0, b - g)^2 / (b (b - a))``, which is 0
    past b."""
    a, b = blake_bounds(n)
    g = geometry.theta_h
    out = np.subtract(b, g)
    np.maximum(out, 0.0, out=out)
    np.square(out, out=out)
    out *= 1.0 / (b * (b - a))
    core = geometry.cached("theta_h2", lambda: geometry.theta_h**2) * (-1.0 / (a * b))
    core += 1.0
    np.copyto(out, core, where=g <= a)
    return out


ROMANYUK_REFERENCE = (
    "O. N. Romanyuk, An efficient model for reproducing the specular component of "
    "colour, Problemy informatyzatsii ta upravlinnia 2(20), NAU, Kyiv, 2007, pp. 115-120"
)

SCHLICK = diffuse_plus_lobe(
    "schlick",
    schlick_lobe,
    (exponent(doc="Schlick's exponent-like sharpness"),),
    EMPIRICAL_COSINE,
    "C. Schlick, A fast alternative to Phong's specular model, Graphics Gems IV, "
    "Academic Press, 1994",
    """Schlick: ``f = kd / pi + ks c / (n - n c + c)``, ``c = N.H``.

A rational replacement of ``c^n`` (peak 1 at ``c = 1``; equals ``c`` at n = 1).
Up to the inflection point of ``c^n`` (``tan^2 g = 1/(n - 1)``) its relative
error stays within 10 %, as the paper says: measured 9.4 % at n = 2, rising to
``(2/3) e^(1/2) - 1 = 9.9 %`` as n grows. Beyond, its tail falls to zero far
more slowly than ``c^n``.
""",
)

ROMANYUK = diffuse_plus_lobe(
    "romanyuk",
    romanyuk_lobe,
    (exponent(doc="exponent of the cos^n lobe it approximates"),),
    EMPIRICAL_COSINE,
    ROMANYUK_REFERENCE,
    """Romanyuk: ``f = kd / pi + ks max(0, 1 + (7n/16)(c - 1))^2``, ``c = N.H``.

The paper writes ``((7n/16)(c - 1) + 1)^2``; without the clamp the square rises
again past the cut-off ``c = 1 - 16/(7n)``, so the base is clamped at 0 first
(MODELS.md): the lobe is exactly 0 beyond the cut-off.

The paper says its max absolute error against ``c^n`` up to the inflection
point is three times smaller than Schlick's. Measured: 2.6x at n = 5, 3.4x at
n = 10, 4.1x at n = 100, tending to 4.2x (at n = 2 it is worse than Schlick's).
""",
)

GAUSSIAN = diffuse_plus_lobe(
    "gaussian",
    gaussian_lobe,
    (exponent(doc="sharpness; matches (N.H)^n near the peak"),),
    EMPIRICAL_ANGLE,
    ROMANYUK_REFERENCE + " (the Gaussian distribution function it reviews)",
    """Gaussian: ``f = kd / pi + ks exp(-n theta_h^2 / 2)``, ``theta_h = angle(N, H)``.

The paper writes the angle as (H, L); the angle that makes a highlight centred
on the mirror direction is (N, H), which also makes the lobe agree with
``(N.H)^n ~ exp(-n theta_h^2 / 2)`` near the peak (MODELS.md). It needs the
angle itself (an arccos), hence operand ``angle``.
""",
)

BLAKE = diffuse_plus_lobe(
    "blake",
    blake_lobe,
    (exponent(upper=1e3, doc="exponent of the cos^n lobe it approximates"),),
    EMPIRICAL_ANGLE,
    "E. H. Blake, V. C. Disselkoen, A. A. Kuijk, Faster Phong shading, Computer "
    "Graphics Forum, 1991 (as cited by the classification paper)",
    """Blake: ``f = kd / pi + ks lobe(g)``, ``g = theta_h``, with
``a = (n + 5.6)/(n (0.09 n + 5.2))``, ``b = (n + 65)/(5 n + 31.7)`` and
``lobe = 1 - g^2/(a b)`` for ``g <= a``, ``(g - b)^2/(b (b - a))`` for
``a <= g <= b``, 0 for ``g >= b``.

The paper's case list is garbled (MODELS.md fixes it as above). The pieces
meet with equal value ``1 - a/b`` and slope ``-2/b`` at ``g = a``, and with
value and slope 0 at ``g = b``: the lobe is C1. n is limited to [1, 1e3]:
the breakpoints suit moderate exponents. Measured max absolute difference from
``cos^n(g)``: 0.05 at n = 1, 0.02 for n = 10-30, 0.04 at n = 100, 0.17 at
n = 300 and 0.39 at n = 1000 (b tends to 0.2 rad, far wider than ``cos^n``).
""",
)

MODELS = (
    LAMBERT,
    PHONG,
    PHONG_NORMALIZED,
    BLINN,
    BLINN_NORMALIZED,
    SCHLICK,
    ROMANYUK,
    GAUSSIAN,
    BLAKE,
)
