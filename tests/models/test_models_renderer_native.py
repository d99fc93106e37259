"""Renderer-native models against scalar references written here from the glTF 2.0
specification (appendix B, KHR_materials_anisotropy) and Mitsuba 3's roughconductor,
and, where Mitsuba is installed, value by value against Mitsuba's own ``eval``; on
both evaluation paths (the compiled kernels and the numpy formulas)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import hemisphere_pairs, mitsuba_eval, with_f32

from brdffit import get_model

pytestmark = pytest.mark.usefixtures("evaluation_path")


# ------------------------------------------------ references (math module only)
def ggx_d(h, at, ab, rot=0.0):
    ht = h[0] * math.cos(rot) + h[1] * math.sin(rot)
    hb = -h[0] * math.sin(rot) + h[1] * math.cos(rot)
    q = (ht / at) ** 2 + (hb / ab) ** 2 + h[2] ** 2
    return 1.0 / (math.pi * at * ab * q * q)


def gltf_reference(wi, wo, base, metallic, roughness, strength=0.0, rot=0.0):
    """glTF 2.0 appendix B, written as the spec's pseudo-code (mix, fresnel_mix)."""
    alpha = roughness**2
    at = alpha + (1 - alpha) * strength**2  # mix(alpha, 1, strength^2)
    h = [a + b for a, b in zip(wi, wo)]
    n = math.sqrt(sum(x * x for x in h))
    h = [x / n for x in h]
    vdoth = sum(a * b for a, b in zip(wo, h))
    t = (math.cos(rot), math.sin(rot), 0.0)
    b = (-math.sin(rot), math.cos(rot), 0.0)

    def dot(u, v):
        return sum(x * y for x, y in zip(u, v))

    nl, nv = wi[2], wo[2]
    # The sample viewer's V_GGX_anisotropic (height-correlated), equal to the
    # isotropic 0.5 / (NL sqrt(NV^2 (1 - a^2) + a^2) + NV sqrt(...)) when at = ab.
    ggxv = nl * math.sqrt((at * dot(t, wo)) ** 2 + (alpha * dot(b, wo)) ** 2 + nv**2)
    ggxl = nv * math.sqrt((at * dot(t, wi)) ** 2 + (alpha * dot(b, wi)) ** 2 + nl**2)
    spec = ggx_d(h, at, alpha, rot) * 0.5 / (ggxv + ggxl)
    w = (1 - abs(vdoth)) ** 5
    metal = spec * (base + (1 - base) * w)
    fr = 0.04 + 0.96 * w
    dielectric = (1 - fr) * base / math.pi + fr * spec
    return (1 - metallic) * dielectric + metallic * metal


def conductor_fresnel(c, eta, k):
    """Exact conductor Fresnel with complex arithmetic (s and p amplitudes)."""
    n = complex(eta, k)
    s2 = 1 - c * c
    ct = np.sqrt(complex(1 - s2 / (n * n)))
    rs = (c - n * ct) / (c + n * ct)
    rp = (n * c - ct) / (n * c + ct)
    return 0.5 * (abs(rs) ** 2 + abs(rp) ** 2)


def mitsuba_reference(wi, wo, scale, au, av, eta, k):
    h = [a + b for a, b in zip(wi, wo)]
    n = math.sqrt(sum(x * x for x in h))
    h = [x / n for x in h]

    def g1(v):
        tan2 = (v[0] ** 2 + v[1] ** 2) / v[2] ** 2
        s = v[0] ** 2 + v[1] ** 2
        c2 = v[0] ** 2 / s if s > 0 else 0.5
        a2 = au * au * c2 + av * av * (1 - c2)
        return 2 / (1 + math.sqrt(1 + a2 * tan2))

    f = (
        1.0
        if (eta == 0 and k == 1)
        else conductor_fresnel(sum(a * b for a, b in zip(wi, h)), eta, k)
    )
    return scale * f * ggx_d(h, au, av) * g1(wi) * g1(wo) / (4 * wi[2] * wo[2])


CASES = [
    ("gltf_pbr", {"base_color": 0.6, "metallic": 0.0, "roughness": 0.5}),
    ("gltf_pbr", {"base_color": 0.9, "metallic": 1.0, "roughness": 0.2}),
    ("gltf_pbr", {"base_color": 0.3, "metallic": 0.4, "roughness": 0.8}),
    ("gltf_pbr_anisotropic", {"base_color": 0.8, "metallic": 1.0, "roughness": 0.3,
                              "anisotropy_strength": 0.7, "anisotropy_rotation": 0.0}),
    ("gltf_pbr_anisotropic", {"base_color": 0.5, "metallic": 0.2, "roughness": 0.4,
                              "anisotropy_strength": 0.5, "anisotropy_rotation": 1.1}),
    ("mitsuba_roughconductor", {"specular_reflectance": 0.8, "alpha": 0.2, "eta": 0.0, "k": 1.0}),
    ("mitsuba_roughconductor", {"specular_reflectance": 1.0, "alpha": 0.05, "eta": 0.2, "k": 3.1}),
    ("mitsuba_roughconductor_anisotropic",
     {"specular_reflectance": 0.7, "alpha_u": 0.3, "alpha_v": 0.06, "eta": 1.1, "k": 2.0}),
]  # fmt: skip


def reference(name, wi, wo, p):
    if name.startswith("gltf"):
        return gltf_reference(
            wi, wo, p["base_color"], p["metallic"], p["roughness"],
            p.get("anisotropy_strength", 0.0), p.get("anisotropy_rotation", 0.0),
        )  # fmt: skip
    au = p.get("alpha", p.get("alpha_u"))
    av = p.get("alpha", p.get("alpha_v"))
    return mitsuba_reference(wi, wo, p["specular_reflectance"], au, av, p["eta"], p["k"])


@pytest.mark.parametrize("name, params", CASES)
def test_equals_the_scalar_reference(name, params, evaluation_path):
    wi, wo = hemisphere_pairs(300, seed=21, grazing=False)
    got = get_model(name).evaluate(wi, wo, params)
    want = [reference(name, a, b, params) for a, b in zip(wi, wo)]
    np.testing.assert_allclose(got, want, rtol=with_f32(1e-9, name, evaluation_path == "compiled"))


def test_anisotropy_rotation_turns_the_highlight_about_the_normal(evaluation_path):
    """Rotating the directions by -r equals rotating the anisotropy by +r (tangent = x)
    (to the float32 rounding of the compiled loop's factor, on two geometries)."""
    model = get_model("gltf_pbr_anisotropic")
    wi, wo = hemisphere_pairs(300, seed=22, grazing=False)
    base = {"base_color": 0.5, "metallic": 1.0, "roughness": 0.3, "anisotropy_strength": 0.8}
    r = 0.7
    rot = np.array([[math.cos(r), -math.sin(r), 0], [math.sin(r), math.cos(r), 0], [0, 0, 1]])
    turned = model.evaluate(wi @ rot, wo @ rot, {**base, "anisotropy_rotation": 0.0})
    np.testing.assert_allclose(
        model.evaluate(wi, wo, {**base, "anisotropy_rotation": r}),
        turned,
        rtol=2 * with_f32(1e-9, model.name, evaluation_path == "compiled"),
    )
    # Along x the highlight is wider (alpha_t > alpha_b): off-specular along x is brighter.
    wi1 = np.array([[0.0, 0.0, 1.0]] * 2)
    off = math.radians(20)
    wo1 = np.array([[math.sin(off), 0, math.cos(off)], [0, math.sin(off), math.cos(off)]])
    f = model.evaluate(wi1, wo1, {**base, "anisotropy_rotation": 0.0})
    assert f[0] > 3 * f[1]


# ------------------------------------------------------ Mitsuba, where installed
@pytest.mark.parametrize("name, params", [c for c in CASES if c[0].startswith("mitsuba")])
def test_mitsuba_roughconductor_matches_mitsuba_eval(name, params):
    """Mitsuba's eval is f cos(theta_o) (the cosine of its ``wo`` argument)."""
    wi, wo = hemisphere_pairs(200, seed=23, grazing=False)
    d = {"type": "roughconductor", "distribution": "ggx", "specular_reflectance":
         {"type": "rgb", "value": [params["specular_reflectance"]] * 3}}  # fmt: skip
    if "alpha" in params:
        d["alpha"] = params["alpha"]
    else:
        d["alpha_u"], d["alpha_v"] = params["alpha_u"], params["alpha_v"]
    if (params["eta"], params["k"]) == (0.0, 1.0):
        d["material"] = "none"
    else:
        d["eta"], d["k"] = params["eta"], params["k"]
    got = mitsuba_eval(d, wi, wo)[:, 0]
    f = get_model(name).evaluate(wi, wo, params)
    big = f * wo[:, 2] > 1e-6 * f.max()  # float32 in Mitsuba: compare where it is resolved
    np.testing.assert_allclose(got[big], (f * wo[:, 2])[big], rtol=1e-4)
    # Not f itself: the cosine matters (a pitfall when reading Mitsuba's eval).
    assert np.max(np.abs(got[big] / f[big] - 1)) > 0.05


# ---------------------------------------------------------- Mitsuba roughplastic
PLASTIC = [
    {"diffuse": 0.8, "specular_reflectance": 1.0, "alpha": 0.2, "eta": 1.5},
    {"diffuse": 0.4, "specular_reflectance": 0.6, "alpha": 0.05, "eta": 1.3},
    {"diffuse": 1.2, "specular_reflectance": 1.0, "alpha": 0.6, "eta": 2.0},
]


@pytest.mark.parametrize("params", PLASTIC)
def test_mitsuba_roughplastic_matches_mitsuba_eval(params):
    """Mitsuba's diffuse_reflectance is the model's ``diffuse`` times 1 - R_int, and
    its eta is int_ior / ext_ior with ext_ior written as 1 (its default is air)."""
    from brdffit.models.mitsuba_plastic import internal_reflectance

    wi, wo = hemisphere_pairs(200, seed=24, grazing=False)
    r_int = internal_reflectance(params["alpha"], params["eta"])
    assert 0.2 < r_int < 0.8
    grey = {"type": "rgb", "value": [params["diffuse"] * (1 - r_int)] * 3}
    spec = {"type": "rgb", "value": [params["specular_reflectance"]] * 3}
    d = {"type": "roughplastic", "distribution": "ggx", "alpha": params["alpha"],
         "int_ior": params["eta"], "ext_ior": 1.0, "diffuse_reflectance": grey,
         "specular_reflectance": spec}  # fmt: skip
    got = mitsuba_eval(d, wi, wo)[:, 0] / wo[:, 2]
    f = get_model("mitsuba_roughplastic").evaluate(wi, wo, params)
    np.testing.assert_allclose(got, f, rtol=1e-4)
    # The diffuse part is not kd / pi: it falls towards grazing with T(N.L) T(N.V).
    only = get_model("mitsuba_roughplastic").evaluate(
        wi, wo, {**params, "specular_reflectance": 0.0}
    )
    ratio = only / (params["diffuse"] / math.pi)
    assert ratio.max() < 1.0 and ratio.max() / ratio.min() > 1.5


@pytest.mark.parametrize("transmit", [True, False])
def test_half_of_the_rule_gives_the_whole_rules_integrals(monkeypatch, transmit):
    """The transmittance and reflectance integrals are even in the rule's px (its
    nodes mirror in px): the half rule the model uses gives the full rule's values."""
    from brdffit.models import mitsuba_plastic as mp

    for alpha, eta in [(0.001, 1.05), (0.2, 1.5), (1.0, 3.0)]:
        half = mp._interface_integral(alpha, eta, 32, transmit)
        with monkeypatch.context() as patch:
            patch.setattr(mp, "_half_rule", mp._rule)
            whole = mp._interface_integral(alpha, eta, 32, transmit)
        np.testing.assert_allclose(half, whole, rtol=1e-13, atol=1e-300)
        assert np.all(half > 0.0)


def test_mitsubas_default_ext_ior_is_air_not_vacuum():
    mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 (pip install mitsuba) is not installed")
    mi.set_variant("scalar_rgb")
    text = str(mi.load_dict({"type": "roughplastic", "int_ior": 1.5}))
    assert "eta = 1.5," not in text and "eta = 1.49" in text


# ------------------------------------------------------------ Mitsuba principled
def principled_reference(wi, wo, p):
    """Burley 2012 / Mitsuba principled.cpp reflection lobes, in scalar arithmetic."""
    base, metal, rough = p["base_color"], p["metallic"], p["roughness"]
    aspect = math.sqrt(1 - 0.9 * p["anisotropic"]) if "anisotropic" in p else 1.0
    au, av = max(1e-3, rough**2 / aspect), max(1e-3, rough**2 * aspect)
    eta = 2 / (1 - math.sqrt(0.08 * p["specular"])) - 1
    h = [a + b for a, b in zip(wi, wo)]
    n = math.sqrt(sum(x * x for x in h))
    h = [x / n for x in h]
    cd = sum(a * b for a, b in zip(wi, h))
    ct = math.sqrt(1 - (1 - cd * cd) / eta**2)
    f_diel = 0.5 * (((cd - eta * ct) / (cd + eta * ct)) ** 2
                    + ((eta * cd - ct) / (eta * cd + ct)) ** 2)  # fmt: skip

    def w(c):
        return (1 - c) ** 5

    def g1(v):
        s = v[0] ** 2 + v[1] ** 2
        a2 = (au**2 * v[0] ** 2 + av**2 * v[1] ** 2) / s if s > 0 else 0.0
        return 2 / (1 + math.sqrt(1 + a2 * s / v[2] ** 2))

    fresnel = (1 - metal) * f_diel + metal * (base + (1 - base) * w(cd))
    spec = fresnel * ggx_d(h, au, av) * g1(wi) * g1(wo) / (4 * wi[2] * wo[2])
    fi, fo, rr = w(wi[2]), w(wo[2]), 2 * rough * cd * cd
    diffuse = (1 - 0.5 * fi) * (1 - 0.5 * fo) + rr * (fi + fo + fi * fo * (rr - 1))
    return spec + (1 - metal) * base / math.pi * diffuse


PRINCIPLED = [
    ("mitsuba_principled", {"base_color": 0.6, "metallic": 0.0, "roughness": 0.5,
                            "specular": 0.5}),
    ("mitsuba_principled", {"base_color": 0.8, "metallic": 1.0, "roughness": 0.3,
                            "specular": 0.5}),
    ("mitsuba_principled", {"base_color": 0.3, "metallic": 0.4, "roughness": 0.7,
                            "specular": 0.9}),
    ("mitsuba_principled_anisotropic", {"base_color": 0.7, "metallic": 0.8, "roughness": 0.4,
                                        "specular": 0.5, "anisotropic": 0.7}),
]  # fmt: skip


@pytest.mark.parametrize("name, params", PRINCIPLED)
def test_mitsuba_principled_equals_reference_and_mitsuba(name, params, evaluation_path):
    """Within 1e-9 of the scalar reference (plus the compiled loop's float32 bound:
    helpers.with_f32); within 1e-4 of Mitsuba (float32)."""
    wi, wo = hemisphere_pairs(200, seed=25, grazing=False)
    f = get_model(name).evaluate(wi, wo, params)
    want = [principled_reference(a, b, params) for a, b in zip(wi, wo)]
    np.testing.assert_allclose(f, want, rtol=with_f32(1e-9, name, evaluation_path == "compiled"))
    d = {"type": "principled", "base_color": {"type": "rgb", "value": [params["base_color"]] * 3}}
    d |= {k: v for k, v in params.items() if k != "base_color"}
    got = mitsuba_eval(d, wi, wo)[:, 0] / wo[:, 2]
    big = f > 1e-6 * f.max()
    np.testing.assert_allclose(got[big], f[big], rtol=1e-4)


@pytest.mark.parametrize(
    "aniso, settings, iso",
    [
        ("gltf_pbr_anisotropic", {"anisotropy_strength": 0.0, "anisotropy_rotation": 0.7},
         "gltf_pbr"),
        ("mitsuba_roughconductor_anisotropic", {"alpha_u": 0.2, "alpha_v": 0.2, "eta": 0.3},
         "mitsuba_roughconductor"),
        ("mitsuba_principled_anisotropic", {"anisotropic": 0.0, "metallic": 0.4},
         "mitsuba_principled"),
    ],
)  # fmt: skip
def test_renderer_anisotropic_models_reduce_to_their_isotropic_forms(
    aniso, settings, iso, evaluation_path
):
    """Without anisotropy each is its isotropic model, at grazing angles too (the
    hard cases of hemisphere_pairs reach N.L = 2e-11: glTF's anisotropic Lambda
    clamped N.L at 1e-300, not at the cosines' 1e-10, and was 2 % off there)."""
    a, i = get_model(aniso), get_model(iso)
    params = {**a.defaults(), **settings}
    iso_params = {k: params.get(k, params.get("alpha_u")) for k in i.param_names}
    wi, wo = hemisphere_pairs(2000, seed=44)
    assert (wi[:, 2] < 1e-10).any()
    compiled = evaluation_path == "compiled"
    rtol = with_f32(with_f32(1e-12, aniso, compiled), iso, compiled)
    np.testing.assert_allclose(
        a.evaluate(wi, wo, params), i.evaluate(wi, wo, iso_params), rtol=rtol, atol=0
    )
