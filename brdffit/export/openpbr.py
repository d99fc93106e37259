"""OpenPBR: a MaterialX document with one ``open_pbr_surface``.

Source: OpenPBR Surface specification v1.1 (academysoftwarefoundation.github.io/
OpenPBR; AcademySoftwareFoundation/OpenPBR, index.html) and its MaterialX
definition (reference/open_pbr_surface.mtlx, shipped in MaterialX's bxdf
library). The export fits OpenPBR's own opaque BRDF
(:data:`brdffit.export.openpbr_brdf.OPENPBR`, which evaluates the spec's formulas:
F82-tint metal, exact dielectric Fresnel, height-correlated GGX, the OpenPBR
anisotropy map, the diffuse albedo-scaled by ``1 - E_spec(V)``) to the fitted
BRDF, or to the data when given, and states the error and albedo of that BRDF.

Written inputs: ``base_weight = 1``, ``base_color``, ``base_metalness``,
``base_diffuse_roughness = 0`` (Lambert), ``specular_weight = 1``,
``specular_color`` (grey), ``specular_roughness`` (``alpha = r^2``),
``specular_roughness_anisotropy`` and ``specular_ior``. The anisotropy runs
along ``geometry_tangent``, which is the mesh tangent (x of brdffit's frame); a
fit whose anisotropy axis is turned by ``anisotropy_rotation`` (``r``) gets a
node graph that turns the world tangent counter-clockwise about the normal,
``T cos(r) + (N x T) sin(r)`` (a cross product: MaterialX's ``rotate3d`` does
not say which way it turns, and its GLSL and OSL code read differently).
"""

from __future__ import annotations

import math

import numpy as np

from ..fitting import fit
from .core import Material, reference_data, rgb
from .openpbr_brdf import OPENPBR, OPENPBR_ANISOTROPIC, for_fitting

__all__ = ["openpbr_material", "openpbr_parameters", "openpbr_document"]

RENDER_NOTE = (
    "The error is that of OpenPBR's BRDF as the spec writes it (single-scatter GGX, "
    "E_spec integrated exactly); MaterialX's GLSL reference approximates E_spec with a "
    "fitted curve at the mean alpha and adds multiple-scattering energy, so renders of "
    "rough materials are slightly brighter."
)


#: Local evaluations of the final polish with the full-accuracy quadrature.
POLISH_EVALS = 60
#: Larger data are fitted on a seeded subsample of this many samples (each distinct
#: view direction costs an E(V) per evaluation); the error is stated on all of them.
FIT_SAMPLES = 1000


def fit_native(material: Material, model, data=None) -> Material:
    """``model`` (OpenPBR's or Blender's BRDF) fitted to the material or the data:
    searched with the coarse quadrature, then polished with the full one, on at
    most FIT_SAMPLES samples."""
    samples, _ = reference_data(material, data)
    rgb(np.zeros(len(samples.channels)), samples.channels)  # one or three, before the fit
    if samples.n > FIT_SAMPLES:
        samples = samples.subsample(FIT_SAMPLES, seed=0)
    coarse = fit(samples, for_fitting(model), loss="log")
    start = {p.name: coarse.params[p.name] for p in model.shape_params}
    result = fit(samples, model, loss="log", start=start, global_algorithm=None, restarts=0,
                 local_evals=POLISH_EVALS)  # fmt: skip
    return Material(model, dict(result.params), tuple(samples.channels))


def subsample_note(data) -> tuple:
    """What a fit to large data says about its subsample."""
    if data is None or data.n <= FIT_SAMPLES:
        return ()
    return (
        f"fitted on a seeded subsample of {FIT_SAMPLES} of the {data.n} samples; "
        "the error is stated on all of them.",
    )


def openpbr_material(material: Material, data=None) -> tuple:
    """(native Material evaluating OpenPBR's BRDF, notes)."""
    aniso = material.anisotropic
    native = fit_native(material, OPENPBR_ANISOTROPIC if aniso else OPENPBR, data)
    notes = (
        f"{material.model} is not OpenPBR's BRDF: OpenPBR's opaque base was fitted to it "
        "(log loss); the error is that of the fitted OpenPBR material.",
        RENDER_NOTE,
        *subsample_note(data),
    )
    if aniso:
        notes += (
            "The anisotropy follows geometry_tangent: the fit's x axis is the mesh tangent.",
        )
    return native, notes


def openpbr_parameters(native: Material) -> dict:
    """The ``open_pbr_surface`` inputs of a fitted OpenPBR material."""
    p = native.params
    tint = float(p["specular_color"])
    q = {
        "base_weight": 1.0,
        "base_color": rgb(p["base_color"], native.channels),
        "base_metalness": float(p["base_metalness"]),
        "base_diffuse_roughness": 0.0,
        "specular_weight": 1.0,
        "specular_color": [tint, tint, tint],
        "specular_roughness": float(p["specular_roughness"]),
        "specular_ior": float(p["specular_ior"]),
    }
    if "specular_roughness_anisotropy" in p:
        q["specular_roughness_anisotropy"] = float(p["specular_roughness_anisotropy"])
        q["tangent_rotation_degrees"] = math.degrees(float(p["anisotropy_rotation"]))
    return q


def _tangent_graph(name: str, degrees: float) -> list:
    """``T cos(r) + (N x T) sin(r)``: the tangent turned counter-clockwise about ``N``
    (written with a cross product, whose handedness is fixed, not ``rotate3d``)."""
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    return [
        f'  <nodegraph name="{name}_tangent">',
        '    <tangent name="tangent" type="vector3">',
        '      <input name="space" type="string" value="world" />',
        "    </tangent>",
        '    <normal name="normal" type="vector3">',
        '      <input name="space" type="string" value="world" />',
        "    </normal>",
        '    <crossproduct name="bitangent" type="vector3">',
        '      <input name="in1" type="vector3" nodename="normal" />',
        '      <input name="in2" type="vector3" nodename="tangent" />',
        "    </crossproduct>",
        '    <multiply name="along_tangent" type="vector3">',
        '      <input name="in1" type="vector3" nodename="tangent" />',
        f'      <input name="in2" type="float" value="{c:.9g}" />',
        "    </multiply>",
        '    <multiply name="along_bitangent" type="vector3">',
        '      <input name="in1" type="vector3" nodename="bitangent" />',
        f'      <input name="in2" type="float" value="{s:.9g}" />',
        "    </multiply>",
        '    <add name="turned" type="vector3">',
        '      <input name="in1" type="vector3" nodename="along_tangent" />',
        '      <input name="in2" type="vector3" nodename="along_bitangent" />',
        "    </add>",
        '    <output name="out" type="vector3" nodename="turned" />',
        "  </nodegraph>",
    ]


def openpbr_document(q: dict, name: str = "brdffit") -> str:
    """A MaterialX 1.39 document: the surface, its material, the tangent graph if any."""
    lines = ['<?xml version="1.0"?>', '<materialx version="1.39">']
    degrees = q.get("tangent_rotation_degrees", 0.0)
    if degrees:
        lines += _tangent_graph(name, degrees)
    lines.append(f'  <open_pbr_surface name="{name}_surface" type="surfaceshader">')
    for key, value in q.items():
        if key == "tangent_rotation_degrees":
            continue
        if isinstance(value, list):
            shown = ", ".join(f"{x:.9g}" for x in value)
            lines.append(f'    <input name="{key}" type="color3" value="{shown}" />')
        else:
            lines.append(f'    <input name="{key}" type="float" value="{value:.9g}" />')
    if degrees:
        lines.append(
            f'    <input name="geometry_tangent" type="vector3" nodegraph="{name}_tangent" '
            'output="out" />'
        )
    lines += [
        "  </open_pbr_surface>",
        f'  <surfacematerial name="{name}" type="material">',
        f'    <input name="surfaceshader" type="surfaceshader" nodename="{name}_surface" />',
        "  </surfacematerial>",
        "</materialx>",
    ]
    return "\n".join(lines) + "\n"
