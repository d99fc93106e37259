"""Mitsuba 3's ``roughplastic`` (GGX) as a model: a rough dielectric coating over a
diffuse base, exactly as Mitsuba evaluates it.

``f = specular_reflectance F(V.H; eta) D G1(L) G1(V) / (4 N.L N.V)
+ diffuse / (pi eta^2) T(N.L) T(N.V)``

with the exact dielectric Fresnel, GGX ``D``, the separable Smith ``G``, and
``T(mu)`` the transmittance of the rough interface at incidence cosine ``mu``:
``T(mu) = integral (1 - F(wi.m)) G1(wt, m) D_wi(m) dm`` over the visible normals
``m`` of ``wi`` (``wt`` the refracted direction). Mitsuba tabulates ``T`` at 64
cosines ``max(1e-6, i/63)``, each by a 32 x 32 Gauss-Legendre rule over the unit
square mapped to visible normals (Heitz and d'Eon 2014, with the concentric
disk map), and interpolates linearly; this module does the same, so its values
match Mitsuba's to single precision.

Mitsuba's ``diffuse_reflectance`` is divided by ``1 - R_int``, the internal
diffuse reflectance of the interface (``R_int = 2 mean_i(R(mu_i; 1/eta) mu_i)``
over the same 64 cosines, ``R`` by a 128 x 128 rule). ``R_int`` depends on
``alpha`` and ``eta`` only and costs a million evaluations, so the model's
linear parameter is ``diffuse = diffuse_reflectance / (1 - R_int)``;
:func:`internal_reflectance` gives ``R_int`` for an export. Mitsuba's ``eta`` is
``int_ior / ext_ior``, and its default ``ext_ior`` is air (1.000277), not 1.

References: Mitsuba 3, src/bsdfs/roughplastic.cpp and
include/mitsuba/render/microfacet.h (``eval_transmittance``, ``eval_reflectance``,
``sample_visible_11``); E. Heitz and E. d'Eon, Importance sampling microfacet-based
BSDFs using the distribution of visible normals, EGSR 2014; C. Kelemen and
L. Szirmay-Kalos, A microfacet based coupled specular-matte BRDF model with
importance sampling, Eurographics 2001 (the coupled diffuse term).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from ..data.geometry import Geometry
from .base import Classification, Design, Model, Param
from .params import roughness
from .renderers import isotropic_lobe
from .shared import fresnel_dielectric

__all__ = ["MODELS", "MITSUBA_ROUGHPLASTIC", "internal_reflectance", "transmittance_table"]

TABLE_SIZE = 64


@lru_cache(maxsize=4)
def _rule(res: int) -> tuple:
    """Gauss-Legendre nodes on the unit square, concentric-disk mapped: (px, py, w)."""
    x, w = np.polynomial.legendre.leggauss(res)
    u, v = np.meshgrid(0.5 * x + 0.5, 0.5 * x + 0.5)
    weight = np.outer(w, w).ravel() * 0.25
    a, b = 2.0 * u.ravel() - 1.0, 2.0 * v.ravel() - 1.0
    swap = np.abs(a) < np.abs(b)  # Shirley-Chiu concentric map (Mitsuba's warp.h)
    r = np.where(swap, b, a)
    phi = 0.25 * math.pi * np.where(swap, a, b) / r
    phi = np.where(swap, 0.5 * math.pi - phi, phi)
    return r * np.cos(phi), r * np.sin(phi), weight


@lru_cache(maxsize=4)
def _half_rule(res: int) -> tuple:
    """The nodes of :func:`_rule` with ``px > 0``, their weights doubled: the rule is
    symmetric under ``px -> -px`` (``a -> -a`` in the concentric map; ``res`` even
    leaves no node at ``px = 0``), and so are both integrands, in which ``px`` flips
    the sign of ``m_y`` and of the outgoing ``y`` only. Half the work: the table took
    5.6 ms, rebuilt at every new ``alpha`` of a fit (measured)."""
    px, py, weight = _rule(res)
    keep = px > 0.0
    if 2 * np.count_nonzero(keep) != px.size:
        raise ValueError(f"res={res}: the rule is not symmetric in px (res must be even)")
    return px[keep], py[keep], 2.0 * weight[keep]


def _cosines() -> np.ndarray:
    return np.maximum(1e-6, np.linspace(0.0, 1.0, TABLE_SIZE))


def _visible_normals(mu: np.ndarray, alpha: float, res: int):
    """Mitsuba's GGX visible normals of ``wi = (sqrt(1 - mu^2), 0, mu)`` at the
    rule's nodes (half of them, :func:`_half_rule`): arrays (len(mu), K) of m_x, m_y,
    m_z, and the weights."""
    px, py, weight = _half_rule(res)
    sx = alpha * np.sqrt(1.0 - mu * mu)
    norm = np.sqrt(sx * sx + mu * mu)
    ct = (mu / norm)[:, None]
    st = np.sqrt(np.maximum(1.0 - ct * ct, 0.0))
    s = 0.5 * (1.0 + ct)
    y = (1.0 - s) * np.sqrt(np.maximum(1.0 - px * px, 0.0)) + s * py
    z = np.sqrt(np.maximum(1.0 - px * px - y * y, 0.0))
    inv = 1.0 / (st * y + ct * z)
    slope_x = (ct * y - st * z) * inv * alpha
    slope_y = px * inv * alpha
    length = np.sqrt(slope_x * slope_x + slope_y * slope_y + 1.0)
    return -slope_x / length, -slope_y / length, 1.0 / length, weight


def _g1(vx, vy, vz, dot_vm, alpha: float) -> np.ndarray:
    xy = alpha * alpha * (vx * vx + vy * vy)
    g = 2.0 / (1.0 + np.sqrt(1.0 + xy / (vz * vz)))
    g = np.where(xy == 0.0, 1.0, g)
    return np.where(dot_vm * vz <= 0.0, 0.0, g)


def _interface_integral(alpha: float, eta: float, res: int, transmit: bool) -> np.ndarray:
    """Mitsuba's ``eval_transmittance`` (``transmit``) or ``eval_reflectance`` at
    the table's cosines."""
    mu = _cosines()
    mx, my, mz, weight = _visible_normals(mu, alpha, res)
    wx, wz = np.sqrt(1.0 - mu * mu)[:, None], mu[:, None]
    c = wx * mx + wz * mz  # wi.m > 0 for visible normals
    f = fresnel_dielectric(c, eta)
    if transmit:
        cos_t = np.sqrt(np.maximum(1.0 - (1.0 - c * c) / (eta * eta), 0.0))
        k = c / eta - cos_t  # wt = m (c/eta - cos_t) - wi/eta
        ox, oy, oz = mx * k - wx / eta, my * k, mz * k - wz / eta
        value = _g1(ox, oy, oz, ox * mx + oy * my + oz * mz, alpha) * (1.0 - f)
        value = np.where(oz * wz >= 0.0, 0.0, value)
    else:
        ox, oy, oz = 2.0 * c * mx - wx, 2.0 * c * my, 2.0 * c * mz - wz
        value = _g1(ox, oy, oz, c, alpha) * f
        value = np.where(oz <= 0.0, 0.0, value)
    return value @ weight


@lru_cache(maxsize=256)
def transmittance_table(alpha: float, eta: float) -> np.ndarray:
    """``T`` at Mitsuba's 64 cosines (32 x 32 rule), read-only."""
    table = _interface_integral(alpha, eta, 32, transmit=True)
    table.setflags(write=False)
    return table


@lru_cache(maxsize=64)
def internal_reflectance(alpha: float, eta: float) -> float:
    """Mitsuba's ``R_int``: ``2 mean(R(mu; 1/eta) mu)`` with a 128 x 128 rule."""
    return float(
        np.mean(_interface_integral(alpha, 1.0 / eta, 128, transmit=False) * _cosines()) * 2.0
    )


def _lerp_nodes(x: np.ndarray) -> tuple:
    """Mitsuba's ``lerp_gather`` on a table of :data:`TABLE_SIZE` values over [0, 1]:
    the index below each ``x`` and the weight of the value above it."""
    x = x * (TABLE_SIZE - 1)
    index = np.minimum(x.astype(np.int64), TABLE_SIZE - 2)
    return index, x - index


def _lerp(table: np.ndarray, nodes: tuple) -> np.ndarray:
    index, w1 = nodes
    return (1.0 - w1) * table[index] + w1 * table[index + 1]


def _design(geometry: Geometry, shape) -> Design:
    alpha, eta = shape["alpha"], shape["eta"]
    table = transmittance_table(float(alpha), float(eta))
    nodes_i, nodes_o = geometry.cached(
        "mitsuba_plastic.lerp_nodes",
        lambda: (_lerp_nodes(geometry.wi[:, 2]), _lerp_nodes(geometry.wo[:, 2])),
    )
    diffuse = _lerp(table, nodes_i) * _lerp(table, nodes_o)
    diffuse *= 1.0 / (math.pi * eta * eta)
    specular = isotropic_lobe(geometry, "ggx", alpha, 1.0)
    specular *= fresnel_dielectric(geometry.cos_d, eta)
    return Design((diffuse, specular))


MITSUBA_ROUGHPLASTIC = Model(
    name="mitsuba_roughplastic",
    params=(
        Param(
            "diffuse",
            0.0,
            10.0,
            0.5,
            linear=True,
            unit="1",
            doc="diffuse_reflectance / (1 - R_int) (module docstring)",
        ),
        Param(
            "specular_reflectance",
            0.0,
            10.0,
            1.0,
            linear=True,
            unit="1",
            doc="Mitsuba specular_reflectance (a scale of the coating's lobe)",
        ),
        roughness(
            "alpha",
            doc="Mitsuba 3 alpha: the GGX width alpha, not squared, not an rms "
            "slope. Renderers: glTF/Disney/Blender/OpenPBR roughness = sqrt(alpha); "
            "pbrt-v4 roughness = alpha (remaproughness false) or alpha^2 (true)",
        ),
        Param("eta", 1.05, 3.0, 1.5, unit="1", doc="int_ior / ext_ior of the coating"),
    ),
    classification=Classification("physical", "isotropic", "cosine", "material"),
    reference="Mitsuba 3 (W. Jakob et al., 2022), src/bsdfs/roughplastic.cpp; Kelemen and "
    "Szirmay-Kalos, Eurographics 2001; Heitz and d'Eon, EGSR 2014",
    design=_design,
    held=("eta",),
    doc="Mitsuba 3 roughplastic (GGX), as Mitsuba evaluates it.\n\n"
    "``f = specular_reflectance F(V.H; eta) D G1 G1 / (4 N.L N.V) + diffuse T(N.L) T(N.V) "
    "/ (pi eta^2)``, ``T`` Mitsuba's tabulated rough-interface transmittance; Mitsuba's "
    "diffuse_reflectance = diffuse (1 - R_int). A fit holds eta unless told to free it.\n",
)

MODELS = (MITSUBA_ROUGHPLASTIC,)
