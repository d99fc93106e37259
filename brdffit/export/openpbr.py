"""OpenPBR: a MaterialX document with one ``open_pbr_surface``.

Source: OpenPBR Surface specification v1.1 (academysoftwarefoundation.github.io/
OpenPBR) and its MaterialX definition (open_pbr_surface.mtlx in MaterialX).
Mapping from glTF metallic-roughness (:mod:`brdffit.export.gltf`):
``base_color``, ``base_metalness = metallic``, ``specular_roughness =
roughness`` (both square it into alpha), ``specular_ior = 1.5``. OpenPBR's own
BRDF differs from glTF's (F82-tint metal Fresnel, energy-preserving dielectric
layering); it is not evaluated here, so the error stated is the glTF one.
"""

from __future__ import annotations

from .core import Material, rgb

__all__ = ["openpbr_parameters", "openpbr_document"]


def openpbr_parameters(native: Material) -> dict:
    p = native.params
    return {
        "base_weight": 1.0,
        "base_color": rgb(p["base_color"], native.channels),
        "base_metalness": float(p["metallic"]),
        "specular_weight": 1.0,
        "specular_roughness": float(p["roughness"]),
        "specular_ior": 1.5,
    }


def openpbr_document(q: dict, name: str = "brdffit") -> str:
    lines = [
        '<?xml version="1.0"?>',
        '<materialx version="1.39">',
        f'  <open_pbr_surface name="{name}_surface" type="surfaceshader">',
    ]
    for key, value in q.items():
        if isinstance(value, list):
            shown = ", ".join(f"{x:.9g}" for x in value)
            lines.append(f'    <input name="{key}" type="color3" value="{shown}" />')
        else:
            lines.append(f'    <input name="{key}" type="float" value="{value:.9g}" />')
    lines += [
        "  </open_pbr_surface>",
        f'  <surfacematerial name="{name}" type="material">',
        f'    <input name="surfaceshader" type="surfaceshader" nodename="{name}_surface" />',
        "  </surfacematerial>",
        "</materialx>",
    ]
    return "\n".join(lines) + "\n"
