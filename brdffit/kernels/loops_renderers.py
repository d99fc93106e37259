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
  Physically-based shading at Disney, SIGGRAPH 2012 course notes).

Models linear in a colour (glTF, principled) write the colour's ``column`` and the
``offset`` when ``column`` has pairs, else the BRDF at the colour ``base`` into ``out``.
"""

from __future__ import annotations

import math

import numba

from ..data.geometry import MIN_COSINE
from ..models.renderer_native import PERFECT_K_MIN
from ._compile import FLAGS, jit
from .elementary import fast_reciprocal
from .loops import _twice_fresnel_dielectric
from .plastic_table import TABLE_SIZE, local_table

_INV_PI = 1.0 / math.pi
_F0 = 0.04  # glTF's dielectric reflectance at normal incidence (ior 1.5)


def _inline(function):
    return numba.njit(inline="always", fastmath=FLAGS)(function)


@_inline
def _ggx_dg(tan2_h, tan2_i, tan2_o, factor, inv_a2, alpha2):
    """``D G1(L) G1(V) / (4 (N.L)(N.V))`` of isotropic GGX without its constant
    ``4 / (pi alpha^2)``; ``factor`` is ``1 / (4 (N.L)(N.V) (N.H)^4)``."""
    t = 1.0 + tan2_h * inv_a2
    g = (1.0 + math.sqrt(1.0 + alpha2 * tan2_i)) * (1.0 + math.sqrt(1.0 + alpha2 * tan2_o))
    return factor / (t * t * g)


@_inline
def _ggx_dg_directions(lx, ly, lz, vx, vy, vz, u2, v2, inv_u2, inv_v2):
    """Anisotropic GGX's ``D G1(L) G1(V) / (4 (N.L)(N.V))`` times ``pi alpha_u
    alpha_v`` from the components of L and V, with the geometry's clamps
    (:class:`~brdffit.data.geometry.Geometry`); also ``|L + V|^2``, ``N.L`` and ``N.V``.

    With ``h = L + V`` (not normalised), ``s = |h|^2`` and ``c = s^(1/2) N.H`` (``N.H``
    clamped to [1e-10, 1]: ``c^2 = min(max(h_z^2, 1e-20 s), s)``), Heitz's ``D =
    s^2 / (pi alpha_u alpha_v Q^2)``, ``Q = c^2 + h_x^2/alpha_u^2 + h_y^2/alpha_v^2``,
    and ``G1(L) = 2 c_L / (c_L + S_L)``, ``S_L = sqrt(c_L^2 + alpha_u^2 l_x^2 + alpha_v^2
    l_y^2)`` (JCGT 3(2), 2014, section 5.4): sums of positive terms, so within
    rounding of the numpy model's tangent form, with no division but one."""
    hx, hy, hz = lx + vx, ly + vy, lz + vz
    s = hx * hx + hy * hy + hz * hz
    c2 = min(max(hz * hz, 1e-20 * s), s)
    q = c2 + (hx * hx * inv_u2 + hy * hy * inv_v2)
    ci, co = max(lz, MIN_COSINE), max(vz, MIN_COSINE)
    si = math.sqrt(ci * ci + (u2 * (lx * lx) + v2 * (ly * ly)))
    so = math.sqrt(co * co + (u2 * (vx * vx) + v2 * (vy * vy)))
    return (s * s) * fast_reciprocal(q * q * ((ci + si) * (co + so))), s, ci, co


@_inline
def _schlick(c):
    """``(1 - c)^5`` in the numpy model's order of products."""
    w = 1.0 - c
    w2 = w * w
    w2 = w2 * w2
    return w * w2


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
def _rotated_spec(sx_h, sy_h, sx_i, sy_i, sx_o, sy_o, factor, at, ab, inv_t, inv_b, c, s):
    """``D V`` of :func:`gltf_anisotropic` at one pair, without its ``2 / (pi at ab)``."""
    ht, hb = (sx_h * c + sy_h * s) * inv_t, (sy_h * c - sx_h * s) * inv_b
    q = 1.0 + (ht * ht + hb * hb)
    lt, lb = at * (sx_i * c + sy_i * s), ab * (sy_i * c - sx_i * s)
    vt, vb = at * (sx_o * c + sy_o * s), ab * (sy_o * c - sx_o * s)
    root = math.sqrt(1.0 + (lt * lt + lb * lb)) + math.sqrt(1.0 + (vt * vt + vb * vb))
    return factor / (q * q * root)


@jit
def gltf_anisotropic(
    sx_h, sy_h, sx_i, sy_i, sx_o, sy_o, factor, weight,
    at, ab, c, s, metallic, base, column, out,
):  # fmt: skip
    """glTF with KHR_materials_anisotropy: ``D = 1 / (pi a_t a_b H_z^4 q^2)``, ``q = 1 +
    (h_t/a_t)^2 + (h_b/a_b)^2`` with ``h = H/H_z`` on the axes ``(t, b)`` rotated by
    ``r`` (``c = cos r``, ``s = sin r``), and ``V = 2 / ((s_L + s_V) 4 (N.L)(N.V))``,
    ``s_w = sqrt(1 + a_t^2 w_t^2 + a_b^2 w_b^2)`` from the slopes ``w / w_z``;
    ``factor = 1 / (4 (N.L)(N.V) H_z^4)``."""
    inv_t, inv_b = 1.0 / at, 1.0 / ab
    scale = 2.0 * _INV_PI / (at * ab)
    diffuse_scale = (1.0 - metallic) * _INV_PI
    if column.shape[0] > 0:
        for i in range(out.shape[0]):
            spec = scale * _rotated_spec(
                sx_h[i], sy_h[i], sx_i[i], sy_i[i], sx_o[i], sy_o[i], factor[i],
                at, ab, inv_t, inv_b, c, s,
            )  # fmt: skip
            column[i], out[i] = _gltf_mix(spec, weight[i], metallic, diffuse_scale)
        return out
    for i in range(out.shape[0]):
        spec = scale * _rotated_spec(
            sx_h[i], sy_h[i], sx_i[i], sy_i[i], sx_o[i], sy_o[i], factor[i],
            at, ab, inv_t, inv_b, c, s,
        )  # fmt: skip
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


@jit
def conductor_anisotropic(lx, ly, lz, vx, vy, vz, alpha_u, alpha_v, eta, k, a, out):
    """:func:`conductor` with anisotropic GGX (``alpha_u`` along T, ``alpha_v`` along
    B), from the components of L and V (:func:`_ggx_dg_directions`; ``V.H = |L + V| /
    2``, clamped to 1, as the geometry's): six arrays, not seven (eight with ``V.H``)."""
    u2, v2 = alpha_u * alpha_u, alpha_v * alpha_v
    inv_u2, inv_v2 = 1.0 / u2, 1.0 / v2
    scale = a * _INV_PI / (alpha_u * alpha_v)
    e2_k2, four_e2k2 = eta * eta - k * k, 4.0 * (eta * eta) * (k * k)
    if eta == 0.0 and k >= PERFECT_K_MIN:  # F = 1: V.H is not needed
        for i in range(out.shape[0]):
            dg, _, _, _ = _ggx_dg_directions(
                lx[i], ly[i], lz[i], vx[i], vy[i], vz[i], u2, v2, inv_u2, inv_v2
            )
            out[i] = scale * dg
        return out
    for i in range(out.shape[0]):
        dg, s, _, _ = _ggx_dg_directions(
            lx[i], ly[i], lz[i], vx[i], vy[i], vz[i], u2, v2, inv_u2, inv_v2
        )
        fresnel = _fresnel_conductor(min(0.5 * math.sqrt(s), 1.0), e2_k2, four_e2k2)
        out[i] = (scale * dg) * fresnel
    return out


@_inline
def _principled_mix(dg, cd, ci, co, fresnel, metallic, rough):
    """Mitsuba principled's ``(column, offset)`` from ``dg = D G / (4 (N.L)(N.V))``:
    Burley's diffuse with retro-reflection ``R = 2 roughness (V.H)^2`` and the
    dielectric ``fresnel`` mixed with Schlick's on base_color by ``metallic``."""
    w, w_i, w_o = _schlick(cd), _schlick(ci), _schlick(co)
    retro = 2.0 * rough * cd * cd
    diffuse = (1.0 - 0.5 * w_i) * (1.0 - 0.5 * w_o)
    diffuse += retro * ((w_i + w_o) + (w_i * w_o) * (retro - 1.0))
    column = (1.0 - metallic) * _INV_PI * diffuse + metallic * (1.0 - w) * dg
    return column, ((1.0 - metallic) * fresnel + metallic * w) * dg


@jit
def principled(
    tan2_h, tan2_i, tan2_o, cos_i, cos_o, cos_d, fresnel,
    alpha2, metallic, rough, base, column, out,
):  # fmt: skip
    """Mitsuba 3's principled reflection with isotropic GGX of width ``alpha``;
    ``fresnel`` the dielectric Fresnel factor of its index (:func:`dielectric`).

    ``(N.H)^2 = 1 / (1 + tan^2 theta_h)`` (also where the geometry clamps ``N.H``), so
    ``D G1(L) G1(V) / (4 (N.L)(N.V)) = p^2 / (pi alpha^2 q^2 g (N.L)(N.V))``, ``p = 1 +
    tan^2 theta_h``, ``q = 1 + tan^2 theta_h / alpha^2``, ``g = (1 + sqrt(1 + alpha^2
    tan^2 theta_L))(1 + sqrt(1 + alpha^2 tan^2 theta_V))``: seven arrays and one
    reciprocal. (The loop of before read six, with ``G1`` from the cosines alone,
    ``tan^2 = (1 - c^2) / c^2``, which holds for unit L and V only: directions are
    accepted within 1e-6 of unit length, and there it was 1e-6 off the numpy model.)"""
    inv_a2 = 1.0 / alpha2
    scale = _INV_PI * inv_a2
    for i in range(out.shape[0]):
        ci, co, t2 = cos_i[i], cos_o[i], tan2_h[i]
        p, q = 1.0 + t2, 1.0 + t2 * inv_a2
        g_i = 1.0 + math.sqrt(1.0 + alpha2 * tan2_i[i])
        g_o = 1.0 + math.sqrt(1.0 + alpha2 * tan2_o[i])
        dg = scale * (p * p) * fast_reciprocal(q * q * (g_i * g_o) * (ci * co))
        col, off = _principled_mix(dg, cos_d[i], ci, co, fresnel[i], metallic, rough)
        if column.shape[0] > 0:
            column[i], out[i] = col, off
        else:
            out[i] = off + base * col
    return out


@jit
def principled_anisotropic(
    lx, ly, lz, vx, vy, vz, fresnel, alpha_u, alpha_v, metallic, rough, base, column, out
):
    """:func:`principled` with anisotropic GGX (``alpha_u`` along T, ``alpha_v`` along
    B), from the components of L and V (:func:`_ggx_dg_directions`; ``V.H = |L + V| /
    2``, clamped to 1, as the geometry's): seven arrays, not eleven (measured at 1M
    pairs: 6.0 -> 4.4 ns a pair, though 0.5 ns more in the cache)."""
    u2, v2 = alpha_u * alpha_u, alpha_v * alpha_v
    inv_u2, inv_v2 = 1.0 / u2, 1.0 / v2
    scale = _INV_PI / (alpha_u * alpha_v)
    for i in range(out.shape[0]):
        dg, s, ci, co = _ggx_dg_directions(
            lx[i], ly[i], lz[i], vx[i], vy[i], vz[i], u2, v2, inv_u2, inv_v2
        )
        cd = min(0.5 * math.sqrt(s), 1.0)
        col, off = _principled_mix(scale * dg, cd, ci, co, fresnel[i], metallic, rough)
        if column.shape[0] > 0:
            column[i], out[i] = col, off
        else:
            out[i] = off + base * col
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
def dielectric(cos_d, eta, out):
    """The unpolarised dielectric Fresnel factor ``F(V.H; eta)``: an input of
    :func:`principled` and :func:`plastic`, whose index a fit usually holds."""
    e2 = eta * eta
    for i in range(out.shape[0]):
        out[i] = 0.5 * _twice_fresnel_dielectric(max(cos_d[i], 1e-300), e2)
    return out
