"""OpenPBR's and Blender's opaque BRDF, evaluated from their published formulas.

The subset written by :mod:`brdffit.export.openpbr` and :mod:`brdffit.export.blender`
(no coat, fuzz, thin film, transmission, subsurface or emission; Lambertian
diffuse; weights 1) is, in both renderers, a mix by metalness ``M`` of a metal
lobe and a dielectric gloss layered over a diffuse::

    f = M F_metal(V.H) S + (1 - M) [t F(V.H; eta) S + (1 - A(V)) base_color / pi]

with ``S = D G2 / (4 N.L N.V)``: GGX ``D`` (anisotropic, along the tangent
``T`` = x rotated counter-clockwise about the normal by ``rotation``) and the
height-correlated Smith ``G2 = 1 / (1 + Lambda(L) + Lambda(V))``; ``F`` the
exact unpolarised dielectric Fresnel of relative index ``eta``; ``V = wo`` the
direction towards the viewer. What differs between the two:

``openpbr`` (OpenPBR Surface v1.1, sections "Microfacet model", "Dielectric base",
"Glossy-diffuse", "Metal", "Layering" and "Reduction to a mixture of lobes")
    ``alpha_t = r^2 sqrt(2 / (1 + (1 - a)^2))``, ``alpha_b = (1 - a) alpha_t``
    (``r`` = specular_roughness, ``a`` = specular_roughness_anisotropy);
    ``t`` = specular_color (a grey tint here); the metal's Fresnel is the
    F82-tint model of Kutz et al. (2021), ``F_metal = F_s(mu) - mu (1 - mu)^6 /
    (mu_b (1 - mu_b)^6) (1 - t) F_s(mu_b)`` with Schlick's ``F_s(mu) = F0 +
    (1 - F0)(1 - mu)^5``, ``F0`` = base_color, ``mu_b = 1/7`` (82 degrees), so
    ``F_metal(mu_b) = t F_s(mu_b)``; and the non-reciprocal albedo scaling of
    the spec's equation "non-reciprocal-albedo-scaling", ``A(V) = E_F(V)``,
    the directional albedo of the untinted single-scatter dielectric lobe
    ``F S`` seen from the viewer (specular_color tints "only the initial
    reflection", so the light entering the base sees the untinted Fresnel, as
    MaterialX's ``dielectric_bsdf`` throughput does).
``blender`` (Cycles, intern/cycles/kernel/svm/closure.h, Principled BSDF with
distribution GGX; kernel/closure/bsdf_microfacet.h, bsdf_util.h)
    ``alpha_x = r^2 / k``, ``alpha_y = r^2 k``, ``k = sqrt(1 - 0.9 a)``
    (``r`` = Roughness, ``a`` = Anisotropic), the tangent turned by Anisotropic
    Rotation x 2 pi; ``t = 1`` (Specular Tint white); the metal's F82 tint with
    a white tint, i.e. Schlick's ``F_s``; and the lower layer weighted by
    ``1 - A(V)`` with ``A(V) = E_F(V) / E_1(V)``: Cycles'
    ``bsdf_microfacet_estimate_albedo`` tabulates ``s``, the Fresnel blend
    averaged over the lobe *normalised by the lobe with F = 1*, and
    ``closure_layering_weight`` takes ``1 - mix(F0, 1, s)``; with the
    single-scatter GGX no energy compensation multiplies it back.

Neither renderer computes ``E`` exactly (MaterialX fits an analytic curve at
the mean alpha and adds a multiple-scattering compensation; Cycles reads a
16^3 Monte-Carlo table at the mean roughness); this module evaluates the
formulas they approximate, with ``E_F`` and ``E_1`` integrated over the
visible normals of the view direction (Heitz, "Sampling the GGX distribution
of visible normals", JCGT 7(4), 2018): ``E_F(V) = int F(V.m) G2(V, L) / G1(V)
dD_V(m)``, ``L`` the mirror of ``V`` about ``m``, Gauss-Legendre in the radial
variable up to the horizon and equal steps in azimuth (:func:`view_albedo`).

References: OpenPBR Surface specification v1.1 (AcademySoftwareFoundation/OpenPBR,
index.html) and reference/open_pbr_surface.mtlx; MaterialX
libraries/pbrlib/genglsl/mx_dielectric_bsdf.glsl; P. Kutz, M. Hasan, P.
Edmondson, Novel aspects of the Adobe Standard Material, 2021 (F82 tint);
E. Heitz, JCGT 3(2), 2014 (height-correlated Smith); Blender Cycles as above.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from ..data.geometry import Geometry
from ..models.base import INV_PI, Classification, Design, Model, Param
from ..models.renderer_native import gltf_specular
from ..models.shared import fresnel_dielectric

__all__ = [
    "MU_BAR",
    "OPENPBR",
    "OPENPBR_ANISOTROPIC",
    "BLENDER",
    "BLENDER_ANISOTROPIC",
    "blender_alphas",
    "f82_tint",
    "openpbr_alphas",
    "view_albedo",
]

#: The cosine of F82-tint's "grazing edge", about 81.8 degrees.
MU_BAR = 1.0 / 7.0
#: Nodes of the visible-normal quadrature: Gauss-Legendre in u, equal steps in azimuth.
#: E comes within 1e-5 (absolute) of a 64 x 256 rule for moderate anisotropy, 1e-4
#: for alpha_t / alpha_b = 9 at grazing views.
QUADRATURE = (24, 40)
#: The quadrature of the models a fit searches with: no horizon search, E within
#: about 2 % of QUADRATURE's (the polish that follows uses QUADRATURE), twenty times
#: faster. Stated errors always use QUADRATURE.
FIT_QUADRATURE = (8, 16)


def openpbr_alphas(roughness: float, anisotropy: float) -> tuple:
    """OpenPBR's ``(alpha_t, alpha_b)``: ``alpha_t^2 + alpha_b^2 = 2 r^4``."""
    alpha_t = roughness * roughness * math.sqrt(2.0 / (1.0 + (1.0 - anisotropy) ** 2))
    return alpha_t, (1.0 - anisotropy) * alpha_t


def blender_alphas(roughness: float, anisotropic: float) -> tuple:
    """Cycles' Principled ``(alpha_x, alpha_y) = (r^2 / k, r^2 k)``, ``k = sqrt(1 - 0.9 a)``."""
    r2 = roughness * roughness
    if anisotropic <= 0.0:
        return r2, r2
    k = math.sqrt(1.0 - 0.9 * anisotropic)
    return r2 / k, r2 * k


def f82_tint(mu, tint: float) -> tuple:
    """``(column, offset)`` with ``F_metal(mu) = F0 column + offset`` (module docstring)."""
    w = (1.0 - mu) ** 5
    w_bar = (1.0 - MU_BAR) ** 5
    k = mu * (1.0 - mu) ** 6 / (MU_BAR * (1.0 - MU_BAR) ** 6) * (1.0 - tint)
    return (1.0 - w) - k * (1.0 - w_bar), w - k * w_bar


def _lambda(x, y, z, ax: float, ay: float):
    """GGX's Smith ``Lambda`` of direction ``(x, y, z)`` (arrays), alphas along x and y."""
    return 0.5 * (np.sqrt(1.0 + ((ax * x) ** 2 + (ay * y) ** 2) / (z * z)) - 1.0)


@lru_cache(maxsize=8)
def _rule(n_u: int, n_phi: int) -> tuple:
    x, w = np.polynomial.legendre.leggauss(n_u)
    phi = 2.0 * math.pi * (np.arange(n_phi) + 0.5) / n_phi
    return 0.5 * (x + 1.0), 0.5 * w / n_phi, phi


class _VisibleNormals:
    """Heitz's (2018) map from the unit disk to the visible normals of views ``v``."""

    def __init__(self, v: np.ndarray, ax: float, ay: float):
        s = np.stack([ax * v[:, 0], ay * v[:, 1], v[:, 2]], axis=1)
        s /= np.linalg.norm(s, axis=1, keepdims=True)
        flat = np.hypot(s[:, 0], s[:, 1]) < 1e-9
        t1 = np.stack([-s[:, 1], s[:, 0], np.zeros(len(s))], axis=1)
        t1[flat] = (1.0, 0.0, 0.0)
        t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
        self.ax, self.ay = ax, ay
        self.v, self.s, self.t1 = v.T[..., None], s.T[..., None], t1.T[..., None]
        self.t2 = np.cross(s, t1).T[..., None]
        self.blend = 0.5 * (1.0 + s[:, 2:3])

    def light(self, u: np.ndarray, cos_phi: np.ndarray, sin_phi: np.ndarray) -> tuple:
        """``V.m`` and the three components of ``L`` at disk points ``r = sqrt(u)``,
        angle ``phi`` (``u`` of shape (K, Q), the angle's cosine and sine (Q,))."""
        r = np.sqrt(u)
        p1, p2 = r * cos_phi, r * sin_phi
        p2 = (1.0 - self.blend) * np.sqrt(np.maximum(1.0 - p1 * p1, 0.0)) + self.blend * p2
        pz = np.sqrt(np.maximum(1.0 - p1 * p1 - p2 * p2, 0.0))
        t1, t2, s = self.t1, self.t2, self.s
        mx = self.ax * (p1 * t1[0] + p2 * t2[0] + pz * s[0])
        my = self.ay * (p1 * t1[1] + p2 * t2[1] + pz * s[1])
        mz = np.maximum(p1 * t1[2] + p2 * t2[2] + pz * s[2], 0.0)
        inv = 1.0 / np.sqrt(mx * mx + my * my + mz * mz)
        mx *= inv
        my *= inv
        mz *= inv
        v = self.v
        c = mx * v[0] + my * v[1] + mz * v[2]
        return c, 2.0 * c * mx - v[0], 2.0 * c * my - v[1], 2.0 * c * mz - v[2]

    def horizon(self, phi: np.ndarray, steps: int = 14) -> np.ndarray:
        """Per azimuth ``phi`` (Q,), the ``u`` (K, Q) beyond which ``L`` is below the
        horizon (1: never)."""
        trig = np.cos(phi), np.sin(phi)
        lo, hi = np.zeros((len(self.blend), len(phi))), np.ones((len(self.blend), len(phi)))
        below = self.light(hi, *trig)[3] <= 0.0
        for _ in range(steps):
            mid = 0.5 * (lo + hi)
            up = self.light(mid, *trig)[3] > 0.0
            lo, hi = np.where(up, mid, lo), np.where(up, hi, mid)
        return np.where(below, lo, 1.0)


def _visible_quadrature(v: np.ndarray, alpha_t: float, alpha_b: float, quadrature: tuple):
    """``(V.m, w)`` (K, Q): ``sum(w X(V.m))`` is the albedo of ``X(V.H) S`` at ``v``."""
    v = np.asarray(v, dtype=float)
    n_u, n_phi = quadrature
    u_nodes, w_nodes, phi_nodes = _rule(n_u, n_phi)
    vn = _VisibleNormals(v, alpha_t, alpha_b)
    if n_u > FIT_QUADRATURE[0]:
        top = vn.horizon(phi_nodes)
    else:
        top = np.ones((len(v), n_phi))
    u = (top[..., None] * u_nodes).reshape(len(v), -1)
    weights = np.broadcast_to(top[..., None] * w_nodes, (len(v), n_phi, n_u))
    weights = weights.reshape(len(v), -1)
    phi = np.repeat(phi_nodes, n_u)
    c, lx, ly, lz = vn.light(u, np.cos(phi), np.sin(phi))
    weights = np.where(lz > 0.0, weights, 0.0)
    lz = np.maximum(lz, 1e-12)
    lam_v = _lambda(v[:, 0], v[:, 1], v[:, 2], alpha_t, alpha_b)[:, None]
    ratio = weights * (1.0 + lam_v) / (1.0 + lam_v + _lambda(lx, ly, lz, alpha_t, alpha_b))
    return np.clip(c, 1e-12, 1.0), ratio


def view_albedo(
    v: np.ndarray, alpha_t: float, alpha_b: float, eta: float, quadrature: tuple = QUADRATURE
) -> tuple:
    """``(E_F, E_1)`` at views ``v`` (K, 3) given in the anisotropy frame (x = T).

    ``E_F`` is the directional albedo of ``F(V.H; eta) S`` seen from ``v``,
    ``E_1`` that of ``S`` (``F = 1``): module docstring. The integrand
    ``F G2 / G1`` is smooth in ``u`` up to the horizon, where ``G2`` vanishes, so
    ``u`` runs over Gauss-Legendre nodes up to the horizon (found by bisection;
    not with FIT_QUADRATURE, which masks the pairs below it) and the azimuth
    over equal steps (a periodic rule).
    """
    c, ratio = _visible_quadrature(v, alpha_t, alpha_b, quadrature)
    return (ratio * fresnel_dielectric(c, eta)).sum(axis=1), ratio.sum(axis=1)


def _frame_views(geometry: Geometry, rotation: float, isotropic: bool):
    """Distinct view directions in the anisotropy frame, and each pair's index."""
    if isotropic:
        cos_o = geometry.cos_o
        key = ("openpbr_brdf.views", "iso")
        unique, index = geometry.cached(key, lambda: np.unique(cos_o, return_inverse=True))
        sin_o = np.sqrt(np.maximum(1.0 - unique * unique, 0.0))
        return np.stack([sin_o, 0 * sin_o, unique], axis=1), index
    key = ("openpbr_brdf.views", "aniso")
    unique, index = geometry.cached(
        key, lambda: np.unique(geometry.wo, axis=0, return_inverse=True)
    )
    c, s = math.cos(rotation), math.sin(rotation)
    t = unique[:, 0] * c + unique[:, 1] * s
    b = unique[:, 1] * c - unique[:, 0] * s
    return np.stack([t, b, unique[:, 2]], axis=1), np.ravel(index)


#: Each target's names of (roughness, anisotropy, ior, metalness).
NAMES = {
    "openpbr": ("specular_roughness", "specular_roughness_anisotropy", "specular_ior",
                "base_metalness"),
    "blender": ("roughness", "anisotropic", "ior", "metallic"),
}  # fmt: skip


def _design(geometry: Geometry, shape, target: str, quadrature: tuple) -> Design:
    """Column of ``base_color`` and the offset (module docstring)."""
    names = NAMES[target]
    rough, aniso = shape[names[0]], shape.get(names[1], 0.0)
    rotation = shape.get("anisotropy_rotation", 0.0)
    eta, metal = shape[names[2]], shape[names[3]]
    alphas = openpbr_alphas if target == "openpbr" else blender_alphas
    alpha_t, alpha_b = alphas(rough, aniso)
    tint = shape.get("specular_color", 1.0)
    spec = gltf_specular(geometry, alpha_t, alpha_b, rotation)
    views, index = _frame_views(geometry, rotation, alpha_t == alpha_b)
    e_f, e_1 = view_albedo(views, alpha_t, alpha_b, eta, quadrature)
    lost = e_f if target == "openpbr" else e_f / e_1
    metal_col, metal_off = f82_tint(geometry.cos_d, tint)
    column = (1.0 - metal) * INV_PI * (1.0 - lost[index]) + metal * metal_col * spec
    dielectric = tint * fresnel_dielectric(geometry.cos_d, eta)
    offset = ((1.0 - metal) * dielectric + metal * metal_off) * spec
    return Design((column,), offset)


def _roughness(name: str, doc: str) -> Param:
    return Param(name, 0.03, 1.0, 0.5, log_scale=True, unit="1", doc=doc)


_ROTATION = Param(
    "anisotropy_rotation", -math.pi / 2, math.pi / 2, 0.0, unit="rad",
    doc="angle of the anisotropy tangent, counter-clockwise about the normal from x",
)  # fmt: skip
_BASE = Param("base_color", 0.0, 1.0, 0.5, linear=True, unit="1", doc="base_color")
_IOR_DOC = "relative index of the dielectric (exact Fresnel)"


def _openpbr_params(anisotropic: bool) -> tuple:
    extra = (
        Param("specular_roughness_anisotropy", 0.0, 0.95, 0.5, unit="1",
              doc="OpenPBR anisotropy a: alpha_t = r^2 sqrt(2/(1 + (1-a)^2)), "
                  "alpha_b = (1-a) alpha_t"),
        _ROTATION,
    ) if anisotropic else ()  # fmt: skip
    return (
        _BASE,
        Param("base_metalness", 0.0, 1.0, 0.0, unit="1", doc="base_metalness"),
        _roughness("specular_roughness", "OpenPBR specular_roughness r: GGX alpha = r^2"),
        *extra,
        Param("specular_ior", 1.01, 3.0, 1.5, unit="1", doc=_IOR_DOC),
        Param("specular_color", 0.0, 1.0, 1.0, unit="1",
              doc="specular_color (grey): dielectric Fresnel tint and the metal's F82 tint"),
    )  # fmt: skip


def _blender_params(anisotropic: bool) -> tuple:
    extra = (
        Param("anisotropic", 0.0, 1.0, 0.5, unit="1",
              doc="Anisotropic a: alpha_x = r^2 / sqrt(1 - 0.9 a), alpha_y = r^2 sqrt(1 - 0.9 a)"),
        _ROTATION,
    ) if anisotropic else ()  # fmt: skip
    return (
        _BASE,
        Param("metallic", 0.0, 1.0, 0.0, unit="1", doc="Metallic"),
        _roughness("roughness", "Principled Roughness r: GGX alpha = r^2"),
        *extra,
        Param("ior", 1.01, 3.0, 1.5, unit="1", doc=_IOR_DOC),
    )


def _model(target: str, anisotropic: bool, quadrature: tuple = QUADRATURE) -> Model:
    name = target + ("_anisotropic" if anisotropic else "")
    symmetry = "anisotropic" if anisotropic else "isotropic"
    source = {
        "openpbr": "OpenPBR Surface v1.1 (AcademySoftwareFoundation/OpenPBR), opaque base",
        "blender": "Blender Cycles Principled BSDF, GGX (intern/cycles/kernel/svm/closure.h)",
    }[target]
    params = _openpbr_params(anisotropic) if target == "openpbr" else _blender_params(anisotropic)
    return Model(
        name=name,
        params=params,
        classification=Classification("physical", symmetry, "cosine", "material"),
        reference=source,
        design=lambda geometry, shape: _design(geometry, shape, target, quadrature),
        reciprocal=False,
        doc=f"{source}: see brdffit.export.openpbr_brdf.",
    )


#: OpenPBR's opaque BRDF (unregistered: fitted only to export).
OPENPBR = _model("openpbr", False)
OPENPBR_ANISOTROPIC = _model("openpbr", True)
#: Blender's Principled BSDF with GGX (unregistered: fitted only to export).
BLENDER = _model("blender", False)
BLENDER_ANISOTROPIC = _model("blender", True)


def for_fitting(model: Model) -> Model:
    """The same model with the coarser quadrature (the fit's search only)."""
    target, _, rest = model.name.partition("_")
    return _model(target, bool(rest), FIT_QUADRATURE)
