"""Direction pairs, checked once and prepared once.

A fit evaluates a model thousands of times on the same directions. Everything
that depends on the directions only (cosines, the half vector and its azimuth,
the mirror direction) is computed here, lazily and at most once per
:class:`Geometry`, so that each evaluation does only the parameter-dependent
arithmetic. Models may also cache their own parameter-free terms (shadowing,
for instance) with :meth:`Geometry.cached`.

Conventions are those of MODELS.md: normal ``N = (0, 0, 1)``, tangent
``T = (1, 0, 0)``, bitangent ``B = (0, 1, 0)``, ``wi = L`` towards the light and
``wo = V`` towards the viewer, both pointing away from the surface.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from functools import cached_property

import numpy as np

from .. import kernels
from ..errors import DataError
from ..words import plural

__all__ = ["Geometry", "check_directions", "directions_from_angles", "angles_from_directions"]

#: Cosines are clamped at this value in the derived quantities (not in the
#: validity test), so that models that diverge at the horizon (Ward's
#: 1/sqrt(N.L N.V), the 1/(4 N.L N.V) of microfacet models) stay finite for
#: every direction above it. It is 5.7e-9 degrees above the horizon.
MIN_COSINE = 1e-10

#: Directions must have unit length within this tolerance.
UNIT_TOLERANCE = 1e-6


def check_directions(wi, wo) -> tuple[np.ndarray, np.ndarray]:
    """Return ``wi`` and ``wo`` as float arrays of shape (N, 3), or raise DataError."""
    arrays = []
    for name, w in (("wi", wi), ("wo", wo)):
        try:
            a = np.asarray(w, dtype=float)
        except (TypeError, ValueError) as exc:
            raise DataError(
                f"{name} must be an array of numbers of shape (N, 3): {exc}", name
            ) from None
        if a.ndim == 1 and a.shape == (3,):
            a = a[None, :]
        if a.ndim != 2 or a.shape[1] != 3:
            raise DataError(f"{name} has shape {a.shape}; it must be (N, 3) unit vectors", name)
        bad = ~np.isfinite(a).all(axis=1)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise DataError(
                f"{name}[{i}] = {a[i].tolist()} is not finite; "
                f"{plural(int(bad.sum()), 'direction')} with NaN or inf",
                name,
            )
        norm = np.linalg.norm(a, axis=1)
        off = np.abs(norm - 1.0) > UNIT_TOLERANCE
        if off.any():
            i = int(np.flatnonzero(off)[0])
            raise DataError(
                f"{name}[{i}] has length {norm[i]:.9g}; directions must be unit vectors "
                f"(length 1 within {UNIT_TOLERANCE})",
                name,
            )
        arrays.append(a)
    if arrays[0].shape[0] != arrays[1].shape[0]:
        raise DataError(
            f"wi has {arrays[0].shape[0]} directions but wo has {arrays[1].shape[0]}; "
            "they must pair up one to one",
            "wo",
        )
    return arrays[0], arrays[1]


def directions_from_angles(theta, phi, degrees: bool = True) -> np.ndarray:
    """Unit vectors ``(sin t cos p, sin t sin p, cos t)`` of shape (N, 3)."""
    theta = np.asarray(theta, dtype=float)
    phi = np.asarray(phi, dtype=float)
    if degrees:
        theta, phi = np.radians(theta), np.radians(phi)
    st = np.sin(theta)
    return np.stack([st * np.cos(phi), st * np.sin(phi), np.cos(theta)], axis=-1)


def angles_from_directions(w: np.ndarray, degrees: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Polar and azimuth angles of unit vectors; azimuth in [0, 360) degrees."""
    w = np.asarray(w, dtype=float)
    theta = np.arccos(np.clip(w[..., 2], -1.0, 1.0))
    phi = np.mod(np.arctan2(w[..., 1], w[..., 0]), 2 * np.pi)
    if degrees:
        return np.degrees(theta), np.degrees(phi)
    return theta, phi


class Geometry:
    """A set of direction pairs with their parameter-free quantities.

    Only pairs with both directions strictly above the horizon are kept for
    evaluation (``valid``); every model is zero elsewhere, and :meth:`scatter`
    puts values computed on the valid pairs back into arrays of length ``n``.

    Parameters
    ----------
    wi, wo : array_like, shape (N, 3)
        Unit directions towards the light and the viewer, in the local frame.
    check : bool
        Validate shapes, finiteness and unit length (default). Internal callers
        that built the directions themselves may skip it.
    """

    def __init__(self, wi, wo, check: bool = True):
        if check:
            wi, wo = check_directions(wi, wo)
        else:
            wi, wo = np.asarray(wi, dtype=float), np.asarray(wo, dtype=float)
        self.n = wi.shape[0]
        # The z columns copied once (a comparison of a strided column took 3 ms on a
        # MERL file, its copy 1.2 and the copy's 0.3): the same flags, and, where
        # every pair is valid, the cosines from them (the same values, formed anyway
        # by every fit: 2.4 ms less).
        z_i, z_o = wi[:, 2].copy(), wo[:, 2].copy()
        valid = np.greater(z_i, 0.0)
        valid &= np.greater(z_o, 0.0)
        self.all_valid = bool(valid.all())
        self.valid = valid
        self.wi = wi if self.all_valid else wi[valid]
        self.wo = wo if self.all_valid else wo[valid]
        self.m = self.wi.shape[0]
        self._cache: dict = {}
        if self.all_valid:
            self.cos_i = np.maximum(z_i, MIN_COSINE, out=z_i)
            self.cos_o = np.maximum(z_o, MIN_COSINE, out=z_o)

    def cached(self, key, compute: Callable[[], np.ndarray]):
        """Return ``compute()``, computed once per geometry and key."""
        try:
            return self._cache[key]
        except KeyError:
            value = self._cache[key] = compute()
            return value

    def scatter(self, values: np.ndarray) -> np.ndarray:
        """Place values of the valid pairs (M,) or (M, C) into zeros of length N."""
        if self.all_valid:
            return values
        out = np.zeros((self.n, *values.shape[1:]), dtype=values.dtype)
        out[self.valid] = values
        return out

    # Cosines with the normal, clamped away from zero (see MIN_COSINE).
    @cached_property
    def cos_i(self) -> np.ndarray:
        return np.maximum(self.wi[:, 2], MIN_COSINE)

    @cached_property
    def cos_o(self) -> np.ndarray:
        return np.maximum(self.wo[:, 2], MIN_COSINE)

    def directions(self) -> tuple:
        """``wi`` and ``wo`` contiguous and read-only, as the compiled loops take them:
        one compiled version of a loop for a file's read-only directions and a
        subset's writable ones (each version is a cache load of a first fit)."""
        out = []
        for w in (self.wi, self.wo):
            w = np.ascontiguousarray(w).view()
            w.flags.writeable = False
            out.append(w)
        return tuple(out)

    def _half_terms(self) -> bool:
        """Form ``|L + V|``, :attr:`cos_h` and :attr:`cos_d` at once by the compiled pass
        of :func:`brdffit.kernels.loops.half_terms` (the same values, 25 -> 6 ms on a
        MERL file), where the kernels run on this geometry, their loops are already
        loaded (no numba import for a geometry alone), and none of the three is formed
        yet; whether it did."""
        loops = sys.modules.get("brdffit.kernels.loops")
        if loops is None or not kernels.wanted(self.m):
            return False
        if any(name in self.__dict__ for name in ("_half_norm", "half", "cos_h", "cos_d")):
            return False
        norm, cos_h, cos_d = (np.empty(self.m) for _ in range(3))
        wi, wo = self.directions()
        loops.half_terms(wi, wo, MIN_COSINE, norm, cos_h, cos_d)
        self.__dict__.update(_half_norm=norm, cos_h=cos_h, cos_d=cos_d)
        return True

    @cached_property
    def _half_norm(self) -> np.ndarray:
        """``|L + V|``, its square summed over the three columns in place: no squared
        copy of L + V (np.linalg.norm makes one), and twice as fast as an einsum's
        inner loop of three elements; the same value (x^2 + y^2 + z^2 in that order)."""
        total = self.wi + self.wo
        x, y, z = total.T
        square = x * x
        square += y * y
        square += z * z
        return np.sqrt(square, out=square)

    @cached_property
    def _half_scale(self) -> np.ndarray:
        """``|L + V|``, at least 1e-300: what the half vector's components divide by."""
        return np.maximum(self._half_norm, 1e-300)

    @cached_property
    def half(self) -> np.ndarray:
        """Unit half vector H = (L + V) / |L + V|, shape (M, 3)."""
        total = self.wi + self.wo
        total /= self._half_scale[:, None]
        return total

    def _half_component(self, axis: int) -> np.ndarray:
        """One component of :attr:`half`, the same value, without forming (and keeping)
        the (M, 3) half vector when it is not there already (the isotropic models need
        its z component or the length of its tangential part only: a MERL file's is
        26 MB and 5-10 ms)."""
        if "half" in self.__dict__:
            return self.half[:, axis]
        return (self.wi[:, axis] + self.wo[:, axis]) / self._half_scale

    @cached_property
    def cos_h(self) -> np.ndarray:
        """N.H, clamped away from zero."""
        if self._half_terms():
            return self.__dict__["cos_h"]
        return np.clip(self._half_component(2), MIN_COSINE, 1.0)

    @cached_property
    def cos_d(self) -> np.ndarray:
        """V.H (= L.H), the cosine that enters Fresnel, as |L + V| / 2: the same
        value, symmetric in L and V by construction, and without the cancellation
        of (1 + L.V) / |L + V| when L and V are nearly opposite."""
        if self._half_terms():
            return self.__dict__["cos_d"]
        return np.clip(0.5 * self._half_norm, 0.0, 1.0)

    def _half_sines(self) -> bool:
        """Form :attr:`sin2_h` and :attr:`tan2_h` at once by the compiled pass of
        :func:`brdffit.kernels.loops_geometry.half_sines` (the same values, 15 -> 4 ms
        on a MERL file), where the kernels run on this geometry, that loop module is
        loaded (by the models whose inputs it forms) and neither is formed; whether it
        did."""
        loops = sys.modules.get("brdffit.kernels.loops_geometry")
        if loops is None or not kernels.wanted(self.m):
            return False
        if "sin2_h" in self.__dict__ or "tan2_h" in self.__dict__:
            return False
        cos_h, sin2_h, tan2_h = self.cos_h, np.empty(self.m), np.empty(self.m)
        wi, wo = self.directions()
        loops.half_sines(wi, wo, self._half_norm, cos_h, sin2_h, tan2_h)
        self.__dict__.update(sin2_h=sin2_h, tan2_h=tan2_h)
        return True

    @cached_property
    def sin2_h(self) -> np.ndarray:
        """sin^2(theta_h), from the tangential part of H (accurate near H = N)."""
        if self._half_sines():
            return self.__dict__["sin2_h"]
        x, y = self._half_component(0), self._half_component(1)
        return np.minimum(x**2 + y**2, 1.0)

    @cached_property
    def tan2_h(self) -> np.ndarray:
        if self._half_sines():
            return self.__dict__["tan2_h"]
        return self.sin2_h / self.cos_h**2

    @cached_property
    def theta_h(self) -> np.ndarray:
        return np.arctan2(np.sqrt(self.sin2_h), self.cos_h)

    @cached_property
    def log_cos_h(self) -> np.ndarray:
        """ln(N.H), for power lobes evaluated as exp(n ln c)."""
        return np.log(self.cos_h)

    @cached_property
    def cos2_phi_h(self) -> np.ndarray:
        """cos^2 of the azimuth of H; 1/2 where H = N (the azimuth is undefined there
        and every lobe that uses it is independent of it)."""
        h = self.half
        s2 = h[:, 0] ** 2 + h[:, 1] ** 2
        out = np.full(self.m, 0.5)
        ok = s2 > 1e-300
        out[ok] = h[ok, 0] ** 2 / s2[ok]
        return out

    @cached_property
    def sin2_phi_h(self) -> np.ndarray:
        return 1.0 - self.cos2_phi_h

    @cached_property
    def cos_r(self) -> np.ndarray:
        """R.V with R = 2 (N.L) N - L, the mirror direction of L (Phong's operand)."""
        dot = np.einsum("ij,ij->i", self.wi, self.wo)
        return np.clip(2.0 * self.wi[:, 2] * self.wo[:, 2] - dot, -1.0, 1.0)
