"""The openpbr export: the MaterialX document loads in MaterialX, and OpenPBR's BRDF
at the written inputs, evaluated by the tests' own implementation of the spec
(renderer_reference), has the error and albedo the export states."""

from __future__ import annotations

import math

import numpy as np
import pytest
import renderer_reference as ref
from helpers import hemisphere_pairs

import brdffit
from brdffit import export

mx = pytest.importorskip("MaterialX", reason="MaterialX (pip install materialx) is absent")


def gonio(model, params, noise=0.005):
    return brdffit.synthesize(model, params, geometry="gonio", noise=noise, seed=0)


def read_materialx(text: str):
    """The surface node's inputs as numbers, and the tangent's rotation (radians)."""
    doc = mx.createDocument()
    mx.readFromXmlString(doc, text)
    library = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), library)
    doc.importLibrary(library)
    valid, message = doc.validate()
    assert valid, message
    node = doc.getNode("brdffit_surface")
    nodedef = node.getNodeDef()
    assert nodedef.getNodeString() == "open_pbr_surface"
    q = {}
    for given in node.getInputs():
        assert given.getType() == nodedef.getActiveInput(given.getName()).getType()
        value = given.getValue()
        q[given.getName()] = list(value) if given.getType() == "color3" else value
    graph = doc.getNodeGraph("brdffit_tangent")
    if graph is not None:  # T cos(r) + (N x T) sin(r)
        cross = graph.getNode("bitangent")
        assert cross.getCategory() == "crossproduct"
        assert [cross.getInput(i).getNodeName() for i in ("in1", "in2")] == ["normal", "tangent"]
        turned = graph.getNode("turned")
        parts = [graph.getNode(turned.getInput(i).getNodeName()) for i in ("in1", "in2")]
        assert [p.getInput("in1").getNodeName() for p in parts] == ["tangent", "bitangent"]
        cos, sin = (p.getInputValue("in2") for p in parts)
        assert cos * cos + sin * sin == pytest.approx(1.0, rel=1e-6)  # MaterialX floats are 32-bit
        q["rotation"] = math.atan2(sin, cos)
    return q


def reproduce(e, data):
    """The export's stated error recomputed from the document by renderer_reference."""
    q = read_materialx(e.document)
    f = ref.openpbr(data.wi, data.wo, q)
    y = data.values.reshape(data.n, -1)
    return q, ref.rms_log(f, y, data.wi[:, 2])


@pytest.fixture(scope="module")
def plastic():
    data = gonio("ggx", {"kd": [0.3, 0.2, 0.1], "ks": [1.0] * 3, "alpha": 0.2, "f0": 0.04})
    return export(brdffit.fit(data, "ggx"), "openpbr", data=data), data


def test_stated_error_and_albedo_are_openpbrs(plastic):
    e, data = plastic
    err = e.conversion_error
    q, rms = reproduce(e, data)
    assert q["base_diffuse_roughness"] == 0.0 and q["specular_weight"] == 1.0
    assert rms == pytest.approx(err["rms_log_target"], rel=1e-4)
    assert err["rms_log_target"] < 0.02  # within about 2 % of a GGX plastic
    for theta, stated in zip(err["albedo_theta_i"], err["albedo_target"], strict=True):
        np.testing.assert_allclose(ref.albedo(ref.openpbr, q, theta), stated, rtol=1e-4)
    assert any("OpenPBR's opaque base was fitted" in n for n in e.notes)


def test_layering_is_albedo_scaling_seen_from_the_viewer(plastic):
    """f(L, V) != f(V, L): the diffuse is scaled by 1 - E_spec(V), V = wo."""
    e, _ = plastic
    wi = np.array([[0.0, 0.0, 1.0]])
    wo = np.array([[math.sin(1.3), 0.0, math.cos(1.3)]])
    forth, back = e.native.evaluate(wi, wo), e.native.evaluate(wo, wi)
    q = read_materialx(e.document)
    np.testing.assert_allclose(forth, ref.openpbr(wi, wo, q), rtol=1e-5)
    np.testing.assert_allclose(back, ref.openpbr(wo, wi, q), rtol=1e-5)
    assert not np.allclose(forth, back, rtol=1e-3)


@pytest.fixture(scope="module")
def tinted_metal():
    """Data synthesised from an OpenPBR metal by renderer_reference, exported."""
    truth = {"base_weight": 1.0, "base_color": [0.95, 0.64, 0.54], "base_metalness": 1.0,
             "specular_color": [0.7] * 3, "specular_roughness": 0.35,
             "specular_ior": 1.5}  # fmt: skip
    grid = gonio("lambert", {"kd": 0.5}, noise=0.0)
    values = ref.openpbr(grid.wi, grid.wo, truth)
    data = brdffit.Measurements(grid.wi, grid.wo, values, channels=("r", "g", "b"))
    seed = {"model": "gltf_pbr", "params": {"base_color": 0.5, "metallic": 1.0, "roughness": 0.5}}
    return truth, export(seed, "openpbr", data=data)


def test_round_trip_recovers_the_openpbr_material(tinted_metal):
    truth, e = tinted_metal
    q = read_materialx(e.document)
    # roughness, not alpha = roughness^2: the pitfall every exporter meets
    assert q["specular_roughness"] == pytest.approx(0.35, rel=1e-3)
    assert q["base_metalness"] == pytest.approx(1.0, abs=1e-3)
    np.testing.assert_allclose(q["base_color"], truth["base_color"], rtol=2e-3)
    np.testing.assert_allclose(q["specular_color"], truth["specular_color"], rtol=5e-3)
    assert e.conversion_error["rms_log_target"] < 1e-4


def test_f82_tint_holds_at_82_degrees(tinted_metal):
    """The metal's Fresnel at cos = 1/7 is specular_color x Schlick's (the spec's F82 tint)."""
    _, e = tinted_metal
    q = read_materialx(e.document)
    half = np.array([0.0, 0.0, 1.0])
    wo = np.array([[math.sqrt(1 - ref.MU_82**2), 0.0, ref.MU_82]])
    wi = 2 * (wo @ half)[:, None] * half - wo  # the mirror pair: V.H = 1/7
    r = q["specular_roughness"]
    spec, _ = ref.Lobe(r * r, r * r).spec(wi, wo)
    metal = type(e.native)(e.native.model, {**e.native.params, "base_metalness": 1.0},
                           e.native.channels)  # fmt: skip
    fresnel = metal.evaluate(wi, wo)[0] / spec[0]
    base = np.asarray(q["base_color"])
    np.testing.assert_allclose(fresnel, q["specular_color"] * ref.schlick(ref.MU_82, base),
                               rtol=1e-6)  # fmt: skip
    assert (fresnel < ref.schlick(ref.MU_82, base)).all()


def test_anisotropy_follows_the_tangent_x():
    """A highlight stretched along y: OpenPBR's tangent (alpha_t >= alpha_b) turns 90 degrees."""
    params = {"kd": [0.02] * 3, "ks": [0.9, 0.6, 0.5], "alpha_u": 0.1, "alpha_v": 0.3, "f0": 1.0}
    data = gonio("ggx_anisotropic", params)
    e = export(brdffit.fit(data, "ggx_anisotropic"), "openpbr", data=data)
    q, rms = reproduce(e, data)
    assert abs(abs(math.degrees(q["rotation"])) - 90.0) < 5.0
    assert q["specular_roughness_anisotropy"] > 0.3
    assert rms == pytest.approx(e.conversion_error["rms_log_target"], rel=1e-4)
    assert any("geometry_tangent" in n for n in e.notes)


def test_document_turns_the_tangent_counter_clockwise():
    """The node graph's tangent is x turned by +0.5 rad towards y, as the native model's."""
    from brdffit.export.core import Material
    from brdffit.export.openpbr import openpbr_document, openpbr_parameters
    from brdffit.export.openpbr_brdf import OPENPBR_ANISOTROPIC

    params = {"base_color": [0.5, 0.4, 0.3], "base_metalness": 0.5, "specular_roughness": 0.5,
              "specular_roughness_anisotropy": 0.7, "anisotropy_rotation": 0.5,
              "specular_ior": 1.6, "specular_color": 0.9}  # fmt: skip
    model = OPENPBR_ANISOTROPIC
    native = Material(model, model.check_params(params), ("r", "g", "b"))
    q = read_materialx(openpbr_document(openpbr_parameters(native)))
    assert q["rotation"] == pytest.approx(0.5, rel=1e-6)
    wi, wo = hemisphere_pairs(60, seed=5, grazing=False)
    keep = wo[:, 2] > 0.1
    np.testing.assert_allclose(native.evaluate(wi[keep], wo[keep]),
                               ref.openpbr(wi[keep], wo[keep], q), rtol=1e-4)  # fmt: skip
    q["rotation"] = -0.5
    assert not np.allclose(native.evaluate(wi[keep], wo[keep]), ref.openpbr(wi[keep], wo[keep], q),
                           rtol=1e-2)  # fmt: skip


def test_more_than_three_channels_are_refused_before_any_fit():
    names = ("450nm", "500nm", "550nm", "600nm", "650nm")
    data = brdffit.synthesize("lambert", {"kd": [0.5] * 5}, geometry="gonio", channels=names)
    seed = {"model": "lambert", "params": {"kd": [0.5] * 5}, "channels": list(names)}
    with pytest.raises(brdffit.ParameterError, match="one or three channels") as raised:
        export(seed, "openpbr", data=data)
    assert raised.value.field == "channels"
