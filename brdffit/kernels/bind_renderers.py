"""The compiled forms of the renderer-native models, registered in
:data:`brdffit.kernels.bind.SPECS`.

Their designs are not the ``kd/pi + ks lobe`` of :class:`~brdffit.kernels.bind._Lobe`:
glTF and Mitsuba's principled have one colour column and an offset
(:class:`_Coloured`), Mitsuba's roughconductor one scaled lobe (:class:`_Scaled`),
its roughplastic two columns (:class:`_Plastic`). Each offers ``design`` and
``evaluate`` as :class:`~brdffit.kernels.bind.CompiledDesign` expects; the loops
are :mod:`brdffit.kernels.loops_renderers`, imported (and numba with them) on the
first call only.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping

import numpy as np

from ..models.base import Design
from ..models.mitsuba_plastic import transmittance_table
from ..models.mitsuba_principled import principled_alphas, principled_eta
from . import inputs_renderers as inputs

__all__ = ["SPECS"]

#: The ``column`` argument that asks a coloured loop for the BRDF itself.
_NO_COLUMN = np.empty(0)


def _loop(name: str) -> Callable:
    from . import loops_renderers  # numba compiles (or loads its cache) on first use

    return getattr(loops_renderers, name)


class _Coloured:
    """``offset + base_color column``: the loop writes both, or the sum at a colour."""

    def __init__(self, loop: str, prepare: Callable, shape: Callable):
        self.loop, self.prepare, self.shape = loop, prepare, shape

    def design(self, geometry, shape: Mapping) -> Design:
        column, offset = np.empty(geometry.m), np.empty(geometry.m)
        _loop(self.loop)(*self.prepare(geometry), *self.shape(shape), 0.0, column, offset)
        return Design((column,), offset)

    def evaluate(self, geometry, shape: Mapping, coefs) -> np.ndarray:
        (base,) = (float(c) for c in coefs)
        out = np.empty(geometry.m)
        return _loop(self.loop)(*self.prepare(geometry), *self.shape(shape), base, _NO_COLUMN, out)


class _Scaled:
    """``a lobe``: one column, the lobe at ``a = 1``."""

    def __init__(self, loop: str, prepare: Callable, shape: Callable):
        self.loop, self.prepare, self.shape = loop, prepare, shape

    def run(self, geometry, shape: Mapping, a: float) -> np.ndarray:
        out = np.empty(geometry.m)
        return _loop(self.loop)(*self.prepare(geometry), *self.shape(shape), a, out)

    def design(self, geometry, shape: Mapping) -> Design:
        return Design((self.run(geometry, shape, 1.0),))

    def evaluate(self, geometry, shape: Mapping, coefs) -> np.ndarray:
        (a,) = (float(c) for c in coefs)
        return self.run(geometry, shape, a)


def _gltf_shape(s: Mapping) -> tuple:
    alpha = float(s["roughness"]) ** 2
    return alpha * alpha, float(s["metallic"])


def _gltf_anisotropic_shape(s: Mapping) -> tuple:
    """``alpha_t = alpha + (1 - alpha) strength^2``, ``alpha_b = alpha`` (the numpy
    model's expressions), the rotation's cosine and sine, and ``metallic``."""
    alpha = float(s["roughness"]) ** 2
    strength = float(s["anisotropy_strength"])
    rotation = float(s["anisotropy_rotation"])
    alpha_t = alpha + (1.0 - alpha) * strength * strength
    return alpha_t, alpha, math.cos(rotation), math.sin(rotation), float(s["metallic"])


def _conductor_shape(*widths: str) -> Callable:
    if len(widths) == 1:
        return lambda s: (float(s[widths[0]]) ** 2, float(s["eta"]), float(s["k"]))
    return lambda s: (*(float(s[w]) for w in widths), float(s["eta"]), float(s["k"]))


#: Model name -> its compiled form.
SPECS = {
    "gltf_pbr": _Coloured("gltf", inputs.gltf_inputs, _gltf_shape),
    "gltf_pbr_anisotropic": _Coloured(
        "gltf_anisotropic", inputs.gltf_anisotropic_inputs, _gltf_anisotropic_shape
    ),
    "mitsuba_roughconductor": _Scaled(
        "conductor", inputs.conductor_inputs, _conductor_shape("alpha")
    ),
    "mitsuba_roughconductor_anisotropic": _Scaled(
        "conductor_anisotropic",
        inputs.conductor_anisotropic_inputs,
        _conductor_shape("alpha_u", "alpha_v"),
    ),
}


def _principled_shape(anisotropic: bool) -> Callable:
    """Mitsuba's widths (``principled_alphas``; the square of the isotropic one), then
    metallic, roughness and the index of ``specular`` (``principled_eta``)."""

    def shape(s: Mapping) -> tuple:
        rough = float(s["roughness"])
        au, av = principled_alphas(rough, float(s["anisotropic"]) if anisotropic else None)
        widths = (au, av) if anisotropic else (au * au,)
        return (*widths, float(s["metallic"]), rough, principled_eta(float(s["specular"])))

    return shape


SPECS["mitsuba_principled"] = _Coloured(
    "principled", inputs.principled_inputs, _principled_shape(False)
)
SPECS["mitsuba_principled_anisotropic"] = _Coloured(
    "principled_anisotropic", inputs.principled_anisotropic_inputs, _principled_shape(True)
)


class _Plastic:
    """Mitsuba's roughplastic: columns ``(diffuse, specular)``; the transmittance table
    of ``(alpha, eta)`` from the numpy model (cached there)."""

    @staticmethod
    def run(geometry, shape: Mapping, kd: float, ks: float, diffuse: np.ndarray):
        alpha, eta = float(shape["alpha"]), float(shape["eta"])
        table = transmittance_table(alpha, eta)
        out = np.empty(geometry.m)
        terms = inputs.plastic_inputs(geometry)
        return _loop("plastic")(*terms, table, alpha * alpha, eta, kd, ks, diffuse, out)

    def design(self, geometry, shape: Mapping) -> Design:
        diffuse = np.empty(geometry.m)
        return Design((diffuse, self.run(geometry, shape, 1.0, 1.0, diffuse)))

    def evaluate(self, geometry, shape: Mapping, coefs) -> np.ndarray:
        kd, ks = (float(c) for c in coefs)
        return self.run(geometry, shape, kd, ks, _NO_COLUMN)


SPECS["mitsuba_roughplastic"] = _Plastic()
