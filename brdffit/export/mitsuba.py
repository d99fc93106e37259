"""Mitsuba 3: a dict for ``mitsuba.load_dict`` and the same as a scene XML fragment.

Source: Mitsuba 3 plugin reference (mitsuba.readthedocs.io, "BSDFs":
``diffuse``, ``roughconductor``, ``blendbsdf``) and src/bsdfs/roughconductor.cpp.
Conventions that matter here: ``roughconductor`` defaults to the *Beckmann*
distribution, so ``distribution = "ggx"`` is always written; its ``alpha`` is
the distribution's alpha (not squared, not remapped); its Smith ``G`` is
separable, ``G1(L) G1(V)``; its Fresnel is the exact conductor Fresnel of
``eta + i k``, and ``material = "none"`` means ``F = 1``; ``alpha_u`` acts along
the tangent (x). ``blendbsdf`` with ``weight = w`` is ``(1 - w) bsdf_0 + w bsdf_1``.
``BSDF.eval`` returns the BRDF times ``cos(theta_o)`` of its ``wo`` argument.

The native model is ``lambert + mitsuba_roughconductor`` (or its anisotropic
form): ``kd / pi + ks F D G1 G1 / (4 N.L N.V)``, written as
``blendbsdf(weight w, diffuse(kd / (1 - w)), roughconductor(ks / w))``.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..models import get_model
from ..models.mitsuba_plastic import internal_reflectance
from .core import Material, rgb, to_native

__all__ = [
    "from_document",
    "mitsuba_dict",
    "mitsuba_parameters",
    "mitsuba_xml",
    "native_model",
    "principled",
    "roughplastic",
]

NONE_ETA_K = (0.0, 1.0)


def native_model(material: Material) -> str:
    """The Mitsuba-native model of the material's symmetry."""
    aniso = material.anisotropic
    return "lambert+mitsuba_roughconductor" + ("_anisotropic" if aniso else "")


def _exact(material: Material):
    """Neutral Mitsuba parameters if the material is exactly Mitsuba's, else None."""
    p, name = material.params, material.model
    zero = np.zeros(1)
    if name == "lambert":
        return {"kd": p["kd"], "ks": zero, "alpha_u": 0.1, "alpha_v": 0.1, "eta_k": NONE_ETA_K}
    if name in ("ggx", "ggx_anisotropic") and p["f0"] == 1.0:
        au, av = (p["alpha"],) * 2 if name == "ggx" else (p["alpha_u"], p["alpha_v"])
        return {"kd": p["kd"], "ks": p["ks"], "alpha_u": au, "alpha_v": av, "eta_k": NONE_ETA_K}
    for lobe in ("mitsuba_roughconductor", "mitsuba_roughconductor_anisotropic"):
        prefix = f"{lobe}." if name.startswith("lambert+") else ""
        if name not in (lobe, f"lambert+{lobe}"):
            continue
        q = {k[len(prefix) :]: v for k, v in p.items() if k.startswith(prefix)}
        au = q.get("alpha", q.get("alpha_u"))
        av = q.get("alpha", q.get("alpha_v"))
        kd = p["lambert.kd"] if prefix else zero
        eta_k = (q["eta"], q["k"])
        return {"kd": kd, "ks": q["specular_reflectance"], "alpha_u": au, "alpha_v": av,
                "eta_k": eta_k}  # fmt: skip
    return None


def _from_native(native: Material) -> dict:
    p = native.params
    lobe = next(k.split(".")[0] for k in p if k.startswith("mitsuba_"))
    q = {k.split(".", 1)[1]: v for k, v in p.items() if k.startswith(lobe + ".")}
    return {
        "kd": p["lambert.kd"],
        "ks": q["specular_reflectance"],
        "alpha_u": q.get("alpha", q.get("alpha_u")),
        "alpha_v": q.get("alpha", q.get("alpha_v")),
        "eta_k": (q["eta"], q["k"]),
    }


def mitsuba_parameters(material: Material, data=None) -> tuple:
    """(neutral parameters, native Material, exact?, notes)."""
    exact = _exact(material)
    if exact is not None:
        return exact, _native_material(exact, material.channels), True, ()
    name = native_model(material)
    # kd + ks <= 1 per channel, so that blendbsdf's two reflectances can stay <= 1.
    model = replace(get_model(name), coefficient_constraints=(((1.0, 1.0), 1.0),))
    native = to_native(material, model, data)
    notes = (
        f"{material.model} is not a Mitsuba BSDF: {name} (diffuse + GGX roughconductor, "
        "its eta and k free, so k = 0 gives a dielectric's Fresnel) was fitted to it; "
        "the error is that of the fitted stand-in.",
    )
    return _from_native(native), native, False, notes


def _native_material(p: dict, channels) -> Material:
    iso = p["alpha_u"] == p["alpha_v"]
    lobe = "mitsuba_roughconductor" + ("" if iso else "_anisotropic")
    alphas = {"alpha": p["alpha_u"]} if iso else {"alpha_u": p["alpha_u"], "alpha_v": p["alpha_v"]}
    params = {"lambert.kd": p["kd"], f"{lobe}.specular_reflectance": p["ks"]}
    params.update({f"{lobe}.{k}": v for k, v in alphas.items()})
    params[f"{lobe}.eta"], params[f"{lobe}.k"] = p["eta_k"]
    return Material(f"lambert+{lobe}", params, channels)


def _rgb(value) -> dict:
    return {"type": "rgb", "value": value}


def mitsuba_dict(p: dict, channels) -> dict:
    """The ``load_dict`` dict of neutral parameters (see the module docstring)."""
    kd, ks = np.asarray(rgb(p["kd"], channels)), np.asarray(rgb(p["ks"], channels))
    conductor = {"type": "roughconductor", "distribution": "ggx"}
    if p["alpha_u"] == p["alpha_v"]:
        conductor["alpha"] = float(p["alpha_u"])
    else:
        conductor["alpha_u"], conductor["alpha_v"] = float(p["alpha_u"]), float(p["alpha_v"])
    if tuple(p["eta_k"]) == NONE_ETA_K:
        conductor["material"] = "none"
    else:
        conductor["eta"], conductor["k"] = (float(x) for x in p["eta_k"])
    # A lobe below 1e-9 of the other is dropped: blendbsdf's weight would round to 0 or 1.
    if ks.max() <= 1e-9 * kd.max() or not ks.any():
        return {"type": "diffuse", "reflectance": _rgb(kd.tolist())}
    if kd.max() <= 1e-9 * ks.max():
        return {**conductor, "specular_reflectance": _rgb(ks.tolist())}
    # Mitsuba refuses reflectances above 1: where kd + ks > 1 they are clipped,
    # and the export's native material (from_document) shows the clipped BRDF.
    w = float(ks.max() / (ks.max() + kd.max()))
    return {
        "type": "blendbsdf",
        "weight": w,
        "bsdf_0": {"type": "diffuse", "reflectance": _rgb(np.minimum(kd / (1 - w), 1).tolist())},
        "bsdf_1": {**conductor, "specular_reflectance": _rgb(np.minimum(ks / w, 1).tolist())},
    }


def from_document(d: dict, channels) -> Material:
    """The native Material that a Mitsuba dict of :func:`mitsuba_dict` evaluates to."""
    w = d.get("weight", 1.0 if d["type"] == "roughconductor" else 0.0)
    parts = [d["bsdf_0"], d["bsdf_1"]] if d["type"] == "blendbsdf" else [d]
    kd, ks, conductor = np.zeros(3), np.zeros(3), {"alpha": 0.1, "material": "none"}
    for part in parts:
        if part["type"] == "diffuse":
            kd = (1 - w) * np.asarray(part["reflectance"]["value"])
        else:
            ks, conductor = w * np.asarray(part["specular_reflectance"]["value"]), part
    eta_k = NONE_ETA_K if "material" in conductor else (conductor["eta"], conductor["k"])
    au = conductor.get("alpha", conductor.get("alpha_u"))
    av = conductor.get("alpha", conductor.get("alpha_v"))
    if len(channels) == 1:  # a grey material written as RGB
        kd, ks = kd[:1], ks[:1]
    neutral = {"kd": kd, "ks": ks, "alpha_u": au, "alpha_v": av, "eta_k": eta_k}
    return _native_material(neutral, channels)


def _xml(d: dict, indent: str, name: str | None = None, version: bool = False) -> list:
    attrs = f' type="{d["type"]}"' + (f' name="{name}"' if name else "")
    attrs = (' version="3.0.0"' if version else "") + attrs
    lines = [f"{indent}<bsdf{attrs}>"]
    for key, value in d.items():
        if key == "type":
            continue
        if isinstance(value, dict) and value.get("type") == "rgb":
            shown = ", ".join(f"{x:.9g}" for x in value["value"])
            lines.append(f'{indent}    <rgb name="{key}" value="{shown}"/>')
        elif isinstance(value, dict):
            lines += _xml(value, indent + "    ")
        elif isinstance(value, str):
            lines.append(f'{indent}    <string name="{key}" value="{value}"/>')
        else:
            lines.append(f'{indent}    <float name="{key}" value="{value:.9g}"/>')
    lines.append(f"{indent}</bsdf>")
    return lines


def mitsuba_xml(d: dict) -> str:
    """The dict as a Mitsuba 3 XML ``<bsdf>`` element (for ``load_string`` or a scene)."""
    return "\n".join(_xml(d, "", version=True)) + "\n"


def roughplastic(material: Material) -> tuple:
    """(document, native Material, notes) of a ``mitsuba_roughplastic`` fit: exact,
    unless a reflectance above 1 had to be clipped (Mitsuba refuses them)."""
    p = material.params
    r_int = internal_reflectance(float(p["alpha"]), float(p["eta"]))
    diffuse = np.asarray(rgb(p["diffuse"], material.channels)) * (1.0 - r_int)
    specular = np.asarray(rgb(p["specular_reflectance"], material.channels))
    notes = []
    if diffuse.max() > 1 or specular.max() > 1:
        notes.append("reflectances above 1 were clipped to 1 (Mitsuba refuses them)")
        diffuse, specular = np.minimum(diffuse, 1.0), np.minimum(specular, 1.0)
    document = {
        "type": "roughplastic",
        "distribution": "ggx",
        "alpha": float(p["alpha"]),
        "int_ior": float(p["eta"]),
        "ext_ior": 1.0,  # Mitsuba's default is air, 1.000277
        "diffuse_reflectance": _rgb(diffuse.tolist()),
        "specular_reflectance": _rgb(specular.tolist()),
    }
    params = {
        "diffuse": diffuse / (1.0 - r_int),
        "specular_reflectance": specular,
        "alpha": p["alpha"],
        "eta": p["eta"],
    }
    if len(material.channels) == 1:
        params["diffuse"], params["specular_reflectance"] = diffuse[:1] / (1 - r_int), specular[:1]
    return document, Material(material.model, params, material.channels), tuple(notes)


def principled(material: Material) -> dict:
    """The ``principled`` dict of a ``mitsuba_principled(_anisotropic)`` fit (exact:
    every parameter is Mitsuba's own, base_color within [0, 1])."""
    p = material.params
    document = {
        "type": "principled",
        "base_color": _rgb(rgb(p["base_color"], material.channels)),
        "metallic": float(p["metallic"]),
        "roughness": float(p["roughness"]),
        "specular": float(p["specular"]),
    }
    if "anisotropic" in p:
        document["anisotropic"] = float(p["anisotropic"])
    return document
