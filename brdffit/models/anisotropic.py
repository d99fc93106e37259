"""Anisotropic models of the classification paper with a normalised lobe: Ward,
Ashikhmin-Shirley and the anisotropic Phong lobe. The empirical highlight shapes
(Heidrich-Seidel, Ohara, Wang, Fournier) live in
:mod:`brdffit.models.anisotropic_shapes`.

``T = (1, 0, 0)`` is the "x"/"u" direction of every model, ``B = (0, 1, 0)`` its
"y"/"v" direction (MODELS.md). Terms that depend on the directions only are
cached on the :class:`Geometry` (keys ``"anisotropic.*"``). The anisotropic
microfacet models live in :mod:`brdffit.models.microfacet`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

import numpy as np

from ..data.geometry import MIN_COSINE, Geometry
from ..errors import ParameterError
from .base import Classification, Design, Model, diffuse_plus_lobe
from .params import exponent, roughness, unit_interval

__all__ = ["MODELS", "ashikhmin_shirley_coefficients", "ashikhmin_shirley_params"]

EMPIRICAL_ANISO = Classification("empirical", "anisotropic", "cosine", "light")
PHYSICAL_ANISO = Classification("physical", "anisotropic", "cosine", "light")
FRESNEL_ANISO = Classification("empirical", "anisotropic", "cosine", "material")


def _normalised(model: Model) -> Model:
    """The model with ``ks`` as the dimensionless scale of a normalised lobe."""
    ks = dataclasses.replace(model.param("ks"), unit="1", doc="specular albedo scale")
    params = tuple(ks if p.name == "ks" else p for p in model.params)
    return dataclasses.replace(model, params=params)


# ------------------------------------------------------- parameter-free terms
def _tan2_axes(geometry: Geometry) -> tuple[np.ndarray, np.ndarray]:
    """``((H.T)/(N.H))^2`` and ``((H.B)/(N.H))^2``; they sum to tan^2(theta_h)."""

    def compute():
        h = geometry.half
        inv_c2 = 1.0 / geometry.cos_h**2
        return h[:, 0] ** 2 * inv_c2, h[:, 1] ** 2 * inv_c2

    return geometry.cached("anisotropic.tan2_axes", compute)


def _log_cos_h_axes(geometry: Geometry) -> tuple[np.ndarray, np.ndarray]:
    """``cos^2(phi_h) ln(N.H)`` and ``sin^2(phi_h) ln(N.H)``, so that
    ``(N.H)^(nu cos^2 phi_h + nv sin^2 phi_h) = exp(nu A + nv B)``."""

    def compute():
        log_c = geometry.log_cos_h
        return geometry.cos2_phi_h * log_c, geometry.sin2_phi_h * log_c

    return geometry.cached("anisotropic.log_cos_h_axes", compute)


def _anisotropic_power(geometry: Geometry, nu: float, nv: float) -> np.ndarray:
    """``(N.H)^(nu cos^2 phi_h + nv sin^2 phi_h)``: ``nu`` along T, ``nv`` along B."""
    a, b = _log_cos_h_axes(geometry)
    power = a * nu
    power += b * nv
    return np.exp(power, out=power)


# -------------------------------------------------------------------- Ward
def _ward_factor(geometry: Geometry) -> np.ndarray:
    return geometry.cached(
        "anisotropic.ward_factor",
        lambda: 1.0 / (4.0 * math.pi * np.sqrt(geometry.cos_i * geometry.cos_o)),
    )


def ward_anisotropic_lobe(geometry: Geometry, alpha_x: float, alpha_y: float) -> np.ndarray:
    """``exp(-((H.T/alpha_x)^2 + (H.B/alpha_y)^2)/(N.H)^2)
    / (4 pi alpha_x alpha_y sqrt((N.L)(N.V)))``."""
    tx, ty = _tan2_axes(geometry)
    e = tx * (-1.0 / alpha_x**2)
    e -= ty * (1.0 / alpha_y**2)
    lobe = np.exp(e, out=e)
    lobe *= _ward_factor(geometry)
    lobe *= 1.0 / (alpha_x * alpha_y)
    return lobe


WARD_ANISOTROPIC = _normalised(
    diffuse_plus_lobe(
        "ward_anisotropic",
        ward_anisotropic_lobe,
        (
            roughness(
                "alpha_x",
                0.1,
                "Ward 1992 width along the tangent T: the slope Gaussian "
                "exp(-(s_T/alpha_x)^2), sqrt(2) x the rms slope along T (a Beckmann "
                "alpha_u). Renderers: Mitsuba 3 alpha_u with distribution 'beckmann'; "
                "glTF/Disney/OpenPBR/pbrt-v4 use GGX: no exact mapping",
            ),
            roughness(
                "alpha_y",
                0.3,
                "Ward 1992 width along the bitangent B: sqrt(2) x the "
                "rms slope along B (a Beckmann alpha_v). Renderers: Mitsuba 3 alpha_v "
                "with distribution 'beckmann'; GGX renderers: no exact mapping",
            ),
        ),
        PHYSICAL_ANISO,
        "G. J. Ward, Measuring and modeling anisotropic reflection, SIGGRAPH 1992, "
        "Computer Graphics 26(2) 265-272, eq. 5a",
        """Anisotropic Ward: ``f = kd/pi + ks exp(-tan^2(theta_h) (cos^2 phi_h/alpha_x^2
+ sin^2 phi_h/alpha_y^2)) / (4 pi alpha_x alpha_y sqrt((N.L)(N.V)))``.

The exponent is ``((H.T/alpha_x)^2 + (H.B/alpha_y)^2)/(N.H)^2`` (the paper's is
garbled). ``physical``, as isotropic ``ward``: an elliptical Gaussian
distribution of slopes, normalised so that ``ks`` is an albedo (its
``1/sqrt((N.L)(N.V))`` is fitted, not derived). ``cosine``: dot products only;
``(H.T)^2/(N.H)^2``, ``(H.B)^2/(N.H)^2`` and ``1/(4 pi sqrt((N.L)(N.V)))`` are
cached. Equals ``ward`` with ``alpha = alpha_x = alpha_y``.
""",
        ks_upper=10.0,
    )
)


# ---------------------------------------------------- anisotropic Phong lobe
def ashikhmin_phong_lobe(geometry: Geometry, nu: float, nv: float) -> np.ndarray:
    """``sqrt((nu+1)(nv+1))/(2 pi) (N.H)^(nu cos^2 phi_h + nv sin^2 phi_h)``."""
    lobe = _anisotropic_power(geometry, nu, nv)
    lobe *= math.sqrt((nu + 1.0) * (nv + 1.0)) / (2.0 * math.pi)
    return lobe


ASHIKHMIN_PHONG = _normalised(
    diffuse_plus_lobe(
        "ashikhmin_phong",
        ashikhmin_phong_lobe,
        (
            exponent("nu", 1e5, 100.0, "Phong exponent along T"),
            exponent("nv", 1e5, 10.0, "Phong exponent along B"),
        ),
        EMPIRICAL_ANISO,
        "M. Ashikhmin and P. Shirley, An anisotropic Phong BRDF model, Journal of "
        "Graphics Tools 5(2) 25-32, 2000 (the half-vector density of its eq. 4)",
        """Anisotropic Phong lobe: ``f = kd/pi + ks sqrt((nu+1)(nv+1))/(2 pi)
(N.H)^(nu cos^2 phi_h + nv sin^2 phi_h)``.

The lobe the paper prints for "Ashikhmin's model" alone: Ashikhmin and
Shirley's density of half vectors, without their Fresnel factor, their
``1/(4 (H.k) max(N.L, N.V))`` and their coupled diffuse term (those make
``ashikhmin_shirley``). With ``nu = nv = n`` it is ``(n+1)/(2 pi)`` times Blinn's
lobe. ``cos^2(phi_h) ln(N.H)`` and ``sin^2(phi_h) ln(N.H)`` are cached.
""",
        ks_upper=10.0,
    )
)


# --------------------------------------------------------- Ashikhmin-Shirley
AS_DIFFUSE_SCALE = 28.0 / (23.0 * math.pi)


def _pow5(x: np.ndarray) -> np.ndarray:
    """x^5 by multiplication (a quarter of the time of ``x ** 5``)."""
    x2 = x * x
    return x2 * x2 * x


def _as_terms(geometry: Geometry) -> tuple:
    """Parameter-free terms of Ashikhmin-Shirley: the diffuse column
    ``28/(23 pi) P``, ``1/(8 pi (H.k) max(N.L, N.V))``, ``(1-c)^5`` and ``1-(1-c)^5``."""

    def compute():
        cos_i, cos_o = geometry.cos_i, geometry.cos_o
        p = (1.0 - _pow5(1.0 - 0.5 * cos_i)) * (1.0 - _pow5(1.0 - 0.5 * cos_o))
        c = np.maximum(geometry.cos_d, MIN_COSINE)
        scale = 1.0 / (8.0 * math.pi * c * np.maximum(cos_i, cos_o))
        w = _pow5(1.0 - geometry.cos_d)
        return AS_DIFFUSE_SCALE * p, scale, w, 1.0 - w

    return geometry.cached("anisotropic.ashikhmin_shirley", compute)


def _as_design(geometry: Geometry, shape: Mapping[str, float]) -> Design:
    nu, nv = shape["nu"], shape["nv"]
    diffuse, scale, w, one_minus_w = _as_terms(geometry)
    s = _anisotropic_power(geometry, nu, nv)
    s *= scale
    s *= math.sqrt((nu + 1.0) * (nv + 1.0))
    return Design(columns=(diffuse, s * one_minus_w), offset=s * w)


def _value(x) -> np.ndarray | float:
    a = np.asarray(x, dtype=float)
    return float(a) if a.ndim == 0 else a


def ashikhmin_shirley_coefficients(params: Mapping) -> list:
    """``[rd_eff, rs] = [rd (1 - rs), rs]``, elementwise for per-channel values."""
    rd, rs = np.asarray(params["rd"], dtype=float), np.asarray(params["rs"], dtype=float)
    return [_value(rd * (1.0 - rs)), _value(rs)]


def ashikhmin_shirley_params(coefs: Mapping) -> dict:
    """``{"rd": rd_eff / (1 - rs), "rs": rs}``, elementwise; the inverse of
    :func:`ashikhmin_shirley_coefficients`.

    Where ``rs = 1`` the diffuse term vanishes for every ``rd``; ``rd = 0`` is
    returned there. The coefficients must satisfy ``0 <= rs <= 1`` and
    ``0 <= rd_eff <= 1 - rs`` (so that ``rd <= 1``), or a ParameterError names
    the first value that does not.
    """
    d, rs = np.broadcast_arrays(*(np.asarray(coefs[k], dtype=float) for k in ("rd_eff", "rs")))
    room = 1.0 - rs
    # Slack of a few ulps: rd (1 - rs) / (1 - rs) may round just above rd = 1.
    checks = (
        ("rs", rs, ~((rs >= 0) & (rs <= 1)), "must lie in [0, 1]"),
        ("rd_eff", d, ~(d >= 0), "must be finite and >= 0"),
        ("rd_eff", d, d > room * (1 + 1e-12), "exceeds 1 - rs, which would need rd > 1"),
    )
    for name, values, bad, need in checks:
        if bad.any():
            i = np.flatnonzero(bad.ravel())[0]
            shown = f"{name}={values.ravel()[i]:g} (rs={rs.ravel()[i]:g})"
            raise ParameterError(
                f"{shown} {need}; the coefficients must satisfy "
                "0 <= rs <= 1 and 0 <= rd_eff <= 1 - rs",
                name,
            )
    with np.errstate(divide="ignore", invalid="ignore"):
        rd = np.where(room > 0, np.minimum(d / room, 1.0), 0.0)
    return {"rd": _value(rd), "rs": _value(rs)}


ASHIKHMIN_SHIRLEY = Model(
    name="ashikhmin_shirley",
    params=(
        unit_interval("rd", 0.5, "diffuse reflectance of the substrate", linear=True),
        unit_interval("rs", 0.05, "specular reflectance at normal incidence (F0)", linear=True),
        exponent("nu", 1e5, 100.0, "Phong exponent along T"),
        exponent("nv", 1e5, 10.0, "Phong exponent along B"),
    ),
    classification=FRESNEL_ANISO,
    reference="M. Ashikhmin and P. Shirley, An anisotropic Phong BRDF model, Journal of "
    "Graphics Tools 5(2) 25-32, 2000, eqs. 4 and 5",
    design=_as_design,
    coefficients=("rd_eff", "rs"),
    coefficient_bounds=((0.0, 1.0), (0.0, 1.0)),
    # rd <= 1 is rd_eff <= 1 - rs: the fitting engine solves within this triangle.
    coefficient_constraints=(((1.0, 1.0), 1.0),),
    to_coefficients=ashikhmin_shirley_coefficients,
    from_coefficients=ashikhmin_shirley_params,
    doc="""Ashikhmin-Shirley: ``f = rho_s + rho_d`` with, for ``c = H.k = V.H``,

``rho_s = S F(c)``, ``F(c) = rs + (1 - rs)(1 - c)^5``,
``S = sqrt((nu+1)(nv+1))/(8 pi) (N.H)^((nu (H.T)^2 + nv (H.B)^2)/(1-(N.H)^2))
/ (c max(N.L, N.V))``,
``rho_d = 28 rd/(23 pi) (1 - rs) (1 - (1 - N.L/2)^5)(1 - (1 - N.V/2)^5)``.

The exponent equals ``nu cos^2 phi_h + nv sin^2 phi_h``. Checked against the
paper (eqs. 4 and 5): the classification paper prints ``(N.L)`` for ``(H.k)``,
``(nu+1)(nu+1)`` for ``(nu+1)(nv+1)`` and ``F(N.L)`` for ``F(H.k)``.

``rs`` enters twice (Fresnel ``F0`` and the ``1 - rs`` of the diffuse term), so
the model is linear not in ``(rd, rs)`` but in the coefficients
``rd_eff = rd (1 - rs)`` (effective diffuse reflectance) and ``rs``:

``f = S (1-c)^5 + rs S (1 - (1-c)^5) + rd_eff 28/(23 pi) P``,
``P = (1 - (1 - N.L/2)^5)(1 - (1 - N.V/2)^5)``.

The design gives the columns ``(28/(23 pi) P, S (1 - (1-c)^5))`` for
``(rd_eff, rs)`` and the offset ``S (1-c)^5``; a fit solves for the coefficients
(offset subtracted, per channel) and maps them back with ``from_coefficients``:
``rd = rd_eff / (1 - rs)``, ``rd = 0`` where ``rs = 1``. The feasible set is
``0 <= rs <= 1``, ``0 <= rd_eff <= 1 - rs``. ``rd``, ``rs`` are flagged linear
because they are per channel and solved for, not searched.

``empirical``: the half-vector density is a Phong lobe chosen for easy
sampling; the diffuse term and ``1/max(N.L, N.V)`` are chosen for energy
conservation and reciprocity, not derived from a surface model. ``material``:
Schlick's Fresnel. Cached: ``28/(23 pi) P``, ``1/(8 pi c max(N.L, N.V))``,
``(1-c)^5``, ``1-(1-c)^5`` and the two ``ln(N.H)`` products of the exponent.
""",
)


MODELS = (
    WARD_ANISOTROPIC,
    ASHIKHMIN_SHIRLEY,
    ASHIKHMIN_PHONG,
)
