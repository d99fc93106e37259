"""Blender 4: the Principled BSDF inputs (JSON) and a Python snippet that sets them.

Source: Blender manual, "Principled BSDF" (docs.blender.org/manual/en/4.2/
render/shader_nodes/shader/principled.html) and Cycles'
intern/cycles/kernel/svm/closure.h (the Principled closure),
kernel/closure/bsdf_microfacet.h and bsdf_util.h (blender/blender). The export
fits the Principled BSDF's own BRDF with ``distribution = 'GGX'`` (single
scatter; Blender's default, multiscatter GGX, adds energy)
(:data:`brdffit.export.openpbr_brdf.BLENDER`: Schlick metal (F82 tint with a
white Specular Tint), exact dielectric Fresnel of IOR (Specular IOR Level 0.5
leaves it unchanged), height-correlated GGX with ``alpha = Roughness^2`` and
Cycles' anisotropy map ``alpha_x = r^2 / sqrt(1 - 0.9 a)``, ``alpha_y = r^2
sqrt(1 - 0.9 a)`` along the tangent, the Lambertian diffuse weighted by
``1 - E_F(V) / E_1(V)``) to the fitted BRDF, or to the data when given, and
states the error and albedo of that BRDF.

Written inputs: Base Color, Metallic, Roughness, IOR, and for anisotropic
fits Anisotropic and Anisotropic Rotation (a fraction of a turn,
counter-clockwise about the normal from the tangent, which is x of brdffit's
frame: Cycles turns ``T`` by ``2 pi`` x rotation with ``rotate_around_axis``).
"""

from __future__ import annotations

import json
import math

from .core import Material, rgb
from .openpbr import fit_native, subsample_note
from .openpbr_brdf import BLENDER, BLENDER_ANISOTROPIC

__all__ = ["blender_material", "blender_inputs", "blender_document"]

RENDER_NOTE = (
    "The error is that of the Principled BSDF's formulas with E_F and E_1 integrated "
    "exactly; Cycles reads the lower layer's weight from a 16^3 Monte-Carlo table of the "
    "same quantity."
)


def blender_material(material: Material, data=None) -> tuple:
    """(native Material evaluating the Principled BSDF, notes)."""
    aniso = material.anisotropic
    native = fit_native(material, BLENDER_ANISOTROPIC if aniso else BLENDER, data)
    notes = (
        f"{material.model} is not Blender's BRDF: the Principled BSDF (GGX) was fitted to "
        "it (log loss); the error is that of the fitted Principled material.",
        RENDER_NOTE,
        "Set the node's distribution to GGX (the snippet does): multiscatter GGX adds energy.",
        *subsample_note(data),
    )
    if aniso:
        notes += ("Anisotropy needs a tangent: the fit's x axis is the tangent.",)
    return native, notes


def blender_inputs(native: Material) -> dict:
    """The Principled BSDF inputs of a fitted Blender material."""
    p = native.params
    inputs = {
        "Base Color": [*rgb(p["base_color"], native.channels), 1.0],
        "Metallic": float(p["metallic"]),
        "Roughness": float(p["roughness"]),
        "IOR": float(p["ior"]),
        "Specular IOR Level": 0.5,
        "Specular Tint": [1.0, 1.0, 1.0, 1.0],
    }
    if "anisotropic" in p:
        inputs["Anisotropic"] = float(p["anisotropic"])
        inputs["Anisotropic Rotation"] = (float(p["anisotropy_rotation"]) / (2 * math.pi)) % 1.0
    return inputs


def blender_document(inputs: dict, name: str = "brdffit") -> dict:
    """The inputs as JSON and a ``bpy`` snippet that makes the material."""
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
