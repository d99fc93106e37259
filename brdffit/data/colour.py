"""Spectral reflectance to CIE XYZ and linear sRGB, with the colour-science package.

Spectral data (the Cornell measurements: 31 bands, 400-700 nm by 10 nm) are
fitted per band; these functions turn spectra, fitted or measured, into colour.

Tristimulus values (CIE 15:2004, section 7):

    X = k sum_l S(l) xbar(l) R(l) dl,   k = 1 / sum_l S(l) ybar(l) dl,

with R the reflectance factor (here a BRDF times pi, or any quantity linear
in it: the map is linear), S the illuminant and xbar, ybar, zbar the colour
matching functions, so that a perfect white reflector (R = 1) has Y = 1.

How the 10 nm, 400-700 nm data are integrated: by the ASTM E308 method, the
standard practice for abridged reflectance data and the default of colour's
``sd_to_XYZ``. It uses the ASTM E2022 weighting factors, which integrate the
1 nm CMFs and illuminant against a Lagrange interpolation of the 10 nm
reflectance, and it folds the weights outside the measured range (the practice
range is 380-780 nm) into the first and last band, which amounts to extending
the reflectance at 400 nm and at 700 nm by constants. Interpolating the CMFs to
the data's own wavelengths and summing there would instead drop the 380-400
and 700-780 nm parts of the CMFs (that moves D65's white by 3e-4 in y) and
sample peaked CMFs at 10 nm only. ``method="Integration"`` (colour's other
method: the reflectance is interpolated to the CMFs' 1 nm grid, Sprague, and
extended by constants) agrees with E308 on the Cornell grid to 1e-6 for a flat
spectrum and 4e-5 for a smooth one; rough spectra are interpolated differently
by the two (6e-4 apart for uniform random noise).

Because every step is linear in the reflectance, the (C, 3) weights of a band
grid are computed once, by passing the C unit spectra through colour, and a
batch of spectra is then one matrix product.

The illuminant is a parameter; D65 is the default because sRGB's white is D65,
so linear sRGB needs no chromatic adaptation. Under illuminant E (the
equal-energy spectrum, which weighs every wavelength alike) pass the white to
:func:`xyz_to_srgb`, which then adapts it to D65 (Bradford).
"""

from __future__ import annotations

import warnings
from functools import lru_cache

import numpy as np

from ..errors import DataError

__all__ = ["OBSERVER", "gamut_note", "spectral_to_xyz", "tristimulus_weights", "xyz_to_srgb"]

OBSERVER = "CIE 1931 2 Degree Standard Observer"
METHODS = ("ASTM E308", "Integration")
E308_STEPS = (1.0, 5.0, 10.0, 20.0)


def _colour():
    # colour-science (the 'colour' extra) imports in about a second; load it only when
    # colour is asked for
    from ..extras import require

    return require("colour", "colour")


def _check_wavelengths(wavelengths_nm, n_channels: int | None) -> tuple:
    wl = np.asarray(wavelengths_nm, dtype=float)
    if wl.ndim != 1 or wl.size < 3:
        raise DataError(
            f"wavelengths_nm has shape {wl.shape}; it must be a list of at least 3 "
            "wavelengths in nm, one per channel",
            "wavelengths_nm",
        )
    if n_channels is not None and wl.size != n_channels:
        raise DataError(
            f"wavelengths_nm has {wl.size} entries but the values have {n_channels} "
            "channels; give one wavelength per channel",
            "wavelengths_nm",
        )
    steps = np.diff(wl)
    if not np.isfinite(wl).all() or (steps <= 0).any() or np.ptp(steps) > 1e-6 * steps[0]:
        raise DataError(
            f"wavelengths_nm = {wl.tolist()} must increase in equal steps (such as "
            "400, 410, ..., 700)",
            "wavelengths_nm",
        )
    if wl[0] < 360 or wl[-1] > 830:
        raise DataError(
            f"wavelengths_nm spans {wl[0]:g} to {wl[-1]:g} nm; the colour matching "
            "functions are defined from 360 to 830 nm",
            "wavelengths_nm",
        )
    return tuple(wl.tolist())


def _check_options(wavelengths_nm, n_channels, illuminant, method) -> tuple:
    """The cache key ``(wavelengths, illuminant, method)``, or DataError."""
    wavelengths = _check_wavelengths(wavelengths_nm, n_channels)
    if not isinstance(illuminant, str) or illuminant not in _colour().SDS_ILLUMINANTS:
        raise DataError(
            f"illuminant={illuminant!r} is unknown; use the name of a CIE illuminant of "
            "colour.SDS_ILLUMINANTS, such as 'D65' or 'E'",
            "illuminant",
        )
    if method not in METHODS:
        raise DataError(f"method={method!r} is unknown; use one of {METHODS}", "method")
    step = round(wavelengths[1] - wavelengths[0], 6)
    if method == "ASTM E308" and step not in E308_STEPS:
        raise DataError(
            f"wavelengths_nm are {step:g} nm apart; the ASTM E308 method needs 1, 5, 10 or "
            "20 nm steps: use method='Integration' for other grids",
            "wavelengths_nm",
        )
    return wavelengths, illuminant, method


@lru_cache(maxsize=32)
def _weights(wavelengths: tuple, illuminant: str, method: str) -> np.ndarray:
    colour = _colour()
    unit_spectra = colour.MultiSpectralDistributions(np.eye(len(wavelengths)), wavelengths)
    cmfs = colour.MSDS_CMFS[OBSERVER]
    illuminant_sd = colour.SDS_ILLUMINANTS[illuminant]
    with warnings.catch_warnings():
        # colour announces that it aligns the grids; that is the documented method here
        warnings.simplefilter("ignore", colour.utilities.ColourRuntimeWarning)
        xyz = colour.msds_to_XYZ(unit_spectra, cmfs, illuminant_sd, method=method)
    weights = np.asarray(xyz, dtype=float) / 100.0  # colour scales the white to Y = 100
    weights.setflags(write=False)
    return weights


def tristimulus_weights(
    wavelengths_nm, illuminant: str = "D65", method: str = "ASTM E308"
) -> np.ndarray:
    """The (C, 3) matrix ``W`` with ``XYZ = R @ W`` for spectra sampled at ``wavelengths_nm``.

    Row ``c`` is the XYZ of the unit spectrum of band ``c``; the rows sum to the
    XYZ of the illuminant's white, with Y = 1. Cached per grid.
    """
    return _weights(*_check_options(wavelengths_nm, None, illuminant, method))


def spectral_to_xyz(
    values, wavelengths_nm, illuminant: str = "D65", method: str = "ASTM E308"
) -> np.ndarray:
    """CIE 1931 XYZ of reflectance spectra, white reflector at Y = 1.

    Parameters
    ----------
    values : array_like, shape (N, C) or (C,)
        Reflectance factors (or any quantity proportional to them, such as a
        BRDF in 1/sr) at the wavelengths, one spectrum per row.
    wavelengths_nm : array_like, shape (C,)
        Equally spaced, increasing, within 360-830 nm (the Cornell grid is
        400, 410, ..., 700).
    illuminant : str
        A CIE illuminant of ``colour.SDS_ILLUMINANTS``: ``"D65"`` (default,
        the white of sRGB) or ``"E"`` (equal energy), for instance.
    method : {"ASTM E308", "Integration"}
        See the module docstring.

    Returns
    -------
    ndarray, shape (N, 3) or (3,)
    """
    values = np.asarray(values, dtype=float)
    if values.ndim not in (1, 2):
        raise DataError(
            f"values have shape {values.shape}; give spectra as (N, C) or one as (C,)", "values"
        )
    return values @ _weights(*_check_options(wavelengths_nm, values.shape[-1], illuminant, method))


def _white_xy(white) -> np.ndarray | None:
    if white is None:
        return None
    colour = _colour()
    if isinstance(white, str):
        table = colour.CCS_ILLUMINANTS[OBSERVER]
        if white not in table:
            raise DataError(
                f"white={white!r} is not a CIE illuminant of the 1931 observer; use a name "
                "such as 'D65' or 'E', or the white's xy or XYZ",
                "white",
            )
        return np.asarray(table[white], dtype=float)
    w = np.asarray(white, dtype=float)
    if w.shape == (3,) and w.sum() > 0:
        return w[:2] / w.sum()
    if w.shape == (2,) and 0 < w[1] <= 1:
        return w
    raise DataError(
        f"white={white!r} must be an illuminant name, a chromaticity (x, y) or an XYZ",
        "white",
    )


def _srgb_matrix(source_xy) -> np.ndarray:
    """XYZ -> linear sRGB, after a Bradford adaptation from ``source_xy`` when it is given."""
    colour = _colour()
    srgb = colour.RGB_COLOURSPACES["sRGB"]
    # derived from the primaries and D65 (SMPTE RP 177) so that D65 maps to (1, 1, 1)
    # exactly; IEC 61966-2-1's printed 4-digit matrix misses it by 1.6e-4
    to_rgb = np.linalg.inv(colour.normalised_primary_matrix(srgb.primaries, srgb.whitepoint))
    if source_xy is None:
        return to_rgb
    cat = colour.adaptation.matrix_chromatic_adaptation_VonKries(
        colour.xy_to_XYZ(source_xy), colour.xy_to_XYZ(srgb.whitepoint), transform="Bradford"
    )
    return to_rgb @ cat


def xyz_to_srgb(xyz, white=None) -> np.ndarray:
    """Linear sRGB (IEC 61966-2-1 primaries and D65 white, no transfer curve) of CIE XYZ.

    Parameters
    ----------
    xyz : array_like, shape (N, 3) or (3,)
    white : None, str or array_like
        The white the XYZ are relative to. None (default) means sRGB's own D65
        (CIE chromaticity 0.3127, 0.3290): no adaptation, and D65 with Y = 1
        maps to (1, 1, 1). Otherwise an illuminant name (``"E"``: tabulated
        chromaticity), a chromaticity ``(x, y)`` or an XYZ, such as
        ``tristimulus_weights(wavelengths, "E").sum(0)`` (the white the spectra
        were integrated with, which maps a flat spectrum to exact grey); that
        white is mapped to D65 by the Bradford transform (Lam 1985).

    Colours outside the sRGB gamut (saturated spectra, such as a narrow band at
    520 nm) have a negative component. They are returned as they are, NOT
    clipped: the map stays linear (a fit in sRGB is then the same linear map of
    a fit per band, and sigma propagates), and clipping would change the colour's
    luminance and hue. :meth:`Measurements.to_srgb` says how many values are
    negative (:func:`gamut_note`); clip for display only (``np.clip(rgb, 0, None)``).
    """
    xyz = np.asarray(xyz, dtype=float)
    if xyz.shape[-1:] != (3,) or xyz.ndim > 2:
        raise DataError(f"xyz has shape {xyz.shape}; it must be (N, 3) or (3,)", "xyz")
    return xyz @ _srgb_matrix(_white_xy(white)).T


def gamut_note(rgb, where: str = "") -> None:
    """Note (:func:`brdffit.notes.note`) how many linear sRGB values are negative.

    A negative component means the colour lies outside the sRGB gamut (or the
    spectrum itself was negative: measurement noise). The values are kept, not
    clipped (see :func:`xyz_to_srgb`); nothing is said when none is negative.
    """
    rgb = np.asarray(rgb, dtype=float)
    negative = int(np.count_nonzero(rgb < 0))
    if negative:
        from ..notes import note

        rows = int(np.count_nonzero((rgb.reshape(-1, rgb.shape[-1]) < 0).any(axis=1)))
        note(
            f"{where + ': ' if where else ''}{negative} of {rgb.size} linear sRGB values "
            f"(in {rows} of {rgb.size // rgb.shape[-1]} samples) are negative: those colours "
            "lie outside the sRGB gamut (or their spectra are negative); they are kept, not "
            "clipped, so that the map stays linear (clip for display only)",
            stacklevel=3,
        )
