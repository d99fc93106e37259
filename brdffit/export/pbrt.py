"""pbrt-v4: a material statement (``mix`` of ``diffuse`` and ``conductor``).

Source: pbrt-v4 file format (pbrt.org/fileformat-v4, "Materials") and
src/pbrt/bxdfs.h, materials.cpp (github.com/mmp/pbrt-v4). Conventions:
``roughness`` is remapped by default (``remaproughness`` true:
``alpha = sqrt(roughness)``), so it is written as alpha with
``remaproughness false``; the Trowbridge-Reitz (GGX) masking is the
height-correlated ``G = 1 / (1 + Lambda(L) + Lambda(V))``; a ``conductor`` given
``reflectance`` r uses ``eta = 1`` and ``k = 2 sqrt(r) / sqrt(1 - r)`` with the
exact conductor Fresnel (so ``F(0) = r``, rising to 1 at grazing, and no
scale); ``uroughness`` acts along x; ``mix`` picks ``materials[1]`` with
probability ``amount``, which averages to ``(1 - amount) m0 + amount m1``.

The exported BRDF, evaluated here from those formulas, is
``(1 - w) R / pi + w F(V.H; 1 + i k(r)) D G / (4 N.L N.V)``; its parameters come
from the Mitsuba-native form (:mod:`brdffit.export.mitsuba`) with ``w = max ks /
(max ks + max kd)``, ``R = kd / (1 - w)``, ``r = ks / w`` (clipped below 1).
"""

from __future__ import annotations

import numpy as np

from ..models import Design, Model, Param
from ..models.base import INV_PI, Classification
from ..models.renderer_native import gltf_specular
from ..models.shared import fresnel_conductor
from .core import rgb

__all__ = ["pbrt_parameters", "pbrt_statement", "pbrt_model"]

R_MAX = 0.999


def pbrt_parameters(p: dict, channels) -> dict:
    """pbrt's parameters from Mitsuba-native neutral parameters."""
    kd, ks = np.asarray(rgb(p["kd"], channels)), np.asarray(rgb(p["ks"], channels))
    w = float(ks.max() / (ks.max() + kd.max())) if ks.any() else 0.0
    return {
        "amount": w,
        "diffuse_reflectance": (kd / (1 - w)).tolist() if w < 1 else [0.0] * 3,
        "conductor_reflectance": np.clip(ks / w if w else ks, 0.0, R_MAX).tolist(),
        "uroughness": float(p["alpha_u"]),
        "vroughness": float(p["alpha_v"]),
    }


def pbrt_values(geometry, q: dict) -> np.ndarray:
    """The pbrt BRDF of parameters ``q``, shape (M, 3)."""
    spec = gltf_specular(geometry, q["uroughness"], q["vroughness"])
    out = np.empty((geometry.m, 3))
    for c in range(3):
        r = q["conductor_reflectance"][c]
        k = 2.0 * np.sqrt(r) / np.sqrt(1.0 - r)
        f = fresnel_conductor(geometry.cos_d, 1.0, k)
        out[:, c] = (1 - q["amount"]) * q["diffuse_reflectance"][c] * INV_PI
        out[:, c] += q["amount"] * f * spec
    return out


def pbrt_model(q: dict) -> Model:
    """An unregistered one-coefficient Model of the exported BRDF (for albedo)."""
    return Model(
        name="pbrt_export",
        params=(Param("scale", 0.0, 1.0, 1.0, linear=True, doc="1: the BRDF as exported"),),
        classification=Classification("physical", "anisotropic", "cosine", "material"),
        reference="pbrt-v4 (M. Pharr, W. Jakob, G. Humphreys), materials.cpp, bxdfs.h",
        design=lambda geometry, shape: Design((pbrt_values(geometry, q),)),
        doc="pbrt-v4 mix of diffuse and conductor, as exported.",
    )


def _floats(values) -> str:
    return " ".join(f"{v:.9g}" for v in values)


def pbrt_statement(q: dict, name: str = "brdffit") -> str:
    """The ``MakeNamedMaterial`` statements of parameters ``q``."""
    return (
        f'MakeNamedMaterial "{name}_diffuse"\n'
        f'    "string type" "diffuse"\n'
        f'    "rgb reflectance" [ {_floats(q["diffuse_reflectance"])} ]\n'
        f'MakeNamedMaterial "{name}_conductor"\n'
        f'    "string type" "conductor"\n'
        f'    "rgb reflectance" [ {_floats(q["conductor_reflectance"])} ]\n'
        f'    "float uroughness" {q["uroughness"]:.9g}\n'
        f'    "float vroughness" {q["vroughness"]:.9g}\n'
        f'    "bool remaproughness" false\n'
        f'MakeNamedMaterial "{name}"\n'
        f'    "string type" "mix"\n'
        f'    "string materials" [ "{name}_diffuse" "{name}_conductor" ]\n'
        f'    "float amount" {q["amount"]:.9g}\n'
    )
