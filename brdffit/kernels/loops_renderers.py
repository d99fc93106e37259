"""The compiled loops of the renderer-native models: one fused pass per evaluation.

As :mod:`brdffit.kernels.loops`, each loop reads the parameter-free inputs of
:mod:`brdffit.kernels.inputs_renderers` and computes the formula of its numpy model
pair by pair, in the same order of operations where rounding matters:

- glTF 2.0's metallic-roughness BRDF (glTF 2.0 specification, appendix B) with
  GGX ``D`` and the height-correlated Smith visibility (Heitz, JCGT 3(2), 2014),
  and its KHR_materials_anisotropy form;
- Mitsuba 3's ``roughconductor`` (src/bsdfs/roughconductor.cpp): GGX ``D``, the
  separable Smith ``G`` (Walter, Marschner, Li and Torrance, EGSR 2007, eqs. 33-34)
  and the exact conductor Fresnel (Born and Wolf, Principles of Optics, 14.2);
- Mitsuba 3's ``roughplastic`` (src/bsdfs/roughplastic.cpp; Kelemen and
  Szirmay-Kalos, Eurographics 2001) with its tabulated transmittance;
- Mitsuba 3's ``principled`` reflection lobes (src/bsdfs/principled.cpp; Burley,
  Physically-based shading at Disney, SIGGRAPH 2012 course notes), in
  :mod:`brdffit.kernels.loops_principled`.

Models linear in a colour (glTF, principled) write the colour's ``column`` and the
``offset`` when ``column`` has pairs, else the BRDF at the colour ``base`` into ``out``.
"""

from __future__ import annotations

import math

from ..data.geometry import MIN_COSINE
from ..models.renderer_native import PERFECT_K_MIN
from ._compile import jit
from .loops import _twice_fresnel_dielectric
from .loops_microfacet import ggx_anisotropic_dg, wide
from .loops_principled import (  # noqa: F401 (the loops bind_renderers looks up here)
    _inline,
    principled,
    principled_anisotropic,
    principled_unit,
)
from .plastic_table import TABLE_SIZE, local_table

_INV_PI = 1.0 / math.pi
_F0 = 0.04  # glTF's dielectric reflectance at normal incidence (ior 1.5)


@_inline
def _ggx_dg(tan2_h, tan2_i, tan2_o, factor, inv_a2, alpha2):
    """``D G1(L) G1(V) / (4 (N.L)(N.V))`` of isotropic GGX without its constant
    ``4 / (pi alpha^2)``; ``factor`` is ``1 / (4 (N.L)(N.V) (N.H)^4)``."""
    t = 1.0 + tan2_h * inv_a2
    g = (1.0 + math.sqrt(1.0 + alpha2 * tan2_i)) * (1.0 + math.sqrt(1.0 + alpha2 * tan2_o))
    return factor / (t * t * g)


@_inline
def _gltf_mix(spec, w, metallic, diffuse_scale):
    """glTF's ``(column, offset)`` from ``spec = D V``: ``(1 - m)(1 - Fd)/pi + m (1 -
    w) spec`` and ``((1 - m) Fd + m w) spec``, ``Fd = 0.04 + 0.96 w``."""
    fd = w * (1.0 - _F0) + _F0
    column = diffuse_scale * (1.0 - fd) + metallic * (1.0 - w) * spec
    return column, ((1.0 - metallic) * fd + metallic * w) * spec


@jit
def gltf(tan2_h, tan2_i, tan2_o, factor, weight, alpha2, metallic, base, column, out):
    """glTF with ``alpha^2 = alpha2``: ``spec = D V = 2 factor / (pi alpha^2 t^2 (s_L +
    s_V))``, ``t = 1 + tan^2/alpha^2``, ``s = sqrt(1 + alpha^2 tan^2)``."""
    inv_a2 = 1.0 / alpha2
    scale = 2.0 * _INV_PI * inv_a2
    diffuse_scale = (1.0 - metallic) * _INV_PI
    design = column.shape[0] > 0
    for i in range(out.shape[0]):
        t = 1.0 + tan2_h[i] * inv_a2
        s = math.sqrt(1.0 + alpha2 * tan2_i[i]) + math.sqrt(1.0 + alpha2 * tan2_o[i])
        col, off = _gltf_mix(scale * factor[i] / (t * t * s), weight[i], metallic, diffuse_scale)
        if design:
            column[i] = col
            out[i] = off
        else:
            out[i] = off + base * col
    return out


@_inline
def _rotated_spec(hx, hy, sx_i, sy_i, sx_o, sy_o, at, ab, inv_t2, inv_b2, c, s):
    """``D V`` of :func:`gltf_anisotropic` at one pair, without its ``2 inv_4_cos / (pi
    at ab)``: ``1 / (q^2 (s_L + s_V))``, ``q = (h_t/a_t)^2 + (h_b/a_b)^2 + h_z^2`` with
    ``h_z^2 = 1 - h_x^2 - h_y^2`` (H is normalised; ``q >= |H|^2 = 1`` as ``a_t, a_b <=
    1``, so the rounding of ``h_z^2`` moves ``q`` by a few ulps only). A true division:
    ``s_L`` is infinite for L within 1e-154 of the horizon, as the numpy model's, and
    the value then 0 as there."""
    ht, hb = hx * c + hy * s, hy * c - hx * s
    q = ht * ht * inv_t2 + hb * hb * inv_b2 + (1.0 - hx * hx - hy * hy)
    lt, lb = at * (sx_i * c + sy_i * s), ab * (sy_i * c - sx_i * s)
    vt, vb = at * (sx_o * c + sy_o * s), ab * (sy_o * c - sx_o * s)
    root = math.sqrt(1.0 + (lt * lt + lb * lb)) + math.sqrt(1.0 + (vt * vt + vb * vb))
    return 1.0 / (q * q * root)


@wide
@jit
def gltf_anisotropic(
    hx, hy, sx_i, sy_i, sx_o, sy_o, inv_4_cos, weight,
    at, ab, c, s, metallic, base, column, out,
):  # fmt: skip
    """glTF with KHR_materials_anisotropy: ``D = 1 / (pi a_t a_b q^2)`` (H's components
    ``h_t``, ``h_b`` on the axes ``(t, b)`` rotated by ``r``: ``c = cos r``, ``s = sin
    r``), ``V = 2 / ((s_L + s_V) 4 (N.L)(N.V))``, ``s_w = sqrt(1 + a_t^2 w_t^2 + a_b^2
    w_b^2)`` from the slopes ``w / w_z`` (:func:`_rotated_spec`). The loop of before
    read H's slopes and ``1 / (4 (N.L)(N.V) H_z^4)``, which overflowed for H within
    1e-77 of the horizon (the value then NaN); now H's ``x`` and ``y``."""
    inv_t2, inv_b2 = 1.0 / (at * at), 1.0 / (ab * ab)
    scale = 2.0 * _INV_PI / (at * ab)
    diffuse_scale = (1.0 - metallic) * _INV_PI
    if column.shape[0] > 0:
        for i in range(out.shape[0]):
            spec = (scale * inv_4_cos[i]) * _rotated_spec(
                hx[i], hy[i], sx_i[i], sy_i[i], sx_o[i], sy_o[i], at, ab, inv_t2, inv_b2, c, s
            )
            column[i], out[i] = _gltf_mix(spec, weight[i], metallic, diffuse_scale)
        return out
    for i in range(out.shape[0]):
        spec = (scale * inv_4_cos[i]) * _rotated_spec(
            hx[i], hy[i], sx_i[i], sy_i[i], sx_o[i], sy_o[i], at, ab, inv_t2, inv_b2, c, s
        )
        col, off = _gltf_mix(spec, weight[i], metallic, diffuse_scale)
        out[i] = off + base * col
    return out


@_inline
def _fresnel_conductor(c, e2_k2, four_e2k2):
    """The unpolarised conductor Fresnel factor at ``c = V.H`` in the numpy model's
    form (:func:`brdffit.models.shared.fresnel_conductor`), ``e2_k2 = eta^2 - k^2``."""
    c2 = c * c
    s2 = 1.0 - c2
    t0 = e2_k2 - s2
    a2b2 = math.sqrt(t0 * t0 + four_e2k2)
    a = math.sqrt(max(0.5 * (a2b2 + t0), 0.0))
    t1 = a2b2 + c2
    t2 = 2.0 * c * a
    rs = (t1 - t2) / max(t1 + t2, 1e-300)
    t3 = c2 * a2b2 + s2 * s2
    t4 = t2 * s2
    return 0.5 * (rs + rs * (t3 - t4) / max(t3 + t4, 1e-300))


@jit
def conductor(tan2_h, tan2_i, tan2_o, factor, cos_d, alpha2, eta, k, a, out):
    """``a F(V.H; eta + i k) D G1(L) G1(V) / (4 (N.L)(N.V))``, GGX, ``F`` skipped where
    it is exactly 1 (:func:`~brdffit.models.renderer_native.perfect_conductor`)."""
    inv_a2 = 1.0 / alpha2
    scale = 4.0 * a * _INV_PI * inv_a2
    e2_k2, four_e2k2 = eta * eta - k * k, 4.0 * (eta * eta) * (k * k)
    if eta == 0.0 and k >= PERFECT_K_MIN:
        for i in range(out.shape[0]):
            out[i] = scale * _ggx_dg(tan2_h[i], tan2_i[i], tan2_o[i], factor[i], inv_a2, alpha2)
        return out
    for i in range(out.shape[0]):
        lobe = scale * _ggx_dg(tan2_h[i], tan2_i[i], tan2_o[i], factor[i], inv_a2, alpha2)
        out[i] = lobe * _fresnel_conductor(cos_d[i], e2_k2, four_e2k2)
    return out


@wide
@jit
def conductor_anisotropic(
    tan2_t, tan2_b, tx_i, ty_i, tx_o, ty_o, inv_4_cos, cos_d, alpha_u, alpha_v, eta, k, a, out
):
    """:func:`conductor` with anisotropic GGX (``alpha_u`` along T, ``alpha_v`` along B),
    the ``D G`` of anisotropic GGX's loop
    (:func:`~brdffit.kernels.loops_microfacet.ggx_anisotropic_dg`, float32 inputs:
    :func:`~brdffit.kernels.inputs_renderers.conductor_anisotropic_inputs`)."""
    u2, v2 = alpha_u * alpha_u, alpha_v * alpha_v
    inv_u2, inv_v2 = 1.0 / u2, 1.0 / v2
    scale = 4.0 * a * _INV_PI / (alpha_u * alpha_v)
    e2_k2, four_e2k2 = eta * eta - k * k, 4.0 * (eta * eta) * (k * k)
    if eta == 0.0 and k >= PERFECT_K_MIN:  # F = 1: V.H is not read
        for i in range(out.shape[0]):
            out[i] = scale * ggx_anisotropic_dg(
                tan2_t[i], tan2_b[i], tx_i[i], ty_i[i], tx_o[i], ty_o[i], inv_4_cos[i],
                inv_u2, inv_v2, u2, v2,
            )  # fmt: skip
        return out
    for i in range(out.shape[0]):
        lobe = scale * ggx_anisotropic_dg(
            tan2_t[i], tan2_b[i], tx_i[i], ty_i[i], tx_o[i], ty_o[i], inv_4_cos[i],
            inv_u2, inv_v2, u2, v2,
        )  # fmt: skip
        out[i] = lobe * _fresnel_conductor(cos_d[i], e2_k2, four_e2k2)
    return out


@_inline
def _node(z):
    """The index below ``z`` in [0, 1] in a table of :data:`TABLE_SIZE` values at ``i /
    (n - 1)`` and the weight of the value above it: Mitsuba's ``lerp_gather``, as
    :func:`brdffit.models.mitsuba_plastic._lerp_nodes`. Not a function of the table:
    an array passed to an inlined function kept the loop from vectorising (measured)."""
    x = z * (TABLE_SIZE - 1)
    index = min(int(x), TABLE_SIZE - 2)
    return index, x - index


@jit
def plastic_diffuse(z_i, z_o, table, eta, out):
    """Mitsuba 3's roughplastic diffuse column ``T(z_L) T(z_V) / (pi eta^2)``, ``T``
    the transmittance ``table`` interpolated linearly, from its copy on the stack
    (:func:`~brdffit.kernels.plastic_table.local_table`: the look-ups vectorise)."""
    local = local_table(table)
    scale = 1.0 / (math.pi * eta * eta)
    for i in range(out.shape[0]):
        j, w = _node(z_i[i])
        k, v = _node(z_o[i])
        t_i, t_o = (1.0 - w) * local[j] + w * local[j + 1], (1.0 - v) * local[k] + v * local[k + 1]
        out[i] = t_i * t_o * scale
    return out


@jit
def plastic(tan2_h, tan2_i, tan2_o, factor, fresnel, alpha2, ks, out):
    """Mitsuba 3's roughplastic specular column times ``ks``: ``ks F(V.H; eta) D G1(L)
    G1(V) / (4 (N.L)(N.V))``, GGX, ``F`` given (``fresnel``)."""
    inv_a2 = 1.0 / alpha2
    scale = 4.0 * _INV_PI * inv_a2
    for i in range(out.shape[0]):
        s = scale * _ggx_dg(tan2_h[i], tan2_i[i], tan2_o[i], factor[i], inv_a2, alpha2)
        out[i] = ks * (s * fresnel[i])
    return out


@jit
def plastic_evaluate(
    z_i, z_o, tan2_h, tan2_i, tan2_o, factor, fresnel, table, eta, alpha2, kd, ks, out
):
    """Mitsuba 3's roughplastic in one pass: ``kd`` times the column of
    :func:`plastic_diffuse` plus :func:`plastic` (measured: 6.1 -> 3.2 ns a pair,
    against the two passes of before, whose first could not vectorise)."""
    local = local_table(table)
    diffuse_scale = 1.0 / (math.pi * eta * eta)
    inv_a2 = 1.0 / alpha2
    scale = 4.0 * _INV_PI * inv_a2
    for i in range(out.shape[0]):
        j, w = _node(z_i[i])
        k, v = _node(z_o[i])
        t_i, t_o = (1.0 - w) * local[j] + w * local[j + 1], (1.0 - v) * local[k] + v * local[k + 1]
        diffuse = t_i * t_o * diffuse_scale
        s = scale * _ggx_dg(tan2_h[i], tan2_i[i], tan2_o[i], factor[i], inv_a2, alpha2)
        out[i] = kd * diffuse + ks * (s * fresnel[i])
    return out


@jit
def plastic_unit(z_i, z_o, tan2_h, fresnel, table, eta, alpha2, kd, ks, out):
    """:func:`plastic_evaluate` for directions of unit length (within ``UNIT_ERROR``:
    :func:`~brdffit.kernels.inputs_renderers.unit_directions`) from four arrays, not
    seven: the cosines are the table's ``z`` clamped as the geometry's (``N.L =
    max(z, MIN_COSINE)``), and the specular term is
    :func:`~brdffit.kernels.loops_principled.principled_unit`'s ``p^2 / (pi alpha^2
    q^2 (c_L + S_L)(c_V + S_V))``, ``p = 1 + tan^2 theta_h = 1 / (N.H)^2``, ``q = 1 +
    tan^2 theta_h / alpha^2``, ``S(c) = sqrt(c^2 (1 - alpha^2) + alpha^2)``: GGX's
    ``D G1(L) G1(V) / (4 (N.L)(N.V))`` with ``tan^2 = (1 - c^2) / c^2``: 40 bytes a
    pair with the output instead of 64. Measured beside :func:`plastic_evaluate` in
    one process at 1 M pairs: the same in the cache (2.2 ns a pair, the table's
    gathers, two roots and a division), 1.05-1.3x streamed from memory while other
    processes load it (a reciprocal by
    :func:`~brdffit.kernels.elementary.fast_reciprocal` in place of the division was
    slower here: 0.91x)."""
    local = local_table(table)
    diffuse_scale = 1.0 / (math.pi * eta * eta)
    inv_a2 = 1.0 / alpha2
    scale = _INV_PI * inv_a2
    b = 1.0 - alpha2
    for i in range(out.shape[0]):
        zi, zo = z_i[i], z_o[i]
        j, w = _node(zi)
        k, v = _node(zo)
        t_i, t_o = (1.0 - w) * local[j] + w * local[j + 1], (1.0 - v) * local[k] + v * local[k + 1]
        ci, co = max(zi, MIN_COSINE), max(zo, MIN_COSINE)
        t2 = tan2_h[i]
        p, q = 1.0 + t2, 1.0 + t2 * inv_a2
        g = (ci + math.sqrt(ci * ci * b + alpha2)) * (co + math.sqrt(co * co * b + alpha2))
        dg = scale * (p * p) / (q * q * g)
        out[i] = kd * (t_i * t_o * diffuse_scale) + ks * (dg * fresnel[i])
    return out


@jit
def dielectric(cos_d, eta, out):
    """The unpolarised dielectric Fresnel factor ``F(V.H; eta)``: an input of
    :func:`principled` and :func:`plastic`, whose index a fit usually holds."""
    e2 = eta * eta
    for i in range(out.shape[0]):
        out[i] = 0.5 * _twice_fresnel_dielectric(max(cos_d[i], 1e-300), e2)
    return out
