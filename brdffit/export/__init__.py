"""From a fit to a renderer's material: ``export(result, target) -> Export``.

One module per target (each cites its primary source): :mod:`.mitsuba`
(``mitsuba``, ``mitsuba-xml``), :mod:`.gltf`, :mod:`.openpbr`, :mod:`.pbrt`,
:mod:`.blender`. Shared machinery and the conversion error: :mod:`.core`.
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from .blender import blender_document, blender_inputs, blender_material
from .core import (
    Export,
    Material,
    conversion_error,
    material_of,
    native_albedo,
    rms_log_error,
    to_native,
)
from .gltf import gltf_document, gltf_material, material_from_gltf
from .mitsuba import (
    from_document,
    mitsuba_dict,
    mitsuba_parameters,
    mitsuba_xml,
    principled,
    roughplastic,
)
from .openpbr import openpbr_document, openpbr_material, openpbr_parameters
from .openpbr_albedo import native_albedo as fitted_albedo
from .pbrt import pbrt_evaluator, pbrt_model, pbrt_parameters, pbrt_statement

__all__ = ["Export", "Material", "export", "export_targets", "material_from_gltf", "material_of"]

TARGETS = {
    "mitsuba": "Mitsuba 3 dict for mitsuba.load_dict (diffuse, roughconductor, blendbsdf)",
    "mitsuba-xml": "Mitsuba 3 XML <bsdf> fragment (the same BSDF)",
    "gltf": "glTF 2.0 asset with one metallic-roughness material (+ KHR_materials_anisotropy)",
    "openpbr": "MaterialX document with an open_pbr_surface (OpenPBR's BRDF fitted)",
    "pbrt": "pbrt-v4 material statement (conductor, coateddiffuse or mix, the closest)",
    "blender": "Blender 4 Principled BSDF (GGX) inputs and a Python snippet (its BRDF fitted)",
}


def export_targets() -> dict:
    """The export targets: name -> what the document is."""
    return dict(TARGETS)


def export(result, target: str, data=None) -> Export:
    """The fitted material of ``result`` as a ``target`` material, with its error.

    Parameters
    ----------
    result : FitResult or dict
        A fit, or its ``to_dict()`` (``brdffit fit --json``).
    target : str
        One of :func:`export_targets`.
    data : Measurements, optional
        When given, approximate exports are fitted to the data (not to the
        fitted BRDF) and the error is measured on the data's directions.
    """
    if target not in TARGETS:
        raise ParameterError(
            f"target={target!r} is not an export target; choose one of {', '.join(TARGETS)}",
            "target",
        )
    material = material_of(result)
    if target == "pbrt":
        return _via_pbrt(material, data)
    if target in ("mitsuba", "mitsuba-xml"):
        return _via_mitsuba(material, target, data)
    if target in ("openpbr", "blender"):
        return _via_fitted(material, target, data)
    return _via_gltf(material, target, data)


def _via_pbrt(material: Material, data) -> Export:
    q, notes = pbrt_parameters(material, data)
    native = Material(pbrt_model(q), {"scale": 1.0}, material.channels)
    error = conversion_error(material, pbrt_evaluator(q), native_albedo(native), data)
    notes = (
        *notes,
        "fitted and evaluated here from pbrt-v4's formulas (height-correlated G, exact "
        "Fresnel; coateddiffuse: the expectation of its random walk); roughness is alpha "
        "(remaproughness false).",
    )
    return Export(pbrt_statement(q), "pbrt", q, {**error, "exact": False}, notes, native, "pbrt")


def _mitsuba_document(material: Material, data) -> tuple:
    """(document, native Material that it evaluates to, exact?, notes)."""
    if material.model.startswith("mitsuba_principled"):
        return principled(material), material, True, ()
    if material.model == "mitsuba_roughplastic":
        document, native, notes = roughplastic(material)
        return document, native, not notes, notes
    neutral, native, exact, notes = mitsuba_parameters(material, data)
    document = mitsuba_dict(neutral, material.channels)
    written = from_document(document, material.channels)
    wi, wo = _probe_pairs()
    before, after = native.evaluate(wi, wo), written.evaluate(wi, wo)
    if not np.allclose(after, before, rtol=1e-9, atol=1e-12 * np.abs(before).max()):
        exact = False
        notes = (*notes, "reflectances above 1 were clipped to 1 (Mitsuba refuses them)")
    if exact:
        return document, written, exact, notes
    return _closer_of(material, data, (document, written, exact, notes))


def _closer_of(material: Material, data, blend: tuple) -> tuple:
    """The blend stand-in or a fitted ``principled``, whichever errs less."""
    aniso = material.anisotropic
    name = "mitsuba_principled" + ("_anisotropic" if aniso else "")
    candidate = to_native(material, name, data)
    errors = [rms_log_error(material, m.evaluate, data) for m in (blend[1], candidate)]
    if errors[0] <= errors[1]:
        return blend
    notes = (
        f"{material.model} is not a Mitsuba BSDF: {name} (reflection lobes) was fitted to "
        f"it, closer than a diffuse + roughconductor blend (RMS {errors[1]:.4g} vs "
        f"{errors[0]:.4g}); the error is that of the fitted principled.",
    )
    return principled(candidate), candidate, False, notes


def _via_mitsuba(material: Material, target: str, data) -> Export:
    document, native, exact, notes = _mitsuba_document(material, data)
    error = conversion_error(material, native.evaluate, native_albedo(native), data)
    notes = (*notes, "Mitsuba's BSDF.eval returns the BRDF times cos(theta_o).")
    params = {**document}
    if target == "mitsuba-xml":
        document = mitsuba_xml(document)
    ext = "xml" if target == "mitsuba-xml" else "json"
    return Export(document, target, params, {**error, "exact": exact}, notes, native, ext)


def _probe_pairs():
    from ..data.geometry import directions_from_angles
    from ..synth import hemisphere_angles

    ti, pi_, to, po = hemisphere_angles(500, np.random.default_rng(0))
    return directions_from_angles(ti, pi_), directions_from_angles(to, po)


def _via_gltf(material: Material, target: str, data) -> Export:
    native, exact, notes = gltf_material(material, data)
    error = conversion_error(material, native.evaluate, native_albedo(native), data)
    document = gltf_document(native)
    params = document["materials"][0]
    return Export(document, target, params, {**error, "exact": exact}, notes, native, "gltf")


def _via_fitted(material: Material, target: str, data) -> Export:
    """OpenPBR or Blender: the target's own BRDF fitted, its error stated."""
    if target == "openpbr":
        native, notes = openpbr_material(material, data)
        params = openpbr_parameters(native)
        document, ext = openpbr_document(params), "mtlx"
    else:
        native, notes = blender_material(material, data)
        params = blender_inputs(native)
        document, ext = blender_document(params), "json"
    error = conversion_error(material, native.evaluate, fitted_albedo(native), data)
    return Export(document, target, params, {**error, "exact": False}, notes, native, ext)
