"""pbrt-v4 statements: their syntax (parsed here), alpha with remaproughness false,
the conductor evaluated from the parsed text, and the choice between the forms."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from helpers import hemisphere_pairs

import brdffit
from brdffit import ParameterError, export
from brdffit.data.geometry import Geometry
from brdffit.export.core import material_of
from brdffit.export.pbrt import pbrt_parameters, pbrt_values
from brdffit.export.pbrt_layer import PBRT_COATEDDIFFUSE, coated_tables

TOKEN = re.compile(r'"[^"]*"|\[|\]|[^\s\[\]"]+')
TYPES = {"float", "integer", "bool", "string", "rgb", "spectrum"}


def parse(text: str) -> dict:
    """``MakeNamedMaterial "name" "type param" value | [ values ] ...`` -> {name: {param:
    (type, values)}}; fails on anything else."""
    tokens, out, i = TOKEN.findall(text), {}, 0
    while i < len(tokens):
        assert tokens[i] == "MakeNamedMaterial", tokens[i]
        name, params, i = tokens[i + 1].strip('"'), {}, i + 2
        while i < len(tokens) and tokens[i].startswith('"'):
            kind, param = tokens[i].strip('"').split()
            assert kind in TYPES and param not in params, tokens[i]
            if tokens[i + 1] == "[":
                end = tokens.index("]", i + 2)
                raw, i = tokens[i + 2 : end], end + 1
            else:
                raw, i = [tokens[i + 1]], i + 2
            params[param] = (kind, [_value(kind, r) for r in raw])
        out[name] = params
    return out


def _value(kind, raw):
    if kind == "string":
        assert raw.startswith('"'), raw
        return raw.strip('"')
    if kind == "bool":
        assert raw in ("true", "false"), raw
        return raw == "true"
    return int(raw) if kind == "integer" else float(raw)


def pbrt_conductor(wi, wo, alpha_u, alpha_v, n):
    """pbrt-v4's ConductorBxDF (bxdfs.h): Trowbridge-Reitz D, height-correlated G,
    FrComplex of the complex index ``n`` (util/scattering.h), complex arithmetic."""
    h = (wi + wo) / np.linalg.norm(wi + wo, axis=-1, keepdims=True)
    e = (h[:, 0] / alpha_u) ** 2 + (h[:, 1] / alpha_v) ** 2 + h[:, 2] ** 2
    d = 1 / (math.pi * alpha_u * alpha_v * e * e)

    def lam(w):
        return (
            np.sqrt(1 + ((alpha_u * w[:, 0]) ** 2 + (alpha_v * w[:, 1]) ** 2) / w[:, 2] ** 2) - 1
        ) / 2

    c = np.sum(wo * h, axis=-1).astype(complex)
    ct = np.sqrt(1 - (1 - c * c) / (n * n))
    r_parl = (n * c - ct) / (n * c + ct)
    r_perp = (c - n * ct) / (c + n * ct)
    f = (abs(r_parl) ** 2 + abs(r_perp) ** 2) / 2
    return d * f / (1 + lam(wi) + lam(wo)) / (4 * wi[:, 2] * wo[:, 2])


def conductor_from_text(params, wi, wo):
    """(M, 3) values of a parsed conductor, as pbrt reads its parameters."""
    assert params["remaproughness"] == ("bool", [False])
    au, av = params["uroughness"][1][0], params["vroughness"][1][0]
    if "reflectance" in params:  # materials.cpp: eta = 1, k = 2 sqrt(r) / sqrt(1 - r)
        r = np.array(params["reflectance"][1])
        n = [complex(1, 2 * math.sqrt(x) / math.sqrt(1 - x)) for x in r]
    else:
        (_, eta), (_, k) = params["eta"], params["k"]
        assert eta[1] == eta[3] and k[1] == k[3] and len(eta) == len(k) == 4  # constant spectra
        n = [complex(eta[1], k[1])] * 3
    return np.stack([pbrt_conductor(wi, wo, au, av, x) for x in n], axis=-1)


@pytest.fixture(scope="module")
def grey_metal():
    params = {"specular_reflectance": 1.0, "alpha": 0.09, "eta": 0.2, "k": 3.0}
    return export({"model": "mitsuba_roughconductor", "params": params}, "pbrt")


@pytest.fixture(scope="module")
def coloured_metal():
    params = {"kd": [0.0] * 3, "ks": [0.95, 0.7, 0.4], "alpha_u": 0.1, "alpha_v": 0.25, "f0": 1}
    return export({"model": "ggx_anisotropic", "params": params}, "pbrt")


def test_metals_are_plain_conductors_evaluated_exactly(grey_metal, coloured_metal):
    wi, wo = hemisphere_pairs(200, seed=3, grazing=False)
    for e in (grey_metal, coloured_metal):
        (name, params), *rest = parse(e.document).items()
        assert not rest and name == "brdffit" and params["type"] == ("string", ["conductor"])
        assert e.notes[0].startswith("pbrt form conductor")
        want = conductor_from_text(params, wi, wo)
        np.testing.assert_allclose(e.native.evaluate(wi, wo), want, rtol=1e-4)
    assert "eta" in parse(grey_metal.document)["brdffit"]
    rgb = parse(coloured_metal.document)["brdffit"]["reflectance"]
    assert rgb[0] == "rgb" and rgb[1][0] > rgb[1][1] > rgb[1][2] and max(rgb[1]) < 1


def test_alpha_is_written_with_remaproughness_false(grey_metal):
    params = parse(grey_metal.document)["brdffit"]
    alpha = params["uroughness"][1][0]
    assert abs(alpha - 0.09) < 0.01 and params["vroughness"][1][0] == pytest.approx(alpha, 0.05)
    assert params["remaproughness"] == ("bool", [False])
    # The pitfall: pbrt's default (remaproughness true) would render sqrt(alpha) = 0.3.
    wi, wo = hemisphere_pairs(200, seed=4, grazing=False)
    written = conductor_from_text(params, wi, wo)
    remapped = {**params, "uroughness": ("float", [math.sqrt(alpha)])}
    remapped["vroughness"] = ("float", [math.sqrt(params["vroughness"][1][0])])
    peak = np.argmax(written[:, 0])
    assert conductor_from_text(remapped, wi, wo)[peak, 0] < 0.2 * written[peak, 0]


def coat_export(diffuse):
    """The pbrt export of data synthesised from pbrt's coateddiffuse."""
    params = {"diffuse": diffuse, "alpha": 0.2, "eta": 1.6, "thickness": 0.01}
    data = brdffit.synthesize(PBRT_COATEDDIFFUSE, params, geometry="gonio")
    return export(brdffit.fit(data, "ggx"), "pbrt", data=data)


def test_the_opaque_dielectric_is_a_conductor_with_k_0():
    # A black coat: pbrt's rough dielectric reflection, nothing transmitted comes back.
    e = coat_export(0.0)
    assert "dielectric" not in re.findall(r'"string type" "(\w+)"', e.document)
    text = parse(e.document)["brdffit"]
    assert text["type"] == ("string", ["conductor"])
    assert text["eta"][1][1] == pytest.approx(1.6, 1e-3) and text["k"][1][1] < 1e-3
    assert text["uroughness"][1][0] == pytest.approx(0.2, 1e-3)
    assert e.conversion_error["rms_log_target"] < 1e-3


def test_coateddiffuse_syntax_and_values():
    e = coat_export(0.5)
    text = parse(e.document)["brdffit"]
    assert text["type"] == ("string", ["coateddiffuse"])
    assert [k for k, _ in text.values()] == ["string", "rgb", "float", "float", "bool",
                                            "float", "float", "rgb", "integer"]  # fmt: skip
    assert text["remaproughness"] == ("bool", [False]) and text["maxdepth"] == ("integer", [10])
    assert text["albedo"] == ("rgb", [0.0, 0.0, 0.0]) and text["thickness"][1] == [0.01]
    assert text["uroughness"] == text["vroughness"]
    assert text["uroughness"][1][0] == pytest.approx(0.2, 1e-3)
    assert text["eta"][1][0] == pytest.approx(1.6, 1e-3)
    assert e.conversion_error["rms_log_target"] < 1e-3
    # The written reflectance R gives the diffuse term through 5 bounces on the base.
    r = coated_tables(0.2, 1.6, 0.01)[1]
    big_r = np.array(text["reflectance"][1])
    np.testing.assert_allclose(big_r * sum((big_r * r) ** j for j in range(5)), 0.5, rtol=2e-3)
    # The statement's numbers are the parameters the export evaluates.
    q = e.parameters
    assert text["reflectance"][1] == [float(f"{x:.9g}") for x in q["reflectance"]]
    wi, wo = hemisphere_pairs(50, seed=5, grazing=False)
    got = Geometry(wi, wo).scatter(pbrt_values(Geometry(wi, wo), q))
    np.testing.assert_allclose(e.native.evaluate(wi, wo), got, rtol=1e-12)


def test_a_mix_names_its_parts_and_forms_are_checked(coloured_metal):
    material = material_of({"model": "lambert", "params": {"kd": 0.5}})
    with pytest.raises(ParameterError, match=r"forms=\('dielectric',\).*conductor"):
        pbrt_parameters(material, forms=("dielectric",))
    from brdffit.export.pbrt import pbrt_statement

    q = {"form": "mix", "amount": 0.25, "diffuse_reflectance": [0.2, 0.3, 0.4],
         "uroughness": 0.1, "vroughness": 0.2, "eta": 1.5, "k": 0.0}  # fmt: skip
    text = parse(pbrt_statement(q, name="m"))
    assert list(text) == ["m_diffuse", "m_conductor", "m"]
    assert text["m"]["materials"] == ("string", ["m_diffuse", "m_conductor"])
    assert text["m"]["amount"] == ("float", [0.25])
    assert text["m_diffuse"]["reflectance"] == ("rgb", [0.2, 0.3, 0.4])
