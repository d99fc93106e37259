"""The compiled loops of Mitsuba 3's ``principled`` reflection lobes.

As :mod:`brdffit.kernels.loops_renderers` (which imports them from here, for
:mod:`brdffit.kernels.bind_renderers`): Mitsuba 3's principled BSDF
(src/bsdfs/principled.cpp), its reflection: Burley's diffuse with retro-reflection
(Burley, Physically-based shading at Disney, SIGGRAPH 2012 course notes) and GGX
with the separable Smith masking (Walter, Marschner, Li and Torrance, EGSR 2007;
anisotropic: Heitz, JCGT 3(2), 2014, section 5.4), the dielectric Fresnel factor
mixed with Schlick's on the base colour by ``metallic``. Each loop writes the
colour's ``column`` and the ``offset`` when ``column`` has pairs, else the BRDF at
the colour ``base`` into ``out``. The loops of unit directions and the anisotropic
one read the inputs that tolerate it in float32 and compute in float64
(:mod:`brdffit.kernels.inputs_renderers` bounds the error:
:data:`~brdffit.kernels.inputs.PRINCIPLED_F32_ERROR`,
:data:`~brdffit.kernels.inputs.PRINCIPLED_ANISOTROPIC_F32_ERROR`): they were limited
by their memory traffic (benchmarks/README.md, "Principled and Fournier kernels").
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..data.geometry import MIN_COSINE
from ._compile import FLAGS, jit
from .elementary import fast_reciprocal
from .wide import prefer_wide_vectors

_INV_PI = 1.0 / math.pi


def _inline(function):
    return numba.njit(inline="always", fastmath=FLAGS)(function)


@_inline
def _schlick(c):
    """``(1 - c)^5`` in the numpy model's order of products."""
    w = 1.0 - c
    w2 = w * w
    w2 = w2 * w2
    return w * w2


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


@_inline
def _pair(t2, t2_i, t2_o, ci, co, cd, fresnel, alpha2, inv_a2, scale, metallic, rough):
    """:func:`principled`'s ``(column, offset)`` of one pair."""
    p, q = 1.0 + t2, 1.0 + t2 * inv_a2
    g_i = 1.0 + math.sqrt(1.0 + alpha2 * t2_i)
    g_o = 1.0 + math.sqrt(1.0 + alpha2 * t2_o)
    dg = scale * (p * p) * fast_reciprocal(q * q * (g_i * g_o) * (ci * co))
    return _principled_mix(dg, cd, ci, co, fresnel, metallic, rough)


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
    accepted within 1e-6 of unit length, and there it was 1e-6 off the numpy model.)
    Float64 inputs; design and values in separate loops (see :func:`principled_unit`)."""
    inv_a2 = 1.0 / alpha2
    scale = _INV_PI * inv_a2
    if column.shape[0] > 0:
        for i in range(out.shape[0]):
            column[i], out[i] = _pair(
                tan2_h[i], tan2_i[i], tan2_o[i], cos_i[i], cos_o[i], cos_d[i], fresnel[i],
                alpha2, inv_a2, scale, metallic, rough,
            )  # fmt: skip
        return out
    for i in range(out.shape[0]):
        col, off = _pair(
            tan2_h[i], tan2_i[i], tan2_o[i], cos_i[i], cos_o[i], cos_d[i], fresnel[i],
            alpha2, inv_a2, scale, metallic, rough,
        )  # fmt: skip
        out[i] = off + base * col
    return out


@_inline
def _unit_pair(t2, ci, co, cd, fresnel, alpha2, inv_a2, scale, b, metallic, rough):
    """:func:`principled_unit`'s ``(column, offset)`` of one pair; its inputs converted
    to float64 first (float32 products would round to float32)."""
    t2, ci, co = np.float64(t2), np.float64(ci), np.float64(co)
    p, q = 1.0 + t2, 1.0 + t2 * inv_a2
    g = (ci + math.sqrt(ci * ci * b + alpha2)) * (co + math.sqrt(co * co * b + alpha2))
    dg = scale * (p * p) * fast_reciprocal(q * q * g)
    return _principled_mix(dg, cd, ci, co, np.float64(fresnel), metallic, rough)


@jit
def principled_unit(
    tan2_h, cos_i, cos_o, cos_d, fresnel, alpha2, metallic, rough, base, column, out
):
    """:func:`principled` for directions of unit length (within ``UNIT_ERROR``, see
    :func:`brdffit.kernels.inputs_renderers.unit_directions`), where ``tan^2 = (1 -
    c^2) / c^2``: from five arrays, not :func:`principled`'s seven (measured: +20 % for
    six against eight, then 3.0 -> 2.6 ns a pair in the cache for five with
    :func:`~brdffit.kernels.elementary.fast_reciprocal`):
    ``G1(c) = 2 / (1 + sqrt(1 + alpha^2 tan^2)) = 2 c / (c + S(c))``, ``S(c) =
    sqrt(c^2 (1 - alpha^2) + alpha^2)`` (a sum of positive terms: alpha <= 1), and
    ``(N.H)^2 = 1 / (1 + tan^2 theta_h)`` (also where the geometry clamps ``N.H``),
    so ``D G1(L) G1(V) / (4 (N.L)(N.V)) = p^2 / (pi alpha^2 q^2 (c_L + S_L)(c_V +
    S_V))`` with ``p = 1 + tan^2 theta_h``, ``q = 1 + tan^2 theta_h / alpha^2``.

    ``tan2_h``, ``cos_i``, ``cos_o`` and ``fresnel`` may be float32
    (:func:`~brdffit.kernels.inputs_renderers.principled_inputs` states the error);
    the arithmetic is float64. One loop for the design (``column`` given) and one for
    the values: a test of ``column`` inside the loop cost 0.5-1.4 ns of 2.2-4.6 a
    pair (measured at 1 M pairs)."""
    inv_a2 = 1.0 / alpha2
    scale = _INV_PI * inv_a2
    b = 1.0 - alpha2
    if column.shape[0] > 0:
        for i in range(out.shape[0]):
            column[i], out[i] = _unit_pair(
                tan2_h[i], cos_i[i], cos_o[i], cos_d[i], fresnel[i],
                alpha2, inv_a2, scale, b, metallic, rough,
            )  # fmt: skip
        return out
    for i in range(out.shape[0]):
        col, off = _unit_pair(
            tan2_h[i], cos_i[i], cos_o[i], cos_d[i], fresnel[i],
            alpha2, inv_a2, scale, b, metallic, rough,
        )  # fmt: skip
        out[i] = off + base * col
    return out


@_inline
def _anisotropic_pair(
    lx, ly, lz, vx, vy, vz, tx, ty, cd, fresnel, u2, v2, inv_u2, inv_v2, scale, metallic, rough
):  # fmt: skip
    """:func:`principled_anisotropic`'s ``(column, offset)`` of one pair, in float64."""
    lx, ly, lz = np.float64(lx), np.float64(ly), np.float64(lz)
    vx, vy, vz = np.float64(vx), np.float64(vy), np.float64(vz)
    tx, ty = np.float64(tx), np.float64(ty)
    ci, co = max(lz, MIN_COSINE), max(vz, MIN_COSINE)
    si = math.sqrt(ci * ci + (u2 * (lx * lx) + v2 * (ly * ly)))
    so = math.sqrt(co * co + (u2 * (vx * vx) + v2 * (vy * vy)))
    p, q = 1.0 + (tx + ty), 1.0 + (tx * inv_u2 + ty * inv_v2)
    dg = scale * (p * p) / (q * q * ((ci + si) * (co + so)))
    return _principled_mix(dg, cd, ci, co, np.float64(fresnel), metallic, rough)


@jit
def principled_anisotropic(
    lx, ly, lz, vx, vy, vz, tan2_t, tan2_b, cos_d, fresnel,
    alpha_u, alpha_v, metallic, rough, base, column, out,
):  # fmt: skip
    """:func:`principled` with anisotropic GGX (``alpha_u`` along T, ``alpha_v`` along
    B), from the components of L and V, ``tan2_t = (H.T / N.H)^2``, ``tan2_b = (H.B /
    N.H)^2``, ``V.H`` and ``F``
    (:func:`~brdffit.kernels.inputs_renderers.principled_anisotropic_inputs`: all but
    ``V.H`` float32, and the error that adds): Heitz's ``D = p^2 / (pi alpha_u alpha_v
    q^2)``, ``p = 1 + tan2_t + tan2_b = 1 / (N.H)^2``, ``q = 1 + tan2_t / alpha_u^2 +
    tan2_b / alpha_v^2``, and ``G1(L) / (N.L) = 2 / (c_L + S_L)``, ``S_L = sqrt(c_L^2 +
    alpha_u^2 l_x^2 + alpha_v^2 l_y^2)`` (JCGT 3(2), 2014, section 5.4; ``c_L = N.L``
    clamped as the geometry's): sums of positive terms, two roots and one division.
    512-bit vectors where the processor has them
    (:func:`~brdffit.kernels.wide.prefer_wide_vectors`). Measured at 1 M pairs beside
    the loop before (seven float64 arrays, ``H`` formed from L and V, three roots,
    the test of ``column`` inside the loop): 5.4-6.0 -> 3.7-3.8 ns a pair streamed
    from memory, 3.7-5.1 -> 2.6-3.5 in the cache; then the division in place of
    :func:`~brdffit.kernels.elementary.fast_reciprocal` (about ten instructions a
    vector of eight, where the loop's instructions and not its divider bound it):
    1.11x streamed, 1.07x in the cache (one process, 5 rounds)."""
    prefer_wide_vectors()
    u2, v2 = alpha_u * alpha_u, alpha_v * alpha_v
    inv_u2, inv_v2 = 1.0 / u2, 1.0 / v2
    scale = _INV_PI / (alpha_u * alpha_v)
    if column.shape[0] > 0:
        for i in range(out.shape[0]):
            column[i], out[i] = _anisotropic_pair(
                lx[i], ly[i], lz[i], vx[i], vy[i], vz[i], tan2_t[i], tan2_b[i], cos_d[i],
                fresnel[i], u2, v2, inv_u2, inv_v2, scale, metallic, rough,
            )  # fmt: skip
        return out
    for i in range(out.shape[0]):
        col, off = _anisotropic_pair(
            lx[i], ly[i], lz[i], vx[i], vy[i], vz[i], tan2_t[i], tan2_b[i], cos_d[i],
            fresnel[i], u2, v2, inv_u2, inv_v2, scale, metallic, rough,
        )  # fmt: skip
        out[i] = off + base * col
    return out
