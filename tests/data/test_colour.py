"""Spectral to XYZ and linear sRGB: known cases and independent references.

The references are written here from the primary definitions: the CIE 15
tristimulus sum over colour-science's 1 nm tables (plain loops), the sRGB
matrix derived from the primaries of IEC 61966-2-1 (SMPTE RP 177), and von
Kries adaptation with Lam's Bradford matrix.
"""

from __future__ import annotations

import math

import colour
import numpy as np
import pytest

from brdffit import DataError
from brdffit.data.colour import spectral_to_xyz, tristimulus_weights, xyz_to_srgb

CORNELL = np.arange(400, 701, 10.0)  # 31 bands, as in the Cornell files
OBSERVER = "CIE 1931 2 Degree Standard Observer"
# IEC 61966-2-1 (sRGB): primaries and white chromaticities
SRGB_PRIMARIES = ((0.64, 0.33), (0.30, 0.60), (0.15, 0.06))
D65_XY = (0.3127, 0.3290)
# Lam (1985), the Bradford cone response matrix
BRADFORD = ((0.8951, 0.2664, -0.1614), (-0.7502, 1.7135, 0.0367), (0.0389, -0.0685, 1.0296))


def xy_to_xyz(x, y):
    return np.array([x / y, 1.0, (1.0 - x - y) / y])


def tristimulus_1nm(reflectance, illuminant, lo=360, hi=830):
    """CIE 15 sum over the 1 nm steps of the CMF table: X = k sum S xbar R,
    k = 1 / sum S ybar. The illuminant table is interpolated linearly; colour's
    D65 stops at 780 nm and is extended by its last value (np.interp), where
    the CMFs are below 1e-4 of their peak."""
    cmfs = colour.MSDS_CMFS[OBSERVER]
    table = dict(zip(cmfs.wavelengths.tolist(), cmfs.values.tolist()))  # 1 nm steps
    sd = colour.SDS_ILLUMINANTS[illuminant]
    total, norm = [0.0, 0.0, 0.0], 0.0
    for wl in range(lo, hi + 1):
        s = float(np.interp(wl, sd.wavelengths, sd.values))
        xbar = table[float(wl)]
        r = reflectance(wl)
        for m in range(3):
            total[m] += s * xbar[m] * r
        norm += s * xbar[1]
    return np.array(total) / norm


def chromaticity(xyz):
    xyz = np.asarray(xyz)
    return xyz[:2] / xyz.sum()


@pytest.mark.parametrize("illuminant", ["D65", "E"])
@pytest.mark.parametrize("method", ["ASTM E308", "Integration"])
def test_flat_spectrum_has_y_half_and_the_illuminant_chromaticity(illuminant, method):
    xyz = spectral_to_xyz(np.full((2, 31), 0.5), CORNELL, illuminant=illuminant, method=method)
    assert xyz.shape == (2, 3)
    assert xyz[0, 1] == pytest.approx(0.5, abs=1e-12)
    # tabulated chromaticity: 4 digits, and the CMF table realises E's 1/3 to 5e-5
    table = colour.CCS_ILLUMINANTS[OBSERVER][illuminant]
    np.testing.assert_allclose(chromaticity(xyz[0]), table, atol=1e-4)
    # the 1 nm sum of the definition: 10 nm weights reproduce it to E308's 1e-5
    white = tristimulus_1nm(lambda wl: 1.0, illuminant)
    np.testing.assert_allclose(chromaticity(xyz[0]), chromaticity(white), atol=1e-5)


def test_smooth_spectrum_agrees_with_the_1nm_definition_within_the_interpolation_bound():
    amplitude, period = 0.3, 300.0

    def reflectance(wl):
        wl = min(max(wl, 400.0), 700.0)  # E308 extends the end bands by constants
        return 0.5 + amplitude * math.sin(2 * math.pi * (wl - 400.0) / period)

    samples = np.array([reflectance(wl) for wl in CORNELL])

    def linear(wl):  # linear interpolation of the 10 nm samples, as a reference
        return float(np.interp(wl, CORNELL, samples))

    reference = tristimulus_1nm(linear, "D65")
    # linear interpolation errs by at most h^2/8 max|R''| on each 10 nm step
    bound = 10.0**2 / 8 * amplitude * (2 * math.pi / period) ** 2
    white = tristimulus_1nm(lambda wl: 1.0, "D65")
    got = spectral_to_xyz(samples, CORNELL)
    assert got.shape == (3,)
    assert (np.abs(got - reference) <= bound * white).all(), (got - reference, bound * white)


@pytest.mark.filterwarnings("ignore::colour.utilities.ColourRuntimeWarning")
@pytest.mark.parametrize("illuminant", ["D65", "E"])
def test_batch_matrix_matches_colour_science_per_spectrum(illuminant):
    rng = np.random.default_rng(7)
    spectra = rng.uniform(0.0, 1.0, (4, 31))
    got = spectral_to_xyz(spectra, CORNELL, illuminant=illuminant)
    cmfs = colour.MSDS_CMFS[OBSERVER]
    for row, spectrum in zip(got, spectra):
        sd = colour.SpectralDistribution(dict(zip(CORNELL, spectrum)))
        expected = colour.sd_to_XYZ(sd, cmfs, colour.SDS_ILLUMINANTS[illuminant]) / 100.0
        np.testing.assert_allclose(row, expected, rtol=1e-12, atol=1e-14)


def test_weights_sum_to_the_white_and_are_read_only():
    weights = tristimulus_weights(CORNELL, "E")
    assert weights.shape == (31, 3)
    assert weights.sum(axis=0)[1] == pytest.approx(1.0, abs=1e-12)
    with pytest.raises(ValueError):
        weights[0, 0] = 1.0


def test_d65_white_maps_to_linear_srgb_ones():
    np.testing.assert_allclose(xyz_to_srgb(xy_to_xyz(*D65_XY)), [1.0, 1.0, 1.0], atol=1e-12)
    # a flat 0.5 spectrum under D65 is grey: to the E308 white's 1e-4 from the table ...
    grey = xyz_to_srgb(spectral_to_xyz(np.full(31, 0.5), CORNELL))
    np.testing.assert_allclose(grey, 0.5, atol=2e-4)
    # ... and exactly grey when that white is named as the source white
    white = tristimulus_weights(CORNELL, "D65").sum(axis=0)
    exact = xyz_to_srgb(spectral_to_xyz(np.full(31, 0.5), CORNELL), white=white)
    np.testing.assert_allclose(exact, 0.5, atol=1e-12)


def test_srgb_matrix_is_the_one_derived_from_the_primaries():
    # SMPTE RP 177: columns are the primaries' XYZ scaled so that they add up to the white
    primaries = np.column_stack([xy_to_xyz(x, y) for x, y in SRGB_PRIMARIES])
    scale = np.linalg.solve(primaries, xy_to_xyz(*D65_XY))
    rgb_to_xyz = primaries * scale
    xyz = np.random.default_rng(2).uniform(0, 1, (5, 3))
    np.testing.assert_allclose(xyz_to_srgb(xyz), xyz @ np.linalg.inv(rgb_to_xyz).T, atol=1e-12)


def test_flat_spectrum_under_e_becomes_grey_through_bradford():
    e_white = tristimulus_weights(CORNELL, "E").sum(axis=0)
    xyz = spectral_to_xyz(np.full(31, 0.5), CORNELL, illuminant="E")
    np.testing.assert_allclose(xyz_to_srgb(xyz, white=e_white), 0.5, atol=1e-12)
    # von Kries in Lam's cone space, from E's tabulated white to D65
    cone = np.array(BRADFORD)
    gain = (cone @ xy_to_xyz(*D65_XY)) / (cone @ xy_to_xyz(1 / 3, 1 / 3))
    adapt = np.linalg.inv(cone) @ np.diag(gain) @ cone
    sample = np.array([0.3, 0.2, 0.7])
    np.testing.assert_allclose(
        xyz_to_srgb(sample, white="E"), xyz_to_srgb(adapt @ sample), rtol=1e-12
    )
    np.testing.assert_allclose(
        xyz_to_srgb(sample, white=(1 / 3, 1 / 3)), xyz_to_srgb(sample, white="E"), rtol=1e-12
    )


@pytest.mark.parametrize(
    "values, wavelengths, options, field",
    [
        (np.ones((2, 31)), CORNELL[:-1], {}, "wavelengths_nm"),
        (np.ones((2, 3)), [400, 410, 430], {}, "wavelengths_nm"),
        (np.ones((2, 3)), [300, 310, 320], {}, "wavelengths_nm"),
        (np.ones((2, 2)), [400, 410], {}, "wavelengths_nm"),
        (np.ones((2, 101)), np.arange(400, 701, 3.0), {}, "wavelengths_nm"),
        (np.ones((2, 31)), CORNELL, {"illuminant": "D66"}, "illuminant"),
        (np.ones((2, 31)), CORNELL, {"method": "Riemann"}, "method"),
        (np.ones((2, 2, 31)), CORNELL, {}, "values"),
    ],
)
def test_bad_spectral_input_raises_data_error_naming_the_field(
    values, wavelengths, options, field
):
    with pytest.raises(DataError) as err:
        spectral_to_xyz(values, wavelengths, **options)
    assert err.value.field == field


def test_other_grids_work_with_the_integration_method():
    grid = np.arange(400, 701, 3.0)
    xyz = spectral_to_xyz(np.full(len(grid), 0.25), grid, method="Integration")
    assert xyz[1] == pytest.approx(0.25, abs=1e-12)


@pytest.mark.parametrize("white", ["Z99", (0.3, 0.0), (1.0, 2.0, 3.0, 4.0)])
def test_bad_white_raises(white):
    with pytest.raises(DataError) as err:
        xyz_to_srgb([0.5, 0.5, 0.5], white=white)
    assert err.value.field == "white"


# ------------------------------------------- out of gamut (issue 17): kept and said
def _spectral_measurements(spectrum):
    from brdffit import Measurements

    n = 4
    theta = np.full(n, 30.0)
    values = np.tile(np.asarray(spectrum, dtype=float), (n, 1))
    bands = [f"{w:g}nm" for w in CORNELL]
    return Measurements.from_angles(theta, np.zeros(n), theta, np.full(n, 180.0), values,
                                    channels=bands, degrees=True, source="green.csv")  # fmt: skip


def test_out_of_gamut_srgb_is_kept_linear_and_noted():
    narrow = np.where(CORNELL == 520.0, 1.0, 0.0)  # a spectral green, outside sRGB
    data = _spectral_measurements(narrow)
    with pytest.warns(
        UserWarning,
        match=r"green.csv: 8 of 12 linear sRGB values \(in 4 of 4 "
        r"samples\) are negative: those colours lie outside the sRGB gamut",
    ):
        rgb = data.to_srgb()  # fmt: skip
    expected = xyz_to_srgb(spectral_to_xyz(narrow, CORNELL))
    assert (expected < 0).sum() == 2  # red and blue below zero for a spectral green
    assert np.allclose(rgb.values, expected, rtol=1e-12, atol=0)  # not clipped


def test_in_gamut_srgb_says_nothing(recwarn):
    rgb = _spectral_measurements(np.full(31, 0.4)).to_srgb()
    # grey to 3e-4: the E308-integrated D65 white is not exactly sRGB's tabulated one
    assert np.allclose(rgb.values, 0.4, rtol=3e-4) and (rgb.values > 0).all()
    assert not [w for w in recwarn if "sRGB" in str(w.message)]
