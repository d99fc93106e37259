"""The blender export: Cycles' Principled BSDF (GGX) at the written inputs, evaluated
by the tests' own implementation of Cycles' formulas (renderer_reference), has
the error and albedo the export states."""

from __future__ import annotations

import math

import numpy as np
import pytest
import renderer_reference as ref
from helpers import hemisphere_pairs

import brdffit
from brdffit import export


def gonio(model, params, noise=0.005):
    return brdffit.synthesize(model, params, geometry="gonio", noise=noise, seed=0)


def reproduce(e, data):
    """The export's stated error recomputed from the written inputs by renderer_reference."""
    inputs = e.document["principled_bsdf"]["inputs"]
    f = ref.blender(data.wi, data.wo, inputs)
    return inputs, ref.rms_log(f, data.values.reshape(data.n, -1), data.wi[:, 2])


@pytest.fixture(scope="module")
def plastic():
    data = gonio("ggx", {"kd": [0.3, 0.2, 0.1], "ks": [1.0] * 3, "alpha": 0.2, "f0": 0.04})
    return export(brdffit.fit(data, "ggx"), "blender", data=data), data


def test_stated_error_and_albedo_are_the_principled_bsdfs(plastic):
    e, data = plastic
    err = e.conversion_error
    inputs, rms = reproduce(e, data)
    assert inputs["Specular IOR Level"] == 0.5 and inputs["Specular Tint"] == [1.0] * 4
    assert rms == pytest.approx(err["rms_log_target"], rel=1e-4)
    assert err["rms_log_target"] < 0.02
    for theta, stated in zip(err["albedo_theta_i"], err["albedo_target"], strict=True):
        np.testing.assert_allclose(ref.albedo(ref.blender, inputs, theta), stated, rtol=1e-4)
    snippet = e.document["python"]
    compile(snippet, "snippet", "exec")
    assert "node.distribution = 'GGX'" in snippet and e.document["principled_bsdf"]["distribution"]


def test_blender_layering_differs_from_openpbrs(plastic):
    """Cycles weights the diffuse by 1 - E_F/E_1 (the lobe's Fresnel average), OpenPBR
    by 1 - E_F: at the same values Blender's diffuse is the darker."""
    e, _ = plastic
    inputs = e.document["principled_bsdf"]["inputs"]
    q = {"base_weight": 1.0, "base_color": inputs["Base Color"][:3], "base_metalness": 0.0,
         "specular_color": [1.0] * 3, "specular_roughness": inputs["Roughness"],
         "specular_ior": inputs["IOR"]}  # fmt: skip
    wi = np.array([[math.sin(0.9), 0.0, math.cos(0.9)]])
    wo = np.array([[0.0, math.sin(1.2), math.cos(1.2)]])
    dielectric = {**inputs, "Metallic": 0.0}
    got = type(e.native)(e.native.model, {**e.native.params, "metallic": 0.0}, e.native.channels)
    np.testing.assert_allclose(got.evaluate(wi, wo), ref.blender(wi, wo, dielectric), rtol=1e-4)
    assert (ref.blender(wi, wo, dielectric) < ref.openpbr(wi, wo, q)).all()


def test_round_trip_recovers_a_principled_metal():
    """Data from a Principled metal (Schlick, Roughness 0.35) come back with
    Roughness 0.35, not alpha = 0.1225."""
    truth = {"Base Color": [0.95, 0.64, 0.54, 1.0], "Metallic": 1.0, "Roughness": 0.35,
             "IOR": 1.5}  # fmt: skip
    grid = gonio("lambert", {"kd": 0.5}, noise=0.0)
    values = ref.blender(grid.wi, grid.wo, truth)
    data = brdffit.Measurements(grid.wi, grid.wo, values, channels=("r", "g", "b"))
    seed = {"model": "gltf_pbr", "params": {"base_color": 0.5, "metallic": 1.0, "roughness": 0.5}}
    e = export(seed, "blender", data=data)
    inputs = e.document["principled_bsdf"]["inputs"]
    assert inputs["Roughness"] == pytest.approx(0.35, rel=1e-3)
    assert inputs["Metallic"] == pytest.approx(1.0, abs=1e-3)
    np.testing.assert_allclose(inputs["Base Color"][:3], truth["Base Color"][:3], rtol=2e-3)
    assert e.conversion_error["rms_log_target"] < 1e-4


def test_anisotropic_rotation_turns_the_tangent_x():
    """A highlight stretched along y: Cycles' alpha_x (along T) is the larger, so T
    turns a quarter turn (Anisotropic Rotation 0.25 or 0.75)."""
    params = {"kd": [0.02] * 3, "ks": [0.9, 0.6, 0.5], "alpha_u": 0.1, "alpha_v": 0.3, "f0": 1.0}
    data = gonio("ggx_anisotropic", params)
    e = export(brdffit.fit(data, "ggx_anisotropic"), "blender", data=data)
    inputs, rms = reproduce(e, data)
    assert min(abs(inputs["Anisotropic Rotation"] - t) for t in (0.25, 0.75)) < 0.015
    assert inputs["Anisotropic"] > 0.3
    assert rms == pytest.approx(e.conversion_error["rms_log_target"], rel=1e-4)


def test_anisotropic_rotation_is_a_counter_clockwise_fraction_of_a_turn():
    """Anisotropic Rotation = rotation / 2 pi; Cycles turns T = x by 2 pi x it towards y."""
    from brdffit.export.blender import blender_inputs
    from brdffit.export.core import Material
    from brdffit.export.openpbr_brdf import BLENDER_ANISOTROPIC as MODEL

    params = {"base_color": [0.5, 0.4, 0.3], "metallic": 0.5, "roughness": 0.5,
              "anisotropic": 0.7, "anisotropy_rotation": 0.5, "ior": 1.6}  # fmt: skip
    native = Material(MODEL, MODEL.check_params(params), ("r", "g", "b"))
    inputs = blender_inputs(native)
    assert inputs["Anisotropic Rotation"] == pytest.approx(0.5 / (2 * math.pi), rel=1e-12)
    wi, wo = hemisphere_pairs(60, seed=6, grazing=False)
    keep = wo[:, 2] > 0.1
    wi, wo = wi[keep], wo[keep]
    np.testing.assert_allclose(native.evaluate(wi, wo), ref.blender(wi, wo, inputs), rtol=1e-4)
    mirrored = {**inputs, "Anisotropic Rotation": 1 - inputs["Anisotropic Rotation"]}
    assert not np.allclose(native.evaluate(wi, wo), ref.blender(wi, wo, mirrored), rtol=1e-2)
