"""Anisotropic empirical highlight shapes of the classification paper (MODELS.md):
Heidrich-Seidel's fibre lobe, Ohara's ellipsoid, Wang's blended exponent and
Fournier's sum of tilted Phong lobes, each ``kd / pi + ks * lobe``.

``T = (1, 0, 0)`` is the "x"/"u" direction of every model, ``B = (0, 1, 0)`` its
"y"/"v" direction (MODELS.md). Terms that depend on the directions only are
cached on the :class:`Geometry`. Ward, Ashikhmin-Shirley and the anisotropic
Phong lobe live in :mod:`brdffit.models.anisotropic`.
"""

from __future__ import annotations

import math

import numpy as np

from ..data.geometry import Geometry
from .anisotropic import EMPIRICAL_ANISO, _tan2_axes
from .base import diffuse_plus_lobe
from .params import exponent, radius, unit_interval

__all__ = ["MODELS"]

#: Reference [4] of the classification paper, its source for Ohara, Wang and Fournier.
MALASHENKOVA = (
    "as cited by I. V. Malashenkova and A. Moiseikin, Modelling the surface properties "
    "of an object, Matematicheskaya morfologiya 5(4), 2006; lobe fixed by MODELS.md"
)


# ---------------------------------------------------------- Heidrich-Seidel
def _heidrich_seidel_log_base(geometry: Geometry) -> np.ndarray:
    """``ln(sqrt(1-(L.T)^2) sqrt(1-(V.T)^2) - (L.T)(V.T))``, ``-inf`` where it is <= 0."""

    def compute():
        lt, vt = geometry.wi[:, 0], geometry.wo[:, 0]
        base = np.sqrt(np.maximum(1.0 - lt * lt, 0.0)) * np.sqrt(np.maximum(1.0 - vt * vt, 0.0))
        base -= lt * vt
        out = np.full(geometry.m, -np.inf)
        np.log(base, out=out, where=base > 0)
        return out

    return geometry.cached("anisotropic.heidrich_seidel_log_base", compute)


def heidrich_seidel_lobe(geometry: Geometry, n: float) -> np.ndarray:
    """``max(0, sqrt(1-(L.T)^2) sqrt(1-(V.T)^2) - (L.T)(V.T))^n``."""
    lobe = _heidrich_seidel_log_base(geometry) * n
    return np.exp(lobe, out=lobe)


HEIDRICH_SEIDEL = diffuse_plus_lobe(
    "heidrich_seidel",
    heidrich_seidel_lobe,
    (exponent(doc="exponent of the fibre reflection cosine"),),
    EMPIRICAL_ANISO,
    "W. Heidrich and H.-P. Seidel, Realistic, hardware-accelerated shading and "
    "lighting, SIGGRAPH 1999 (after Banks 1994)",
    """Heidrich-Seidel: ``f = kd/pi + ks max(0, sqrt(1-(L.T)^2) sqrt(1-(V.T)^2)
- (L.T)(V.T))^n``.

The base is the cosine between V and the nearest mirror direction of L about
a fibre along T (``R.T = -L.T``): symmetric in L and V. T is the anisotropy
direction D projected on the tangent plane; D = T = (1, 0, 0) is fixed (data
come in the frame of their tangent). The paper's ``(L x T)(V x T)`` means the
lengths ``|L x T| |V x T|``. The base is parameter-free: its logarithm is
cached (``-inf`` where the base is <= 0), so an evaluation is one exp.
""",
)


# -------------------------------------------------------------------- Ohara
def ohara_lobe(geometry: Geometry, a: float, b: float, n: float) -> np.ndarray:
    """``(1 + tan^2(theta_h) (cos^2 phi_h / a^2 + sin^2 phi_h / b^2))^(-n/2)``."""
    tx, ty = _tan2_axes(geometry)
    x = tx * (1.0 / a**2)
    x += ty * (1.0 / b**2)
    lobe = np.log1p(x, out=x)
    lobe *= -0.5 * n
    return np.exp(lobe, out=lobe)


OHARA = diffuse_plus_lobe(
    "ohara",
    ohara_lobe,
    (
        radius("a", 1.0, "ellipsoid radius along T (c = 1)"),
        radius("b", 0.5, "ellipsoid radius along B (c = 1)"),
        exponent(doc="exponent of the elliptical highlight"),
    ),
    EMPIRICAL_ANISO,
    MALASHENKOVA,
    """Ohara: ``f = kd/pi + ks [a^2 b^2 (N.H)^2 / (a^2 b^2 (N.H)^2
+ (1-(N.H)^2)(b^2 cos^2 phi_h + a^2 sin^2 phi_h))]^(n/2)``.

Ellipsoid radii ``a``, ``b``, ``c = 1`` along T, B, N. The paper writes ``H.L``
for ``N.H`` and a constant ``c^2`` in the numerator (absorbed in ``ks``).
Evaluated as ``(1 + (H.T)^2/(a N.H)^2 + (H.B)^2/(b N.H)^2)^(-n/2)`` (divide by
``a^2 b^2 (N.H)^2``), with the squared tangents cached. Isotropic when
``a = b``. Near the peak the lobe is ``exp(-n/2 (H.T/(a N.H))^2 - ...)``: for
narrow highlights only ``n/a^2`` and ``n/b^2`` are well determined.
""",
)


# --------------------------------------------------------------------- Wang
def wang_lobe(geometry: Geometry, m: float, zeta: float) -> np.ndarray:
    """``(N.H)^(m zeta / (m - (m - zeta) cos^2 phi_h))``."""
    power = (m * zeta) / (m - (m - zeta) * geometry.cos2_phi_h)
    power *= geometry.log_cos_h
    return np.exp(power, out=power)


WANG = diffuse_plus_lobe(
    "wang",
    wang_lobe,
    (exponent("m", doc="exponent along T"), exponent("zeta", doc="exponent along B")),
    EMPIRICAL_ANISO,
    MALASHENKOVA,
    """Wang: ``f = kd/pi + ks (N.H)^(m zeta / (m - (m - zeta) cos^2 phi_h))``.

Exponent ``m`` along T (phi_h = 0), ``zeta`` along B; equals Blinn with
``n = m`` when ``m = zeta``. The paper writes ``H.L`` where ``N.H`` is meant.
The denominator ``m sin^2 phi_h + zeta cos^2 phi_h`` is at least 1, and the
exponent is irrelevant at ``H = N`` where ``ln(N.H) = 0``.
""",
)


# ------------------------------------------------------------------ Fournier
def _half_t(geometry: Geometry) -> np.ndarray:
    """H.T as a contiguous array (a column of ``half`` is strided)."""
    return geometry.cached("anisotropic.half_t", lambda: np.ascontiguousarray(geometry.half[:, 0]))


def fournier_lobe(geometry: Geometry, n: float, t: float) -> np.ndarray:
    """``(1/3) sum_{s in -1, 0, 1} max(0, N_s.H)^n``, ``N_s = normalise(N + t s T)``."""
    hx = _half_t(geometry)
    inv = 1.0 / math.sqrt(1.0 + t * t)
    centre = geometry.cos_h * inv
    side = hx * (t * inv)
    lobe = np.exp(geometry.log_cos_h * n)
    for tilted in (centre + side, centre - side):
        # max(0, c)^n as exp(n ln c): ln 0 = -inf gives exactly 0, and is cheaper
        # than np.power.
        np.maximum(tilted, 0.0, out=tilted)
        with np.errstate(divide="ignore"):
            np.log(tilted, out=tilted)
        tilted *= n
        lobe += np.exp(tilted, out=tilted)
    lobe *= 1.0 / 3.0
    return lobe


FOURNIER = diffuse_plus_lobe(
    "fournier",
    fournier_lobe,
    (
        exponent(doc="Blinn exponent of each lobe"),
        unit_interval("t", 0.3, "tangent of the tilt of the outer normals towards T"),
    ),
    EMPIRICAL_ANISO,
    "A. Fournier, Normal distribution functions and multiple surfaces, Graphics "
    "Interface '92 Workshop on Local Illumination, 45-52, 1992; construction fixed by MODELS.md",
    """Fournier: ``f = kd/pi + ks (1/K) sum_k max(0, N_k.H)^n``,
``N_k = normalise(N + t s_k T)``, ``K = 3``, ``s_k in {-1, 0, 1}``.

Fournier approximates an anisotropic normal distribution by isotropic Phong
lobes about tilted normals; MODELS.md fixes the construction. ``N_0.H = N.H``,
``N_(+-1).H = ((N.H) +- t (H.T)) / sqrt(1 + t^2)``: the tilted normals depend
on the shape parameter ``t``, so only ``N.H``, its log and ``H.T`` are cached
and each tilted cosine costs a multiply-add. Blinn when ``t = 0``.
""",
)


MODELS = (
    HEIDRICH_SEIDEL,
    OHARA,
    WANG,
    FOURNIER,
)
