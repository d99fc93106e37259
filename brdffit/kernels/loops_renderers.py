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

from ._compile import FLAGS, jit

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
def _ggx_dg_anisotropic(tan2_t, tan2_b, tx_i, ty_i, tx_o, ty_o, factor, inv_u2, inv_v2, u2, v2):
    """As :func:`_ggx_dg` with ``alpha_u`` along T, ``alpha_v`` along B (Heitz 2014,
    section 5.4), without its constant ``4 / (pi alpha_u alpha_v)``."""
    t = 1.0 + tan2_t * inv_u2 + tan2_b * inv_v2
    g = (1.0 + math.sqrt(1.0 + u2 * tx_i + v2 * ty_i)) * (
        1.0 + math.sqrt(1.0 + u2 * tx_o + v2 * ty_o)
    )
    return factor / (t * t * g)


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


@jit
def gltf_anisotropic(
    hx, hy, hz, sx_i, sy_i, sx_o, sy_o, inv_4_cos, weight,
    alpha_t, alpha_b, cos_r, sin_r, metallic, base, column, out,
):  # fmt: skip
    """glTF with KHR_materials_anisotropy: ``D = 1 / (pi alpha_t alpha_b q^2)``, ``q =
    (H_t/alpha_t)^2 + (H_b/alpha_b)^2 + H_z^2`` with ``(t, b)`` the axes rotated by
    ``r`` (``cos_r``, ``sin_r``), and ``V = 2 / ((s_L + s_V) 4 (N.L)(N.V))``, ``s =
    sqrt(1 + (alpha_t^2 w_t^2 + alpha_b^2 w_b^2) / w_z^2)`` from the slopes ``w/w_z``."""
    inv_t, inv_b = 1.0 / alpha_t, 1.0 / alpha_b
    scale = 2.0 * _INV_PI / (alpha_t * alpha_b)
    diffuse_scale = (1.0 - metallic) * _INV_PI
    design = column.shape[0] > 0
    for i in range(out.shape[0]):
        ht = (hx[i] * cos_r + hy[i] * sin_r) * inv_t
        hb = (hy[i] * cos_r - hx[i] * sin_r) * inv_b
        q = ht * ht + hb * hb + hz[i] * hz[i]
        lt = alpha_t * (sx_i[i] * cos_r + sy_i[i] * sin_r)
        lb = alpha_b * (sy_i[i] * cos_r - sx_i[i] * sin_r)
        vt = alpha_t * (sx_o[i] * cos_r + sy_o[i] * sin_r)
        vb = alpha_b * (sy_o[i] * cos_r - sx_o[i] * sin_r)
        s = math.sqrt(1.0 + (lt * lt + lb * lb)) + math.sqrt(1.0 + (vt * vt + vb * vb))
        spec = scale * inv_4_cos[i] / (q * q * s)
        col, off = _gltf_mix(spec, weight[i], metallic, diffuse_scale)
        if design:
            column[i] = col
            out[i] = off
        else:
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
    """``a F(V.H; eta + i k) D G1(L) G1(V) / (4 (N.L)(N.V))``, GGX. ``eta = 0`` (with
    ``k`` not 0) is Mitsuba's ``material = "none"``: the numpy ``F`` is exactly 1 there
    (``a = 0`` in its form), so the loop skips it."""
    inv_a2 = 1.0 / alpha2
    scale = 4.0 * a * _INV_PI * inv_a2
    e2_k2, four_e2k2 = eta * eta - k * k, 4.0 * (eta * eta) * (k * k)
    if eta == 0.0 and k >= 1e-100:
        for i in range(out.shape[0]):
            out[i] = scale * _ggx_dg(tan2_h[i], tan2_i[i], tan2_o[i], factor[i], inv_a2, alpha2)
        return out
    for i in range(out.shape[0]):
        lobe = scale * _ggx_dg(tan2_h[i], tan2_i[i], tan2_o[i], factor[i], inv_a2, alpha2)
        out[i] = lobe * _fresnel_conductor(cos_d[i], e2_k2, four_e2k2)
    return out


@jit
def conductor_anisotropic(
    tan2_t, tan2_b, tx_i, ty_i, tx_o, ty_o, factor, cos_d, alpha_u, alpha_v, eta, k, a, out
):
    """:func:`conductor` with anisotropic GGX (``alpha_u`` along T, ``alpha_v`` along B)."""
    u2, v2 = alpha_u * alpha_u, alpha_v * alpha_v
    inv_u2, inv_v2 = 1.0 / u2, 1.0 / v2
    scale = 4.0 * a * _INV_PI / (alpha_u * alpha_v)
    e2_k2, four_e2k2 = eta * eta - k * k, 4.0 * (eta * eta) * (k * k)
    for i in range(out.shape[0]):
        lobe = scale * _ggx_dg_anisotropic(
            tan2_t[i], tan2_b[i], tx_i[i], ty_i[i], tx_o[i], ty_o[i], factor[i],
            inv_u2, inv_v2, u2, v2,
        )  # fmt: skip
        if eta == 0.0 and k >= 1e-100:  # loop-invariant: LLVM moves it out of the loop
            out[i] = lobe
        else:
            out[i] = lobe * _fresnel_conductor(cos_d[i], e2_k2, four_e2k2)
    return out
