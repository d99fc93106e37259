"""The text of pbrt-v4 material statements (pbrt.org/fileformat-v4, "Materials").

Every statement is a ``MakeNamedMaterial`` whose parameters are typed lists
(``"float uroughness" 0.1``, ``"rgb reflectance" [ r g b ]``, ``"spectrum eta"
[ lambda value ... ]``); roughness is always alpha with ``"bool remaproughness"
false`` (pbrt's default true would take ``sqrt`` of it).
"""

from __future__ import annotations

__all__ = ["pbrt_statement"]


def _floats(values) -> str:
    return " ".join(f"{v:.9g}" for v in values)


def _roughness_lines(q: dict) -> str:
    return (
        f'    "float uroughness" {q["uroughness"]:.9g}\n'
        f'    "float vroughness" {q["vroughness"]:.9g}\n'
        '    "bool remaproughness" false\n'
    )


def _conductor(name: str, q: dict) -> str:
    if "reflectance" in q:
        fresnel = f'    "rgb reflectance" [ {_floats(q["reflectance"])} ]\n'
    else:
        fresnel = (
            f'    "spectrum eta" [ 300 {q["eta"]:.9g} 800 {q["eta"]:.9g} ]\n'
            f'    "spectrum k" [ 300 {q["k"]:.9g} 800 {q["k"]:.9g} ]\n'
        )
    return (
        f'MakeNamedMaterial "{name}"\n    "string type" "conductor"\n'
        + fresnel
        + _roughness_lines(q)
    )


def _coateddiffuse(name: str, q: dict) -> str:
    return (
        f'MakeNamedMaterial "{name}"\n'
        '    "string type" "coateddiffuse"\n'
        f'    "rgb reflectance" [ {_floats(q["reflectance"])} ]\n'
        + _roughness_lines(q)
        + f'    "float eta" {q["eta"]:.9g}\n'
        f'    "float thickness" {q["thickness"]:.9g}\n'
        '    "rgb albedo" [ 0 0 0 ]\n'
        f'    "integer maxdepth" {int(q["maxdepth"])}\n'
    )


def _mix(name: str, q: dict) -> str:
    return (
        f'MakeNamedMaterial "{name}_diffuse"\n'
        '    "string type" "diffuse"\n'
        f'    "rgb reflectance" [ {_floats(q["diffuse_reflectance"])} ]\n'
        + _conductor(f"{name}_conductor", q)
        + f'MakeNamedMaterial "{name}"\n'
        '    "string type" "mix"\n'
        f'    "string materials" [ "{name}_diffuse" "{name}_conductor" ]\n'
        f'    "float amount" {q["amount"]:.9g}\n'
    )


def pbrt_statement(q: dict, name: str = "brdffit") -> str:
    """The ``MakeNamedMaterial`` statement(s) of parameters ``q`` (any form); the
    material to use is ``name``."""
    form = q.get("form", "mix")
    writers = {"conductor": _conductor, "coateddiffuse": _coateddiffuse, "mix": _mix}
    return writers[form](name, q)
