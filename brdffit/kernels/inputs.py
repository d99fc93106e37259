"""Parameter-free inputs of the kernels, computed once per geometry.

Each kernel reads a few contiguous float64 arrays over the valid pairs of a
:class:`~brdffit.data.geometry.Geometry`: the factors of its model that do not
depend on a parameter, combined as far as possible so that an evaluation reads
few bytes per pair. They are cached on the geometry (``Geometry.cached``) like the
numpy models' own terms, and computed with the same formulas and clamps (MODELS.md
conventions; :mod:`brdffit.models.shared` for the pieces), so the compiled and the
numpy evaluations agree to rounding.
"""

from __future__ import annotations

import math

import numpy as np

from .. import kernels
from ..data.geometry import MIN_COSINE, Geometry
from ..models.microfacet import inv_4_cos
from ..models.shared import schlick_weight, vcavity_g

__all__ = [
    "ashikhmin_phong_inputs",
    "BECKMANN_ANISOTROPIC_F32_ERROR",
    "BECKMANN_F32_ERROR",
    "CONDUCTOR_ANISOTROPIC_F32_ERROR",
    "COT_MAX",
    "F32_ERROR",
    "GGX_ANISOTROPIC_F32_ERROR",
    "PRINCIPLED_ANISOTROPIC_F32_ERROR",
    "PRINCIPLED_F32_ERROR",
    "ashikhmin_shirley_inputs",
    "beckmann_anisotropic_inputs",
    "beckmann_inputs",
    "blake_inputs",
    "blinn_inputs",
    "cook_torrance_inputs",
    "cook_torrance_schlick_inputs",
    "heidrich_seidel_inputs",
    "ggx_anisotropic_inputs",
    "inv_4_cos32",
    "microfacet_inputs",
    "phong_inputs",
    "schlick_inputs",
    "torrance_sparrow_inputs",
    "wang_inputs",
    "ward_anisotropic_inputs",
    "ward_inputs",
]

#: The largest ``1 / tan`` of the inputs: finite in float32, so that ``cot / alpha``
#: (alpha >= 1e-3) stays finite; every ``a = cot / alpha`` over ``smith.A_MAX`` gives
#: the same ``G1``.
COT_MAX = 1e30


def _tan2_of(w: np.ndarray, cos: np.ndarray) -> np.ndarray:
    """``tan^2`` of a polar angle as ``(x^2 + y^2) / z^2`` (accurate near the normal)."""
    return (w[:, 0] ** 2 + w[:, 1] ** 2) / (cos * cos)


def _pow5(x: np.ndarray) -> np.ndarray:
    x2 = x * x
    return x2 * x2 * x


def _log_ward_factor(g: Geometry) -> np.ndarray:
    """``ln(1 / (4 pi sqrt((N.L)(N.V))))``, of both Ward lobes; cached (the factor by
    :func:`brdffit.kernels.loops_geometry.ward_factor` where the kernels run)."""

    def compute():
        if not _geometry_loops(g):
            return np.log(1.0 / (4.0 * math.pi * np.sqrt(g.cos_i * g.cos_o)))
        from . import loops_geometry

        out = np.empty(g.m)
        loops_geometry.ward_factor(g.cos_i, g.cos_o, out)
        return np.log(out, out=out)

    return g.cached("kernels.log_ward_factor", compute)


def _geometry_loops(g: Geometry) -> bool:
    """Whether the loops of :mod:`brdffit.kernels.loops_geometry` run on ``g`` (loaded
    here if so: the geometry's ``sin2_h`` and ``tan2_h`` then come from them too)."""
    return kernels.wanted(g.m, modules=("loops_geometry",))


def _theta_h2(g: Geometry) -> np.ndarray:
    """``theta_h^2``, of Blake's and Torrance-Sparrow's lobes; cached."""
    return g.cached("kernels.theta_h2", lambda: g.theta_h**2)


def _microfacet_factor(g: Geometry) -> np.ndarray:
    """``1 / (4 (N.L)(N.V) (N.H)^4)``, of the microfacet loops (not cached: each caches
    it in its own form)."""
    c2 = g.cos_h * g.cos_h
    return 1.0 / (4.0 * g.cos_i * g.cos_o * c2 * c2)


def microfacet_inputs(g: Geometry) -> tuple:
    """GGX with Smith shadowing: ``tan^2 theta_h``, ``tan^2`` of L and of V,
    ``1 / (4 (N.L)(N.V) (N.H)^4)`` and Schlick's ``(1 - V.H)^5``."""

    def compute():
        if _geometry_loops(g):
            return _microfacet_compiled(g)
        tan2_i, tan2_o = _tan2_of(g.wi, g.cos_i), _tan2_of(g.wo, g.cos_o)
        return g.tan2_h, tan2_i, tan2_o, _microfacet_factor(g), schlick_weight(g.cos_d)

    return g.cached("kernels.microfacet", compute)


def _microfacet_compiled(g: Geometry) -> tuple:
    """:func:`microfacet_inputs` (and the geometry's ``sin2_h`` and ``tan2_h``, unless
    formed) by the one pass of :mod:`brdffit.kernels.loops_geometry`: the same values."""
    from . import loops_geometry

    cos_h, cos_d = g.cos_h, g.cos_d  # the compiled half terms first: |L + V| with them
    form = "sin2_h" not in g.__dict__ and "tan2_h" not in g.__dict__
    sin2_h, tan2_h = (np.empty(g.m), np.empty(g.m)) if form else (g.tan2_h, g.tan2_h)
    out = np.empty((4, g.m))
    wi, wo = g.directions()
    cosines = (g.cos_i, g.cos_o, cos_h, cos_d, g._half_norm)
    loops_geometry.microfacet_terms(wi, wo, *cosines, form, sin2_h, tan2_h, out)
    if form:
        g.__dict__.update(sin2_h=sin2_h, tan2_h=tan2_h)
    return tan2_h, *out


def _cot_of(tan2: np.ndarray) -> np.ndarray:
    """``1 / tan`` of a polar angle, at most :data:`COT_MAX` (the normal's is infinite)."""
    with np.errstate(divide="ignore"):
        cot = 1.0 / np.sqrt(tan2)
    return np.minimum(cot, COT_MAX, out=cot)


def _log_microfacet_factor(g: Geometry) -> np.ndarray:
    """``ln(1 / (4 (N.L)(N.V) (N.H)^4))``, of both Beckmann loops; cached."""

    return g.cached("kernels.log_microfacet_factor", lambda: np.log(_microfacet_factor(g)))


#: The relative error that float32 inputs add to Beckmann (see :func:`beckmann_inputs`).
BECKMANN_F32_ERROR = 2e-7


def beckmann_inputs(g: Geometry) -> tuple:
    """Beckmann: ``tan^2 theta_h`` and the logarithm of ``1 / (4 (N.L)(N.V) (N.H)^4)``
    (added to the exponent of ``D``) in float64, then in float32 ``1 / tan`` of L and V
    (Smith's ``a = 1 / (alpha tan)``, at most :data:`COT_MAX`) and Schlick's
    ``(1 - V.H)^5``; cached.

    float32 where the value tolerates it (as :func:`ggx_anisotropic_inputs`; measured:
    the loop 1.2x faster): ``G1`` changes by at most the relative change of ``a``
    (``G1`` is proportional to ``a`` near 0 and flattens out after), 6e-8 for L and
    for V, ``F`` by at most 6e-8: within :data:`BECKMANN_F32_ERROR` of the float64
    model. ``D``'s exponent stays float64."""

    def compute():
        cot_i = _cot_of(_tan2_of(g.wi, g.cos_i)).astype(np.float32)
        cot_o = _cot_of(_tan2_of(g.wo, g.cos_o)).astype(np.float32)
        weight = schlick_weight(g.cos_d).astype(np.float32)
        return g.tan2_h, cot_i, cot_o, _log_microfacet_factor(g), weight

    return g.cached("kernels.beckmann", compute)


def _tan2_axes_of(w: np.ndarray, cos: np.ndarray) -> tuple:
    """``(x/z)^2`` and ``(y/z)^2`` of a direction (of H: ``(H.T/N.H)^2``, ``(H.B/N.H)^2``,
    which sum to ``tan^2``), so that ``alpha^2 tan^2`` of Smith's anisotropic ``G1``
    is ``alpha_u^2 (x/z)^2 + alpha_v^2 (y/z)^2`` (Heitz 2014, section 5.4)."""
    inv_c2 = 1.0 / (cos * cos)
    return w[:, 0] ** 2 * inv_c2, w[:, 1] ** 2 * inv_c2


def _h_axes(g: Geometry) -> tuple:
    """:func:`_tan2_axes_of` of H; cached."""
    return g.cached("kernels.h_axes", lambda: _tan2_axes_of(g.half, g.cos_h))


def _axes32(g: Geometry) -> tuple:
    """:func:`_tan2_axes_of` L and of V and Schlick's ``(1 - V.H)^5``, in float32: the
    inputs of the anisotropic GGX and Beckmann loops that tolerate it (and of the
    anisotropic roughconductor's, but the weight); cached."""

    def compute():
        single = (
            *_tan2_axes_of(g.wi, g.cos_i),
            *_tan2_axes_of(g.wo, g.cos_o),
            schlick_weight(g.cos_d),
        )
        return tuple(x.astype(np.float32) for x in single)

    return g.cached("kernels.axes32", compute)


def inv_4_cos32(g: Geometry) -> np.ndarray:
    """``1 / (4 (N.L)(N.V))`` in float32, at most 2.5e19 (the cosines are clamped at
    ``MIN_COSINE``); cached. The anisotropic GGX loops multiply it by ``(1 + tan2_t +
    tan2_b)^2``, which is ``1 / (N.H)^4`` to a few ulps (H is of unit length; where
    ``N.H`` is clamped at ``MIN_COSINE`` the two differ by under 1e-20 relative): the
    factor ``1 / (4 (N.L)(N.V) (N.H)^4)`` itself reaches 2.5e59 near the horizon,
    infinite in float32 (the loop of before returned ``inf`` where the numpy model is
    finite, for N.H near 1e-10: tests/models/test_kernels.py)."""
    return g.cached("kernels.inv_4_cos32", lambda: inv_4_cos(g).astype(np.float32))


#: The relative error that float32 inputs add to anisotropic GGX (see
#: :func:`ggx_anisotropic_inputs`), stated and tested.
GGX_ANISOTROPIC_F32_ERROR = 2e-7


def ggx_anisotropic_inputs(g: Geometry) -> tuple:
    """Anisotropic GGX: ``(H.T / N.H)^2``, ``(H.B / N.H)^2`` in float64, then in float32
    :func:`_tan2_axes_of` L and of V, ``1 / (4 (N.L)(N.V))`` (:func:`inv_4_cos32`) and
    Schlick's ``(1 - V.H)^5``.

    The loop is limited by its memory traffic (eight float64 arrays: 72 bytes a pair
    with its output; measured at 0.6-0.7x of Mitsuba's GGX), so the inputs that
    tolerate it are float32, 48 bytes a pair. Each adds its rounding, at most
    ``2^-24`` relative, to the value: Smith's ``G1 = 2 / (1 + sqrt(1 + s))`` changes
    by at most half the relative change of ``s`` (so 3e-8 for L and for V), the factor
    and Schlick's ``F = f0 + (1 - f0) w`` by at most 6e-8 each: in all within
    :data:`GGX_ANISOTROPIC_F32_ERROR` of the float64 model (tests/models/test_kernels.py).
    ``D``'s ``tan^2`` stay float64: its ``t^2`` would amplify theirs."""
    axes = _axes32(g)
    return (*_h_axes(g), *axes[:4], inv_4_cos32(g), axes[4])


#: The relative error that float32 inputs add to Mitsuba's anisotropic roughconductor
#: (:func:`brdffit.kernels.inputs_renderers.conductor_anisotropic_inputs`: those of
#: anisotropic GGX but Schlick's weight, 1.2e-7 to first order), stated and tested.
CONDUCTOR_ANISOTROPIC_F32_ERROR = 1.3e-7


#: The relative error that float32 inputs add to anisotropic Beckmann (see
#: :func:`beckmann_anisotropic_inputs`: 1.2e-7 to first order), stated and tested.
BECKMANN_ANISOTROPIC_F32_ERROR = 1.3e-7


def beckmann_anisotropic_inputs(g: Geometry) -> tuple:
    """Anisotropic Beckmann: ``(H.T / N.H)^2``, ``(H.B / N.H)^2`` and, as
    :func:`beckmann_inputs`, the logarithm of the factor in float64, then in float32
    :func:`_tan2_axes_of` L and of V and Schlick's weight (those of
    :func:`ggx_anisotropic_inputs`).

    float32 where the value tolerates it: ``alpha^2 tan^2 = alpha_u^2 tx + alpha_v^2
    ty`` changes by at most ``2^-24`` relative, so ``a = 1 / sqrt(alpha^2 tan^2)`` by
    3e-8 and Smith's ``G1`` (whose relative change is at most that of ``a``) by 3e-8
    for L and for V, ``F`` by at most 6e-8: 1.2e-7 in all, with the loop's one-step
    roots (2e-13) and its ``exp`` (:func:`~brdffit.kernels.elementary.fast_exp_7`,
    5e-11) within :data:`BECKMANN_ANISOTROPIC_F32_ERROR` of the float64 model
    (tested; 2.7e-8 observed over random parameters). Measured:
    the loop 1.1x faster streamed from memory (its arithmetic, not its memory, is most
    of its time)."""
    axes = _axes32(g)
    return (*_h_axes(g), *axes[:4], _log_microfacet_factor(g), axes[4])


#: The relative error that float32 inputs add to Mitsuba's principled: ``5 u``, ``u =
#: 2^-24`` (derived in :func:`brdffit.kernels.inputs_renderers.principled_inputs`).
PRINCIPLED_F32_ERROR = 5 * 2.0**-24
#: The same for its anisotropic form: ``7 u`` (derived in
#: :func:`brdffit.kernels.inputs_renderers.principled_anisotropic_inputs`).
PRINCIPLED_ANISOTROPIC_F32_ERROR = 7 * 2.0**-24

#: Model name -> the relative error its loop's float32 inputs add (the bounds above;
#: the other loops read float64 only).
F32_ERROR = {
    "beckmann": BECKMANN_F32_ERROR,
    "ggx_anisotropic": GGX_ANISOTROPIC_F32_ERROR,
    "beckmann_anisotropic": BECKMANN_ANISOTROPIC_F32_ERROR,
    "mitsuba_principled": PRINCIPLED_F32_ERROR,
    "mitsuba_principled_anisotropic": PRINCIPLED_ANISOTROPIC_F32_ERROR,
    "mitsuba_roughconductor_anisotropic": CONDUCTOR_ANISOTROPIC_F32_ERROR,
}


def ward_inputs(g: Geometry) -> tuple:
    """Ward: ``tan^2 theta_h`` and ``ln(1 / (4 pi sqrt((N.L)(N.V))))``."""
    _geometry_loops(g)  # loaded before tan2_h: the geometry's compiled pass forms it
    return g.tan2_h, _log_ward_factor(g)


def cook_torrance_inputs(g: Geometry) -> tuple:
    """Cook-Torrance: ``tan^2 theta_h``, ``ln(G / (4 pi (N.L)(N.V) (N.H)^4))`` with the
    V-cavity ``G = min(1, 2 (N.H) min(N.L, N.V) / (V.H))`` and ``V.H``."""

    def compute():
        if _geometry_loops(g):  # the same values in one pass
            from . import loops_geometry

            factor, cos_d = np.empty(g.m), np.empty(g.m)
            loops_geometry.cook_torrance_factor(g.cos_h, g.cos_i, g.cos_o, g.cos_d, factor, cos_d)
            return g.tan2_h, np.log(factor, out=factor), cos_d
        c2 = g.cos_h * g.cos_h
        shadowing = vcavity_g(g.cos_h, g.cos_i, g.cos_o, g.cos_d)
        factor = shadowing / (4.0 * g.cos_i * g.cos_o) * (1.0 / (math.pi * c2 * c2))
        return g.tan2_h, np.log(factor), np.maximum(g.cos_d, 1e-300)

    return g.cached("kernels.cook_torrance", compute)


def cook_torrance_schlick_inputs(g: Geometry) -> tuple:
    """As :func:`cook_torrance_inputs`, with Schlick's ``(1 - V.H)^5`` for ``V.H``."""
    return (*cook_torrance_inputs(g)[:2], microfacet_inputs(g)[4])


def torrance_sparrow_inputs(g: Geometry) -> tuple:
    """Torrance-Sparrow: ``theta_h^2``, ``ln(G / (4 (N.L)(N.V)))`` with the V-cavity
    ``G`` and ``V.H``."""

    def compute():
        shadowing = vcavity_g(g.cos_h, g.cos_i, g.cos_o, g.cos_d)
        factor = shadowing / (4.0 * g.cos_i * g.cos_o)
        return _theta_h2(g), np.log(factor), np.maximum(g.cos_d, 1e-300)

    return g.cached("kernels.torrance_sparrow", compute)


def blake_inputs(g: Geometry) -> tuple:
    """Blake: ``theta_h`` and ``theta_h^2``."""
    return g.theta_h, _theta_h2(g)


def blinn_inputs(g: Geometry) -> tuple:
    """Blinn: ``ln(N.H)``, so that ``(N.H)^n = exp(n ln(N.H))``."""
    return (g.log_cos_h,)


def phong_inputs(g: Geometry) -> tuple:
    """Phong: ``ln(max(0, R.V))``, with -1e300 for ``ln 0`` (finite for the loop)."""

    def compute():
        with np.errstate(divide="ignore"):
            log_cos_r = np.log(np.maximum(g.cos_r, 0.0))
        return (np.maximum(log_cos_r, -1e300, out=log_cos_r),)

    return g.cached("kernels.phong", compute)


def heidrich_seidel_inputs(g: Geometry) -> tuple:
    """Heidrich-Seidel: ``ln(sqrt(1-(L.T)^2) sqrt(1-(V.T)^2) - (L.T)(V.T))`` as in
    :mod:`brdffit.models.anisotropic_shapes`, with -1e300 for ``ln`` of a base <= 0."""

    def compute():
        lt, vt = g.wi[:, 0], g.wo[:, 0]
        base = np.sqrt(np.maximum(1.0 - lt * lt, 0.0)) * np.sqrt(np.maximum(1.0 - vt * vt, 0.0))
        base -= lt * vt
        out = np.full(g.m, -1e300)
        np.log(base, out=out, where=base > 0)
        return (out,)

    return g.cached("kernels.heidrich_seidel", compute)


def schlick_inputs(g: Geometry) -> tuple:
    """Schlick's lobe: ``N.H`` and ``1 - N.H = sin^2(theta_h) / (1 + N.H)``."""
    return g.cos_h, g.cached("kernels.schlick", lambda: g.sin2_h / (1.0 + g.cos_h))


def wang_inputs(g: Geometry) -> tuple:
    """Wang: ``ln(N.H)`` and ``cos^2(phi_h)``."""
    return g.log_cos_h, g.cos2_phi_h


def ward_anisotropic_inputs(g: Geometry) -> tuple:
    """Anisotropic Ward: ``(H.T / N.H)^2``, ``(H.B / N.H)^2`` and the logarithm of
    Ward's factor."""
    return (*_h_axes(g), _log_ward_factor(g))


def ashikhmin_phong_inputs(g: Geometry) -> tuple:
    """Ashikhmin's anisotropic Phong lobe: ``cos^2(phi_h) ln(N.H)``, ``sin^2(phi_h)
    ln(N.H)`` (those of :func:`ashikhmin_shirley_inputs`)."""
    return ashikhmin_shirley_inputs(g)[:2]


def ashikhmin_shirley_inputs(g: Geometry) -> tuple:
    """Ashikhmin-Shirley: ``cos^2(phi_h) ln(N.H)``, ``sin^2(phi_h) ln(N.H)``,
    ``ln(1 / (8 pi (V.H) max(N.L, N.V)))``, ``(1 - V.H)^5`` and the diffuse column
    ``28/(23 pi) (1 - (1 - N.L/2)^5)(1 - (1 - N.V/2)^5)``."""

    def compute():
        log_c = g.log_cos_h
        c = np.maximum(g.cos_d, MIN_COSINE)
        scale = 1.0 / (8.0 * math.pi * c * np.maximum(g.cos_i, g.cos_o))
        diffuse = (1.0 - _pow5(1.0 - 0.5 * g.cos_i)) * (1.0 - _pow5(1.0 - 0.5 * g.cos_o))
        diffuse *= 28.0 / (23.0 * math.pi)
        along_t = g.cos2_phi_h * log_c
        weight = schlick_weight(g.cos_d)
        return along_t, g.sin2_phi_h * log_c, np.log(scale), weight, diffuse

    return g.cached("kernels.ashikhmin_shirley", compute)
