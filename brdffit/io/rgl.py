"""The RGL-EPFL material database format (``.bsdf``: Mitsuba's ``tensor_file``).

Sources checked (public code; formulas rewritten here, nothing copied):

- container: see :mod:`brdffit.io.tensor_file`;
- evaluation: Mitsuba 3 ``src/bsdfs/measured.cpp`` (``Measured::eval`` and
  ``sample``; the RGB branch reads the field ``rgb`` in place of ``spectra``)
  and ``powitacq_rgb.inl`` (``BRDF::eval``/``sample``), whose header
  ``powitacq_rgb.h`` documents ``eval`` as "Evaluate f_r * cos";
- warp: Mitsuba 3 ``include/mitsuba/core/distr_2d.h`` (``Marginal2D`` with
  ``Continuous = true``: ``sample_continuous``, ``invert_continuous``, ``eval``,
  ``interpolate_weights``) and its copy in ``powitacq_rgb.inl``.

Model (Dupuy and Jakob 2018, "An adaptive parameterization for efficient
material acquisition and rendering"). With ``u(theta) = sqrt(2 theta / pi)``
and ``u(phi) = (phi + pi) / (2 pi)``, a point ``s`` of the unit square is warped
by the ``vndf`` table of the incident direction (a bilinear density on
``[0, 1]^2``, sampled by inverting its marginal CDF over rows, then its
conditional CDF over columns, both exact for the bilinear patch) to
``u_m = (u_theta, u_phi)`` of the microfacet normal ``m``:
``theta_m = u_theta^2 pi / 2``, ``phi_m = (2 u_phi - 1) pi + phi_i`` (isotropic:
relative to the incident azimuth); then ``wo = 2 (wi . m) m - wi``. The ``rgb``
table holds, at the nodes of a regular grid in ``s``, values ``R`` such that
Mitsuba's ``eval`` (the cosine-weighted BRDF, ``f_r cos theta_o``, as in every
Mitsuba BSDF and as documented by ``powitacq_rgb.h``) is
``R(s) * D(u_m) / (4 sigma(u_wi))`` when the ``jacobian`` flag is 1 and ``R(s)``
when it is 0, with ``D`` = ``ndf`` and ``sigma`` read by bilinear interpolation
(tables over ``(u_theta, u_phi)``, columns along theta). So the BRDF, not
multiplied by a cosine, is that divided by ``cos theta_o``.

This reader returns, for each stored incident node ``(phi_i, theta_i)`` and each
node ``s`` of the ``rgb`` grid, the pair ``(wi, wo(s))`` and ``f_r`` there; the
stored value is used as it is (Mitsuba does not clip it; the RGL loader clips
negatives to 0; Measurements counts any with a warning). Pairs whose ``wo`` is
at or below the horizon are dropped (Mitsuba's ``eval`` is 0 there), and so are
the pairs of an incident node at it; "at the horizon" means ``cos theta <=``
:data:`HORIZON_COS` (1e-6, 0.00006 degrees), because the database stores
``theta_i = pi/2`` rounded to float32 (89.99999 degrees), where ``f_r`` is
undefined and the division by ``cos theta_o`` gives values near 1e9 at the
mirror direction.

Duplicates: the grid nodes that the warp sends onto the normal
(``u_theta = 0``) all give the mirror direction; they are kept as one pair,
valued as Mitsuba's ``eval`` values the mirror (its half vector has
``phi_m = atan2(0, 0) = 0``). A node warped to ``u_phi = 1`` is the node warped
to ``u_phi = 0`` when their ``u_theta`` agree (the same azimuth); Mitsuba's eval
wraps to 0, so only that one is kept. The counts are returned and reported in a
warning.

Only isotropic RGB files (one ``phi_i``, a ``rgb`` field) are read; spectral or
anisotropic files are refused. The field ``valid`` (a bit mask, undocumented by
both loaders, which ignore it) is not used.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..errors import FormatError
from ..notes import note
from ..words import plural
from .limits import DEFAULT_MAX_SAMPLES, check_samples
from .source import as_source
from .tensor_file import DTYPES, MAGIC, TensorField, read_tensor_file

__all__ = [
    "DTYPES",
    "HORIZON_COS",
    "MAGIC",
    "RglSamples",
    "TensorField",
    "bilinear",
    "read_rgl",
    "read_rgl_arrays",
    "marginal_cdf",
    "read_tensor_file",
    "warp_sample",
]

CHANNELS = ("r", "g", "b")
#: A direction with ``cos theta`` at or below this is taken to be at the horizon: the
#: database stores theta_i = pi/2 as float32 (89.99999 degrees, cos 7.5e-8), where the
#: BRDF is undefined and ``f_r = eval / cos theta_o`` reaches 1e9 at its mirror.
HORIZON_COS = 1e-6


class RglSamples(NamedTuple):
    """The BRDF at the stored direction pairs of an RGL file, as plain arrays."""

    wi: np.ndarray  #: (N, 3) incident directions (stored theta_i, phi_i nodes)
    wo: np.ndarray  #: (N, 3) outgoing directions, the warped grid nodes
    values: np.ndarray  #: (N, 3) BRDF in 1/sr (r, g, b), no cosine factor
    sample: np.ndarray  #: (N, 2) grid node (x, y) in the unit square of each pair
    incident_index: np.ndarray  #: (N,) index into theta_i of each pair
    description: str
    n_stored: int  #: incident nodes x grid nodes in the file
    n_incident_below_horizon: int  #: pairs dropped because wi is not above the horizon
    n_below_horizon: int  #: pairs dropped because wo is not above the horizon
    n_merged: int  #: duplicate nodes dropped (warped onto the normal, or onto u_phi = 1 = 0)


# ---------------------------------------------------------------------- warp
def _cdfs(density: np.ndarray) -> tuple:
    """Normalised density, conditional CDF per row and marginal CDF (index units)."""
    d = np.asarray(density, dtype=float)
    conditional = np.zeros_like(d)
    conditional[:, 1:] = np.cumsum(0.5 * (d[:, 1:] + d[:, :-1]), axis=1)
    rows = conditional[:, -1]
    marginal = np.zeros(d.shape[0])
    marginal[1:] = np.cumsum(0.5 * (rows[1:] + rows[:-1]))
    total = marginal[-1]
    if not total > 0:
        raise ValueError("the density integrates to zero; it cannot be sampled")
    return d / total, conditional / total, marginal / total


def _solve_linear(c0, c1, target):
    """``s`` in [0, 1] with ``c0 s + (c1 - c0) s^2 / 2 = target`` (linear density).

    The root ``(c0 - sqrt(c0^2 - 2 target (c0 - c1))) / (c0 - c1)`` of distr_2d.h,
    rationalised so that it has no cancellation and covers ``c0 = c1``.
    """
    root = np.sqrt(np.maximum(c0 * c0 + 2.0 * target * (c1 - c0), 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        s = 2.0 * target / (c0 + root)
    return np.clip(np.nan_to_num(s, nan=0.0, posinf=0.0), 0.0, 1.0)


def marginal_cdf(density, y) -> np.ndarray:
    """The marginal CDF of ``y`` of a bilinear density (what the row step inverts)."""
    d, conditional, marginal = _cdfs(density)
    ny = d.shape[0]
    p = np.clip(np.asarray(y, float), 0, 1) * (ny - 1)
    i = np.minimum(p.astype(int), ny - 2)
    t, r0, r1 = p - i, conditional[i, -1], conditional[i + 1, -1]
    return marginal[i] + r0 * t + (r1 - r0) * t * t / 2


def warp_sample(density, x, y) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Forward warp of points ``(x, y)`` of the unit square by a bilinear density.

    ``density`` has shape (ny, nx): row ``i`` at ``y = i / (ny - 1)``, column
    ``j`` at ``x = j / (nx - 1)``. Row first (marginal CDF), then column
    (conditional CDF at the sampled height), each solved exactly within its
    patch; Mitsuba 3's ``Marginal2D::sample_continuous``. Returns the warped
    ``x``, ``y`` and the density there (w.r.t. the unit square).
    """
    d, conditional, marginal = _cdfs(density)
    ny, nx = d.shape
    x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
    x, y = x.ravel(), y.ravel()
    row = np.clip(np.searchsorted(marginal, y, side="left") - 1, 0, ny - 2)
    r0, r1 = conditional[row, -1], conditional[row + 1, -1]
    t = _solve_linear(r0, r1, y - marginal[row])
    cdf = (1 - t)[:, None] * conditional[row] + t[:, None] * conditional[row + 1]
    target = x * ((1 - t) * r0 + t * r1)
    col = np.clip((cdf < target[:, None]).sum(axis=1) - 1, 0, nx - 2)
    picked = cdf[np.arange(len(col)), col]
    c0 = (1 - t) * d[row, col] + t * d[row + 1, col]
    c1 = (1 - t) * d[row, col + 1] + t * d[row + 1, col + 1]
    s = _solve_linear(c0, c1, target - picked)
    pdf = ((1 - s) * c0 + s * c1) * (nx - 1) * (ny - 1)
    return (col + s) / (nx - 1), (row + t) / (ny - 1), pdf


def bilinear(table, x, y) -> np.ndarray:
    """Bilinear interpolation of ``table`` (ny, nx) at ``(x, y)`` in the unit square.

    The raw values (Mitsuba's ``Marginal2D::eval`` of a table built with
    ``normalize=false``); points are clamped to the square.
    """
    t = np.asarray(table, dtype=float)
    ny, nx = t.shape
    px = np.clip(np.asarray(x, float), 0, 1) * (nx - 1)
    py = np.clip(np.asarray(y, float), 0, 1) * (ny - 1)
    ix = np.minimum(px.astype(int), nx - 2)
    iy = np.minimum(py.astype(int), ny - 2)
    wx, wy = px - ix, py - iy
    top = (1 - wx) * t[iy, ix] + wx * t[iy, ix + 1]
    bottom = (1 - wx) * t[iy + 1, ix] + wx * t[iy + 1, ix + 1]
    return (1 - wy) * top + wy * bottom


# --------------------------------------------------------------- RGL layout
def _field(fields: dict, name: str, ndim: int, path, dtype: str = "<f4") -> TensorField:
    if name not in fields:
        raise FormatError(
            f"{path}: the tensor file has no field {name!r}; an RGL material file has "
            f"theta_i, phi_i, ndf, sigma, vndf, rgb, jacobian (fields: {', '.join(fields)})",
            "source",
        )
    f = fields[name]
    if f.dtype != np.dtype(dtype) or len(f.shape) != ndim:
        raise FormatError(
            f"{path}: field {name!r} (header data at byte {f.offset}) is {f.dtype} with shape "
            f"{list(f.shape)}; it must be {np.dtype(dtype)} with {plural(ndim, 'dimension')}",
            "source",
        )
    return f


def _check_layout(fields: dict, path) -> dict:
    """The fields the model needs, checked against each other (measured.cpp's checks)."""
    if "rgb" not in fields and ("spectra" in fields or "wavelengths" in fields):
        raise FormatError(
            f"{path} is a spectral RGL file (field 'spectra'); brdffit reads the RGB files "
            "of the database (the *_rgb.bsdf downloads)",
            "source",
        )
    need = {"theta_i": 1, "phi_i": 1, "ndf": 2, "sigma": 2, "vndf": 4, "rgb": 5}
    f = {name: _field(fields, name, ndim, path) for name, ndim in need.items()}
    f["jacobian"] = _field(fields, "jacobian", 1, path, "u1")
    n_phi, n_theta = f["phi_i"].shape[0], f["theta_i"].shape[0]
    if n_phi != 1:
        raise FormatError(
            f"{path}: phi_i (data at byte {f['phi_i'].offset}) has {n_phi} values; brdffit "
            "reads isotropic RGL files (one incident azimuth), not anisotropic ones",
            "source",
        )
    expected = {"vndf": (n_phi, n_theta), "rgb": (n_phi, n_theta, 3)}
    for name, head in expected.items():
        shape = f[name].shape
        if shape[: len(head)] != head or min(shape[-2:]) < 2:
            raise FormatError(
                f"{path}: field {name!r} (data at byte {f[name].offset}) has shape "
                f"{list(shape)}; it must start with {list(head)} (phi_i, theta_i"
                f"{', 3 channels' if name == 'rgb' else ''}) and have a grid of at least 2 x 2",
                "source",
            )
    if f["jacobian"].shape != (1,) or min(f["ndf"].shape + f["sigma"].shape) < 2:
        raise FormatError(
            f"{path}: jacobian must hold one byte and ndf, sigma be grids of at least 2 x 2; "
            f"their shapes are {list(f['jacobian'].shape)}, {list(f['ndf'].shape)}, "
            f"{list(f['sigma'].shape)}",
            "source",
        )
    bad = [n for n in ("theta_i", "phi_i", "ndf", "sigma", "vndf", "rgb")
           if not np.isfinite(f[n].data).all()]  # fmt: skip
    if bad:
        raise FormatError(
            f"{path}: field {bad[0]!r} (at byte {f[bad[0]].offset}) is not finite", "source"
        )
    return f


def _u_theta(theta):
    return np.sqrt(np.asarray(theta, float) * (2.0 / math.pi))


def _u_phi(phi):
    return (np.asarray(phi, float) + math.pi) / (2.0 * math.pi)


def _directions(theta_i: float, phi_i: float, u_x, u_y) -> tuple:
    """``wi`` and ``wo = reflect(wi, m)`` for warped points ``u_m = (u_x, u_y)``."""
    theta_m = u_x**2 * (math.pi / 2)
    phi_m = (2 * u_y - 1) * math.pi + phi_i  # isotropic: relative azimuth
    m = np.stack(
        [np.sin(theta_m) * np.cos(phi_m), np.sin(theta_m) * np.sin(phi_m), np.cos(theta_m)],
        axis=-1,
    )
    wi = np.array([math.sin(theta_i) * math.cos(phi_i), math.sin(theta_i) * math.sin(phi_i)])
    wi = np.append(wi, math.cos(theta_i))
    wo = 2 * (m @ wi)[:, None] * m - wi
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    return np.broadcast_to(wi, wo.shape).copy(), wo


def _grid_and_warp(vndf, ny: int, nx: int, phi_i: float) -> tuple:
    """Grid nodes ``s`` and their warped ``u_m``, the nodes mapped onto the normal merged.

    Every node that the warp sends to ``u_theta = 0`` (m = n) gives the mirror
    direction; they are one pair, whose sample is the inverse warp of the
    normal as Mitsuba's eval computes it (``phi_m = atan2(0, 0) = 0``).
    """
    gy, gx = np.meshgrid(np.arange(ny) / (ny - 1), np.arange(nx) / (nx - 1), indexing="ij")
    sx, sy = gx.ravel(), gy.ravel()
    u_x, u_y, _ = warp_sample(vndf, sx, sy)
    normal = np.flatnonzero(u_x == 0)
    if len(normal) > 1:
        keep = np.ones(len(sx), bool)
        keep[normal[1:]] = False
        n, u_y0 = normal[0], _u_phi(-phi_i) % 1.0
        sx, sy, u_x, u_y = sx.copy(), sy.copy(), u_x.copy(), u_y.copy()
        sx[n], sy[n], u_y[n] = 0.0, marginal_cdf(vndf, u_y0), u_y0
        sx, sy, u_x, u_y = sx[keep], sy[keep], u_x[keep], u_y[keep]
    # u_phi = 1 is u_phi = 0 (phi = pi = -pi); Mitsuba wraps it to 0, keep that node
    seam = np.flatnonzero(u_y == 1.0)
    start = u_x[u_y == 0.0]
    twin = np.array([np.any(np.abs(start - u_x[n]) <= 1e-12) for n in seam], bool)
    keep = np.ones(len(sx), bool)
    keep[seam[twin]] = False
    merged = max(len(normal) - 1, 0) + int(twin.sum())
    return sx[keep], sy[keep], u_x[keep], u_y[keep], merged


def _incident_slice(f: dict, k: int) -> tuple:
    """Pairs and BRDF values of incident node ``k`` (the nodes of the rgb grid)."""
    theta_i, phi_i = float(f["theta_i"].data[k]), float(f["phi_i"].data[0])
    ny, nx = f["rgb"].shape[3:]
    sx, sy, u_x, u_y, merged = _grid_and_warp(f["vndf"].data[0, k], ny, nx, phi_i)
    wi, wo = _directions(theta_i, phi_i, u_x, u_y)
    stored = np.stack([bilinear(f["rgb"].data[0, k, c], sx, sy) for c in range(3)], axis=1)
    if f["jacobian"].data[0]:
        ndf = bilinear(f["ndf"].data, u_x, u_y)
        sigma = bilinear(f["sigma"].data, _u_theta(theta_i), _u_phi(phi_i))
        stored = stored * (ndf / (4.0 * sigma))[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        values = stored / wo[:, 2:3]  # Mitsuba's eval is f_r cos(theta_o)
    return wi, wo, values, np.stack([sx, sy], axis=1), merged


def _checked_slice(f: dict, k: int, path) -> tuple:
    """:func:`_incident_slice`, with a table that cannot be sampled named as the file's fault."""
    try:
        return _incident_slice(f, k)
    except ValueError as exc:  # a vndf table whose density integrates to zero
        raise FormatError(
            f"{path}: the vndf table of incident node {k} (field 'vndf', data from byte "
            f"{f['vndf'].offset}) cannot be used: {exc}",
            "source",
        ) from exc


def read_rgl_arrays(source, max_samples: int | None = DEFAULT_MAX_SAMPLES) -> RglSamples:
    """Read an isotropic RGB RGL material file (a path, bytes or a binary file object)
    into arrays (see the module doc); at most ``max_samples`` stored pairs
    (:mod:`brdffit.io.limits`)."""
    source = as_source(source)
    path, fields = source.name, read_tensor_file(source)
    f = _check_layout(fields, path)
    parts, n_incident, n_merged = [], 0, 0
    n_theta, (ny, nx) = f["theta_i"].shape[0], f["rgb"].shape[3:]
    check_samples(n_theta * ny * nx, max_samples, path, "by the shape of its field 'rgb'")
    for k in range(n_theta):
        theta_i = float(f["theta_i"].data[k])
        if not math.cos(theta_i) > HORIZON_COS:
            n_incident += ny * nx
            continue
        wi, wo, values, sample, merged = _checked_slice(f, k, path)
        n_merged += merged
        parts.append((wi, wo, values, sample, np.full(len(wi), k)))
    if not parts:
        raise FormatError(
            f"{path}: every incident direction (theta_i) is at the horizon", "source"
        )
    wi, wo, values, sample, index = (np.concatenate(a) for a in zip(*parts))
    above = wo[:, 2] > HORIZON_COS
    description = ""
    if "description" in fields:
        description = fields["description"].data.tobytes().decode("utf-8", errors="replace")
    return RglSamples(
        wi[above],
        wo[above],
        values[above],
        sample[above],
        index[above],
        description,
        n_theta * ny * nx,
        n_incident,
        int((~above).sum()),
        n_merged,
    )


def read_rgl(source, max_samples: int | None = DEFAULT_MAX_SAMPLES):
    """Read an isotropic RGB RGL ``.bsdf`` file as :class:`~brdffit.Measurements`.

    Channels r, g, b (linear sRGB, as stored), units 1/sr. A ``UserWarning``
    says how many stored pairs were dropped because a direction is not above
    the horizon.
    """
    from ..data.measurements import Measurements

    source = as_source(source)
    path, s = source.name, read_rgl_arrays(source, max_samples)
    dropped = s.n_incident_below_horizon + s.n_below_horizon + s.n_merged
    if dropped:
        note(
            f"{path}: {dropped} of {s.n_stored} stored direction pairs dropped: "
            f"{s.n_below_horizon} with wo at or below the horizon, "
            f"{s.n_incident_below_horizon} at an incident angle at the horizon "
            "(Mitsuba's measured BSDF is zero there), and "
            f"{s.n_merged} duplicates (grid nodes warped to the same direction); "
            f"{len(s.wi)} pairs kept",
            stacklevel=4,  # the caller of brdffit.read
        )
    return Measurements(s.wi, s.wo, s.values, channels=CHANNELS, source=path, units="1/sr")
