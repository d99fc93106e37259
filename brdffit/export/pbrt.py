"""pbrt-v4: a material statement (``mix`` of ``diffuse`` and ``conductor``).

Source: pbrt-v4 file format (pbrt.org/fileformat-v4, "Materials") and
src/pbrt/bxdfs.h, materials.cpp (github.com/mmp/pbrt-v4). Conventions:
``roughness`` is remapped by default (``remaproughness`` true:
``alpha = sqrt(roughness)``), so it is written as alpha with
``remaproughness false``; the Trowbridge-Reitz (GGX) masking is the
height-correlated ``G = 1 / (1 + Lambda(L) + Lambda(V))``; a ``conductor`` uses
the exact conductor Fresnel of ``eta + i k`` (written as constant spectra; with
``k = 0`` it is a dielectric's Fresnel) and has no scale; ``uroughness`` acts
along x; ``mix`` picks ``materials[1]`` with
probability ``amount``, which averages to ``(1 - amount) m0 + amount m1``.

The exported BRDF, evaluated here from those formulas, is
``(1 - w) R / pi + w F(V.H; eta + i k) D G / (4 N.L N.V)``. Exactly that form (with
``kd = (1 - w) R`` and ``ks = w`` per channel, ``kd + ks <= 1``) is fitted to the
material or the data; pbrt's ``amount`` is one number, so ``w`` is the largest
``ks`` and a coloured specular keeps only its brightest channel (a note says so).
"""

from __future__ import annotations

import numpy as np

from ..models import Design, Model, Param
from ..models.base import INV_PI, Classification
from ..models.params import roughness
from ..models.renderer_native import gltf_specular
from ..models.shared import fresnel_conductor
from .core import Material, rgb, to_native

R_MAX = 0.9999

__all__ = ["pbrt_parameters", "pbrt_statement", "pbrt_model"]


def _design(geometry, shape) -> Design:
    spec = gltf_specular(geometry, shape["alpha_u"], shape["alpha_v"])
    spec *= fresnel_conductor(geometry.cos_d, shape["eta"], shape["k"])
    return Design((INV_PI, spec))


#: The form fitted before writing pbrt's statement (unregistered: pbrt only).
PBRT_MIX = Model(
    name="pbrt_mix",
    params=(
        Param("kd", 0.0, 1.0, 0.5, linear=True, unit="1", doc="(1 - amount) reflectance"),
        Param("ks", 0.0, 1.0, 0.5, linear=True, unit="1", doc="amount of the conductor"),
        roughness("alpha_u", doc="uroughness (remaproughness false), along x"),
        roughness("alpha_v", doc="vroughness (remaproughness false)"),
        Param("eta", 0.05, 10.0, 1.5, unit="1", doc="conductor eta"),
        Param("k", 0.0, 10.0, 0.0, unit="1", doc="conductor k"),
    ),
    classification=Classification("physical", "anisotropic", "cosine", "material"),
    reference="pbrt-v4 (M. Pharr, W. Jakob, G. Humphreys), materials.cpp, bxdfs.h",
    design=_design,
    coefficient_constraints=(((1.0, 1.0), 1.0),),
    doc="kd/pi + ks F(eta + i k) D G2 / (4 N.L N.V): pbrt-v4's mix of diffuse and conductor.",
)


def pbrt_parameters(material: Material, data=None) -> tuple:
    """(pbrt parameters, notes) from a material: PBRT_MIX fitted, then written."""
    native = to_native(material, PBRT_MIX, data)
    p = native.params
    kd, ks = np.asarray(rgb(p["kd"], native.channels)), np.asarray(rgb(p["ks"], native.channels))
    w = float(min(ks.max(), 1.0))
    q = {
        "amount": w,
        "diffuse_reflectance": (np.minimum(kd / (1.0 - w), 1.0) if w < 1 else kd * 0).tolist(),
        "uroughness": float(p["alpha_u"]),
        "vroughness": float(p["alpha_v"]),
    }
    if not (ks.max() > 0 and ks.min() < 0.98 * ks.max()):
        q["eta"], q["k"] = float(p["eta"]), float(p["k"])
        return q, ()
    # A coloured specular: pbrt's "reflectance" r per channel (eta = 1, k from r)
    # with F(0) = ks F(0; eta, k) / amount; the shape of F(theta) is then pbrt's.
    f0 = float(fresnel_conductor(np.ones(1), p["eta"], p["k"])[0])
    q["reflectance"] = np.clip(ks * f0 / w, 0.0, R_MAX).tolist()
    note = (f"coloured specular {ks.round(4).tolist()}: written as pbrt's conductor "
            "reflectance (F at normal incidence, eta = 1), which keeps the colour")  # fmt: skip
    return q, (note,)


def _conductor_eta_k(q: dict):
    """Per channel (eta, k) of the conductor as pbrt evaluates it."""
    if "reflectance" not in q:
        return [(q["eta"], q["k"])] * 3
    r = np.asarray(q["reflectance"])
    return [(1.0, float(2.0 * np.sqrt(x) / np.sqrt(1.0 - x))) for x in r]


def pbrt_values(geometry, q: dict) -> np.ndarray:
    """The pbrt BRDF of parameters ``q``, shape (M, 3)."""
    spec = gltf_specular(geometry, q["uroughness"], q["vroughness"])
    out = np.empty((geometry.m, 3))
    for c, (eta, k) in enumerate(_conductor_eta_k(q)):
        out[:, c] = (1 - q["amount"]) * q["diffuse_reflectance"][c] * INV_PI
        out[:, c] += q["amount"] * spec * fresnel_conductor(geometry.cos_d, eta, k)
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


def _fresnel_lines(q: dict) -> str:
    if "reflectance" in q:
        return f'    "rgb reflectance" [ {_floats(q["reflectance"])} ]\n'
    return (
        f'    "spectrum eta" [ 300 {q["eta"]:.9g} 800 {q["eta"]:.9g} ]\n'
        f'    "spectrum k" [ 300 {q["k"]:.9g} 800 {q["k"]:.9g} ]\n'
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
        + _fresnel_lines(q)
        + f'    "float uroughness" {q["uroughness"]:.9g}\n'
        f'    "float vroughness" {q["vroughness"]:.9g}\n'
        f'    "bool remaproughness" false\n'
        f'MakeNamedMaterial "{name}"\n'
        f'    "string type" "mix"\n'
        f'    "string materials" [ "{name}_diffuse" "{name}_conductor" ]\n'
        f'    "float amount" {q["amount"]:.9g}\n'
    )
