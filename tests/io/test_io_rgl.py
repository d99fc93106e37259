"""The RGL-EPFL material format (Mitsuba tensor_file, ``.bsdf``).

Reference code here is written from the primary sources (Mitsuba 3
``measured.cpp`` and ``distr_2d.h``, RGL ``brdf-loader``), not from the
module: tensor files are packed with struct by the test's own writer; the warp
is checked against the marginal and conditional CDFs of the bilinear density,
evaluated in closed form by scalar code (the definition the warp inverts); the
BRDF is re-evaluated by Mitsuba's ``eval`` route (half vector, inverse warp,
bilinear lookup of rgb, ndf and sigma, with linear interpolation between the
stored incident angles), scalar.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import shared_file
from io_helpers import pack_tensor, tiny_rgl

import brdffit
from brdffit import FormatError
from brdffit.io import detect_format
from brdffit.io.rgl import read_rgl_arrays, read_tensor_file, warp_sample

FIELDS = {
    "a": np.arange(6, dtype="<f4").reshape(2, 3) / 7,
    "bytes": np.frombuffer(b"hello", dtype="u1"),
    "ints": np.array([[-3, 4], [5, -6]], dtype="<i2"),
    "big": np.array([1e300, -2.5], dtype="<f8"),
    "cube": np.arange(24, dtype="<u4").reshape(2, 3, 4),
}


def test_tensor_file_round_trips_exactly(tmp_path):
    path = tmp_path / "t.bsdf"
    path.write_bytes(pack_tensor(FIELDS))
    fields = read_tensor_file(path)
    assert list(fields) == list(FIELDS)
    for name, a in FIELDS.items():
        assert fields[name].dtype == a.dtype and fields[name].shape == a.shape
        np.testing.assert_array_equal(fields[name].data, a)
        assert fields[name].offset % 8 == 0
    assert detect_format(path) == "rgl"
    other = tmp_path / "t.dat"
    other.write_bytes(path.read_bytes())
    assert detect_format(other) == "rgl"  # by the magic bytes


@pytest.mark.parametrize(
    "damage, pattern",
    [
        (lambda r: b"tensor_fil\x00\x00" + r[12:], r"wrong magic at byte 0"),
        (lambda r: r[:13], r"version needs 2 bytes at byte 12, but the file ends at byte 13"),
        (lambda r: r[:12] + b"\x02\x00" + r[14:], r"version \(2, 0\) at byte 12"),
        (lambda r: r[:16], r"field count needs 4 bytes at byte 14, but the file ends at byte 16"),
        (lambda r: r[:25], r"header of field 'a' needs 11 bytes at byte 21, but .* byte 25"),
        (lambda r: r[:40], r"shape of field 'a' needs 16 bytes at byte 32, but .* byte 40"),
        (lambda r: r[:-3], r"data of field 'cube' .* from byte \d+ needs the file to reach"),
        (lambda r: r[:23] + b"\x0c" + r[24:], r"unknown dtype code 12 at byte 23"),
    ],
)
def test_broken_tensor_files_name_the_byte(tmp_path, damage, pattern):
    path = tmp_path / "broken.bsdf"
    raw = pack_tensor(FIELDS)
    # name length at 18, name at 20, ndim at 21, dtype at 23, offset at 24, shape at 32
    assert raw[18:24] == b"\x01\x00a\x02\x00\x0a"
    path.write_bytes(damage(raw))
    with pytest.raises(FormatError, match=pattern) as info:
        read_tensor_file(path)
    assert str(path) in str(info.value)


def test_a_small_rgl_file_reads_every_pair(tmp_path):
    path = tmp_path / "tiny.bsdf"
    path.write_bytes(pack_tensor(tiny_rgl()))
    s = read_rgl_arrays(path)
    assert s.n_stored == 18 and s.description == "tiny"
    assert len(s.wi) + s.n_below_horizon + s.n_incident_below_horizon + s.n_merged == 18
    assert np.all(s.wo[:, 2] > 0) and np.all(np.isfinite(s.values))


@pytest.mark.parametrize(
    "changes, pattern",
    [
        ({"phi_i": np.array([0.0, 1.0], "<f4")}, r"isotropic"),
        ({"rgb": None, "spectra": np.zeros((1, 2, 4, 3, 3), "<f4")}, r"spectral"),
        ({"ndf": None}, r"no field 'ndf'"),
        ({"rgb": np.zeros((1, 2, 2, 3, 3), "<f4")}, r"field 'rgb' .* shape \[1, 2, 2, 3, 3\]"),
        ({"theta_i": np.zeros(2, "<f8")}, r"field 'theta_i' .* float64"),
    ],
)
def test_rgl_files_outside_the_supported_kind_are_refused(tmp_path, changes, pattern):
    path = tmp_path / "odd.bsdf"
    path.write_bytes(pack_tensor(tiny_rgl(**changes)))
    with pytest.raises(FormatError, match=pattern):
        read_rgl_arrays(path)


# ---------------------------------------------------------------- real file
RGL_FILE = ("rgl", "satin_rosaline_rgb.bsdf")


@pytest.fixture(scope="module")
def real_path():
    return shared_file(*RGL_FILE)


@pytest.fixture(scope="module")
def real_fields(real_path):
    return read_tensor_file(real_path)


@pytest.fixture(scope="module")
def real_samples(real_path):
    return read_rgl_arrays(real_path)


def test_real_file_has_the_documented_fields(real_fields):
    shapes = {name: f.shape for name, f in real_fields.items()}
    assert shapes == {
        "version": (2,),
        "description": (51,),
        "phi_i": (1,),
        "theta_i": (8,),
        "sigma": (2, 128),
        "ndf": (2, 128),
        "vndf": (1, 8, 128, 128),
        "luminance": (1, 8, 32, 32),
        "rgb": (1, 8, 3, 32, 32),
        "jacobian": (1,),
        "valid": (1024,),
    }
    assert real_fields["jacobian"].data[0] == 1
    theta = np.degrees(real_fields["theta_i"].data)
    assert theta[0] == 0 and 89.9999 < theta[-1] < 90 and np.all(np.diff(theta) > 0)


def test_real_file_reads_through_brdffit_read(real_path):
    with pytest.warns(
        UserWarning, match=r"2367 of 8192 stored direction pairs dropped: 1033 .* 310 duplicates"
    ):
        data = brdffit.read(real_path)
    assert data.n == 5825 and data.channels == ("r", "g", "b") and data.units == "1/sr"
    assert data.source == str(real_path) and data.below_horizon_count == 0
    assert np.isfinite(data.values).all() and data.values.min() > 0
    assert 250 < data.values.max() < 275  # the mirror peak at theta_i = 78.7 degrees


def test_real_file_counts(real_samples):
    s = real_samples
    assert s.n_stored == 8 * 32 * 32
    assert s.n_incident_below_horizon == 1024  # theta_i = float32(pi/2) - 1 ulp
    # the 32 nodes of column x = 0 all give the mirror, and in three slices the
    # nodes of row y = 1 (u_phi = 1) repeat those of row y = 0 (u_phi = 0)
    assert s.n_merged == 7 * 31 + 3 * 31
    assert len(s.wi) + s.n_below_horizon + s.n_incident_below_horizon + s.n_merged == s.n_stored
    assert np.bincount(s.incident_index).tolist() == [745, 767, 809, 829, 865, 897, 913]
    for k in range(7):  # one pair per incident angle at the mirror
        sel = s.incident_index == k
        mirror = s.wi[sel][0] * np.array([-1, -1, 1])
        assert (_angle_deg(s.wo[sel], mirror) < 1e-6).sum() == 1


def _angle_deg(a, b):
    return np.degrees(np.arccos(np.clip(np.sum(a * b, axis=-1), -1, 1)))


def test_real_highlight_is_at_the_mirror_direction(real_samples):
    s = real_samples
    for k in range(7):
        sel = s.incident_index == k
        wi, wo, lum = s.wi[sel], s.wo[sel], s.values[sel].sum(axis=1)
        mirror = wi[0] * np.array([-1, -1, 1])
        peak = wo[np.argmax(lum)]
        assert _angle_deg(peak, mirror) < 2.0, k
        # and the values fall away from it: the median beyond 30 degrees is far lower
        far = _angle_deg(wo, mirror) > 30
        assert np.median(lum[far]) < 0.2 * lum.max(), k


# ------------------------------------------------ warp: CDFs of the density
class Bilinear:
    """A density on the unit square, bilinear between nodes (ny, nx), normalised.

    ``cdfs(x, y)`` gives the marginal CDF of y and the conditional CDF of x at
    height y in closed form: the quantities Marginal2D's sample() inverts.
    """

    def __init__(self, table):
        d = np.asarray(table, dtype=float)
        rows = (d[:, :-1] + d[:, 1:]).sum(axis=1) / 2  # integral of each row (index units)
        self.total = ((rows[:-1] + rows[1:]) / 2).sum()
        self.d, self.rows = d / self.total, rows / self.total
        self.ny, self.nx = d.shape

    @staticmethod
    def _cell(v, n):
        p = min(max(v, 0.0), 1.0) * (n - 1)
        i = min(int(p), n - 2)
        return i, p - i

    def cdfs(self, x, y):
        i, t = self._cell(y, self.ny)
        j, s = self._cell(x, self.nx)
        r = self.rows
        below = sum((r[k] + r[k + 1]) / 2 for k in range(i))
        marginal = below + r[i] * t + (r[i + 1] - r[i]) * t * t / 2
        g = (1 - t) * self.d[i] + t * self.d[i + 1]  # the density along x at height y
        left = sum((g[k] + g[k + 1]) / 2 for k in range(j))
        partial = left + g[j] * s + (g[j + 1] - g[j]) * s * s / 2
        return partial / ((1 - t) * r[i] + t * r[i + 1]), marginal

    def density(self, x, y):
        i, t = self._cell(y, self.ny)
        j, s = self._cell(x, self.nx)
        d = self.d
        top = (1 - s) * d[i, j] + s * d[i, j + 1]
        return ((1 - t) * top + t * ((1 - s) * d[i + 1, j] + s * d[i + 1, j + 1])) * (
            (self.nx - 1) * (self.ny - 1)
        )


@pytest.mark.parametrize("k", [0, 3, 6])
def test_forward_warp_inverts_the_cdfs_of_the_real_vndf(real_fields, k):
    table = real_fields["vndf"].data[0, k]
    ref = Bilinear(table)
    rng = np.random.default_rng(k)
    u = np.concatenate([rng.uniform(0, 1, (150, 2)), [[0, 0], [1, 1], [0.5, 0], [0, 0.5]]])
    x, y, pdf = warp_sample(table, u[:, 0], u[:, 1])
    assert np.all((x >= 0) & (x <= 1) & (y >= 0) & (y <= 1))
    for n in range(len(u)):
        cx, cy = ref.cdfs(x[n], y[n])
        assert abs(cy - u[n, 1]) < 1e-9 and abs(cx - u[n, 0]) < 1e-9, (n, u[n], cx, cy)
        assert pdf[n] == pytest.approx(ref.density(x[n], y[n]), rel=1e-9, abs=1e-12)


def test_forward_warp_of_a_uniform_density_is_the_identity():
    x, y, pdf = warp_sample(np.ones((3, 5)), [0.1, 0.7], [0.3, 0.95])
    np.testing.assert_allclose([x, y], [[0.1, 0.7], [0.3, 0.95]], atol=1e-12)
    np.testing.assert_allclose(pdf, 1.0)


# ------------------------------------ BRDF by Mitsuba's eval route, scalar
def _bilinear_raw(t, x, y):
    ny, nx = t.shape
    i, a = Bilinear._cell(y, ny)
    j, b = Bilinear._cell(x, nx)
    top = (1 - b) * t[i, j] + b * t[i, j + 1]
    return (1 - a) * top + a * ((1 - b) * t[i + 1, j] + b * t[i + 1, j + 1])


def _elevation(d):
    """measured.cpp's stable polar angle: 2 asin(|d - z| / 2)."""
    return 2 * math.asin(0.5 * math.sqrt(d[0] ** 2 + d[1] ** 2 + (d[2] - 1) ** 2))


class MitsubaEval:
    """measured.cpp's eval for an isotropic RGB file, divided by cos(theta_o)."""

    def __init__(self, fields):
        self.theta = fields["theta_i"].data.astype(float)
        self.vndf = [Bilinear(v) for v in fields["vndf"].data[0]]
        self.rgb = fields["rgb"].data[0].astype(float)
        self.ndf, self.sigma = fields["ndf"].data, fields["sigma"].data

    def _weights(self, theta_i):
        k = int(np.clip(np.searchsorted(self.theta, theta_i) - 1, 0, len(self.theta) - 2))
        w = min(max((theta_i - self.theta[k]) / (self.theta[k + 1] - self.theta[k]), 0), 1)
        return k, w

    def _invert(self, k, w, ux, uy):
        """Sample for u_m: the CDFs of the theta_i-interpolated (normalised) density."""
        a, b = self.vndf[k], self.vndf[k + 1]
        mix = Bilinear.__new__(Bilinear)
        mix.d, mix.rows = (1 - w) * a.d + w * b.d, (1 - w) * a.rows + w * b.rows
        mix.ny, mix.nx = a.ny, a.nx
        return mix.cdfs(ux, uy)

    def __call__(self, wi, wo):
        h = np.asarray(wi) + np.asarray(wo)
        h = h / math.sqrt(h @ h)
        theta_i, phi_i = _elevation(wi), math.atan2(wi[1], wi[0])
        theta_m, phi_m = _elevation(h), math.atan2(h[1], h[0])
        ux = math.sqrt(theta_m * 2 / math.pi)
        uy = (phi_m - phi_i + math.pi) / (2 * math.pi)
        uy -= math.floor(uy)
        k, w = self._weights(theta_i)
        sx, sy = self._invert(k, w, ux, uy)
        rgb = [
            (1 - w) * _bilinear_raw(self.rgb[k, c], sx, sy)
            + w * _bilinear_raw(self.rgb[k + 1, c], sx, sy)
            for c in range(3)
        ]
        factor = _bilinear_raw(self.ndf, ux, uy) / (
            4
            * _bilinear_raw(
                self.sigma, math.sqrt(theta_i * 2 / math.pi), (phi_i + math.pi) / (2 * math.pi)
            )
        )
        return np.array(rgb) * factor / wo[2]


@pytest.fixture(scope="module")
def mitsuba_eval(real_fields):
    return MitsubaEval(real_fields)


def test_values_agree_with_mitsubas_eval_route(real_samples, mitsuba_eval):
    s = real_samples
    rng = np.random.default_rng(1)
    picks = rng.choice(len(s.wi), 300, replace=False)
    mirrors = np.flatnonzero(s.sample[:, 0] == 0)  # the merged pairs
    assert len(mirrors) == 7
    for n in np.concatenate([picks, mirrors]):
        wo = s.wo[n]
        if s.sample[n, 0] == 0:
            # at the mirror the half vector is the normal and its azimuth is atan2(0, 0):
            # rounding in wo must not pick another one
            np.testing.assert_allclose(wo, s.wi[n] * [-1, -1, 1], atol=1e-15)
            wo = s.wi[n] * np.array([-1.0, -1.0, 1.0])
        expected = mitsuba_eval(s.wi[n], wo)
        np.testing.assert_allclose(s.values[n], expected, rtol=2e-6, err_msg=str(n))


def test_real_brdf_is_roughly_reciprocal(real_samples, mitsuba_eval):
    """f(wi, wo) from the file against f(wo, wi) evaluated by Mitsuba's route, where
    wo lies inside the stored incident range and neither direction is grazing."""
    s = real_samples
    theta_o = np.degrees(np.arccos(s.wo[:, 2]))
    inside = (theta_o < 70) & (s.incident_index <= 5) & (s.incident_index >= 1)
    rng = np.random.default_rng(2)
    picks = rng.choice(np.flatnonzero(inside), 300, replace=False)
    swapped = np.array([mitsuba_eval(s.wo[n], s.wi[n]) for n in picks])
    ratio = np.log(s.values[picks] / swapped)
    # measured: median |log ratio| 0.02, median log ratio < 0.004; without the
    # division by cos(theta_o) the ratio would be cos(theta_o) / cos(theta_i)
    assert np.median(np.abs(ratio)) < 0.05
    assert abs(np.median(ratio)) < 0.02


def test_real_directional_albedo_is_below_one(real_samples, real_fields):
    """a(wi) = integral of f_r cos(theta_o) over wo, by the change of variables of the
    warp: wo(s) has density p = vndf(u_m) / J with J = 2 pi^2 u_theta sin(theta_m)
    4 (wi . m) (measured.cpp's pdf), so a = integral over s of f_r cos / p (trapezoid
    over the rgb grid; the pairs below the horizon contribute zero)."""
    s = real_samples
    albedo = []
    for k in range(7):
        sel = np.flatnonzero(s.incident_index == k)
        ref = Bilinear(real_fields["vndf"].data[0, k])
        total = np.zeros(3)
        for n in sel:
            wi, wo, (sx, sy) = s.wi[n], s.wo[n], s.sample[n]
            if sx == 0:
                continue  # the mirror pair: J = 0 there, a set of measure zero
            m = (wi + wo) / np.linalg.norm(wi + wo)
            theta_m = math.acos(m[2])
            u_x = math.sqrt(theta_m * 2 / math.pi)
            u_y = ((math.atan2(m[1], m[0]) - math.atan2(wi[1], wi[0])) / (2 * math.pi) + 0.5) % 1
            jac = 2 * math.pi**2 * u_x * math.sin(theta_m) * 4 * (wi @ m)
            weight = (0.5 if sx in (0, 1) else 1) * (0.5 if sy in (0, 1) else 1) / 31**2
            total += weight * s.values[n] * wo[2] * jac / ref.density(u_x, u_y)
        albedo.append(total)
    albedo = np.array(albedo)
    # measured: 0.55 .. 0.71 per channel and incident angle
    assert np.all(albedo > 0.3) and np.all(albedo < 1.0), albedo
