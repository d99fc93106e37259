"""Directional albedo of the OpenPBR and Blender BRDFs of :mod:`.openpbr_brdf`.

``a(L) = integral f(L, V) cos(theta_v) dw_v`` (MODELS.md), as
:func:`brdffit.models.properties.albedo` defines it for every model, computed
lobe by lobe instead of by adaptive quadrature over ``V`` (whose every ``V``
would need its own ``E(V)``):

- the specular lobes are reciprocal, so their albedo at ``L`` is the view
  albedo of :func:`~.openpbr_brdf.view_albedo` at ``L``, with the dielectric's
  Fresnel (times the tint) and with the metal's F82-tint Fresnel;
- the diffuse lobe gives ``(1 - M) base_color (1 - <A>)`` with ``<A> =
  integral A(V) cos(theta_v) dw_v / pi`` (Gauss-Legendre in ``cos(theta_v)``,
  equal steps in azimuth for anisotropic lobes), the same for every ``L``.

Reference: OpenPBR Surface v1.1, "Layering" (the albedo of an albedo-scaled
layer); see :mod:`.openpbr_brdf` for the formulas.
"""

from __future__ import annotations

import math

import numpy as np

from ..models.shared import fresnel_dielectric
from .core import Material
from .openpbr_brdf import (
    NAMES,
    QUADRATURE,
    _visible_quadrature,
    blender_alphas,
    f82_tint,
    openpbr_alphas,
)

__all__ = ["native_albedo"]

#: Nodes of ``<A>``: Gauss-Legendre in cos(theta_v), equal steps in azimuth.
MEAN_NODES = (32, 32)


def _settings(native: Material) -> dict:
    p = native.params
    target = native.model.name.partition("_")[0]
    names = NAMES[target]
    alphas = openpbr_alphas if target == "openpbr" else blender_alphas
    alpha_t, alpha_b = alphas(p[names[0]], p.get(names[1], 0.0))
    return {
        "target": target,
        "alphas": (alpha_t, alpha_b),
        "rotation": float(p.get("anisotropy_rotation", 0.0)),
        "eta": float(p[names[2]]),
        "metal": float(p[names[3]]),
        "tint": float(p.get("specular_color", 1.0)),
        "base": np.atleast_1d(np.asarray(p["base_color"], dtype=float)),
    }


def _mean_layer_albedo(s: dict) -> float:
    """``<A>``: the cosine-weighted mean over views of what the gloss takes from the base."""
    alpha_t, alpha_b = s["alphas"]
    x, w = np.polynomial.legendre.leggauss(MEAN_NODES[0])
    mu, w = 0.5 * (x + 1.0), 0.5 * w
    n_phi = 1 if alpha_t == alpha_b else MEAN_NODES[1]
    phi = 2.0 * math.pi * (np.arange(n_phi) + 0.5) / n_phi
    mm, pp = np.meshgrid(mu, phi, indexing="ij")
    sin = np.sqrt(1.0 - mm * mm)
    views = np.stack([sin * np.cos(pp), sin * np.sin(pp), mm], axis=-1).reshape(-1, 3)
    c, ratio = _visible_quadrature(views, alpha_t, alpha_b, QUADRATURE)
    e_f = (ratio * fresnel_dielectric(c, s["eta"])).sum(axis=1)
    taken = e_f if s["target"] == "openpbr" else e_f / ratio.sum(axis=1)
    weights = np.repeat(2.0 * w * mu / n_phi, n_phi)
    return float(taken @ weights)


def native_albedo(native: Material):
    """``theta -> albedo`` (per channel) of a fitted OpenPBR or Blender material."""
    s = _settings(native)
    below = 1.0 - _mean_layer_albedo(s)
    alpha_t, alpha_b = s["alphas"]

    def at(theta: float) -> np.ndarray:
        t = math.radians(theta)
        light = np.array([[math.sin(t), 0.0, math.cos(t)]])
        c_r, s_r = math.cos(s["rotation"]), math.sin(s["rotation"])
        light = np.array([[light[0, 0] * c_r, -light[0, 0] * s_r, light[0, 2]]])
        c, ratio = _visible_quadrature(light, alpha_t, alpha_b, QUADRATURE)
        gloss = s["tint"] * float((ratio * fresnel_dielectric(c, s["eta"])).sum())
        column, offset = f82_tint(c, s["tint"])
        metal_col, metal_off = float((ratio * column).sum()), float((ratio * offset).sum())
        base, m = s["base"], s["metal"]
        return (1.0 - m) * (gloss + base * below) + m * (base * metal_col + metal_off)

    return at
