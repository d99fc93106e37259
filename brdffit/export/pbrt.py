"""pbrt-v4: one material statement, ``conductor``, ``coateddiffuse`` or a ``mix``.

Source: pbrt-v4 file format (pbrt.org/fileformat-v4, "Materials") and
src/pbrt/materials.cpp, bxdfs.h/.cpp, util/scattering.h (github.com/mmp/pbrt-v4).
Conventions: ``roughness`` is remapped by default (``remaproughness`` true:
``alpha = RoughnessToAlpha(roughness) = sqrt(roughness)``), so every statement
writes alpha as ``uroughness``/``vroughness`` with ``remaproughness false``; the
Trowbridge-Reitz (GGX) masking is the height-correlated
``G = 1 / (1 + Lambda(L) + Lambda(V))``; ``uroughness`` acts along x; Fresnel is
exact (a ``conductor``'s of ``eta + i k``, written as constant spectra, or from its
``reflectance`` r: ``eta = 1, k = 2 sqrt(r) / sqrt(1 - r)``; a dielectric's of
``eta``); a ``mix`` picks ``materials[1]`` with probability ``amount``, which
averages to ``(1 - amount) m0 + amount m1``.

Three forms are fitted (to the material, or to the data) and evaluated here from
those formulas; the export writes the simplest (in this order) whose conversion error
(RMS of ``ln(1 + f cos)``, :func:`brdffit.export.core.rms_log_error`) is within
0.005 of the lowest (half a percent of ``1 + f cos``, below the noise of most
measurements): a metal whose mix keeps a negligible diffuse term is written as a
plain conductor, a paint as a coateddiffuse unless the mix is clearly closer; the
notes name all three errors:

- ``conductor`` (metals): ``F(V.H; eta + i k) D G / (4 N.L N.V)``, no scale and
  no diffuse term: fitted as such (one grey ``eta + i k``, exactly what is written)
  and, for a coloured metal, with a scale ``ks`` per channel written as
  ``reflectance = ks F(0)``, which keeps the colour and the value at normal
  incidence, not the Fresnel's shape; the closer of the two is the candidate.
- ``coateddiffuse`` (plastics, paints): pbrt's layered BSDF, stochastic in pbrt;
  the expectation of pbrt's own estimator, in closed form, is
  :mod:`brdffit.export.pbrt_layer` (``PBRT_COATEDDIFFUSE``; its MIS weights make
  it brighter than the layered model, as that module says), written with pbrt's
  defaults made explicit (``thickness 0.01``, ``maxdepth 10``, ``albedo 0``) and
  isotropic roughness.
- ``mix`` of ``diffuse`` and ``conductor``: ``(1 - w) R / pi + w F D G / (4 N.L N.V)``,
  fitted with ``kd = (1 - w) R`` and ``ks = w`` per channel (``kd + ks <= 1``);
  ``amount`` is one number, so ``w`` is the largest ``ks`` and a coloured specular
  keeps only its brightest channel.

pbrt's ``dielectric`` is never written: it transmits the ``1 - F`` that a measured
opaque material sends back or absorbs, so a render would see through it. An opaque
dielectric (black glossy plastic, paint, glass on black) reflects only
``F(V.H; eta) D G / (4 N.L N.V)``, which two of the forms give exactly: a
``conductor`` with ``k = 0`` (pbrt's ``FrComplex`` with a real index is
``FrDielectric`` for ``eta >= 1``) and a ``coateddiffuse`` with ``reflectance 0``
(a black base absorbs what the coat transmits); the conductor fit reaches it, and
being the simpler it is written.

pbrt renders spectrally: an ``rgb`` reflectance becomes a smooth spectrum
(``RGBAlbedoSpectrum``), so an RGB render shows approximately, not exactly, the
per-channel values evaluated here.
"""

from __future__ import annotations

import numpy as np

from ..models import Design, Model, Param
from ..models.base import INV_PI, Classification
from ..models.params import roughness
from ..models.renderer_native import gltf_specular
from ..models.shared import fresnel_conductor
from .core import Material, rgb, rms_log_error, to_native
from .pbrt_layer import (
    MAXDEPTH,
    PBRT_COATEDDIFFUSE,
    coated_brdf,
    coated_tables,
    depth_bounces,
    reflectance_from_diffuse,
    transmittance,
)
from .pbrt_statement import pbrt_statement

R_MAX = 0.9999
#: The forms, simplest first; the first within CLOSE of the lowest error wins.
FORMS = ("conductor", "coateddiffuse", "mix")
CLOSE = 0.005
_REFERENCE = "pbrt-v4 (M. Pharr, W. Jakob, G. Humphreys), materials.cpp, bxdfs.h"
_ANISOTROPIC = Classification("physical", "anisotropic", "cosine", "material")

__all__ = [
    "FORMS",
    "pbrt_evaluator",
    "pbrt_parameters",
    "pbrt_statement",
    "pbrt_model",
    "pbrt_values",
]


def _spec_design(geometry, shape) -> np.ndarray:
    spec = gltf_specular(geometry, shape["alpha_u"], shape["alpha_v"])
    return spec * fresnel_conductor(geometry.cos_d, shape["eta"], shape["k"])


def _shape_params() -> tuple:
    return (
        roughness("alpha_u", doc="uroughness (remaproughness false), along x"),
        roughness("alpha_v", doc="vroughness (remaproughness false)"),
        Param("eta", 0.05, 10.0, 1.5, unit="1", doc="conductor eta"),
        Param("k", 0.0, 10.0, 0.0, unit="1", doc="conductor k"),
    )


#: The mix fitted before writing pbrt's ``mix`` (unregistered: pbrt only).
PBRT_MIX = Model(
    name="pbrt_mix",
    params=(
        Param("kd", 0.0, 1.0, 0.5, linear=True, unit="1", doc="(1 - amount) reflectance"),
        Param("ks", 0.0, 1.0, 0.5, linear=True, unit="1", doc="amount of the conductor"),
        *_shape_params(),
    ),
    classification=_ANISOTROPIC,
    reference=_REFERENCE,
    design=lambda geometry, shape: Design((INV_PI, _spec_design(geometry, shape))),
    coefficient_constraints=(((1.0, 1.0), 1.0),),
    doc="kd/pi + ks F(eta + i k) D G2 / (4 N.L N.V): pbrt-v4's mix of diffuse and conductor.",
)

#: pbrt's ``conductor`` as fitted: one ``eta + i k`` and no scale (unregistered).
PBRT_CONDUCTOR = Model(
    name="pbrt_conductor",
    params=_shape_params(),
    classification=_ANISOTROPIC,
    reference=_REFERENCE,
    design=lambda geometry, shape: Design((), _spec_design(geometry, shape)),
    doc="F(eta + i k) D G2 / (4 N.L N.V): pbrt-v4's conductor.",
)

#: With a scale per channel, written as pbrt's ``reflectance`` (unregistered).
PBRT_CONDUCTOR_SCALED = Model(
    name="pbrt_conductor_scaled",
    params=(
        Param("ks", 0.0, 1.0, 1.0, linear=True, unit="1", doc="scale (F(0) = ks F(0; eta, k))"),
        *_shape_params(),
    ),
    classification=_ANISOTROPIC,
    reference=_REFERENCE,
    design=lambda geometry, shape: Design((_spec_design(geometry, shape),)),
    doc="ks F(eta + i k) D G2 / (4 N.L N.V), written as pbrt's conductor reflectance.",
)


def _mix(material: Material, data) -> tuple:
    """(parameters of pbrt's ``mix``, notes): PBRT_MIX fitted, then written."""
    native = to_native(material, PBRT_MIX, data)
    p = native.params
    kd, ks = np.asarray(rgb(p["kd"], native.channels)), np.asarray(rgb(p["ks"], native.channels))
    w = float(min(ks.max(), 1.0))
    q = {
        "form": "mix",
        "amount": w,
        "diffuse_reflectance": (np.minimum(kd / (1.0 - w), 1.0) if w < 1 else kd * 0).tolist(),
        "uroughness": float(p["alpha_u"]),
        "vroughness": float(p["alpha_v"]),
    }
    return _fresnel(q, ks, w, p)


def _fresnel(q: dict, ks: np.ndarray, w: float, p) -> tuple:
    """``eta, k`` when the specular is grey with scale ``w``; else a ``reflectance``."""
    if not (ks.max() > 0 and ks.min() < 0.98 * ks.max()):
        q["eta"], q["k"] = float(p["eta"]), float(p["k"])
        return q, ()
    # pbrt's "reflectance" r per channel (eta = 1, k from r) with F(0) = ks F(0; eta, k) / w;
    # the shape of F(theta) is then pbrt's.
    f0 = float(fresnel_conductor(np.ones(1), p["eta"], p["k"])[0])
    q["reflectance"] = np.clip(ks * f0 / max(w, 1e-12), 0.0, R_MAX).tolist()
    note = (f"coloured specular {ks.round(4).tolist()}: written as pbrt's conductor "
            "reflectance (F at normal incidence, eta = 1), which keeps the colour")  # fmt: skip
    return q, (note,)


def _conductor(material: Material, data) -> tuple:
    """(parameters of pbrt's ``conductor``, notes): the closer of PBRT_CONDUCTOR fitted
    (one ``eta + i k``, grey) and PBRT_CONDUCTOR_SCALED written with ``reflectance``."""
    grey = to_native(material, PBRT_CONDUCTOR, data).params
    q_grey = {"form": "conductor", "uroughness": float(grey["alpha_u"]),
              "vroughness": float(grey["alpha_v"]), "eta": float(grey["eta"]),
              "k": float(grey["k"])}  # fmt: skip
    native = to_native(material, PBRT_CONDUCTOR_SCALED, data)
    p = native.params
    ks = np.asarray(rgb(p["ks"], native.channels))
    f0 = float(fresnel_conductor(np.ones(1), p["eta"], p["k"])[0])
    q = {"form": "conductor", "uroughness": float(p["alpha_u"]), "vroughness": float(p["alpha_v"])}
    q["reflectance"] = np.clip(ks * f0, 0.0, R_MAX).tolist()
    errors = [rms_log_error(material, pbrt_evaluator(x), data) for x in (q_grey, q)]
    if errors[0] <= errors[1]:
        return q_grey, ()
    note = (
        f"conductor: a scale {ks.round(4).tolist()} per channel (pbrt has none) fitted "
        "closer than one eta + i k; written as pbrt's reflectance (F at normal incidence, "
        "eta = 1): the colour and F(0) are kept, the Fresnel's angular shape is pbrt's"
    )
    return q, (note,)


def _coated(material: Material, data) -> tuple:
    """(parameters of pbrt's ``coateddiffuse``, notes): PBRT_COATEDDIFFUSE fitted."""
    native = to_native(material, PBRT_COATEDDIFFUSE, data)
    p = native.params
    alpha, eta, thickness = float(p["alpha"]), float(p["eta"]), float(p["thickness"])
    r = coated_tables(alpha, eta, thickness)[1]
    reflectance, clipped = reflectance_from_diffuse(rgb(p["diffuse"], native.channels), r)
    q = {
        "form": "coateddiffuse",
        "reflectance": reflectance.tolist(),
        "uroughness": alpha,
        "vroughness": alpha,
        "eta": eta,
        "thickness": thickness,
        "maxdepth": MAXDEPTH,
        "internal_reflectance": r,
    }
    n = depth_bounces(MAXDEPTH)
    short = ((reflectance * r) ** n * 100).round(3).tolist()
    cos = np.cos(np.radians([0.0, 60.0]))
    ratio = transmittance(cos, alpha, eta, thickness, True) / transmittance(
        cos, alpha, eta, thickness
    )
    notes = [
        "coateddiffuse: evaluated as the expectation of pbrt's estimator (pbrt_layer), whose "
        f"MIS weights make its diffuse term {ratio[0]:.3f} (light at 0 deg) to "
        f"{ratio[1]:.3f} (60 deg) times the layered model's; maxdepth {MAXDEPTH} allows "
        f"{n} bounces on the base, {short} % of the diffuse term short of the full series "
        "(included)",
    ]
    if clipped:
        notes.append("coateddiffuse: the fitted diffuse term exceeds what reflectance 1 gives; "
                     "reflectance clipped to 1")  # fmt: skip
    return q, tuple(notes)


def _conductor_eta_k(q: dict):
    """Per channel (eta, k) of the conductor as pbrt evaluates it."""
    if "reflectance" not in q:
        return [(q["eta"], q["k"])] * 3
    r = np.asarray(q["reflectance"])
    return [(1.0, float(2.0 * np.sqrt(x) / np.sqrt(1.0 - x))) for x in r]


def pbrt_values(geometry, q: dict) -> np.ndarray:
    """The pbrt BRDF of parameters ``q`` (any form), shape (M, 3)."""
    form = q.get("form", "mix")
    if form == "coateddiffuse":
        return coated_brdf(geometry, q)
    spec = gltf_specular(geometry, q["uroughness"], q["vroughness"])
    amount = q["amount"] if form == "mix" else 1.0
    out = np.empty((geometry.m, 3))
    for c, (eta, k) in enumerate(_conductor_eta_k(q)):
        out[:, c] = amount * spec * fresnel_conductor(geometry.cos_d, eta, k)
        if form == "mix":
            out[:, c] += (1 - amount) * q["diffuse_reflectance"][c] * INV_PI
    return out


def pbrt_model(q: dict) -> Model:
    """An unregistered one-coefficient Model of the exported BRDF (for albedo)."""
    return Model(
        name="pbrt_export",
        params=(Param("scale", 0.0, 1.0, 1.0, linear=True, doc="1: the BRDF as exported"),),
        classification=_ANISOTROPIC,
        reference=_REFERENCE,
        design=lambda geometry, shape: Design((pbrt_values(geometry, q),)),
        doc=f"pbrt-v4 {q.get('form', 'mix')}, as exported.",
    )


def pbrt_evaluator(q: dict):
    """``evaluate(wi, wo) -> (N, 3)``: the pbrt BRDF of parameters ``q`` at any directions."""
    from ..data.geometry import Geometry

    def evaluate(wi, wo):
        geometry = Geometry(wi, wo)
        return geometry.scatter(pbrt_values(geometry, q))

    return evaluate


def pbrt_parameters(material: Material, data=None, forms=FORMS) -> tuple:
    """(pbrt parameters, notes): each of ``forms`` fitted, the lowest error written."""
    unknown = [f for f in forms if f not in FORMS]
    if unknown or not forms:
        from ..errors import ParameterError

        raise ParameterError(
            f"forms={tuple(forms)!r}: pbrt forms are {', '.join(FORMS)} (at least one)", "forms"
        )
    build = {"conductor": _conductor, "coateddiffuse": _coated, "mix": _mix}
    candidates = {f: build[f](material, data) for f in forms}
    errors = {
        f: rms_log_error(material, pbrt_evaluator(q), data) for f, (q, _) in candidates.items()
    }
    lowest = min(errors.values())
    best = next(f for f in FORMS if f in errors and errors[f] <= lowest + CLOSE)
    q, notes = candidates[best]
    listed = ", ".join(f"{f} {e:.4g}" for f, e in errors.items())
    choice = (f"pbrt form {best}: the simplest form within {CLOSE} of the lowest "
              f"conversion error (RMS of ln(1 + f cos)): {listed}")  # fmt: skip
    return q, (choice, *notes)
