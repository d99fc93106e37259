"""Parameter-free inputs of the renderer-native kernels, computed once per geometry.

As :mod:`brdffit.kernels.inputs`, for the loops of
:mod:`brdffit.kernels.loops_renderers`: contiguous float64 arrays over the valid
pairs, cached on the geometry, computed with the clamps of the numpy models
(:mod:`brdffit.models.renderer_native`, :mod:`brdffit.models.mitsuba_plastic`,
:mod:`brdffit.models.mitsuba_principled`), so that both agree to rounding.
"""

from __future__ import annotations

import numpy as np

from ..data.geometry import Geometry
from ..models.microfacet import inv_4_cos
from .inputs import microfacet_inputs

__all__ = [
    "conductor_anisotropic_inputs",
    "conductor_inputs",
    "directions",
    "gltf_anisotropic_inputs",
    "gltf_inputs",
    "plastic_inputs",
    "plastic_z",
    "principled_anisotropic_inputs",
    "principled_inputs",
]


def gltf_inputs(g: Geometry) -> tuple:
    """glTF: those of GGX (:func:`~brdffit.kernels.inputs.microfacet_inputs`):
    ``tan^2`` of H, L and V, ``1 / (4 (N.L)(N.V) (N.H)^4)`` and ``(1 - V.H)^5``."""
    return microfacet_inputs(g)


def _slopes_of(w: np.ndarray) -> tuple:
    """``x / z`` and ``y / z`` of directions ``w``, ``z`` clamped at 1e-300 as the
    glTF model's ``Lambda`` does (not at the cosines' 1e-10)."""
    z = np.maximum(w[:, 2], 1e-300)
    return w[:, 0] / z, w[:, 1] / z


def gltf_anisotropic_inputs(g: Geometry) -> tuple:
    """glTF with KHR_materials_anisotropy: the slopes ``x/z``, ``y/z`` of H, of L and
    of V (rotated in the loop; L's and V's with ``z`` clamped as the numpy model's
    ``Lambda``), ``1 / (4 (N.L)(N.V) H_z^4)`` (``H_z`` unclamped: the numpy ``D`` takes
    H's components) and ``(1 - V.H)^5``. Eight arrays: the ninth of H's three
    components made the loop wait for memory (measured: 175 against 390 M pairs/s
    with the same arrays passed several times)."""

    def compute():
        hz2 = g.half[:, 2] ** 2
        factor = inv_4_cos(g) / (hz2 * hz2)
        slopes = (*_slopes_of(g.half), *_slopes_of(g.wi), *_slopes_of(g.wo))
        return (*slopes, factor, microfacet_inputs(g)[4])

    return g.cached("kernels.gltf_anisotropic", compute)


def conductor_inputs(g: Geometry) -> tuple:
    """Mitsuba's roughconductor: GGX's ``tan^2`` of H, L, V and its factor, and ``V.H``
    (the exact conductor Fresnel is computed in the loop)."""
    return (*microfacet_inputs(g)[:4], g.cos_d)


def directions(g: Geometry) -> tuple:
    """The components ``x, y, z`` of L, then of V, each contiguous; cached. The
    anisotropic GGX loops compute H, its clamped cosine, the ``tan^2`` axes and ``V.H``
    from them (:func:`~brdffit.kernels.loops_renderers._ggx_dg_directions`): six arrays
    read instead of seven to eleven, and those loops are limited by memory traffic."""
    return g.cached(
        "kernels.directions",
        lambda: tuple(np.ascontiguousarray(w[:, j]) for w in (g.wi, g.wo) for j in range(3)),
    )


def conductor_anisotropic_inputs(g: Geometry) -> tuple:
    """Anisotropic roughconductor: :func:`directions`."""
    return directions(g)


def plastic_z(g: Geometry) -> tuple:
    """Mitsuba's roughplastic diffuse: the unclamped ``z`` of L and of V, contiguous
    (the positions in the transmittance table, as the numpy model's ``lerp_gather``)."""
    return g.cached(
        "kernels.plastic_z",
        lambda: (np.ascontiguousarray(g.wi[:, 2]), np.ascontiguousarray(g.wo[:, 2])),
    )


def plastic_inputs(g: Geometry) -> tuple:
    """Mitsuba's roughplastic specular: GGX's ``tan^2`` of H, L, V and its factor."""
    return microfacet_inputs(g)[:4]


def principled_inputs(g: Geometry) -> tuple:
    """Mitsuba's principled: ``tan^2`` of H, L and V (GGX's, cached), ``N.L``, ``N.V``
    and ``V.H`` (Schlick's weights of the last three are computed in the loop)."""
    return (*microfacet_inputs(g)[:3], g.cos_i, g.cos_o, g.cos_d)


def principled_anisotropic_inputs(g: Geometry) -> tuple:
    """Anisotropic principled: :func:`directions`."""
    return directions(g)
