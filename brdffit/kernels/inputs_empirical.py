"""The inputs of :mod:`brdffit.kernels.loops_empirical` and its models' compiled forms.

The inputs are parameter-free arrays over the valid pairs of a
:class:`~brdffit.data.geometry.Geometry`, cached on it; where the numpy model caches
the same array, it is that entry (the same function computes it), so the two paths
read the same numbers and a geometry does not hold them twice. :data:`LOBES` gives
each model's loop, inputs and shape numbers, which :mod:`brdffit.kernels.bind`
binds as its own ``kd/pi + ks lobe`` forms; like those, they import their loops
(and numba) only on their first evaluation.
"""

from __future__ import annotations

from collections.abc import Mapping

from ..data.geometry import Geometry
from ..models.anisotropic import _tan2_axes
from ..models.anisotropic_shapes import _half_t
from ..models.empirical_beyond import _dot_xy
from .inputs import _theta_h2, wang_inputs

__all__ = [
    "LOBES",
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


def _ohara_shape(s: Mapping) -> tuple:
    """``1/a^2``, ``1/b^2`` as the numpy model computes them, and ``n``."""
    return 1.0 / float(s["a"]) ** 2, 1.0 / float(s["b"]) ** 2, float(s["n"])


#: Model name -> ``(loop, inputs, shape)``: the name of its loop in
#: :mod:`~brdffit.kernels.loops_empirical`, the function of the geometry giving the
#: loop's arrays and that of the shape parameters giving its numbers, in its order.
LOBES = {
    "gaussian": ("gaussian", gaussian_inputs, lambda s: (0.5 * float(s["n"]),)),
    "lafortune": ("lafortune", lafortune_inputs, lambda s: (float(s["cxy"]), float(s["n"]))),
    "ohara": ("ohara", ohara_inputs, _ohara_shape),
    "fournier": ("fournier", fournier_inputs, lambda s: (float(s["n"]), float(s["t"]))),
    "wang": ("wang", wang_inputs, lambda s: (float(s["m"]), float(s["zeta"]))),
}
