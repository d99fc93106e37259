"""The compiled per-pair loops: one fused pass per evaluation.

Each loop reads the parameter-free inputs of :mod:`brdffit.kernels.inputs` and
writes ``out[i] = b + a * lobe_i``: with ``a = 1, b = 0`` the lobe column of the
variable projection, with ``a = ks, b = kd / pi`` the BRDF itself, without a
temporary array. Where a lobe has an exponential, its positive factors (the
geometry's, as a cached logarithm, and the parameters' scale) are added to the
exponent: :func:`~brdffit.kernels._compile.fast_exp` flushes results under 3.3e-308
to 0, and a tiny exponential times a large factor (``1/((N.L)(N.V))`` reaches 1e20
at grazing angles) would otherwise lose a value that numpy keeps. The formulas are
those of the numpy models (MODELS.md), whose docstrings cite the primary sources:

- GGX ``D`` and Smith ``G1`` (Walter, Marschner, Li and Torrance, Microfacet
  models for refraction through rough surfaces, EGSR 2007, eqs. 33-34; the Beckmann
  models and anisotropic GGX are in :mod:`brdffit.kernels.loops_microfacet`);
- Ward's isotropic and anisotropic lobes (Ward, SIGGRAPH 1992, eq. 5a);
- Cook-Torrance with V-cavity shadowing and the dielectric Fresnel term or Schlick's
  (Cook and Torrance, ACM TOG 1(1), 1982), Torrance-Sparrow's Gaussian in the angle
  (Torrance and Sparrow, JOSA 57(9), 1967);
- Blinn's ``(N.H)^n`` (Blinn, SIGGRAPH 1977), Phong's ``max(0, R.V)^n`` (Phong,
  CACM 18(6), 1975) and their normalised forms (``(n+8)/(8 pi)``: Akenine-Moller,
  Haines and Hoffman, Real-Time Rendering, 3rd ed., 2008; ``(n+2)/(2 pi)``: Lewis,
  Computer Graphics Forum 13(2), 1994);
- Ashikhmin-Shirley (Ashikhmin and Shirley, JGT 5(2), 2000, eqs. 4-5).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ._compile import FLAGS, fast_exp, jit

_INV_PI = 1.0 / math.pi


@jit
def ggx(tan2_h, tan2_i, tan2_o, factor, weight, alpha2, f0, a, b, out):
    """GGX with Smith ``G1 = 2 / (1 + sqrt(1 + alpha^2 tan^2))`` and Schlick's F."""
    inv_a2 = 1.0 / alpha2
    scale = 4.0 * a * _INV_PI * inv_a2
    for i in range(out.shape[0]):
        t = 1.0 + tan2_h[i] * inv_a2
        g = (1.0 + math.sqrt(1.0 + alpha2 * tan2_i[i])) * (
            1.0 + math.sqrt(1.0 + alpha2 * tan2_o[i])
        )
        fresnel = f0 + (1.0 - f0) * weight[i]
        out[i] = b + scale * factor[i] * fresnel / (t * t * g)
    return out


@jit
def ward(tan2_h, log_factor, alpha2, a, b, out):
    """``exp(-tan^2/alpha^2) / (4 pi alpha^2 sqrt((N.L)(N.V)))``; ``log_factor`` is
    ``ln(1 / (4 pi sqrt((N.L)(N.V))))``."""
    if a <= 0.0:
        out[:] = b
        return out
    inv_a2 = 1.0 / alpha2
    log_scale = math.log(a * inv_a2)
    for i in range(out.shape[0]):
        out[i] = b + fast_exp(log_scale + log_factor[i] - tan2_h[i] * inv_a2)
    return out


@numba.njit(inline="always", fastmath=FLAGS)
def _twice_fresnel_dielectric(c, e2):
    """``Rs + Rp`` (twice the unpolarised dielectric Fresnel factor) at ``c = V.H > 0``,
    ``e2 = eta^2``: ``g = sqrt(max(0, eta^2 - 1 + c^2))``, ``Rs = ((c - g)/(c + g))^2``
    and ``Rp = ((eta^2 c - g)/(eta^2 c + g))^2``
    (:func:`brdffit.models.shared.fresnel_dielectric`), over one common denominator:
    one division instead of three."""
    g = math.sqrt(max(c * c + (e2 - 1.0), 0.0))
    s_num, s_den = (c - g) * (e2 * c + g), (c + g) * (e2 * c + g)
    p_num = (e2 * c - g) * (c + g)
    den = s_den * s_den  # > 0: V.H >= (N.L + N.V)/2 > 0 for valid pairs
    return (s_num * s_num + p_num * p_num) / den if den > 0.0 else 2.0


@jit
def cook_torrance(tan2_h, log_factor, cos_d, m2, eta, a, b, out):
    """Beckmann ``D``, V-cavity ``G`` (in ``log_factor``, the logarithm of
    ``G / (4 pi (N.L)(N.V) (N.H)^4)``) and the exact dielectric Fresnel factor."""
    if a <= 0.0:
        out[:] = b
        return out
    inv_m2 = 1.0 / m2
    e2 = eta * eta
    log_scale = math.log(0.5 * a * inv_m2)
    for i in range(out.shape[0]):
        fresnel = _twice_fresnel_dielectric(cos_d[i], e2)
        out[i] = b + fresnel * fast_exp(log_scale + log_factor[i] - tan2_h[i] * inv_m2)
    return out


@jit
def cook_torrance_schlick(tan2_h, log_factor, weight, m2, f0, a, b, out):
    """:func:`cook_torrance` with Schlick's ``F = f0 + (1 - f0) weight``."""
    if a <= 0.0:
        out[:] = b
        return out
    inv_m2 = 1.0 / m2
    log_scale = math.log(a * inv_m2)
    for i in range(out.shape[0]):
        fresnel = f0 + (1.0 - f0) * weight[i]
        out[i] = b + fresnel * fast_exp(log_scale + log_factor[i] - tan2_h[i] * inv_m2)
    return out


@jit
def torrance_sparrow(theta2_h, log_factor, cos_d, m2, eta, a, b, out):
    """Torrance-Sparrow: ``exp(-theta_h^2/m^2)``, V-cavity ``G`` (in ``log_factor``, the
    logarithm of ``G / (4 (N.L)(N.V))``) and the exact dielectric Fresnel factor:
    :func:`cook_torrance`'s loop with ``theta_h^2`` for ``tan^2`` and no ``1/m^2`` in
    the scale (``a m^2`` cancels it)."""
    return cook_torrance(theta2_h, log_factor, cos_d, m2, eta, a * m2, b, out)


@jit
def blinn(log_cos_h, n, a, b, out):
    """``(N.H)^n = exp(n ln(N.H))``."""
    if a <= 0.0:
        out[:] = b
        return out
    log_a = math.log(a)
    for i in range(out.shape[0]):
        out[i] = b + fast_exp(n * log_cos_h[i] + log_a)
    return out


@jit
def power(log_base, n, factor, a, b, out):
    """``factor base^n = exp(n ln(base) + ln(factor))``: Phong's ``max(0, R.V)^n``,
    Heidrich and Seidel's fibre cosine (SIGGRAPH 1999) and the energy-normalised Phong
    and Blinn lobes (``log_base`` finite: ``ln 0`` is stored as
    -1e300, whose ``n``-th multiple is flushed to 0 as numpy's ``exp(-inf)`` is 0)."""
    if a <= 0.0:
        out[:] = b
        return out
    log_a = math.log(a * factor)
    for i in range(out.shape[0]):
        out[i] = b + fast_exp(n * log_base[i] + log_a)
    return out


@jit
def schlick(cos_h, one_minus_cos_h, n, a, b, out):
    """Schlick's rational lobe ``c / (n (1 - c) + c)``, ``c = N.H`` (Schlick, Computer
    Gems IV, 1994), ``1 - c`` cached without cancellation."""
    for i in range(out.shape[0]):
        c = cos_h[i]
        out[i] = b + a * c / (one_minus_cos_h[i] * n + c)
    return out


@jit
def blake(theta_h, theta2_h, lo, hi, a, b, out):
    """Blake's piecewise quadratic in ``g = theta_h`` (Blake, Disselkoen and Kuijk,
    Faster Phong shading, Computer Graphics Forum 1991; MODELS.md)
    with breakpoints ``lo < hi``: ``1 - g^2/(lo hi)`` up to ``lo``, then
    ``max(0, hi - g)^2 / (hi (hi - lo))``."""
    core_scale = -1.0 / (lo * hi)
    tail_scale = 1.0 / (hi * (hi - lo))
    for i in range(out.shape[0]):
        g = theta_h[i]
        t = max(hi - g, 0.0)
        value = 1.0 + theta2_h[i] * core_scale if g <= lo else t * t * tail_scale
        out[i] = b + a * value
    return out


@jit
def ward_anisotropic(tan2_t, tan2_b, log_factor, alpha_x, alpha_y, a, b, out):
    """``exp(-(tan2_t/alpha_x^2 + tan2_b/alpha_y^2)) / (4 pi alpha_x alpha_y
    sqrt((N.L)(N.V)))``; ``log_factor`` as in :func:`ward`."""
    if a <= 0.0:
        out[:] = b
        return out
    inv_x2 = 1.0 / (alpha_x * alpha_x)
    inv_y2 = 1.0 / (alpha_y * alpha_y)
    log_scale = math.log(a / (alpha_x * alpha_y))
    for i in range(out.shape[0]):
        exponent = log_scale + log_factor[i] - (tan2_t[i] * inv_x2 + tan2_b[i] * inv_y2)
        out[i] = b + fast_exp(exponent)
    return out


@jit
def ashikhmin_phong(log_t, log_b, nu, nv, a, b, out):
    """Ashikhmin's anisotropic Phong lobe ``sqrt((nu+1)(nv+1))/(2 pi)
    (N.H)^(nu cos^2 phi_h + nv sin^2 phi_h)`` (Ashikhmin and Shirley, JGT 5(2), 2000,
    eq. 4), ``log_t``, ``log_b`` as in :func:`ashikhmin_shirley_columns`."""
    if a <= 0.0:
        out[:] = b
        return out
    log_norm = math.log(a * math.sqrt((nu + 1.0) * (nv + 1.0)) * (0.5 * _INV_PI))
    for i in range(out.shape[0]):
        out[i] = b + fast_exp(log_norm + nu * log_t[i] + nv * log_b[i])
    return out


@jit
def ashikhmin_shirley_columns(log_t, log_b, log_scale, weight, nu, nv, column, offset):
    """Ashikhmin-Shirley's specular column ``S (1 - w)`` and offset ``S w`` with
    ``S = sqrt((nu+1)(nv+1)) (N.H)^(nu cos^2 phi_h + nv sin^2 phi_h) / (8 pi (V.H)
    max(N.L, N.V))`` (``log_scale`` the logarithm of the last factor) and
    ``w = (1 - V.H)^5``."""
    log_norm = 0.5 * math.log((nu + 1.0) * (nv + 1.0))
    for i in range(column.shape[0]):
        s = fast_exp(log_norm + log_scale[i] + nu * log_t[i] + nv * log_b[i])
        offset[i] = s * weight[i]
        column[i] = s * (1.0 - weight[i])
    return column, offset


@jit
def ashikhmin_shirley(log_t, log_b, log_scale, weight, diffuse, nu, nv, rd_eff, rs, out):
    """The whole BRDF ``rd_eff D + S (rs + (1 - rs) w)`` (``D`` the diffuse column)."""
    log_norm = 0.5 * math.log((nu + 1.0) * (nv + 1.0))
    for i in range(out.shape[0]):
        s = fast_exp(log_norm + log_scale[i] + nu * log_t[i] + nv * log_b[i])
        out[i] = rd_eff * diffuse[i] + s * (rs + (1.0 - rs) * weight[i])
    return out


@numba.njit(cache=True, error_model="numpy")
def affine_by_channel(lobe, scale, offset, out):
    """``out[i, k] = lobe[i] * scale[k] + offset[k]`` (M, C): a BRDF with its linear
    coefficients per channel, in one pass (numpy's outer product of an (M,) and a (3,)
    array runs an inner loop of 3 elements: 13 ms on a MERL file, 3 here). The same
    operations in the same order as :func:`brdffit.models.base.combine`, without
    contraction into fused multiply-adds: the same values."""
    c = scale.shape[0]
    for i in range(lobe.shape[0]):
        for k in range(c):
            out[i, k] = lobe[i] * scale[k] + offset[k]
    return out


@numba.njit(cache=True, fastmath=True, error_model="numpy")
def moments(lobe, w, wy_t):
    """``(S1, S2)`` and ``T1`` (C,) of :mod:`brdffit.kernels.normal`, ``w`` empty for
    unit weights, ``wy_t`` the weighted targets channel by channel (C, M).
    Reassociation is allowed here (``fastmath=True``): it lets LLVM vectorise the
    sums, which only changes their rounding."""
    c, m = wy_t.shape
    s1 = s2 = 0.0
    if w.shape[0] == 0:
        for i in range(m):
            s1 += lobe[i]
            s2 += lobe[i] * lobe[i]
    else:
        for i in range(m):
            s1 += w[i] * lobe[i]
            s2 += w[i] * lobe[i] * lobe[i]
    t1 = np.zeros(c)
    j = 0
    while j + 3 <= c:  # three channels per pass over the lobe (RGB data: one pass)
        a = b = d = 0.0
        r0, r1, r2 = wy_t[j], wy_t[j + 1], wy_t[j + 2]
        for i in range(m):
            a += r0[i] * lobe[i]
            b += r1[i] * lobe[i]
            d += r2[i] * lobe[i]
        t1[j], t1[j + 1], t1[j + 2] = a, b, d
        j += 3
    for k in range(j, c):
        total = 0.0
        row = wy_t[k]
        for i in range(m):
            total += row[i] * lobe[i]
        t1[k] = total
    return s1, s2, t1


@numba.njit(cache=True, fastmath=True, error_model="numpy")
def moments_by_channel(lobe, w_t, wy_t):
    """``S1``, ``S2`` and ``T1``, each (C,), of :mod:`brdffit.kernels.normal` with a
    weight per sample and channel, ``w_t`` (C, M) (the ``mixed`` loss's ``1 / sigma^2``),
    ``wy_t`` the weighted targets (C, M). One pass over the lobe per channel."""
    c, m = wy_t.shape
    s1, s2, t1 = np.zeros(c), np.zeros(c), np.zeros(c)
    for k in range(c):
        w, wy = w_t[k], wy_t[k]
        a = b = d = 0.0
        for i in range(m):
            wl = w[i] * lobe[i]
            a += wl
            b += wl * lobe[i]
            d += wy[i] * lobe[i]
        s1[k], s2[k], t1[k] = a, b, d
    return s1, s2, t1


@numba.njit(cache=True, error_model="numpy")
def half_terms(wi, wo, min_cosine, norm, cos_h, cos_d):
    """``|L + V|``, ``N.H`` and ``V.H`` of every pair in one pass over ``wi`` and ``wo``
    (M, 3), into ``norm``, ``cos_h`` and ``cos_d`` (M,): the formulas of
    :class:`brdffit.data.geometry.Geometry` (``x^2 + y^2 + z^2`` in that order, its
    root, ``(L_z + V_z) / max(|L + V|, 1e-300)`` clipped to ``[min_cosine, 1]``,
    ``|L + V| / 2`` clipped to ``[0, 1]``), the same operations without fused
    multiply-adds (no ``fastmath``): the same values. numpy took 25 ms on a MERL file
    (the (M, 3) sum ``L + V`` formed, three strided squares); a NaN stays NaN, as in
    numpy's ``maximum`` and ``clip``."""
    for i in range(wi.shape[0]):
        x, y, z = wi[i, 0] + wo[i, 0], wi[i, 1] + wo[i, 1], wi[i, 2] + wo[i, 2]
        square = x * x
        square += y * y
        square += z * z
        length = math.sqrt(square)
        norm[i] = length
        c = z / (1e-300 if length < 1e-300 else length)
        c = min_cosine if c < min_cosine else c
        cos_h[i] = 1.0 if c > 1.0 else c
        d = 0.5 * length
        d = 0.0 if d < 0.0 else d
        cos_d[i] = 1.0 if d > 1.0 else d
