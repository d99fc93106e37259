"""brdffit.export: every target's document loads in the target's own parser where
one is installed, evaluates to what the export says, and states its error."""

from __future__ import annotations

import json
import math
import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from helpers import hemisphere_pairs, mitsuba_eval

import brdffit
from brdffit import ParameterError, export, export_targets, get_model
from brdffit.data.geometry import Geometry
from brdffit.export.core import Material, material_of
from brdffit.export.gltf import material_from_gltf
from brdffit.export.pbrt import pbrt_parameters, pbrt_statement, pbrt_values

TARGETS = sorted(export_targets())


def fitted(model, params, geometry="gonio", seed=0):
    data = brdffit.synthesize(model, params, geometry=geometry, noise=0.005, seed=seed)
    return brdffit.fit(data, model), data


@pytest.fixture(scope="module")
def plastic():
    return fitted("ggx", {"kd": [0.3, 0.2, 0.1], "ks": [1.0] * 3, "alpha": 0.2, "f0": 0.04})


@pytest.fixture(scope="module")
def brushed():
    params = {"kd": [0.02] * 3, "ks": [0.9, 0.6, 0.5], "alpha_u": 0.1, "alpha_v": 0.3, "f0": 1.0}
    return fitted("ggx_anisotropic", params)


def load_mitsuba(e):
    mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 (pip install mitsuba) is absent")
    mi.set_variant("scalar_rgb")
    return mi.load_dict(e.document) if e.target == "mitsuba" else mi.load_string(e.document)


# ------------------------------------------------------------------- every target
@pytest.mark.parametrize("target", TARGETS)
def test_every_target_states_its_error_and_writes(target, plastic, tmp_path):
    result, _ = plastic
    e = export(result, target)
    err = e.conversion_error
    assert err["against"].startswith("fitted BRDF") and err["rms_log_fit"] == 0.0
    assert 0.0 <= err["rms_log_target"] < 0.2
    assert np.shape(err["albedo_target"]) == np.shape(err["albedo_fit"]) == (3, 3)
    assert err["exact"] is False and e.notes  # ggx with Schlick f0 = 0.04 is nobody's model
    assert (e.extension in ("json", "gltf")) == isinstance(e.document, dict)  # JSON or text
    path = e.write(tmp_path / f"material.{e.extension}")
    assert path.read_text() == e.text()
    json.dumps(e.to_dict())


def test_unknown_target_and_bad_result_are_named(plastic):
    with pytest.raises(ParameterError, match=r"target='maya'.*mitsuba"):
        export(plastic[0], "maya")
    with pytest.raises(ParameterError, match="'params'"):
        export({"model": "ggx"}, "gltf")
    with pytest.raises(ParameterError, match="alpha"):
        export({"model": "ggx", "params": {"kd": 0.1, "ks": 1, "alpha": 7, "f0": 1}}, "gltf")


def test_a_result_json_is_enough(plastic):
    result, _ = plastic
    as_json = json.loads(json.dumps(result.to_dict()))
    assert export(as_json, "gltf").document == export(result, "gltf").document


# ----------------------------------------------------------------------- Mitsuba
EXACT_MITSUBA = [
    ("lambert", {"kd": [0.5, 0.4, 0.3]}),
    ("ggx", {"kd": [0.2, 0.1, 0.05], "ks": [0.6, 0.6, 0.5], "alpha": 0.15, "f0": 1.0}),
    ("mitsuba_roughconductor", {"specular_reflectance": [0.9, 0.7, 0.5], "alpha": 0.1,
                                "eta": 0.2, "k": 3.0}),
    ("lambert+mitsuba_roughconductor_anisotropic",
     {"lambert.kd": [0.1, 0.2, 0.3], "mitsuba_roughconductor_anisotropic.specular_reflectance":
      [0.5, 0.5, 0.4], "mitsuba_roughconductor_anisotropic.alpha_u": 0.05,
      "mitsuba_roughconductor_anisotropic.alpha_v": 0.3,
      "mitsuba_roughconductor_anisotropic.eta": 0.0, "mitsuba_roughconductor_anisotropic.k": 1.0}),
]  # fmt: skip


@pytest.mark.parametrize("target", ["mitsuba", "mitsuba-xml"])
@pytest.mark.parametrize("model, params", EXACT_MITSUBA)
def test_exact_mitsuba_exports_evaluate_in_mitsuba_to_the_fit(model, params, target):
    """Mitsuba's eval over cos(theta_o) equals the fitted BRDF within 1e-4."""
    e = export({"model": model, "params": params, "channels": ["r", "g", "b"]}, target)
    assert e.conversion_error["exact"] is True
    assert e.conversion_error["rms_log_target"] < 1e-12
    wi, wo = hemisphere_pairs(150, seed=31, grazing=False)
    got = mitsuba_eval(load_mitsuba(e), wi, wo) / wo[:, 2:3]
    want = get_model(model).evaluate(wi, wo, params)
    big = want > 1e-6 * want.max()
    np.testing.assert_allclose(got[big], want[big], rtol=1e-4)


def test_approximate_mitsuba_export_evaluates_in_mitsuba_to_its_native_model(plastic):
    e = export(plastic[0], "mitsuba")
    wi, wo = hemisphere_pairs(150, seed=32, grazing=False)
    got = mitsuba_eval(load_mitsuba(e), wi, wo) / wo[:, 2:3]
    want = e.native.evaluate(wi, wo)
    big = want > 1e-6 * want.max()
    np.testing.assert_allclose(got[big], want[big], rtol=1e-4)
    # and the reported error is the one of those values against the fitted BRDF
    assert e.conversion_error["rms_log_target"] > 1e-3


def test_mitsuba_pitfalls_are_written_out():
    e = export({"model": "ggx_anisotropic", "params": {"kd": 0.0, "ks": 0.8, "alpha_u": 0.05,
               "alpha_v": 0.2, "f0": 1.0}}, "mitsuba")  # fmt: skip
    d = e.document
    assert d["type"] == "roughconductor" and d["distribution"] == "ggx"  # default is beckmann
    assert d["alpha_u"] == 0.05 and d["alpha_v"] == 0.2  # alpha itself, u along x
    assert d["material"] == "none"  # F = 1, not a default copper
    root = ET.fromstring(export({"model": "lambert", "params": {"kd": 0.5}}, "mitsuba-xml").text())
    assert root.tag == "bsdf" and root.get("type") == "diffuse"


# -------------------------------------------------------------------------- glTF
def test_gltf_round_trip_gives_back_the_material():
    """Data synthesised from a glTF material -> fit gltf_pbr -> export -> factors."""
    truth = {"base_color": [0.8, 0.3, 0.1], "metallic": 0.3, "roughness": 0.45}
    result, _ = fitted("gltf_pbr", truth, seed=3)
    e = export(result, "gltf")
    assert e.conversion_error["exact"] is True
    back = material_from_gltf(json.loads(e.text()))
    assert back.model == "gltf_pbr"
    for name, value in truth.items():
        np.testing.assert_allclose(back.params[name], value, rtol=0.03)  # the fit's error
        # an exact export carries the fitted values themselves
        np.testing.assert_allclose(back.params[name], result.params[name], rtol=1e-9)


def test_gltf_anisotropy_round_trip_and_direction():
    truth = {"base_color": [0.9, 0.6, 0.5], "metallic": 1.0, "roughness": 0.3,
             "anisotropy_strength": 0.6, "anisotropy_rotation": 0.0}  # fmt: skip
    e = export({"model": "gltf_pbr_anisotropic", "params": truth}, "gltf")
    ext = e.document["materials"][0]["extensions"]["KHR_materials_anisotropy"]
    assert ext == {"anisotropyStrength": 0.6, "anisotropyRotation": 0.0}
    assert e.document["extensionsUsed"] == ["KHR_materials_anisotropy"]
    # A brushed metal fitted from Mitsuba's alpha_u > alpha_v: stretched along x, so no turn.
    result, _ = fitted("mitsuba_roughconductor_anisotropic", {"specular_reflectance": 0.9,
                       "alpha_u": 0.3, "alpha_v": 0.08, "eta": 0.0, "k": 1.0})  # fmt: skip
    ext = export(result, "gltf").parameters["extensions"]["KHR_materials_anisotropy"]
    assert abs(ext["anisotropyRotation"]) < 0.1
    result, _ = fitted("mitsuba_roughconductor_anisotropic", {"specular_reflectance": 0.9,
                       "alpha_u": 0.08, "alpha_v": 0.3, "eta": 0.0, "k": 1.0})  # fmt: skip
    ext = export(result, "gltf").parameters["extensions"]["KHR_materials_anisotropy"]
    assert abs(abs(ext["anisotropyRotation"]) - math.pi / 2) < 0.1


def test_gltf_parses_in_pygltflib(plastic):
    pygltflib = pytest.importorskip("pygltflib", reason="pygltflib is absent")
    e = export(plastic[0], "gltf")
    asset = pygltflib.GLTF2.from_json(e.text())
    pbr = asset.materials[0].pbrMetallicRoughness
    assert asset.asset.version == "2.0"
    assert (
        pbr.roughnessFactor
        == e.document["materials"][0]["pbrMetallicRoughness"]["roughnessFactor"]
    )
    assert len(pbr.baseColorFactor) == 4


def test_gltf_roughness_is_the_square_root_of_alpha():
    """The same GGX lobe: Mitsuba alpha 0.09 is glTF roughness 0.3."""
    e = export({"model": "mitsuba_roughconductor", "params": {"specular_reflectance": 1.0,
                "alpha": 0.09, "eta": 0.0, "k": 1.0}}, "gltf")  # fmt: skip
    pbr = e.document["materials"][0]["pbrMetallicRoughness"]
    assert abs(pbr["roughnessFactor"] - 0.3) < 0.02 and pbr["metallicFactor"] > 0.95


# --------------------------------------------------------------- pbrt, others
def pbrt_reference(wi, wo, q, c):
    """pbrt-v4's mix of diffuse and conductor, the Fresnel in complex arithmetic."""
    h = (wi + wo) / np.linalg.norm(wi + wo)
    au, av = q["uroughness"], q["vroughness"]
    d = 1 / (math.pi * au * av * ((h[0] / au) ** 2 + (h[1] / av) ** 2 + h[2] ** 2) ** 2)

    def lam(w):
        return (math.sqrt(1 + ((au * w[0]) ** 2 + (av * w[1]) ** 2) / w[2] ** 2) - 1) / 2

    if "reflectance" in q:  # pbrt: eta = 1, k = 2 sqrt(r) / sqrt(1 - r)
        r = q["reflectance"][c]
        n = complex(1.0, 2 * math.sqrt(r) / math.sqrt(1 - r))
    else:
        n = complex(q["eta"], q["k"])
    ci = float(wi @ h)
    ct = np.sqrt(1 - (1 - ci * ci) / (n * n))
    f = 0.5 * (abs((ci - n * ct) / (ci + n * ct)) ** 2 + abs((n * ci - ct) / (n * ci + ct)) ** 2)
    spec = d * f / (1 + lam(wi) + lam(wo)) / (4 * wi[2] * wo[2])
    return (1 - q["amount"]) * q["diffuse_reflectance"][c] / math.pi + q["amount"] * spec


def test_pbrt_statement_and_its_brdf(brushed):
    e = export(brushed[0], "pbrt")
    q = e.parameters
    assert '"bool remaproughness" false' in e.document  # roughness written as alpha
    assert f'"float uroughness" {q["uroughness"]:.9g}' in e.document
    assert abs(q["uroughness"] - 0.1) < 0.01 and abs(q["vroughness"] - 0.3) < 0.03
    wi, wo = hemisphere_pairs(60, seed=33, grazing=False)
    got = pbrt_values(Geometry(wi, wo), q)
    want = [[pbrt_reference(a, b, q, c) for c in range(3)] for a, b in zip(wi, wo)]
    np.testing.assert_allclose(got, want, rtol=1e-9)
    # A coloured metal keeps its colour through pbrt's reflectance (F at normal incidence).
    r = np.array(q["reflectance"])
    assert f'"rgb reflectance" [ {" ".join(f"{x:.9g}" for x in r)} ]' in e.document
    assert r[0] > r[1] > r[2]
    k = 2 * np.sqrt(r) / np.sqrt(1 - r)
    np.testing.assert_allclose(k**2 / (4 + k**2), r, rtol=1e-12)  # F(0) = r with eta = 1
    assert '"float amount"' in e.document and '"string type" "mix"' in e.document
    # The error reported is that of the written statement, small for this metal.
    assert e.conversion_error["rms_log_target"] < 0.05


def test_pbrt_grey_specular_is_written_with_eta_and_k(plastic):
    q, _ = pbrt_parameters(material_of(plastic[0]), forms=("mix",))
    assert f'"spectrum k" [ 300 {q["k"]:.9g} 800 {q["k"]:.9g} ]' in pbrt_statement(q)
    assert q["k"] < 0.5 and 1.2 < q["eta"] < 2.0  # the plastic's Fresnel: a dielectric's
    assert export(plastic[0], "pbrt").conversion_error["rms_log_target"] < 0.02


def test_blender_inputs_and_snippet(brushed):
    e = export(brushed[0], "blender")
    inputs = e.document["principled_bsdf"]["inputs"]
    assert set(inputs) >= {"Base Color", "Metallic", "Roughness", "Anisotropic"}
    assert 0.0 <= inputs["Anisotropic Rotation"] < 1.0  # a fraction of a turn in Blender
    compile(e.document["python"], "snippet", "exec")
    assert "node.distribution = 'GGX'" in e.document["python"]


def test_error_against_data_when_data_are_given(plastic):
    result, data = plastic
    e = export(result, "gltf", data=data)
    err = e.conversion_error
    assert err["against"] == "data" and err["n_directions"] == data.n
    assert err["rms_log_fit"] > 0  # the data carry noise
    assert err["rms_log_target"] < 3 * err["rms_log_fit"]


def test_native_material_evaluates_like_its_model():
    m = Material("gltf_pbr", {"base_color": 0.5, "metallic": 0.0, "roughness": 0.5})
    wi, wo = hemisphere_pairs(10, seed=34, grazing=False)
    assert m.evaluate(wi, wo).shape == (len(wi), 1)


def test_mitsuba_roughplastic_exports_exactly():
    params = {"diffuse": [0.9, 0.5, 0.2], "specular_reflectance": [1.0] * 3, "alpha": 0.15,
              "eta": 1.6}  # fmt: skip
    e = export({"model": "mitsuba_roughplastic", "params": params}, "mitsuba")
    assert e.conversion_error["exact"] is True
    assert e.document["type"] == "roughplastic" and e.document["ext_ior"] == 1.0
    wi, wo = hemisphere_pairs(100, seed=35, grazing=False)
    got = mitsuba_eval(load_mitsuba(e), wi, wo) / wo[:, 2:3]
    np.testing.assert_allclose(got, get_model("mitsuba_roughplastic").evaluate(wi, wo, params),
                               rtol=1e-4)  # fmt: skip
    xml = export({"model": "mitsuba_roughplastic", "params": params}, "mitsuba-xml")
    got = mitsuba_eval(load_mitsuba(xml), wi, wo) / wo[:, 2:3]
    np.testing.assert_allclose(got, get_model("mitsuba_roughplastic").evaluate(wi, wo, params),
                               rtol=1e-4)  # fmt: skip


@pytest.mark.parametrize("target", ["mitsuba", "mitsuba-xml"])
def test_mitsuba_principled_exports_exactly(target):
    params = {"base_color": [0.8, 0.5, 0.3], "metallic": 0.7, "roughness": 0.35,
              "specular": 0.6, "anisotropic": 0.5}  # fmt: skip
    e = export({"model": "mitsuba_principled_anisotropic", "params": params}, target)
    assert e.conversion_error["exact"] is True and e.parameters["type"] == "principled"
    assert e.parameters["roughness"] == 0.35  # Mitsuba squares it itself: alpha = 0.1225
    wi, wo = hemisphere_pairs(100, seed=36, grazing=False)
    got = mitsuba_eval(load_mitsuba(e), wi, wo) / wo[:, 2:3]
    want = get_model("mitsuba_principled_anisotropic").evaluate(wi, wo, params)
    big = want > 1e-6 * want.max()
    np.testing.assert_allclose(got[big], want[big], rtol=1e-4)


def test_a_negligible_lobe_is_dropped_not_divided_by_zero():
    """blendbsdf's weight ks / (ks + kd) rounds to 1 when kd is 1e-17 of ks."""
    params = {"kd": [1e-17, 0.0, 0.0], "ks": [0.9, 0.8, 0.7], "alpha": 0.2, "f0": 1.0}
    e = export({"model": "ggx", "params": params}, "mitsuba")
    assert e.document["type"] == "roughconductor"
    assert np.isfinite(e.conversion_error["rms_log_target"])


def test_approximate_mitsuba_export_takes_the_closer_stand_in():
    """A glTF dielectric is closer to Mitsuba's principled than to a diffuse +
    conductor blend; the export says which it took and both errors."""
    gltf = {"base_color": [0.6, 0.3, 0.2], "metallic": 0.0, "roughness": 0.5}
    e = export({"model": "gltf_pbr", "params": gltf}, "mitsuba")
    assert e.document["type"] == "principled"
    assert "closer than a diffuse + roughconductor blend" in e.notes[0]
    blend, principled = (
        float(x) for x in re.findall(r"RMS ([\d.e-]+) vs ([\d.e-]+)", e.notes[0])[0][::-1]
    )
    assert principled < blend
    assert e.conversion_error["rms_log_target"] == pytest.approx(principled, rel=1e-3)
