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
        """``prepare(geometry, shape)``: the arrays; ``shape(shape)``: the numbers."""
        self.loop, self.prepare, self.shape = loop, prepare, shape

    def run(self, geometry, shape: Mapping, base: float, column: np.ndarray) -> np.ndarray:
        arrays, numbers = self.prepare(geometry, shape), self.shape(shape)
        return _loop(self.loop)(*arrays, *numbers, base, column, np.empty(geometry.m))

    def design(self, geometry, shape: Mapping) -> Design:
        column = np.empty(geometry.m)
        return Design((column,), self.run(geometry, shape, 0.0, column))

    def evaluate(self, geometry, shape: Mapping, coefs) -> np.ndarray:
        (base,) = (float(c) for c in coefs)
        return self.run(geometry, shape, base, _NO_COLUMN)


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
    "gltf_pbr": _Coloured("gltf", lambda g, s: inputs.gltf_inputs(g), _gltf_shape),
    "gltf_pbr_anisotropic": _Coloured(
        "gltf_anisotropic", lambda g, s: inputs.gltf_anisotropic_inputs(g), _gltf_anisotropic_shape
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


def dielectric_fresnel(geometry, eta: float, dtype=np.float64) -> np.ndarray:
    """``F(V.H; eta)`` on the geometry's pairs, kept for the last ``eta`` asked, as
    ``dtype`` (one slot per dtype).

    A fit usually holds the index (Mitsuba's principled ``specular``, roughplastic's
    ``eta``): the loops then read ``F`` (8 bytes a pair) instead of computing a square
    root and a division per pair (measured: principled 197 -> 262 M pairs/s); a new
    index costs one pass of :func:`~brdffit.kernels.loops_renderers.dielectric`. One
    slot, replaced as a whole (one assignment), so it never grows."""
    key = "kernels.dielectric_slot"
    slot = geometry.cached(key if dtype is np.float64 else f"{key}_{np.dtype(dtype)}", dict)
    last = slot.get("last")
    if last is None or last[0] != eta:
        last = (eta, _loop("dielectric")(geometry.cos_d, eta, np.empty(geometry.m, dtype)))
        slot["last"] = last
    return last[1]


def dielectric_fresnel32(geometry, eta: float) -> np.ndarray:
    """:func:`dielectric_fresnel` in float32 (the loop writes float32), in a slot of its
    own, for the principled loops of float32 inputs (unit directions, anisotropic:
    :func:`~brdffit.kernels.inputs_renderers.principled_inputs` bounds the error).
    Its rounding is within ``2^-24`` relative as the values are 0 or normal float32
    numbers: Mitsuba's index ``2 / (1 - sqrt(0.08 specular)) - 1`` is 1 (``F = 0``) or
    at least ``1 + 4.4e-16``, where ``F >= 4e-32`` at every angle (tested)."""
    return dielectric_fresnel(geometry, eta, np.float32)


class _Principled(_Coloured):
    """:class:`_Coloured` whose ``prepare`` also names the loop (the isotropic model
    has one for directions of unit length, :func:`~.inputs_renderers.unit_directions`)."""

    def run(self, geometry, shape: Mapping, base: float, column: np.ndarray) -> np.ndarray:
        loop, arrays = self.prepare(geometry, shape)
        return _loop(loop)(*arrays, *self.shape(shape), base, column, np.empty(geometry.m))


def _principled(anisotropic: bool) -> _Coloured:
    """Mitsuba's widths (``principled_alphas``; the square of the isotropic one), then
    metallic and roughness; ``F`` of the index of ``specular`` (``principled_eta``)
    after the geometry's inputs."""

    def prepare(g, s: Mapping) -> tuple:
        terms = inputs.principled_anisotropic_inputs if anisotropic else inputs.principled_inputs
        loop, arrays = terms(g)
        fresnel = dielectric_fresnel if loop == "principled" else dielectric_fresnel32
        return loop, (*arrays, fresnel(g, principled_eta(float(s["specular"]))))

    def shape(s: Mapping) -> tuple:
        rough = float(s["roughness"])
        au, av = principled_alphas(rough, float(s["anisotropic"]) if anisotropic else None)
        widths = (au, av) if anisotropic else (au * au,)
        return (*widths, float(s["metallic"]), rough)

    return _Principled("", prepare, shape)


SPECS["mitsuba_principled"] = _principled(False)
SPECS["mitsuba_principled_anisotropic"] = _principled(True)


class _Plastic:
    """Mitsuba's roughplastic: columns ``(diffuse, specular)``; the transmittance table
    of ``(alpha, eta)`` from :mod:`brdffit.kernels.plastic_table` (the numpy model's,
    compiled: 8x faster, measured)."""

    #: The loop modules it imports (:data:`brdffit.kernels.bind.MODULES`).
    modules = ("loops_renderers", "plastic_table")

    @staticmethod
    def _table(shape: Mapping) -> np.ndarray:
        from .plastic_table import transmittance_table

        return transmittance_table(float(shape["alpha"]), float(shape["eta"]))

    @staticmethod
    def _specular(geometry, shape: Mapping) -> tuple:
        """The specular loop's arrays, then ``alpha^2``."""
        fresnel = dielectric_fresnel(geometry, float(shape["eta"]))
        return (*inputs.plastic_inputs(geometry), fresnel, float(shape["alpha"]) ** 2)

    def design(self, geometry, shape: Mapping) -> Design:
        m, eta = geometry.m, float(shape["eta"])
        specular = _loop("plastic")(*self._specular(geometry, shape), 1.0, np.empty(m))
        z = inputs.plastic_z(geometry)
        diffuse = _loop("plastic_diffuse")(*z, self._table(shape), eta, np.empty(m))
        return Design((diffuse, specular))

    def evaluate(self, geometry, shape: Mapping, coefs) -> np.ndarray:
        kd, ks = (float(c) for c in coefs)
        out = np.empty(geometry.m)
        if kd == 0.0:  # the diffuse column is not read: its table need not be built
            return _loop("plastic")(*self._specular(geometry, shape), ks, out)
        table, eta = self._table(shape), float(shape["eta"])
        z = inputs.plastic_z(geometry)
        if inputs.unit_directions(geometry):  # four arrays: the cosines from z
            fresnel, alpha2 = dielectric_fresnel(geometry, eta), float(shape["alpha"]) ** 2
            terms = (*z, geometry.tan2_h, fresnel, table, eta, alpha2, kd, ks, out)
            return _loop("plastic_unit")(*terms)
        *arrays, alpha2 = self._specular(geometry, shape)
        return _loop("plastic_evaluate")(*z, *arrays, table, eta, alpha2, kd, ks, out)


SPECS["mitsuba_roughplastic"] = _Plastic()
