"""Blender 4: the Principled BSDF inputs (JSON) and a Python snippet that sets them.

Source: Blender manual, "Principled BSDF" (docs.blender.org/manual/en/4.2/
render/shader_nodes/shader/principled.html) and
intern/cycles/kernel/closure/bsdf_microfacet.h. Mapping from glTF
metallic-roughness (:mod:`brdffit.export.gltf`, which Blender's own glTF
importer uses): Base Color, Metallic, Roughness (alpha = Roughness^2), IOR 1.5;
``distribution`` is set to single-scatter ``GGX`` (Blender's default,
multiscatter GGX, adds energy that glTF does not have). Anisotropy is carried
with Anisotropic = strength and Anisotropic Rotation = rotation / (2 pi) (a
fraction of a turn), an approximation: Blender's anisotropic roughness law
differs from KHR_materials_anisotropy. Blender's BRDF is not evaluated here,
so the error stated is the glTF one.
"""

from __future__ import annotations

import json
import math

from .core import Material, rgb

__all__ = ["blender_inputs", "blender_document"]


def blender_inputs(native: Material) -> dict:
    p = native.params
    inputs = {
        "Base Color": [*rgb(p["base_color"], native.channels), 1.0],
        "Metallic": float(p["metallic"]),
        "Roughness": float(p["roughness"]),
        "IOR": 1.5,
    }
    if "anisotropy_strength" in p:
        inputs["Anisotropic"] = float(p["anisotropy_strength"])
        inputs["Anisotropic Rotation"] = (float(p["anisotropy_rotation"]) / (2 * math.pi)) % 1.0
    return inputs


def blender_document(inputs: dict, name: str = "brdffit") -> dict:
    snippet = "\n".join(
        [
            "import bpy",
            f"mat = bpy.data.materials.new({name!r})",
            "mat.use_nodes = True",
            'node = mat.node_tree.nodes["Principled BSDF"]',
            "node.distribution = 'GGX'",
            f"for key, value in {json.dumps(inputs)}.items():",
            "    node.inputs[key].default_value = value",
        ]
    )
    return {"principled_bsdf": {"distribution": "GGX", "inputs": inputs}, "python": snippet}
