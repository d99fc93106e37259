"""The inputs of :mod:`brdffit.kernels.loops_empirical` and its models' compiled forms.

The inputs are parameter-free arrays over the valid pairs of a
:class:`~brdffit.data.geometry.Geometry`, cached on it; where the numpy model caches
the same array, it is that entry (the same function computes it), so the two paths
read the same numbers and a geometry does not hold them twice. :data:`SPECS` maps
each model to its compiled form, which :mod:`brdffit.kernels.bind` adds to its own;
like those, it imports its loops (and numba) only on its first evaluation.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from ..data.geometry import Geometry
from ..models.anisotropic import _tan2_axes
from ..models.anisotropic_shapes import _half_t
from ..models.base import INV_PI, Design
from ..models.empirical_beyond import _dot_xy
from .inputs import _theta_h2, wang_inputs

__all__ = [
    "SPECS",
    "fournier_inputs",
    "gaussian_inputs",
    "lafortune_inputs",
    "ohara_inputs",
]


def gaussian_inputs(g: Geometry) -> tuple:
    """Gaussian: ``theta_h^2`` (the loop multiplies it by ``n / 2``: ``n theta_h^2 / 2``
    rounds once either way, as the numpy model's ``-n (theta_h^2 / 2)``)."""
    return (_theta_h2(g),)


def lafortune_inputs(g: Geometry) -> tuple:
    """Lafortune: ``Lx Vx + Ly Vy`` (the numpy model's entry) and ``Lz Vz``."""
    return _dot_xy(g), g.cached("kernels.dot_z", lambda: g.wi[:, 2] * g.wo[:, 2])


def ohara_inputs(g: Geometry) -> tuple:
    """Ohara: ``(H.T / N.H)^2`` and ``(H.B / N.H)^2`` (the numpy model's entries)."""
    return _tan2_axes(g)


def fournier_inputs(g: Geometry) -> tuple:
    """Fournier: ``ln(N.H)``, ``N.H`` and ``H.T`` (the numpy model's entries)."""
    return g.log_cos_h, g.cos_h, _half_t(g)


def _loops():
    from . import loops_empirical  # numba compiles (or loads its cache) on first use

    return loops_empirical


class _Lobe:
    """``kd/pi + ks lobe``: a loop of :mod:`~brdffit.kernels.loops_empirical`, its
    inputs and the shape parameters it takes, as floats in the loop's order."""

    def __init__(self, loop: str, prepare: Callable, shape: Callable):
        self.loop, self.prepare, self.shape = loop, prepare, shape

    def run(self, geometry, shape: Mapping, a: float, b: float) -> np.ndarray:
        out = np.empty(geometry.m)
        return getattr(_loops(), self.loop)(*self.prepare(geometry), *self.shape(shape), a, b, out)

    def design(self, geometry, shape: Mapping) -> Design:
        return Design((INV_PI, self.run(geometry, shape, 1.0, 0.0)))

    def evaluate(self, geometry, shape: Mapping, coefs) -> np.ndarray:
        kd, ks = (float(c) for c in coefs)
        return self.run(geometry, shape, ks, kd * INV_PI)


def _ohara_shape(s: Mapping) -> tuple:
    """``1/a^2``, ``1/b^2`` as the numpy model computes them, and ``n``."""
    return 1.0 / float(s["a"]) ** 2, 1.0 / float(s["b"]) ** 2, float(s["n"])


#: Model name -> its compiled form (merged into :data:`brdffit.kernels.bind.SPECS`).
SPECS = {
    "gaussian": _Lobe("gaussian", gaussian_inputs, lambda s: (0.5 * float(s["n"]),)),
    "lafortune": _Lobe("lafortune", lafortune_inputs, lambda s: (float(s["cxy"]), float(s["n"]))),
    "ohara": _Lobe("ohara", ohara_inputs, _ohara_shape),
    "fournier": _Lobe("fournier", fournier_inputs, lambda s: (float(s["n"]), float(s["t"]))),
    "wang": _Lobe("wang", wang_inputs, lambda s: (float(s["m"]), float(s["zeta"]))),
}
