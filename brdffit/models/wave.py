"""Wave-optics models: He, Torrance, Sillion and Greenberg (1991).

The terms themselves (shadowing, effective roughness, the series over m) are
plain functions in :mod:`brdffit.models.he_terms`; this module assembles them on
a prepared :class:`~brdffit.data.geometry.Geometry`, caching what depends on the
directions only.
"""

from __future__ import annotations

import math

import numpy as np

from ..data.geometry import Geometry
from .base import INV_PI, Classification, Design, Model, Param
from .he_terms import (
    SERIES_TOLERANCE,
    dd_series,
    effective_roughness_ratio,
    roughness_k,
    shadowing,
)
from .shared import fresnel_conductor

__all__ = [
    "MODELS",
    "HE",
    "FITTED_BY_DEFAULT",
    "HELD_BY_DEFAULT",
    "he_components",
    "series_arguments",
]

#: Shape parameters a fit searches by default (a_ud, linear, is solved for).
FITTED_BY_DEFAULT = ("sigma0", "tau")
#: Shape parameters a fit should hold at the values given (see the docstring of HE);
#: ``wavelength`` is taken from the data's channels.
HELD_BY_DEFAULT = ("eta", "k", "aperture")

#: Smallest V.H passed to Fresnel: V.H = 0 only for L = -V, where the conductor
#: formula would divide 0 by 0 at eta = 1, k = 0.
MIN_COS_D = 1e-150

WAVE_PHYSICAL = Classification("physical", "isotropic", "cosine", "material", wave_optics=True)


# ------------------------------------------------- cached parameter-free terms
def _v_terms(geometry: Geometry) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``v_z``, ``v_xy^2`` and ``G = (v.v / v_z)^2`` for ``v = L + V`` (unit vectors).

    He et al. write ``v = k_r - k_i`` with ``k_i`` the propagation direction of
    the incident light, which is ``-L``; so ``v = (2 pi / lambda)(L + V)``.
    """

    def compute():
        s = geometry.wi + geometry.wo
        v_xy2 = s[:, 0] ** 2 + s[:, 1] ** 2
        v_z = geometry.cos_i + geometry.cos_o
        g_factor = ((v_xy2 + v_z * v_z) / v_z) ** 2
        return v_z, v_xy2, g_factor

    return geometry.cached("he.v_terms", compute)


def _inv_pi_cos(geometry: Geometry) -> np.ndarray:
    """``1 / (pi (N.L)(N.V))``, the directional-diffuse normalisation; cached."""
    return geometry.cached("he.inv_pi_cos", lambda: INV_PI / (geometry.cos_i * geometry.cos_o))


def _inv_sqrt_cos(geometry: Geometry) -> np.ndarray:
    """``1 / sqrt((N.L)(N.V))``; cached."""
    return geometry.cached(
        "he.inv_sqrt_cos", lambda: 1.0 / np.sqrt(geometry.cos_i * geometry.cos_o)
    )


def spike_support(aperture: float) -> float:
    """``U = 1 - cos(aperture)`` (radians), without cancellation."""
    return 2.0 * math.sin(0.5 * aperture) ** 2


def _spike_spread(geometry: Geometry, aperture: float) -> np.ndarray:
    """``w(V) / (Omega sqrt((N.L)(N.V)))``: the instrument's response about the mirror
    direction ``R(L)``, ``w = (1 - u/U)^3`` for ``u = 1 - V.R(L) < U = 1 - cos(aperture)``,
    0 beyond; ``Omega = pi U / 2`` is its integral over solid angle, so the spike's
    energy is kept. Only the parameter-free ``1 / sqrt((N.L)(N.V))`` is cached: one
    array per aperture tried would grow without bound in a fit that searched it."""
    inv_sqrt = _inv_sqrt_cos(geometry)
    big_u = spike_support(aperture)
    weight = np.maximum(1.0 - (1.0 - geometry.cos_r) / big_u, 0.0) ** 3
    return weight * (inv_sqrt / (0.5 * math.pi * big_u))


# ------------------------------------------------------------------ the terms
def series_arguments(geometry: Geometry, shape):
    """``g`` and ``a = v_xy^2 tau^2 / 4`` of eq. 78 for each pair (and channel), with the
    factor ``F S`` that both the spike and the lobe carry.

    Parameters are those of :func:`he_components`. Returns ``(g, a, fresnel_shadowing)``:
    ``g`` and ``a`` of shape (M,) for one wavelength, (M, C) for C wavelengths;
    ``fresnel_shadowing`` of shape (M,).
    """
    sigma0, tau = shape["sigma0"], shape["tau"]
    ratio = tau / sigma0
    cos_i, cos_o = geometry.cos_i, geometry.cos_o
    v_z, v_xy2, _ = _v_terms(geometry)
    sigma = sigma0 * effective_roughness_ratio(
        roughness_k(cos_i, ratio) + roughness_k(cos_o, ratio)
    )
    common = shadowing(cos_i, ratio) * shadowing(cos_o, ratio)
    common *= fresnel_conductor(np.maximum(geometry.cos_d, MIN_COS_D), shape["eta"], shape["k"])
    wavelength = np.asarray(shape["wavelength"], dtype=float) * 1e-3  # nm -> micrometres
    if wavelength.ndim:
        sigma, v_z, v_xy2 = sigma[:, None], v_z[:, None], v_xy2[:, None]
    g = (2.0 * math.pi * sigma / wavelength * v_z) ** 2
    a = (math.pi * tau / wavelength) ** 2 * v_xy2
    return g, a, common


def he_components(geometry: Geometry, shape, tolerance: float = SERIES_TOLERANCE):
    """Specular and directional-diffuse BRDFs (1/sr) on the valid pairs of a geometry.

    Parameters
    ----------
    geometry : Geometry
    shape : mapping
        ``sigma0``, ``tau`` (micrometres), ``eta``, ``k``, ``aperture`` (degrees),
        ``wavelength`` (nm; a number or one per channel).
    tolerance : float
        Truncation bound of the series over m (see :func:`~.he_terms.dd_series`).

    Returns
    -------
    specular, directional_diffuse : ndarray
        Shape (M,) for one wavelength, (M, C) for C wavelengths.
    """
    g, a, common = series_arguments(geometry, shape)
    wavelength = np.asarray(shape["wavelength"], dtype=float) * 1e-3
    d = (0.5 * math.pi * shape["tau"] / wavelength) ** 2 * dd_series(g, a, tolerance)
    cone = _spike_spread(geometry, math.radians(shape["aperture"]))
    lobe = common * _v_terms(geometry)[2] * _inv_pi_cos(geometry)
    if g.ndim == 2:
        cone, common, lobe = cone[:, None], common[:, None], lobe[:, None]
    return common * cone * np.exp(-g), lobe * d


def _he_design(geometry: Geometry, shape) -> Design:
    """``a_ud / pi`` as the column, spike and lobe as the offset. With the kernels on,
    :mod:`brdffit.kernels` binds the compiled loop in its place (``bind._He``,
    :mod:`brdffit.kernels.loops_he`) at every size; this numpy form is the reference."""
    specular, directional = he_components(geometry, shape)
    return Design((INV_PI,), offset=specular + directional)


HE = Model(
    name="he",
    params=(
        Param(
            "a_ud",
            0.0,
            1.0,
            0.1,
            linear=True,
            unit="1",
            doc="uniform-diffuse albedo a(lambda); the term a_ud / pi",
        ),
        Param(
            "sigma0",
            1e-3,
            5.0,
            0.18,
            log_scale=True,
            unit="um",
            doc="He et al. 1991 sigma0: rms height (um) of the surface, a height, not a slope; "
            "with a Gaussian correlation the rms slope magnitude is 2 sigma0 / tau, the "
            "Beckmann alpha of the geometric-optics limit (Beckmann-Spizzichino 1963); "
            "renderers: no roughness parameter is a height (fitted)",
        ),
        Param(
            "tau",
            0.05,
            100.0,
            3.0,
            log_scale=True,
            unit="um",
            doc="He et al. 1991 tau: autocorrelation length (um) of the heights, Gaussian "
            "correlation exp(-r^2/tau^2); with sigma0 it sets the slope; renderers: no "
            "parameter is a length (fitted)",
        ),
        Param(
            "eta",
            0.01,
            10.0,
            1.5,
            unit="1",
            doc="real part of the refractive index (held by default)",
        ),
        Param(
            "k",
            0.0,
            20.0,
            0.0,
            unit="1",
            doc="imaginary part of the refractive index, 0 for dielectrics (held by default)",
        ),
        Param(
            "aperture",
            0.01,
            10.0,
            1.0,
            log_scale=True,
            unit="deg",
            doc="half-angle of the instrument's angular response, its support (held by default)",
        ),
        Param(
            "wavelength",
            100.0,
            20000.0,
            550.0,
            unit="nm",
            per_channel=True,
            doc="wavelength of each channel, taken from the data",
        ),
    ),
    classification=WAVE_PHYSICAL,
    reference="X. D. He, K. E. Torrance, F. X. Sillion and D. P. Greenberg, A comprehensive "
    "physical model for light reflection, SIGGRAPH 1991, Computer Graphics 25(4) 175-186",
    design=_he_design,
    held=HELD_BY_DEFAULT,
    doc="""He-Torrance-Sillion-Greenberg: specular + directional diffuse + uniform diffuse.

``f = rho_s + rho_dd + a_ud / pi`` (He et al. 1991), unpolarised light:

- specular, a spike ``R Delta / (cos(theta_i) d omega_i)`` in the paper, with
  ``R = F(theta_i) exp(-g) S(theta_i) S(theta_r)``. A finite-aperture
  instrument measures the spike convolved with its angular response, and so
  does this model: ``rho_s = R w / (Omega sqrt((N.L)(N.V)))`` with the response
  ``w = (1 - u/U)^3``, ``u = 1 - V.R(L)`` (``R(L) = 2 (N.L) N - L`` the mirror
  direction), ``U = 1 - cos(beta)`` for the ``aperture`` ``beta``, ``w = 0``
  beyond it, and ``Omega = pi U / 2 = integral of w over solid angle`` (about
  ``pi beta^2 / 4``; ``w`` falls to half at 0.45 beta). ``R``, ``F``, ``g`` and ``S``
  are those of the pair itself. Why so: ``V.R(L) = L.R(V)``, so the term is
  reciprocal; at the mirror pair it is the paper's form with ``d omega_i =
  Omega``; its energy is ``R mean_w(sqrt(cos theta_o / cos theta_i)) <= R`` (Jensen,
  since ``mean_w(cos theta_o) <= cos theta_i``), tending to ``R`` as beta -> 0; and
  ``w`` is twice continuously differentiable, so quadratures of the albedo and
  gradients of a fit see no jump at the cone's edge (a sharp box would put one
  there).
- directional diffuse (eqs. 76-79): ``rho_dd = F S G D / (pi (N.L)(N.V))``,
  ``D = (pi tau / (2 lambda))^2 sum_{m>=1} exp(-g) g^m / (m! m) exp(-v_xy^2 tau^2 / (4 m))``,
  ``g = (2 pi sigma (cos_i + cos_r) / lambda)^2``, ``v = (2 pi / lambda)(L + V)``.
  The series is summed in a window chosen per sample and stopped by a bound on
  the remainder: the truncation error is at most 1e-6 times the series at
  ``v_xy = 0`` (the lobe's peak for that ``g``); see
  :func:`~brdffit.models.he_terms.dd_series`.
- uniform diffuse ``a_ud / pi`` (the paper's ``a(lambda)``, as an albedo).

Effective roughness ``sigma = sigma0 (1 + z0^2/sigma0^2)^(-1/2)`` with ``z0`` the
root of its implicit equation (eqs. 80-81; Newton in log space, monotone, see
:func:`~brdffit.models.he_terms.effective_roughness_ratio`); shadowing ``S`` of
eqs. 24-25 (Smith); ``F`` the exact unpolarised Fresnel reflectance of the
complex index ``eta + i k`` at the local angle ``V.H`` (the paper's bisector).

Parameters and units: ``sigma0`` and ``tau`` in micrometres, ``wavelength`` in
nm, ``aperture`` in degrees. ``sigma0`` spans 1 nm (a mirror at every wavelength
allowed) to 5 um (deep in the geometric-optics regime; the series then needs
about ``2 sqrt(2 g ln(2 g / 1e-6))`` terms, some 1400 at ``g = 1e4``), ``tau``
0.05 to 100 um. Fitted by default: ``sigma0``, ``tau`` (searched,
log scale) and ``a_ud`` (linear, per channel). Held by default: ``eta`` and
``k`` are material constants a user takes from tables of optical constants;
they set the magnitude of the specular and directional-diffuse terms together
with ``sigma0`` (roughness moves energy between spike and lobe, the index sets
their sum), so searching them as well makes the fit ill-conditioned on data
that miss the spike; ``aperture`` is a property of the instrument, not of the
surface; ``wavelength`` comes from the data's channels (``550nm``...). The shape
parameters are shared by all channels: a dispersive index would need ``eta``
and ``k`` per channel, which this model simplifies away.

On measured paint (``../shared/data/cornell``, 31 bands, l2 loss, fits with
defaults) ``he`` trails ``cook_torrance``: garnet 0.00437 against 0.00269
(0.00371 with ``eta`` free), acrylic 0.183 against 0.052 (0.094 with ``eta``
free, at 1.11). The reasons: the specular magnitude is predicted from the index,
not fitted (cook_torrance has ``ks`` per channel, and on acrylic pushes its
``eta`` to the bound 3); one non-dispersive index; the lobe of the fitted rough
surface (``sigma0 / lambda`` about 1.4) peaks forward of the mirror, 19 degrees
at 60 degrees of incidence on garnet, where the paint's highlight stays at the
mirror; and a paint is a layered medium whose subsurface scattering the
single-interface model leaves to ``a_ud``. tests/fitting/test_fit_real.py checks that
the fit is still sound and within twice cook_torrance's loss (four bands).

Energy (measured by tests/models/test_models_he.py, with ``a_ud = 0``): the
directional albedo stays below 1 for dielectrics (``eta`` up to 10) and for
conductors with ``F(0)`` up to 0.92, from 0 to 89 degrees of incidence. For a
nearly perfect conductor (``F(0) = 0.9999``) it exceeds 1, by about 1e-4 at
normal incidence and up to about 2.5 % at 75 degrees (``sigma0 / lambda = 0.03``,
``tau / lambda = 0.5``); silver's visible index (``eta = 0.06``, ``k = 3.6``,
``F(0) = 0.98``) already exceeds it by about 0.5 % at oblique incidence, while
gold (0.4, 2.4) and aluminium (1.0, 6.7) stay below 0.93. The directional-diffuse
term is a Kirchhoff (physical-optics) approximation whose ``G / cos(theta_r)``
grows towards the horizon, so the lobe returns more than the spike loses. That is the published
model's behaviour and is not corrected here. ``a_ud`` adds itself to the
albedo, so conserving energy also needs ``a_ud <= 1 - (spike + lobe)``.

Linear structure: the specular and directional-diffuse part is an *offset*,
absolute, with no coefficient: its magnitude is the model's prediction from the
index (``F``), which is what makes ``sigma0`` identifiable (in the smooth
regime the lobe's shape depends on ``tau / lambda`` only, and ``sigma0`` enters
through its height ``~ g``); a free per-channel scale would absorb exactly
that. Only ``a_ud`` is a column (``1 / pi``).

Checked against the sources (equation numbers of the paper):

- eq. 76, ``G``: the paper's polarisation factors
  ``[(s_r.k_i)^2 + (p_r.k_i)^2][(s_i.k_r)^2 + (p_i.k_r)^2] / |k_r x k_i|^4`` equal 1,
  because ``(s, p, k)`` is an orthonormal triad, leaving ``G = (v.v / v_z)^2``;
  Radiance's ``He.cal`` notes the same cancellation (found by A. Willmott); a
  test compares with the full form.
- eq. 78: for its exponent ``v_xy^2 tau^2 / (4 m)`` to be dimensionless, ``v``
  carries the wavenumber, ``v = (2 pi / lambda)(L + V)``, as in Radiance's
  ``He.cal`` and Westin's reference code; the default ``he`` variant of the bbm
  library (and, by its account, Holzschuch and Pacanowski's code) puts unit
  vectors there. With the wavenumber, for ``g >> 1`` ``rho_dd`` tends to
  Cook-Torrance with Smith shadowing and a Beckmann slope ``m = 2 sigma / tau``,
  the rms slope of a Gaussian surface of correlation length ``tau``, as
  physical optics must; a test checks this limit.
- eq. 25 misses a factor ``exp(-a^2)``, given by the paper's errata, Westin's
  code, ``He.cal`` and Holzschuch and Pacanowski; included (see
  :func:`~brdffit.models.he_terms.shadowing`).
- eqs. 80-84 (``sigma``, ``z0``, ``K``, ``v_xy``) and eq. 79 (``g`` with the
  effective ``sigma`` and the sum of the two cosines) agree with ``He.cal`` and
  bbm's ``he.h``; both evaluate ``F`` of eq. 76 at ``cos = |L + V| / 2 = V.H``,
  as here.
- The paper's figures could not be read numerically from the copies available;
  the tests check instead its stated limits and trends (the smooth limit ``F``,
  the move from diffuse-like to specular as lambda or theta_i increase or
  sigma0 decreases) and an independent scalar implementation.
""",
)

MODELS = (HE,)
