"""Anisotropic models of the classification paper: Ward, Ashikhmin-Shirley, the
anisotropic Phong lobe, Heidrich-Seidel, Ohara, Wang and Fournier.

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
from .params import exponent, radius, roughness, unit_interval

__all__ = ["MODELS", "ashikhmin_shirley_coefficients", "ashikhmin_shirley_params"]

EMPIRICAL_ANISO = Classification("empirical", "anisotropic", "cosine", "light")
PHYSICAL_ANISO = Classification("physical", "anisotropic", "cosine", "light")
FRESNEL_ANISO = Classification("empirical", "anisotropic", "cosine", "material")

#: Reference [4] of the classification paper, its source for Ohara, Wang and Fournier.
MALASHENKOVA = (
    "as cited by I. V. Malashenkova and A. Moiseikin, Modelling the surface properties "
    "of an object, Matematicheskaya morfologiya 5(4), 2006; lobe fixed by MODELS.md"
)


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


# ---------------------------------------------------------- Heidrich-Seidel
def _heidrich_seidel_log_base(geometry: Geometry) -> np.ndarray:
    """``ln(sqrt(1-(L.T)^2) sqrt(1-(V.T)^2) - (L.T)(V.T))``, ``-inf`` where it is <= 0."""

    def compute():
        lt, vt = geometry.wi[:, 0], geometry.wo[:, 0]
        base = np.sqrt(np.maximum(1.0 - lt * lt, 0.0)) * np.sqrt(np.maximum(1.0 - vt * vt, 0.0))
        base -= lt * vt
        out = np.full(geometry.m, -np.inf)
        np.log(base, out=out, where=base > 0)
        return out

    return geometry.cached("anisotropic.heidrich_seidel_log_base", compute)


def heidrich_seidel_lobe(geometry: Geometry, n: float) -> np.ndarray:
    """``max(0, sqrt(1-(L.T)^2) sqrt(1-(V.T)^2) - (L.T)(V.T))^n``."""
    lobe = _heidrich_seidel_log_base(geometry) * n
    return np.exp(lobe, out=lobe)


HEIDRICH_SEIDEL = diffuse_plus_lobe(
    "heidrich_seidel",
    heidrich_seidel_lobe,
    (exponent(doc="exponent of the fibre reflection cosine"),),
    EMPIRICAL_ANISO,
    "W. Heidrich and H.-P. Seidel, Realistic, hardware-accelerated shading and "
    "lighting, SIGGRAPH 1999 (after Banks 1994)",
    """Heidrich-Seidel: ``f = kd/pi + ks max(0, sqrt(1-(L.T)^2) sqrt(1-(V.T)^2)
- (L.T)(V.T))^n``.

The base is the cosine between V and the nearest mirror direction of L about
a fibre along T (``R.T = -L.T``): symmetric in L and V. T is the anisotropy
direction D projected on the tangent plane; D = T = (1, 0, 0) is fixed (data
come in the frame of their tangent). The paper's ``(L x T)(V x T)`` means the
lengths ``|L x T| |V x T|``. The base is parameter-free: its logarithm is
cached (``-inf`` where the base is <= 0), so an evaluation is one exp.
""",
)


# -------------------------------------------------------------------- Ohara
def ohara_lobe(geometry: Geometry, a: float, b: float, n: float) -> np.ndarray:
    """``(1 + tan^2(theta_h) (cos^2 phi_h / a^2 + sin^2 phi_h / b^2))^(-n/2)``."""
    tx, ty = _tan2_axes(geometry)
    x = tx * (1.0 / a**2)
    x += ty * (1.0 / b**2)
    lobe = np.log1p(x, out=x)
    lobe *= -0.5 * n
    return np.exp(lobe, out=lobe)


OHARA = diffuse_plus_lobe(
    "ohara",
    ohara_lobe,
    (
        radius("a", 1.0, "ellipsoid radius along T (c = 1)"),
        radius("b", 0.5, "ellipsoid radius along B (c = 1)"),
        exponent(doc="exponent of the elliptical highlight"),
    ),
    EMPIRICAL_ANISO,
    MALASHENKOVA,
    """Ohara: ``f = kd/pi + ks [a^2 b^2 (N.H)^2 / (a^2 b^2 (N.H)^2
+ (1-(N.H)^2)(b^2 cos^2 phi_h + a^2 sin^2 phi_h))]^(n/2)``.

Ellipsoid radii ``a``, ``b``, ``c = 1`` along T, B, N. The paper writes ``H.L``
for ``N.H`` and a constant ``c^2`` in the numerator (absorbed in ``ks``).
Evaluated as ``(1 + (H.T)^2/(a N.H)^2 + (H.B)^2/(b N.H)^2)^(-n/2)`` (divide by
``a^2 b^2 (N.H)^2``), with the squared tangents cached. Isotropic when
``a = b``. Near the peak the lobe is ``exp(-n/2 (H.T/(a N.H))^2 - ...)``: for
narrow highlights only ``n/a^2`` and ``n/b^2`` are well determined.
""",
)


# --------------------------------------------------------------------- Wang
def wang_lobe(geometry: Geometry, m: float, zeta: float) -> np.ndarray:
    """``(N.H)^(m zeta / (m - (m - zeta) cos^2 phi_h))``."""
    power = (m * zeta) / (m - (m - zeta) * geometry.cos2_phi_h)
    power *= geometry.log_cos_h
    return np.exp(power, out=power)


WANG = diffuse_plus_lobe(
    "wang",
    wang_lobe,
    (exponent("m", doc="exponent along T"), exponent("zeta", doc="exponent along B")),
    EMPIRICAL_ANISO,
    MALASHENKOVA,
    """Wang: ``f = kd/pi + ks (N.H)^(m zeta / (m - (m - zeta) cos^2 phi_h))``.

Exponent ``m`` along T (phi_h = 0), ``zeta`` along B; equals Blinn with
``n = m`` when ``m = zeta``. The paper writes ``H.L`` where ``N.H`` is meant.
The denominator ``m sin^2 phi_h + zeta cos^2 phi_h`` is at least 1, and the
exponent is irrelevant at ``H = N`` where ``ln(N.H) = 0``.
""",
)


# ------------------------------------------------------------------ Fournier
def _half_t(geometry: Geometry) -> np.ndarray:
    """H.T as a contiguous array (a column of ``half`` is strided)."""
    return geometry.cached("anisotropic.half_t", lambda: np.ascontiguousarray(geometry.half[:, 0]))


def fournier_lobe(geometry: Geometry, n: float, t: float) -> np.ndarray:
    """``(1/3) sum_{s in -1, 0, 1} max(0, N_s.H)^n``, ``N_s = normalise(N + t s T)``."""
    hx = _half_t(geometry)
    inv = 1.0 / math.sqrt(1.0 + t * t)
    centre = geometry.cos_h * inv
    side = hx * (t * inv)
    lobe = np.exp(geometry.log_cos_h * n)
    for tilted in (centre + side, centre - side):
        # max(0, c)^n as exp(n ln c): ln 0 = -inf gives exactly 0, and is cheaper
        # than np.power.
        np.maximum(tilted, 0.0, out=tilted)
        with np.errstate(divide="ignore"):
            np.log(tilted, out=tilted)
        tilted *= n
        lobe += np.exp(tilted, out=tilted)
    lobe *= 1.0 / 3.0
    return lobe


FOURNIER = diffuse_plus_lobe(
    "fournier",
    fournier_lobe,
    (
        exponent(doc="Blinn exponent of each lobe"),
        unit_interval("t", 0.3, "tangent of the tilt of the outer normals towards T"),
    ),
    EMPIRICAL_ANISO,
    "A. Fournier, Normal distribution functions and multiple surfaces, Graphics "
    "Interface '92 Workshop on Local Illumination, 45-52, 1992; construction fixed by MODELS.md",
    """Fournier: ``f = kd/pi + ks (1/K) sum_k max(0, N_k.H)^n``,
``N_k = normalise(N + t s_k T)``, ``K = 3``, ``s_k in {-1, 0, 1}``.

Fournier approximates an anisotropic normal distribution by isotropic Phong
lobes about tilted normals; MODELS.md fixes the construction. ``N_0.H = N.H``,
``N_(+-1).H = ((N.H) +- t (H.T)) / sqrt(1 + t^2)``: the tilted normals depend
on the shape parameter ``t``, so only ``N.H``, its log and ``H.T`` are cached
and each tilted cosine costs a multiply-add. Blinn when ``t = 0``.
""",
)

MODELS = (
    WARD_ANISOTROPIC,
    ASHIKHMIN_SHIRLEY,
    ASHIKHMIN_PHONG,
    HEIDRICH_SEIDEL,
    OHARA,
    WANG,
    FOURNIER,
)
