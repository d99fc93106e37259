"""Models bound to their compiled loops.

:class:`CompiledDesign` replaces a model's design function: it returns the same
:class:`~brdffit.models.base.Design` as the numpy function it wraps, its columns
computed by a compiled loop, and it offers :meth:`CompiledDesign.evaluate`, the
whole BRDF in one pass, which :meth:`brdffit.models.Model.evaluate_prepared` uses.
When the kernels are not wanted for the geometry (:func:`brdffit.kernels.wanted`:
switched off, too few pairs, or numba not installed), both fall back to the numpy
design (``reference``).
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Callable, Mapping

import numpy as np

from ..models.base import INV_PI, Design
from ..models.empirical import blake_bounds
from . import inputs
from .bind_renderers import SPECS as _RENDERER_SPECS
from .inputs_empirical import LOBES as EMPIRICAL_LOBES

__all__ = ["CompiledDesign", "MODULES", "SPECS"]


def _loops(module: str = "loops"):
    """A module of compiled loops, imported on first use (numba compiles, or loads
    its cache, on a loop's first call only)."""
    return importlib.import_module(f".{module}", __package__)


class _Lobe:
    """``kd/pi + ks lobe``: a loop of :mod:`~brdffit.kernels.loops` (or of the module
    ``loops`` of this package), its inputs and the shape parameters it takes,
    transformed (``alpha -> alpha^2``)."""

    def __init__(self, loop: str, prepare: Callable, shape: Callable, loops: str = "loops"):
        self.loop, self.prepare, self.shape, self.loops = loop, prepare, shape, loops

    def run(self, geometry, shape: Mapping, a: float, b: float) -> np.ndarray:
        out = np.empty(geometry.m)
        loop = getattr(_loops(self.loops), self.loop)
        return loop(*self.prepare(geometry), *self.shape(shape), a, b, out)

    def design(self, geometry, shape: Mapping) -> Design:
        return Design((INV_PI, self.run(geometry, shape, 1.0, 0.0)))

    #: :meth:`evaluate` takes coefficients per channel.
    by_channel = True

    def evaluate(self, geometry, shape: Mapping, coefs) -> np.ndarray:
        """The BRDF (M,), or (M, C) when ``kd`` or ``ks`` is given per channel."""
        kd, ks = coefs
        if np.ndim(kd) == 0 and np.ndim(ks) == 0:
            return self.run(geometry, shape, float(ks), float(kd) * INV_PI)
        lobe = self.run(geometry, shape, 1.0, 0.0)
        c = max(np.size(kd), np.size(ks))
        # copies, always writable: numba types a read-only array apart, and a view
        # here (ks per channel) or a copy (ks shared) made two signatures to load
        scale, offset = (
            np.array(np.broadcast_to(np.asarray(v, dtype=float), (c,)))
            for v in (ks, np.multiply(kd, INV_PI))
        )
        return _loops().affine_by_channel(lobe, scale, offset, np.empty((geometry.m, c)))


class _AshikhminShirley:
    """Columns ``(diffuse, S (1 - w))`` and offset ``S w``; see the model's doc."""

    def design(self, geometry, shape: Mapping) -> Design:
        log_t, log_b, scale, weight, diffuse = inputs.ashikhmin_shirley_inputs(geometry)
        column, offset = np.empty(geometry.m), np.empty(geometry.m)
        _loops().ashikhmin_shirley_columns(
            log_t, log_b, scale, weight, float(shape["nu"]), float(shape["nv"]), column, offset
        )
        return Design(columns=(diffuse, column), offset=offset)

    def evaluate(self, geometry, shape: Mapping, coefs) -> np.ndarray:
        rd_eff, rs = (float(c) for c in coefs)
        terms = inputs.ashikhmin_shirley_inputs(geometry)
        nu, nv = float(shape["nu"]), float(shape["nv"])
        return _loops().ashikhmin_shirley(*terms, nu, nv, rd_eff, rs, np.empty(geometry.m))


class _He:
    """``he``: the column ``1 / pi`` (``a_ud``) and the offset ``rho_s + rho_dd`` of
    :func:`~brdffit.kernels.loops_he.he_offset`; :meth:`evaluate` adds ``a_ud / pi``
    in the same pass. Its shape parameters are numbers and ``wavelength`` one or one
    per channel (:meth:`takes`; a batch of shapes, each row's shape compiled). Compiled from one
    pair on: the numpy series costs milliseconds an evaluation at any size, a
    568-sample fit 1.15 s against 0.16 s compiled, which repays numba's load within
    one fit (benchmarks/README.md)."""

    minimum = 1
    by_channel = True
    #: Its loops' module, and the only one :meth:`evaluate` needs for coefficients per
    #: channel.
    modules = channel_modules = ("loops_he",)

    @staticmethod
    def takes(shape: Mapping) -> bool:
        scalar = all(np.ndim(v) == 0 for k, v in shape.items() if k != "wavelength")
        return scalar and np.ndim(shape["wavelength"]) <= 1

    @staticmethod
    def _offset(geometry, shape: Mapping, diffuse=0.0) -> np.ndarray:
        from ..models.he_terms import SERIES_TOLERANCE

        return _loops("loops_he").he_offset(geometry, shape, SERIES_TOLERANCE, diffuse)

    def design(self, geometry, shape: Mapping) -> Design:
        return Design((INV_PI,), offset=self._offset(geometry, shape))

    def evaluate(self, geometry, shape: Mapping, coefs) -> np.ndarray | None:
        """The BRDF (M,), or (M, C) for C wavelengths; None (combine the design's
        columns) when ``a_ud`` has channels the wavelengths do not (one wavelength)."""
        (a_ud,) = coefs
        channels = np.size(shape["wavelength"]) if np.ndim(shape["wavelength"]) else 0
        if np.ndim(a_ud) and np.size(a_ud) != channels:
            return None
        return self._offset(geometry, shape, np.multiply(INV_PI, a_ud))


def _stack_rows(parts: list):
    """One design part over the rows of a batch: the part itself when every row has
    the same object (a constant, a cached column), else the rows stacked (W, M)."""
    if all(part is parts[0] for part in parts):
        return parts[0]
    return np.stack(parts)


def _alpha2(name: str, second: str | None = None) -> Callable:
    if second is None:
        return lambda s: (float(s[name]) ** 2,)
    return lambda s: (float(s[name]) ** 2, float(s[second]))


def _power(k: float | None) -> Callable:
    """The exponent ``n`` and the factor of a power lobe: 1, or ``(n + k)/(k pi)``."""
    if k is None:
        return lambda s: (float(s["n"]), 1.0)
    return lambda s: (float(s["n"]), (float(s["n"]) + k) / (k * math.pi))


def _anisotropic(u: str, v: str) -> Callable:
    return lambda s: (float(s[u]), float(s[v]), float(s["f0"]))


#: Model name -> its compiled form.
SPECS = {
    "ggx": _Lobe("ggx", inputs.microfacet_inputs, _alpha2("alpha", "f0")),
    "beckmann": _Lobe(
        "beckmann", inputs.beckmann_inputs, _alpha2("alpha", "f0"), "loops_microfacet"
    ),
    "ward": _Lobe("ward", inputs.ward_inputs, _alpha2("alpha")),
    "cook_torrance": _Lobe("cook_torrance", inputs.cook_torrance_inputs, _alpha2("m", "eta")),
    "cook_torrance_schlick": _Lobe(
        "cook_torrance_schlick", inputs.cook_torrance_schlick_inputs, _alpha2("m", "f0")
    ),
    "torrance_sparrow": _Lobe(
        "torrance_sparrow", inputs.torrance_sparrow_inputs, _alpha2("m", "eta")
    ),
    "blinn": _Lobe("blinn", inputs.blinn_inputs, lambda s: (float(s["n"]),)),
    "blinn_normalized": _Lobe("power", inputs.blinn_inputs, _power(8.0)),
    "phong": _Lobe("power", inputs.phong_inputs, _power(None)),
    "phong_normalized": _Lobe("power", inputs.phong_inputs, _power(2.0)),
    "heidrich_seidel": _Lobe("power", inputs.heidrich_seidel_inputs, _power(None)),
    "schlick": _Lobe("schlick", inputs.schlick_inputs, lambda s: (float(s["n"]),)),
    "blake": _Lobe("blake", inputs.blake_inputs, lambda s: blake_bounds(float(s["n"]))),
    "ward_anisotropic": _Lobe(
        "ward_anisotropic",
        inputs.ward_anisotropic_inputs,
        lambda s: (float(s["alpha_x"]), float(s["alpha_y"])),
    ),
    "ashikhmin_shirley": _AshikhminShirley(),
    "ashikhmin_phong": _Lobe(
        "ashikhmin_phong",
        inputs.ashikhmin_phong_inputs,
        lambda s: (float(s["nu"]), float(s["nv"])),
    ),
    "ggx_anisotropic": _Lobe(
        "ggx_anisotropic",
        inputs.ggx_anisotropic_inputs,
        _anisotropic("alpha_u", "alpha_v"),
        "loops_microfacet",
    ),
    "beckmann_anisotropic": _Lobe(
        "beckmann_anisotropic",
        inputs.beckmann_anisotropic_inputs,
        _anisotropic("alpha_u", "alpha_v"),
        "loops_microfacet",
    ),
    **{name: _Lobe(*lobe, loops="loops_empirical") for name, lobe in EMPIRICAL_LOBES.items()},
    "he": _He(),
}
SPECS.update(_RENDERER_SPECS)


def _modules(name: str) -> tuple:
    """The loop modules the compiled form of model ``name`` imports."""
    spec = SPECS[name]
    if isinstance(spec, _Lobe):
        return (spec.loops,)
    if hasattr(spec, "modules"):  # a form with loops of its own (a renderer's table, he)
        return spec.modules
    return ("loops_renderers",) if name in _RENDERER_SPECS else ("loops",)


#: Model name -> the loop modules its compiled form needs: only these are imported
#: (:func:`brdffit.kernels.wanted`) when it is first used.
MODULES = {name: _modules(name) for name in SPECS}


class CompiledDesign:
    """A model's design function computed by its compiled loop when the kernels are
    wanted for the geometry, else by ``reference`` (the numpy design it replaces).

    A compiled form may set ``minimum`` (the smallest geometry it runs on, default
    :data:`brdffit.kernels.MIN_PAIRS`), ``takes(shape)`` (whether it computes these
    shape parameters; numpy does the others) and ``channel_modules`` (the modules its
    :meth:`evaluate` needs for coefficients per channel)."""

    def __init__(
        self, reference: Callable, compiled, wanted: Callable[..., bool], modules=("loops",)
    ):
        self.reference, self.compiled, self._wanted = reference, compiled, wanted
        self.modules = modules
        self.minimum = getattr(compiled, "minimum", None)
        self.__doc__ = getattr(reference, "__doc__", None)

    def _on(self, geometry, modules=None) -> bool:
        minimum = () if self.minimum is None else (self.minimum,)
        return self._wanted(geometry.m, *minimum, modules=modules or self.modules)

    def __call__(self, geometry, shape: Mapping) -> Design:
        if not self._on(geometry):
            return self.reference(geometry, shape)
        takes = getattr(self.compiled, "takes", None)
        if takes(shape) if takes else all(np.ndim(value) == 0 for value in shape.values()):
            return self.compiled.design(geometry, shape)
        return self._batched(geometry, shape)

    def _batched(self, geometry, shape: Mapping) -> Design:
        """Shape parameters of shape (W, 1), one row per walker of the posterior
        sampler: the compiled design of each row, array columns stacked to (W, M)
        (columns the same for every row, such as a constant, stay as they are).
        Other shapes go to the numpy design, which broadcasts them."""
        arrays = {k: np.asarray(v, dtype=float) for k, v in shape.items()}
        try:
            common = np.broadcast_shapes(*(a.shape for a in arrays.values()))
        except ValueError:
            return self.reference(geometry, shape)
        if len(common) != 2 or common[1] != 1:
            return self.reference(geometry, shape)
        rows = [
            self.compiled.design(
                geometry, {k: float(np.broadcast_to(a, common)[w, 0]) for k, a in arrays.items()}
            )
            for w in range(common[0])
        ]
        columns = tuple(
            _stack_rows([r.columns[j] for r in rows]) for j in range(len(rows[0].columns))
        )
        offset = None if rows[0].offset is None else _stack_rows([r.offset for r in rows])
        return Design(columns, offset)

    def evaluate(self, geometry, shape: Mapping, coefs) -> np.ndarray | None:
        """The BRDF on the valid pairs in one compiled pass, or None when the kernels
        are off or a coefficient is given per channel to a model whose compiled form
        takes one value each (then the caller combines the design's columns)."""
        if not self._on(geometry):
            return None
        takes = getattr(self.compiled, "takes", None)
        if takes is not None and not takes(shape):
            return None
        channel_modules = getattr(self.compiled, "channel_modules", ("loops",))
        if any(np.ndim(c) for c in coefs) and not (
            getattr(self.compiled, "by_channel", False)
            and self._on(geometry, channel_modules)  # affine_by_channel's module
        ):
            return None
        return self.compiled.evaluate(geometry, shape, coefs)
