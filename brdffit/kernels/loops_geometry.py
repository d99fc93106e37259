"""The microfacet models' parameter-free inputs in compiled passes
(:func:`brdffit.kernels.inputs.microfacet_inputs`, ``ward_inputs``,
``cook_torrance_inputs``; :attr:`Geometry.sin2_h <brdffit.data.geometry.Geometry.sin2_h>`).

numpy forms GGX's five inputs (``tan^2 theta_h`` through ``sin^2 theta_h``, ``tan^2``
of L and of V, ``1 / (4 (N.L)(N.V) (N.H)^4)`` and Schlick's ``(1 - V.H)^5``) in about
twenty passes over arrays of a MERL file's 1.1 million pairs, strided columns of the
(M, 3) directions among them: 39 ms, the largest part of the first evaluation on all
the samples of a whole-MERL ggx fit (52 ms against 4 ms for the next ones). The loop
here reads each pair's directions and cosines once and writes the inputs (and the
geometry's ``sin^2 theta_h`` and ``tan^2 theta_h``) with the same operations in the
same order, without ``fastmath`` (no fused multiply-adds, no reassociation): the
same values bit for bit (tested), a NaN staying NaN as in numpy's ``minimum`` and
``maximum``. The geometry's ``sin^2`` and ``tan^2 theta_h`` of other models come from
:func:`half_sines` (numpy: 15 ms on a MERL file); Ward's and Cook-Torrance's factors
from :func:`ward_factor` and :func:`cook_torrance_factor`, whose logarithm numpy then
takes in place (numpy's ``log``, so the same values: numba's would call the C
library's).
"""

from __future__ import annotations

import math

import numba

__all__ = ["cook_torrance_factor", "half_sines", "microfacet_terms", "ward_factor"]

_PI = math.pi


@numba.njit(cache=True, error_model="numpy", inline="always")
def _sines(wi, wo, norm, cos_h, i, sin2_h, tan2_h):
    """``sin^2`` and ``tan^2 theta_h`` of pair ``i`` into ``sin2_h`` and ``tan2_h``."""
    scale = norm[i]
    scale = 1e-300 if scale < 1e-300 else scale
    x = (wi[i, 0] + wo[i, 0]) / scale
    y = (wi[i, 1] + wo[i, 1]) / scale
    s = x * x + y * y
    s = 1.0 if s > 1.0 else s
    sin2_h[i] = s
    tan2_h[i] = s / (cos_h[i] * cos_h[i])


@numba.njit(cache=True, error_model="numpy")
def half_sines(wi, wo, norm, cos_h, sin2_h, tan2_h):
    """:attr:`Geometry.sin2_h <brdffit.data.geometry.Geometry.sin2_h>` (``min(x^2 + y^2,
    1)`` of the half vector's components ``(L + V) / max(|L + V|, 1e-300)``, ``norm``
    being ``|L + V|``) and ``tan^2 theta_h = sin^2 / cos_h^2`` of every pair."""
    for i in range(wi.shape[0]):
        _sines(wi, wo, norm, cos_h, i, sin2_h, tan2_h)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _minimum(a, b):
    """numpy's ``minimum``: NaN if either is."""
    return a if a < b or a != a else b


@numba.njit(cache=True, error_model="numpy")
def ward_factor(cos_i, cos_o, out):
    """``1 / (4 pi sqrt(cos_i cos_o))`` (whose logarithm is Ward's input)."""
    for i in range(cos_i.shape[0]):
        out[i] = 1.0 / (4.0 * _PI * math.sqrt(cos_i[i] * cos_o[i]))


@numba.njit(cache=True, error_model="numpy")
def cook_torrance_factor(cos_h, cos_i, cos_o, cos_d, out, cos_d_floor):
    """Cook-Torrance's ``G / (4 cos_i cos_o) * (1 / (pi c2 c2))``, ``c2 = cos_h^2`` and
    the V-cavity ``G = min(1, 2 cos_h / max(cos_d, 1e-300) * min(cos_i, cos_o))``, as
    :func:`~brdffit.models.shared.vcavity_g` and
    :func:`~brdffit.kernels.inputs.cook_torrance_inputs` form them, into ``out``; and
    ``max(cos_d, 1e-300)`` into ``cos_d_floor``."""
    for i in range(cos_h.shape[0]):
        d = cos_d[i]
        d = d if d >= 1e-300 or d != d else 1e-300
        cos_d_floor[i] = d
        shadowing = _minimum(1.0, 2.0 * cos_h[i] / d * _minimum(cos_i[i], cos_o[i]))
        c2 = cos_h[i] * cos_h[i]
        out[i] = shadowing / (4.0 * cos_i[i] * cos_o[i]) * (1.0 / (_PI * c2 * c2))


@numba.njit(cache=True, error_model="numpy")
def microfacet_terms(wi, wo, cos_i, cos_o, cos_h, cos_d, norm, form, sin2_h, tan2_h, out):
    """For every pair: ``sin^2 theta_h`` as :attr:`Geometry.sin2_h
    <brdffit.data.geometry.Geometry.sin2_h>` (``min(x^2 + y^2, 1)`` of the half vector's
    components ``(L + V) / max(|L + V|, 1e-300)``, ``norm`` being ``|L + V|``) and
    ``tan^2 theta_h = sin^2 / cos_h^2`` into ``sin2_h`` and ``tan2_h`` when ``form``
    (else ``tan2_h`` is read); and into ``out`` (4, M) the other inputs of
    :func:`~brdffit.kernels.inputs.microfacet_inputs`: ``(x^2 + y^2) / cos^2`` of L and
    of V, ``1 / (4 cos_i cos_o c2 c2)`` with ``c2 = cos_h^2``, and ``(1 - cos_d)^5`` as
    :func:`~brdffit.models.shared.schlick_weight` forms it (``w2 = w w``, ``w2 w2``,
    times ``w``). ``wi``, ``wo`` (M, 3), the cosines and ``norm`` (M,)."""
    for i in range(wi.shape[0]):
        if form:
            _sines(wi, wo, norm, cos_h, i, sin2_h, tan2_h)
        a, b, c = wi[i, 0], wi[i, 1], cos_i[i]
        out[0, i] = (a * a + b * b) / (c * c)
        a, b, c = wo[i, 0], wo[i, 1], cos_o[i]
        out[1, i] = (a * a + b * b) / (c * c)
        c2 = cos_h[i] * cos_h[i]
        out[2, i] = 1.0 / (4.0 * cos_i[i] * cos_o[i] * c2 * c2)
        w = 1.0 - cos_d[i]
        w2 = w * w
        w2 = w2 * w2
        out[3, i] = w * w2
