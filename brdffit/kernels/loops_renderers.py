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

import numba

from ..data.geometry import MIN_COSINE
from ..models.renderer_native import PERFECT_K_MIN
from ._compile import FLAGS, jit
from ._compile import _bits_of_double as _bits
from ._compile import _double_from_bits as _float
from .loops import _twice_fresnel_dielectric
from .loops_microfacet import ggx_anisotropic_dg, sqrt_short, wide
from .loops_principled import (  # noqa: F401 (the loops bind_renderers looks up here)
    _inline,
    principled,
    principled_anisotropic,
    principled_unit,
)
from .plastic_table import TABLE_SIZE, local_table

_INV_PI = 1.0 / math.pi
_F0 = 0.04  # glTF's dielectric reflectance at normal incidence (ior 1.5)
#: ``L + V`` times ``_UP`` in :func:`_anisotropic_spec` (exact): its squares stay
#: normal numbers down to ``|L + V| = 4e-290`` (L = -V but for their heights ``z``
#: gave ``S = 0`` and NaN for ``z < 1e-162``), and ``Q <= S / a^2`` below 2^1023 for
#: widths down to 2^-50; ``_HALF_DOWN`` takes ``sqrt(S _UP^2)`` back to ``sqrt(S) / 2``,
#: exactly.
_UP, _HALF_DOWN = 2.0**450, 0.5 * 2.0**-450


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


#: The fast-math flags of :func:`_square_sum` and :func:`_exact_root`: no fused
#: multiply-adds and no approximate functions, so that they round as numpy does.
_EXACT = FLAGS - {"contract", "afn", "arcp"}


@numba.njit(cache=True, fastmath=_EXACT, error_model="numpy")
def _square_sum(x, y, z):
    """``x^2 + y^2 + z^2`` in that order, each step rounded: the geometry's ``|L + V|^2``."""
    square = x * x
    square += y * y
    square += z * z
    return square


@numba.njit(cache=True, fastmath=_EXACT, error_model="numpy")
def _exact_root(x):
    """``sqrt(x)`` correctly rounded (numpy's), never an estimate."""
    return math.sqrt(x)


@_inline
def _anisotropic_spec(lx, ly, lz, vx, vy, vz, tc, ts, bc, bs, hc, hs, kc, ks):
    """``(D V, w)`` of :func:`gltf_anisotropic` at one pair from the components of L and
    V: ``D V`` without its constant ``1 / (2 pi a_t a_b)``, ``(S^2 / Q^2) / (c_V r_L +
    c_L r_V)``, and Schlick's weight ``w``; the axes' factors are ``tc = a_t cos r``,
    ..., ``hc = cos r / a_t``, ... (:func:`gltf_anisotropic`). ``S = |L + V|^2`` and
    ``w = (1 - clip(sqrt(S) / 2, 0, 1))^5`` as the geometry and the numpy model form
    them (the same operations on ``L + V`` times :data:`_UP`, a power of two: the same
    values; NaN only for ``|L + V| < 1e-297``); ``q = Q / S`` with ``Q = (x_t/a_t)^2 +
    (x_b/a_b)^2 + z^2`` of ``L + V`` (numpy's ``q`` of the normalised H), both scaled by
    the power of two ``p`` that takes ``S`` to [1, 2) (exact; ``S^2`` would underflow for
    ``|L + V| < 1e-77``); ``r_L = sqrt(c_L^2 + (a_t l_t)^2 + (a_b l_b)^2) = c_L sqrt(1 +
    x_L)``, numpy's root of ``Lambda`` times the clamped cosine ``c_L = max(l_z,
    MIN_COSINE)``, so that ``(s_L + s_V) 4 c_L c_V = 4 (c_V r_L + c_L r_V)`` needs no
    division; its argument is in ``[1e-20, 3]``, within
    :func:`~brdffit.kernels.loops_microfacet.sqrt_short`'s range."""
    x, y, z = (lx + vx) * _UP, (ly + vy) * _UP, (lz + vz) * _UP
    square = _square_sum(x, y, z)
    d = min(max(_HALF_DOWN * _exact_root(square), 0.0), 1.0)
    w = 1.0 - d
    w2 = w * w
    w2 *= w2
    w *= w2
    p = _float((2046 - (_bits(square) >> 52)) << 52)  # 2^-e for S = 2^e m
    xt, xb = x * hc + y * hs, y * kc - x * ks
    qs = (xt * xt + xb * xb + z * z) * p
    ss = square * p
    cl, cv = max(lz, MIN_COSINE), max(vz, MIN_COSINE)
    lt, lb = lx * tc + ly * ts, ly * bc - lx * bs
    vt, vb = vx * tc + vy * ts, vy * bc - vx * bs
    r_l = sqrt_short(cl * cl + (lt * lt + lb * lb))
    r_v = sqrt_short(cv * cv + (vt * vt + vb * vb))
    return (ss * ss) / ((qs * qs) * (cv * r_l + cl * r_v)), w


@wide
@jit
def gltf_anisotropic(lx, ly, lz, vx, vy, vz, at, ab, c, s, metallic, base, column, out):
    """glTF with KHR_materials_anisotropy: ``D = 1 / (pi a_t a_b q^2)`` (H's components
    ``h_t``, ``h_b`` on the axes ``(t, b)`` rotated by ``r``: ``c = cos r``, ``s = sin
    r``; ``q = (h_t/a_t)^2 + (h_b/a_b)^2 + h_z^2``), ``V = 2 / ((s_L + s_V) 4 (N.L)(N.V))``,
    ``s_w = sqrt(1 + (a_t^2 w_t^2 + a_b^2 w_b^2) / w_z^2)``, from the components of L and
    V alone (:func:`_anisotropic_spec`): 48 bytes a pair, where the loop before read H's
    ``x`` and ``y``, the slopes of L and V, ``1 / (4 (N.L)(N.V))`` in float32 and
    Schlick's weight (60 bytes, bound by memory; its float32 factor 5.6e-8 off numpy,
    now 1e-13). The value without a colour column: ``spec ((1 - m) F_d + m (w + base
    (1 - w))) + base (1 - m) (1 - F_d) / pi``, the numpy model's ``offset + base
    column`` regrouped, every term positive."""
    tc, ts, bc, bs = at * c, at * s, ab * c, ab * s  # a_t l_t = l_x tc + l_y ts, ...
    hc, hs, kc, ks = c / at, s / at, c / ab, s / ab  # h_t / a_t = h_x hc + h_y hs, ...
    scale = 0.5 * _INV_PI / (at * ab)
    diffuse_scale = (1.0 - metallic) * _INV_PI
    if column.shape[0] > 0:
        for i in range(out.shape[0]):
            spec, w = _anisotropic_spec(
                lx[i], ly[i], lz[i], vx[i], vy[i], vz[i], tc, ts, bc, bs, hc, hs, kc, ks
            )
            column[i], out[i] = _gltf_mix(scale * spec, w, metallic, diffuse_scale)
        return out
    scaled_diffuse = base * diffuse_scale
    for i in range(out.shape[0]):
        spec, w = _anisotropic_spec(
            lx[i], ly[i], lz[i], vx[i], vy[i], vz[i], tc, ts, bc, bs, hc, hs, kc, ks
        )
        fd = w * (1.0 - _F0) + _F0
        mixed = (1.0 - metallic) * fd + metallic * (w + base * (1.0 - w))
        out[i] = (scale * spec) * mixed + scaled_diffuse * (1.0 - fd)
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
