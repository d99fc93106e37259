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
from .inputs import _axes32, _h_axes, inv_4_cos32, microfacet_inputs

__all__ = [
    "conductor_anisotropic_inputs",
    "conductor_inputs",
    "gltf_anisotropic_inputs",
    "gltf_inputs",
    "plastic_inputs",
    "plastic_z",
    "principled_anisotropic_inputs",
    "principled_diffuse_sensitivity",
    "principled_inputs",
    "unit_directions",
]


def gltf_inputs(g: Geometry) -> tuple:
    """glTF: those of GGX (:func:`~brdffit.kernels.inputs.microfacet_inputs`):
    ``tan^2`` of H, L and V, ``1 / (4 (N.L)(N.V) (N.H)^4)`` and ``(1 - V.H)^5``."""
    return microfacet_inputs(g)


def gltf_anisotropic_inputs(g: Geometry) -> tuple:
    """glTF with KHR_materials_anisotropy: the components of L and of V, contiguous
    (``z``: :func:`plastic_z`'s arrays); cached. The loop forms ``|L + V|``, Schlick's
    weight, ``D``'s ``q`` and the visibility from them (six arrays, 48 bytes a pair).

    The loop before read eight arrays, 60 bytes a pair (H's ``x`` and ``y``, the slopes
    of L and V, ``1 / (4 (N.L)(N.V))`` in float32 and the weight), and was limited by
    memory at 2.4 ns a pair on the machine of ``benchmarks/``; this one takes 2.1
    (benchmarks/README.md, "glTF anisotropic and Fournier (seventh stop)") and reads
    float64 only."""

    def compute():
        xy = tuple(np.ascontiguousarray(w[:, j]) for w in (g.wi, g.wo) for j in range(2))
        z_i, z_o = plastic_z(g)
        return (*xy[:2], z_i, *xy[2:], z_o)

    return g.cached("kernels.gltf_anisotropic", compute)


def conductor_inputs(g: Geometry) -> tuple:
    """Mitsuba's roughconductor: GGX's ``tan^2`` of H, L, V and its factor, and ``V.H``
    (the exact conductor Fresnel is computed in the loop)."""
    return (*microfacet_inputs(g)[:4], g.cos_d)


def conductor_anisotropic_inputs(g: Geometry) -> tuple:
    """Anisotropic roughconductor: those of anisotropic GGX
    (:func:`~brdffit.kernels.inputs.ggx_anisotropic_inputs`, cached there) but
    Schlick's weight, then ``V.H`` in float64 for the conductor Fresnel factor.

    The ``tan^2`` axes of L and V and ``1 / (4 (N.L)(N.V))`` in float32, as anisotropic
    GGX's (measured: the loop, limited by memory at 64 bytes of inputs a pair, 2.3 ->
    1.55 ns a pair with 44): ``G1(L) G1(V)`` within 6e-8, the factor within 6e-8, in all within
    :data:`~brdffit.kernels.inputs.CONDUCTOR_ANISOTROPIC_F32_ERROR` of the float64
    model (tested). ``V.H`` stays float64: the Fresnel factor of a conductor changes
    fast with it near grazing."""
    return (*_h_axes(g), *_axes32(g)[:4], inv_4_cos32(g), g.cos_d)


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


#: How far from 1 the squared length of every direction may be for the principled
#: loop that takes ``tan^2 = (1 - c^2) / c^2`` (:func:`unit_directions`).
UNIT_ERROR = 1e-13


def unit_directions(g: Geometry) -> bool:
    """Whether every ``|L|^2`` and ``|V|^2`` is within :data:`UNIT_ERROR` of 1; cached.

    Directions are accepted within 1e-6 of unit length and not normalised. Smith's
    ``G1`` from the cosine alone, ``2 c / (c + sqrt(c^2 (1 - alpha^2) + alpha^2))``,
    puts ``1 - c^2`` for ``x^2 + y^2``: ``alpha^2 (1 - |L|^2)`` off inside a square root
    of at least ``alpha^2``, so within ``UNIT_ERROR / 2`` relative of the numpy ``G1``
    here, but 1e-6 off at the accepted limit."""

    def compute():
        worst = max(float(np.max(np.abs(np.einsum("ij,ij->i", w, w) - 1.0))) for w in (g.wi, g.wo))
        return worst <= UNIT_ERROR

    return g.cached("kernels.unit_directions", compute)


def principled_inputs(g: Geometry) -> tuple:
    """Mitsuba's principled, with the name of its loop: for :func:`unit_directions`,
    ``tan^2(theta_h)``, ``N.L``, ``N.V`` in float32 (cached) and ``V.H`` in float64
    (``principled_unit``, with ``F`` in float32:
    :func:`~brdffit.kernels.bind_renderers.dielectric_fresnel32`); else ``tan^2`` of
    H, L and V (GGX's, cached), ``N.L``, ``N.V`` and ``V.H``, all float64. Schlick's
    weights of the cosines are computed in the loop.

    The unit loop is limited by its memory traffic when its arrays are not in the
    cache (measured at 1 M pairs: 4.4 ns a pair streamed against 2.2 in the cache,
    with float64 inputs: 56 bytes a pair with the output; with these, 40 bytes and
    2.9 ns). Each float32 input carries its rounding, at most ``u = 2^-24`` relative
    (all are normal float32 numbers or 0: ``N.L``, ``N.V >= 1e-10``, ``tan^2 <= 1e20``;
    a ``tan^2`` below float32's normal range moves ``1 + tan^2 / alpha^2`` by less
    than its rounding). To first order the BRDF's relative error is at most ``u`` times
    the sum of its sensitivities ``|d ln f / d ln x|``: ``D``'s ``p^2 / q^2``
    to ``tan^2`` at most 2; each ``c + S(c)`` to its cosine at most 1, so ``D G1 G1 /
    (4 (N.L)(N.V))`` within ``4u``; the offset ``((1 - metallic) F + metallic w) D ...``
    within ``5u`` (``F``'s ``u``); the colour column's diffuse to each cosine at most
    :func:`principled_diffuse_sensitivity` (1.5, through Schlick's weight), so the
    column within ``4u``, and the value (a sum of positive terms) within ``5u``:
    :data:`~brdffit.kernels.inputs.PRINCIPLED_F32_ERROR` (tested, and that it is not
    slack). ``V.H`` stays float64: ``metallic``'s ``(1 - V.H)^5`` has a relative
    sensitivity ``5 V.H / (1 - V.H)`` to it, unbounded at ``L = V``."""
    if unit_directions(g):
        single = g.cached(
            "kernels.principled32",
            lambda: tuple(x.astype(np.float32) for x in (g.tan2_h, g.cos_i, g.cos_o)),
        )
        return "principled_unit", (*single, g.cos_d)
    return "principled", (*microfacet_inputs(g)[:3], g.cos_i, g.cos_o, g.cos_d)


def principled_diffuse_sensitivity(points: int = 100_001) -> float:
    """An upper bound of ``|d ln diffuse / d ln c|`` for the cosine ``c`` of L (or V) in
    Burley's diffuse with retro-reflection ``(1 - w_L/2)(1 - w_V/2) + R (w_L + w_V +
    w_L w_V (R - 1))``, ``w = (1 - c)^5``, ``0 <= R = 2 roughness (V.H)^2 <= 2``: with
    ``A = 1 - w_L / 2 >= 1/2`` and ``K = R (1 - w_V) + R^2 w_V <= 4`` the diffuse is at
    least ``A A_V + K w_L`` (a sum of positive terms) and its derivative in ``w_L`` is
    ``K - A_V / 2``, so the sensitivity is at most ``|dw/d ln c| (1 / (2 A) + 4 / (4 w +
    A / 2))``, ``|dw / d ln c| = 5 (1 - c)^4 c``, maximised on ``points`` cosines in
    [0, 1] (a smooth function: the grid's maximum is within 1e-9 of it); 1.503."""
    c = np.linspace(0.0, 1.0, points)
    w = (1.0 - c) ** 5
    a = 1.0 - 0.5 * w
    return float(np.max(5.0 * (1.0 - c) ** 4 * c * (0.5 / a + 4.0 / (4.0 * w + 0.5 * a))))


def principled_anisotropic_inputs(g: Geometry) -> tuple:
    """Anisotropic principled, with the name of its loop: in float32 (cached) the
    components of L and of V, ``(H.T / N.H)^2`` and ``(H.B / N.H)^2`` (``N.H`` clamped
    as the geometry's), then ``V.H`` in float64 (``F`` in float32:
    :func:`~brdffit.kernels.bind_renderers.dielectric_fresnel32`).

    The loop was limited by its memory traffic (seven float64 arrays, 72 bytes a
    pair with its output: 4.9 ns a pair streamed against 3.0 in the cache, measured
    at 1 M pairs); these are 60 bytes. Each float32 value is within ``u = 2^-24``
    relative of its float64 value (or below float32's normal range, where its
    absolute error, under 1.5e-45, is beyond what the sums it enters can register:
    ``N.L`` is clamped at 1e-10). Sensitivities, as in :func:`principled_inputs`:
    ``D = p^2 / q^2`` with ``p`` and ``q`` sums of positive terms, within ``4u``; each
    ``c + S``, ``S^2`` a sum of positive squares, within ``u``; ``F`` ``u``; the
    diffuse ``3u``: the offset within ``7u``, the colour column within ``6u``, the
    value within ``7u``: :data:`~brdffit.kernels.inputs.PRINCIPLED_ANISOTROPIC_F32_ERROR`
    (tested, and that it is not slack). ``V.H`` stays float64 (see
    :func:`principled_inputs`); computing H from float32 L and V would not do: near
    the specular peak ``l_x + v_x`` cancels, 2e-4 off ``D`` for ``alpha = 0.001``."""

    def compute():
        c2 = g.cos_h * g.cos_h
        axes = tuple(g._half_component(j) ** 2 / c2 for j in range(2))
        single = (*(w[:, j] for w in (g.wi, g.wo) for j in range(3)), *axes)
        return (*(x.astype(np.float32) for x in single), g.cos_d)

    return "principled_anisotropic", g.cached("kernels.principled_anisotropic32", compute)
