"""The compiled loops of the empirical lobes with a power or a logarithm of a
parameter-dependent base: Lafortune, Ohara, Fournier, Gaussian and Wang.

As in :mod:`brdffit.kernels.loops`, each loop writes ``out[i] = b + a * lobe_i``
(``a = 1, b = 0``: the lobe column; ``a = ks, b = kd/pi``: the BRDF) in one pass, and
the lobe's positive scale is added to its exponent (``ln a``), so that the flush of
results under 3.3e-308 by :func:`~brdffit.kernels.elementary.fast_exp_short` never
loses a value numpy keeps. Powers of a base that depends on a parameter are
``exp(n ln base)`` with :func:`~brdffit.kernels.elementary.fast_log`, vectorised
(Fournier's ``2^(n log2 base)`` with :mod:`brdffit.kernels.base2`, in blocks of two
passes: see :func:`fournier`), and every loop asks for 512-bit vectors
(:mod:`brdffit.kernels.wide`).

Where the numpy formula cancels (Lafortune's base ``cxy (Lx Vx + Ly Vy) + Lz Vz``
near the cone where it is 0, Fournier's tilted cosine ``(N.H) c - (H.T) t c``, Wang's
``m - (m - zeta) cos^2 phi_h``), the loop must round as numpy does, product then
sum, or its value moves far from numpy's where the result is small: those few
operations are compiled without fused multiply-adds in helpers of their own (LLVM
inlines them; its fast-math flags are per instruction), the rest of the loop with
them. The formulas are the numpy models' (MODELS.md), whose docstrings cite the
primary sources:

- Lafortune's generalised cosine lobe (Lafortune, Foo, Torrance and Greenberg,
  Non-linear approximation of reflectance functions, SIGGRAPH 1997);
- Ohara's ellipsoid, Wang's blended exponent (as cited by Malashenkova and
  Moiseikin, Matematicheskaya morfologiya 5(4), 2006) and Fournier's tilted Phong
  lobes (Fournier, Normal distribution functions and multiple surfaces, Graphics
  Interface '92 workshop on local illumination, 1992);
- the Gaussian lobe in ``theta_h`` (reviewed by Romanyuk, 2007; MODELS.md).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ._compile import _LOG2E, FLAGS, jit
from .base2 import fast_exp2, log2_pair
from .elementary import fast_exp_short, fast_log, fast_log1p
from .wide import prefer_wide_vectors

#: The fast-math flags of the helpers that round as numpy does (no fused
#: multiply-add): see the module docstring.
_SEPARATE = FLAGS - {"contract"}


@numba.njit(cache=True, fastmath=_SEPARATE, error_model="numpy")
def _product_plus(x, scale, y):
    """``x scale + y`` rounded twice, as numpy's ``x * scale`` then ``+ y``."""
    return x * scale + y


@numba.njit(cache=True, fastmath=_SEPARATE, error_model="numpy")
def _wang_power(cos2, mz, m, dm):
    """Wang's exponent ``m zeta / (m - (m - zeta) cos^2 phi_h)``, rounded as numpy does."""
    return mz / (m - dm * cos2)


@jit
def gaussian(theta2_h, half_n, a, b, out):
    """``exp(-n theta_h^2 / 2)``; ``half_n`` is ``n / 2``."""
    prefer_wide_vectors()
    if a <= 0.0:
        out[:] = b
        return out
    log_a = math.log(a)
    for i in range(out.shape[0]):
        out[i] = b + fast_exp_short(log_a - half_n * theta2_h[i])
    return out


@jit
def lafortune(dot_xy, dot_z, cxy, n, a, b, out):
    """``max(0, cxy (Lx Vx + Ly Vy) + Lz Vz)^n`` (``ln 0`` is
    :data:`~brdffit.kernels.elementary.LOG_ZERO`, whose ``n``-th multiple gives 0)."""
    prefer_wide_vectors()
    if a <= 0.0:
        out[:] = b
        return out
    log_a = math.log(a)
    for i in range(out.shape[0]):
        base = _product_plus(dot_xy[i], cxy, dot_z[i])
        out[i] = b + fast_exp_short(n * fast_log(base) + log_a)
    return out


@jit
def ohara(tan2_t, tan2_b, inv_a2, inv_b2, n, a, b, out):
    """``(1 + tan2_t/a^2 + tan2_b/b^2)^(-n/2)`` as ``exp(-n/2 log1p(...))``
    (``tan2_t``, ``tan2_b``: ``(H.T / N.H)^2``, ``(H.B / N.H)^2``)."""
    prefer_wide_vectors()
    if a <= 0.0:
        out[:] = b
        return out
    log_a = math.log(a)
    half_n = 0.5 * n
    for i in range(out.shape[0]):
        x = tan2_t[i] * inv_a2 + tan2_b[i] * inv_b2
        out[i] = b + fast_exp_short(log_a - half_n * fast_log1p(x))
    return out


#: Pairs per block of the Fournier loop: its logarithms for a block, then its
#: exponentials, through two buffers of 16 KB that stay in the L1 cache. Blocks of
#: 512 pairs, one 4 KB page of each array, made each pass start new streams at every
#: page, where the hardware prefetchers stop: streamed from memory the loop took 2.6
#: ns a pair against 2.3 in the cache; with 2048, 2.3 both (1 M pairs, one process,
#: benchmarks/README.md, seventh stop; 4096 to 16384 the same).
_BLOCK = 2048


@numba.njit(inline="always", fastmath=FLAGS)
def _fournier_logs(cos_h, half_t, inv, side_scale, n, offset, plus, minus):
    """``n log2(N_(+-1).H) + offset`` into ``plus``, ``minus``: the tilted cosines
    rounded as numpy does (:func:`_product_plus`)."""
    for j in range(plus.shape[0]):
        side = half_t[j] * side_scale
        high, low = log2_pair(
            _product_plus(cos_h[j], inv, side), _product_plus(cos_h[j], inv, -side)
        )
        plus[j] = n * high + offset
        minus[j] = n * low + offset


@numba.njit(inline="always", fastmath=FLAGS)
def _fournier_sums(log_cos_h, n2, offset, down, b, plus, minus, out):
    """``b + down (2^(n2 ln(N.H) + offset) + 2^plus + 2^minus)``."""
    for j in range(out.shape[0]):
        centre = fast_exp2(n2 * log_cos_h[j] + offset)
        out[j] = b + (centre + fast_exp2(plus[j]) + fast_exp2(minus[j])) * down


@jit
def fournier(log_cos_h, cos_h, half_t, n, t, a, b, out):
    """``(1/3) sum_{s = -1, 0, 1} max(0, N_s.H)^n`` with ``N_0.H = N.H`` and
    ``N_(+-1).H = (N.H) c +- (H.T) t c``, ``c = 1/sqrt(1 + t^2)``, each power
    ``(a/3) x^n = 2^(n log2 x + log2(a/3))`` (:mod:`brdffit.kernels.base2`), in blocks
    of :data:`_BLOCK` pairs: the two logarithms of a block, then its three powers.

    The powers are summed scaled by ``2^shift`` (64 unless ``a`` is huge) and the sum
    scaled back by ``2^-shift``: a power numpy keeps as a subnormal number beside a
    sum near 1e-300 is a normal number in the sum (before, the terms were added
    relative to the largest, which took a sort of three a pair). Two things the
    pieces leave are below rounding: ``2^(y < -1020)`` reads as ``2^-1020``, ``2^-1084``
    after the scaling by ``2^-64`` (every ``a`` below about 1e282, far above ks's range
    of at most 1e4), below half the smallest subnormal number; a tilted cosine at
    or below 0 (whose power is 0) reads as the smallest normal number ``2^-1022``,
    whose power ``2^(-1022 n)`` is below ``1e-290^n`` of the central lobe's
    ``(N.H)^n``, ``N.H >= 1e-10`` (Geometry's clamp). Tested: within 2e-12 of the
    numpy model (tests/models/test_kernels_base2.py; 1.4e-12 measured, as the loop
    before it, from the rounding of exponents up to 1e4 times a logarithm). Measured
    beside that loop (two logarithms and three exponentials of degree 11 a pair in one
    pass, the three powers sorted) in one process (benchmarks/bench_evaluate_old_new.py,
    1 M pairs): 1.24-2.6x in five runs on a shared machine, median 1.76x; the logs'
    pass 1.3 ns a pair, the powers' 1.1 ns, in the cache."""
    prefer_wide_vectors()
    if a <= 0.0:
        out[:] = b
        return out
    log2_a = math.log2(a / 3.0)
    shift = min(64.0, float(math.floor(1000.0 - log2_a)))  # every 2^y at most 2^1000
    offset = log2_a + shift
    down = 2.0**-shift
    inv = 1.0 / math.sqrt(1.0 + t * t)
    side_scale = t * inv
    n2 = n * _LOG2E
    size = out.shape[0]
    buffers = np.empty(2 * _BLOCK + 8)  # apart by 4096 k + 64 bytes: no 4K aliasing
    plus, minus = buffers[:_BLOCK], buffers[_BLOCK + 8 :]
    for start in range(0, size, _BLOCK):
        stop = min(start + _BLOCK, size)
        high, low = plus[: stop - start], minus[: stop - start]
        _fournier_logs(
            cos_h[start:stop], half_t[start:stop], inv, side_scale, n, offset, high, low
        )
        _fournier_sums(log_cos_h[start:stop], n2, offset, down, b, high, low, out[start:stop])
    return out


@jit
def wang(log_cos_h, cos2_phi_h, m, zeta, a, b, out):
    """Wang's ``(N.H)^(m zeta / (m - (m - zeta) cos^2 phi_h))``: the exponent rounded
    as numpy does (``m - (m - zeta) cos^2`` cancels when ``m >> zeta``), its ``exp``
    with fused multiply-adds."""
    prefer_wide_vectors()
    if a <= 0.0:
        out[:] = b
        return out
    log_a = math.log(a)
    mz, dm = m * zeta, m - zeta
    for i in range(out.shape[0]):
        power = _wang_power(cos2_phi_h[i], mz, m, dm)
        out[i] = b + fast_exp_short(power * log_cos_h[i] + log_a)
    return out
