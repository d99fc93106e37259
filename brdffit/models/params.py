"""The parameter factories the model families share.

One place says what a diffuse albedo, a specular scale, an exponent, a
roughness, a refractive index or a reflectance at normal incidence is (bounds,
default, search scale, unit, meaning), so that two families never disagree on
the same quantity. A family with a parameter of its own declares it beside the
model.
"""

from __future__ import annotations

from .base import Param

__all__ = [
    "KD",
    "KS_NORMALISED",
    "diffuse_params",
    "eta_param",
    "exponent",
    "f0_param",
    "radius",
    "roughness",
    "unit_interval",
]

#: The diffuse albedo, linear (solved, not searched).
KD = Param("kd", 0.0, 1.0, 0.5, linear=True, unit="1", doc="diffuse albedo")

#: Upper bound of ks for a normalised lobe (the lobe integrates to about its
#: Fresnel factor, so ks is an albedo scale near 1; 10 leaves room for data in
#: arbitrary units).
KS_NORMALISED = 10.0


def diffuse_params(ks_upper: float = KS_NORMALISED, ks_unit: str = "1") -> tuple:
    """``kd`` (diffuse albedo) and ``ks`` (specular scale), the linear parameters."""
    return (
        KD,
        Param("ks", 0.0, ks_upper, 1.0, linear=True, unit=ks_unit, doc="specular scale"),
    )


def exponent(name: str = "n", upper: float = 1e4, default: float = 50.0, doc: str = "") -> Param:
    """A specular exponent in [1, upper], searched in log space."""
    return Param(name, 1.0, upper, default, log_scale=True, unit="1", doc=doc or "exponent")


def roughness(name: str, default: float = 0.1, doc: str = "") -> Param:
    """A microfacet width in [0.001, 1], searched in log space.

    "Roughness" means different numbers in different places (GGX or Beckmann
    alpha, glTF/Disney roughness = sqrt(GGX alpha), pbrt-v4's remapped
    roughness), so ``doc`` is required: it must say which width this is (the
    distribution, e.g. "GGX width alpha"; never "rms slope" for GGX, whose
    slopes have no finite variance; Beckmann's alpha is sqrt(2) x the rms slope
    along one direction) and how it maps to the renderers' parameters.
    """
    if not doc:
        raise ValueError(f"roughness({name!r}) needs a doc saying which width it is")
    return Param(name, 1e-3, 1.0, default, log_scale=True, unit="1", doc=doc)


def radius(name: str, default: float, doc: str) -> Param:
    """A length ratio in [0.01, 100], searched in log space."""
    return Param(name, 0.01, 100.0, default, log_scale=True, unit="1", doc=doc)


def unit_interval(name: str, default: float, doc: str, linear: bool = False) -> Param:
    """A dimensionless quantity in [0, 1]."""
    return Param(name, 0.0, 1.0, default, linear=linear, unit="1", doc=doc)


def eta_param() -> Param:
    """A real refractive index in [1, 3], for the exact dielectric Fresnel factor."""
    return Param("eta", 1.0, 3.0, 1.5, unit="1", doc="real refractive index (exact Fresnel)")


def f0_param() -> Param:
    """The reflectance at normal incidence in [0, 1], for Schlick's approximation."""
    return Param("f0", 0.0, 1.0, 0.04, unit="1", doc="reflectance at normal incidence (Schlick)")
