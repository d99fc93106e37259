"""The compiled loops of the Beckmann models and of anisotropic GGX.

As those of :mod:`brdffit.kernels.loops` (``out[i] = b + a * lobe_i``, positive
factors of an exponential added to its exponent), with five changes that bring
these loops to about the speed of Mitsuba 3's LLVM backend on one thread (issue 13,
measured in benchmarks/README.md):

- Beckmann's Smith ``G1`` is the degree-(6, 6) rational function of
  :mod:`brdffit.kernels.smith` (within 2e-8 of the exact one; the numpy models use
  the same function, so both paths agree to rounding but for the float32 inputs
  below);
- square roots and the Beckmann loops' one division are not taken by the divider
  (whose throughput, a few doubles every several cycles, limited these loops), but
  as ``x / sqrt(x)`` with ``1 / sqrt(x)`` (and ``1 / x``) from a float32 estimate
  refined by Newton steps in float64, ``r <- r (3/2 - x r^2 / 2)`` (``r <- r (2 -
  x r)``), each of which squares the relative error: the isotropic Beckmann loop's
  reciprocal takes two steps (within a few ulps), the roots one (:func:`rsqrt`: the
  float32 estimate is within 3e-7, one step within :data:`SHORT_NEWTON_ERROR`,
  2e-13, tested; measured 1.1e-13 on the machine of ``benchmarks/``), far below the
  1e-11 to which the tests hold these loops to the numpy models. Measured, each
  beside the loop before it in one process: anisotropic GGX 1.33x for the first
  form, then 1.2-1.45x for one step instead of two (its last division kept: two
  one-step reciprocals in its place were slower); anisotropic Beckmann 1.3-1.6x for
  one step, the ``exp`` below and its float32 inputs, then 1.1x for a true last
  division (the divider otherwise idle) with the ``exp`` of degree 7;
- ``exp`` is :func:`~brdffit.kernels.elementary.fast_exp_short` (same accuracy,
  fewer operations than :func:`~brdffit.kernels._compile.fast_exp`): the Beckmann
  loop 1.2x; the anisotropic Beckmann loop's, whose float32 inputs cost more, is
  :func:`~brdffit.kernels.elementary.fast_exp_7` (within 5e-11);
- on processors with AVX-512 the loops are compiled with eight doubles to a vector
  (:func:`wide`): LLVM's default for them is four;
- the loops read the inputs that tolerate it in float32
  (:func:`brdffit.kernels.inputs.beckmann_inputs`,
  :func:`~brdffit.kernels.inputs.ggx_anisotropic_inputs` and
  :func:`~brdffit.kernels.inputs.beckmann_anisotropic_inputs` state and bound the
  error: 2e-7 relative, tested), which cuts their memory traffic by a quarter to a
  third.

The formulas, those of the numpy models (:mod:`brdffit.models.renderers`): GGX and
Beckmann ``D`` with the separable Smith masking (Walter, Marschner, Li and
Torrance, Microfacet models for refraction through rough surfaces, EGSR 2007,
eqs. 33-34; Heitz, Understanding the masking-shadowing function in microfacet-based
BRDFs, JCGT 3(2), 2014, sections 5.1 and 5.4) and Schlick's Fresnel factor
(Schlick, Computer Graphics Forum 13(3), 1994).
"""

from __future__ import annotations

import math
import threading

import llvmlite.binding as llvm
import numba
import numpy as np

from ._compile import FLAGS, jit
from .elementary import fast_exp_7, fast_exp_short
from .smith import A_MAX, P, Q

__all__ = [
    "SHORT_NEWTON_ERROR",
    "beckmann",
    "beckmann_anisotropic",
    "ggx_anisotropic",
    "ggx_anisotropic_dg",
    "rsqrt",
    "sqrt_short",
    "wide",
]

_INV_PI = 1.0 / math.pi
#: The bounds of :func:`rsqrt`'s argument: float32 holds them and their roots.
RSQRT_MIN, RSQRT_MAX = 1e-30, 1e30
#: The stated bound on the relative error of :func:`rsqrt` (one Newton step from a
#: float32 estimate; tested).
SHORT_NEWTON_ERROR = 2e-13
_LOCK = threading.Lock()


def wide(dispatcher):
    """``dispatcher`` (a numba function) compiled with LLVM's loop vectoriser set to
    eight lanes when the processor has AVX-512 (measured on the Beckmann loop:
    1.15-1.2x), on the first call with each kind of arguments (a numba compilation,
    or a load from its cache), then the option set back to LLVM's default (0, the
    vectoriser's own choice) so that no other compilation in the process sees it."""
    if not llvm.get_host_cpu_features().get("avx512f", False):
        return dispatcher
    seen = set()

    def call(*args):
        kind = tuple(
            (a.dtype.char, a.ndim, a.flags.c_contiguous) if isinstance(a, np.ndarray) else type(a)
            for a in args
        )
        if kind in seen:
            return dispatcher(*args)
        with _LOCK:
            llvm.set_option("", "-force-vector-width=8")
            try:
                return dispatcher(*args)
            finally:
                llvm.set_option("", "-force-vector-width=0")
                seen.add(kind)

    call.__name__, call.__qualname__ = dispatcher.__name__, dispatcher.__qualname__
    call.__doc__, call.__wrapped__ = dispatcher.__doc__, dispatcher
    return call


@numba.njit(inline="always", fastmath=FLAGS)
def rsqrt(x):
    """``1 / sqrt(x)`` for ``RSQRT_MIN <= x <= RSQRT_MAX`` without the divider: a
    float32 estimate (within 3e-7) and one Newton step in float64, within
    :data:`SHORT_NEWTON_ERROR` relative (see the module docstring)."""
    r = np.float64(np.float32(1.0) / math.sqrt(np.float32(x)))
    return r * (1.5 - 0.5 * x * r * r)


@numba.njit(inline="always", fastmath=FLAGS)
def sqrt_short(x):
    """``sqrt(x)`` for ``RSQRT_MIN <= x <= RSQRT_MAX`` without the divider: ``s = x r``
    from :func:`rsqrt`'s float32 estimate ``r = (1 + e) / sqrt(x)`` and one Newton step
    for the root, ``s + (r / 2)(x - s^2)``, whose relative error is ``-3 e^2 / 2 - e^3
    / 2``: within :data:`SHORT_NEWTON_ERROR` as :func:`rsqrt` (tested), in four
    operations after the estimate where ``x rsqrt(x)`` takes five."""
    r = np.float64(np.float32(1.0) / math.sqrt(np.float32(x)))
    s = x * r
    return s + (0.5 * r) * (x - s * s)


@numba.njit(inline="always", fastmath=FLAGS)
def _reciprocal(x):
    """``1 / x`` for ``1e-30 <= x <= 1e30`` without the divider: a float32 estimate and
    two Newton steps ``r <- r (2 - x r)`` in float64 (within an ulp or two: measured
    4e-16 in the Beckmann loop, 1.08x faster). For the product of the two ``G1``
    denominators, which lie in [0.03, 13] (tests/models/test_kernels.py)."""
    r = np.float64(np.float32(1.0) / np.float32(x))
    r = r * (2.0 - x * r)
    return r * (2.0 - x * r)


@numba.njit(inline="always", fastmath=FLAGS)
def _beckmann_g1_terms(a):
    """``(a Q(x), a Q(x) + P(x))`` of :mod:`brdffit.kernels.smith`, whose ratio is
    Beckmann's Smith ``G1`` at ``a = 1/(alpha tan theta) <= A_MAX``: no library call
    and no table, so the loop vectorises."""
    x = a * (2.0 / A_MAX) - 1.0
    q = Q[0]
    for k in range(1, len(Q)):  # Horner; the tuples are constants, the loops unrolled
        q = q * x + Q[k]
    p = P[0]
    for k in range(1, len(P)):
        p = p * x + P[k]
    n = a * q
    return n, n + p


@wide
@jit
def beckmann(tan2_h, cot_i, cot_o, log_factor, weight, alpha2, f0, a, b, out):
    """Beckmann ``D`` with its Smith ``G1`` (:mod:`brdffit.kernels.smith`) and
    Schlick's F. ``cot_i``, ``cot_o`` are ``1/tan`` of L and V (so ``a = cot/alpha``
    needs no division), ``log_factor`` is ``ln(1 / (4 (N.L)(N.V) (N.H)^4))``, added
    to the exponent of ``D``; one reciprocal per pair for both ``G1``. Any float
    array type (the cached ``cot`` and ``weight`` are float32)."""
    if a <= 0.0:
        out[:] = b
        return out
    inv_a2 = 1.0 / alpha2
    inv_alpha = math.sqrt(inv_a2)
    log_scale = math.log(a * _INV_PI * inv_a2)
    for i in range(out.shape[0]):
        fresnel = f0 + (1.0 - f0) * weight[i]
        n_i, d_i = _beckmann_g1_terms(min(cot_i[i] * inv_alpha, A_MAX))
        n_o, d_o = _beckmann_g1_terms(min(cot_o[i] * inv_alpha, A_MAX))
        lobe = fast_exp_short(log_scale + log_factor[i] - tan2_h[i] * inv_a2)
        out[i] = b + fresnel * lobe * (n_i * n_o) * _reciprocal(d_i * d_o)
    return out


@wide
@jit
def beckmann_anisotropic(
    tan2_t, tan2_b, tx_i, ty_i, tx_o, ty_o, log_factor, weight, alpha_u, alpha_v, f0, a, b, out
):
    """Anisotropic Beckmann (Heitz 2014, section 5.4): ``D = exp(-(tan2_t/alpha_u^2 +
    tan2_b/alpha_v^2)) / (pi alpha_u alpha_v (N.H)^4)`` and the Smith ``G1`` of
    :func:`beckmann` at ``a = 1 / sqrt(s)``, ``s = alpha_u^2 tx + alpha_v^2 ty`` (clamped
    to ``A_MAX`` by clamping ``s`` to ``1/A_MAX^2`` first: ``rsqrt``'s error may take it
    2e-13 past, where the rational function is as accurate; ``s`` is at most 2e20 <
    ``RSQRT_MAX`` for widths in the box, ``alpha <= 1``: ``tx``, ``ty`` are at most
    1e20, the cosines being clamped at 1e-10); ``log_factor`` as in :func:`beckmann`.
    The cached ``tx``, ``ty`` and ``weight`` are float32; ``exp`` is
    :func:`~brdffit.kernels.elementary.fast_exp_7` (within 5e-11) and the last
    division a true one (the divider is otherwise idle here: measured with the
    shorter ``exp`` and without the upper clamp of ``s``, 3.09 -> 2.78 ns a pair)."""
    if a <= 0.0:
        out[:] = b
        return out
    inv_u2, inv_v2 = 1.0 / (alpha_u * alpha_u), 1.0 / (alpha_v * alpha_v)
    u2, v2 = alpha_u * alpha_u, alpha_v * alpha_v
    log_scale = math.log(a * _INV_PI / (alpha_u * alpha_v))
    s_min = 1.0 / (A_MAX * A_MAX)
    for i in range(out.shape[0]):
        s_i = max(u2 * tx_i[i] + v2 * ty_i[i], s_min)  # at most 2e20
        s_o = max(u2 * tx_o[i] + v2 * ty_o[i], s_min)
        fresnel = f0 + (1.0 - f0) * weight[i]
        exponent = log_scale + log_factor[i] - (tan2_t[i] * inv_u2 + tan2_b[i] * inv_v2)
        n_i, d_i = _beckmann_g1_terms(rsqrt(s_i))  # at most A_MAX (1 + 2e-13)
        n_o, d_o = _beckmann_g1_terms(rsqrt(s_o))
        out[i] = b + fresnel * fast_exp_7(exponent) * (n_i * n_o) / (d_i * d_o)
    return out


@numba.njit(inline="always", fastmath=FLAGS)
def ggx_anisotropic_dg(tan2_t, tan2_b, tx_i, ty_i, tx_o, ty_o, inv_4_cos, inv_u2, inv_v2, u2, v2):
    """``D G1(L) G1(V) / (4 (N.L)(N.V))`` of anisotropic GGX without its constant ``4 /
    (pi alpha_u alpha_v)``: ``c^2 inv_4_cos / (t^2 g)``, ``c = 1 + tan2_t + tan2_b = 1 /
    (N.H)^2`` (:func:`~brdffit.kernels.inputs.inv_4_cos32` says why not the whole
    factor), ``t`` and ``g`` as in :func:`ggx_anisotropic` (``sqrt(m) = m rsqrt(m)``)."""
    c = 1.0 + tan2_t + tan2_b
    t = 1.0 + tan2_t * inv_u2 + tan2_b * inv_v2
    m_i = min(1.0 + u2 * tx_i + v2 * ty_i, RSQRT_MAX)
    m_o = min(1.0 + u2 * tx_o + v2 * ty_o, RSQRT_MAX)
    g = (1.0 + m_i * rsqrt(m_i)) * (1.0 + m_o * rsqrt(m_o))
    return (c * c) * inv_4_cos / (t * t * g)


@wide
@jit
def ggx_anisotropic(
    tan2_t, tan2_b, tx_i, ty_i, tx_o, ty_o, inv_4_cos, weight, alpha_u, alpha_v, f0, a, b, out
):
    """Anisotropic GGX (Heitz 2014, section 5.4): ``D = 1 / (pi alpha_u alpha_v (N.H)^4
    t^2)``, ``t = 1 + tan2_t/alpha_u^2 + tan2_b/alpha_v^2``, and Smith ``G1 = 2 / (1 +
    sqrt(m))``, ``m = 1 + alpha_u^2 tx + alpha_v^2 ty``, of L and of V; ``inv_4_cos`` is
    ``1 / (4 (N.L)(N.V))`` (:func:`ggx_anisotropic_dg`). No division but the last. The
    cached inputs but ``tan2_t``, ``tan2_b`` are float32."""
    inv_u2, inv_v2 = 1.0 / (alpha_u * alpha_u), 1.0 / (alpha_v * alpha_v)
    u2, v2 = alpha_u * alpha_u, alpha_v * alpha_v
    scale = 4.0 * a * _INV_PI / (alpha_u * alpha_v)
    for i in range(out.shape[0]):
        fresnel = f0 + (1.0 - f0) * weight[i]
        dg = ggx_anisotropic_dg(
            tan2_t[i], tan2_b[i], tx_i[i], ty_i[i], tx_o[i], ty_o[i], inv_4_cos[i],
            inv_u2, inv_v2, u2, v2,
        )  # fmt: skip
        out[i] = b + scale * fresnel * dg
    return out
