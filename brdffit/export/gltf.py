"""glTF 2.0: an asset (JSON) with one metallic-roughness material.

Source: glTF 2.0 specification, section 3.9 "Materials" and appendix B "BRDF
implementation" (registry.khronos.org/glTF/specs/2.0/glTF-2.0.html); the
KHR_materials_anisotropy extension (github.com/KhronosGroup/glTF,
extensions/2.0/Khronos/KHR_materials_anisotropy). Conventions: ``alpha =
roughnessFactor^2``; GGX with height-correlated Smith visibility; Schlick's
Fresnel; the diffuse is Lambert weighted by ``1 - F`` with ``F0 = 0.04``
(ior 1.5); ``anisotropyRotation`` is counter-clockwise from the mesh TANGENT,
which is x of brdffit's local frame, and the tangent roughness is
``alpha + (1 - alpha) anisotropyStrength^2``.

The native models are ``gltf_pbr`` and ``gltf_pbr_anisotropic``
(:mod:`brdffit.models.renderer_native`).
"""

from __future__ import annotations

from .core import Material, rgb, to_native

__all__ = ["gltf_document", "gltf_material", "material_from_gltf"]

TANGENT_NOTE = (
    "KHR_materials_anisotropy needs the mesh's TANGENT attribute: the fit's x axis is "
    "the tangent, and anisotropyRotation turns counter-clockwise from it."
)


def gltf_material(material: Material, data=None) -> tuple:
    """(native Material, exact?, notes)."""
    if material.model == "gltf_pbr":
        return material, True, ()
    if material.model == "gltf_pbr_anisotropic":
        return material, True, (TANGENT_NOTE,)
    aniso = material.anisotropic
    name = "gltf_pbr_anisotropic" if aniso else "gltf_pbr"
    native = to_native(material, name, data)
    notes = (
        f"{material.model} is not glTF's BRDF: {name} was fitted to it; "
        "the error is that of the fitted glTF material.",
        *((TANGENT_NOTE,) if aniso else ()),
    )
    return native, False, notes


def gltf_document(native: Material, name: str = "brdffit") -> dict:
    """A glTF 2.0 asset whose only material is ``native``."""
    p = native.params
    material = {
        "name": name,
        "pbrMetallicRoughness": {
            "baseColorFactor": [*rgb(p["base_color"], native.channels), 1.0],
            "metallicFactor": float(p["metallic"]),
            "roughnessFactor": float(p["roughness"]),
        },
    }
    doc = {"asset": {"version": "2.0", "generator": "brdffit"}, "materials": [material]}
    if native.model == "gltf_pbr_anisotropic":
        material["extensions"] = {
            "KHR_materials_anisotropy": {
                "anisotropyStrength": float(p["anisotropy_strength"]),
                "anisotropyRotation": float(p["anisotropy_rotation"]),
            }
        }
        doc["extensionsUsed"] = ["KHR_materials_anisotropy"]
    return doc


def material_from_gltf(doc: dict, index: int = 0) -> Material:
    """The native Material of a glTF asset's material ``index`` (factors only)."""
    m = doc["materials"][index]
    pbr = m.get("pbrMetallicRoughness", {})
    params = {
        "base_color": list(pbr.get("baseColorFactor", [1.0, 1.0, 1.0, 1.0])[:3]),
        "metallic": float(pbr.get("metallicFactor", 1.0)),
        "roughness": float(pbr.get("roughnessFactor", 1.0)),
    }
    aniso = m.get("extensions", {}).get("KHR_materials_anisotropy")
    if aniso is None:
        return Material("gltf_pbr", params, ("r", "g", "b"))
    params["anisotropy_strength"] = float(aniso.get("anisotropyStrength", 0.0))
    params["anisotropy_rotation"] = float(aniso.get("anisotropyRotation", 0.0))
    return Material("gltf_pbr_anisotropic", params, ("r", "g", "b"))
