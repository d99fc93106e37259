"""synthesize: model values, seeded noise with the requested statistics, geometries."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from brdffit.errors import DataError, ParameterError
from brdffit.models import get_model
from brdffit.synth import gonio_angles, synthesize


def blinn_scalar(wi, wo, kd, ks, n):
    """Blinn from MODELS.md with the math module: kd/pi + ks max(0, N.H)^n, 0 below the horizon."""
    if wi[2] <= 0 or wo[2] <= 0:
        return 0.0
    h = [a + b for a, b in zip(wi, wo)]
    norm = math.sqrt(sum(x * x for x in h))
    return kd / math.pi + ks * max(0.0, h[2] / norm) ** n


def test_noise_free_values_are_the_model_formula():
    data = synthesize("blinn", {"kd": [0.2, 0.4, 0.6], "ks": 0.7, "n": 30.0}, geometry="gonio")
    assert data.channels == ("r", "g", "b") and data.sigma is None
    for k in range(0, data.n, 7):
        for c, kd in enumerate((0.2, 0.4, 0.6)):
            expected = blinn_scalar(data.wi[k].tolist(), data.wo[k].tolist(), kd, 0.7, 30.0)
            assert math.isclose(data.values[k, c], expected, rel_tol=1e-12)


@pytest.mark.parametrize("noise", [0.01, 0.05])
def test_relative_noise_has_the_requested_standard_deviation(noise):
    params = {"kd": [0.3, 0.5, 0.1], "ks": 0.8, "n": 40.0}
    data = synthesize("blinn", params, geometry="hemisphere", n=4000, noise=noise, seed=11)
    truth = get_model("blinn").evaluate(data.wi, data.wo, params)
    residual = (data.values - truth) / truth
    m = residual.size
    # Standard error of a sample standard deviation is sigma / sqrt(2 m); allow 5 of them.
    assert abs(residual.std() - noise) < 5 * noise / math.sqrt(2 * m)
    assert abs(residual.mean()) < 5 * noise / math.sqrt(m)
    np.testing.assert_allclose(data.sigma, noise * truth, rtol=1e-12)
    # About 68.3 % of the normalised residuals lie within one sigma (binomial, 5 s.e.).
    inside = np.mean(np.abs(data.values - truth) < data.sigma)
    assert abs(inside - 0.6827) < 5 * math.sqrt(0.6827 * 0.3173 / m)


def test_absolute_noise_and_seeds():
    params = {"kd": 0.5, "ks": 0.0, "n": 10.0}  # a constant 0.5/pi
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        a = synthesize("blinn", params, "hemisphere", noise=0.2, noise_kind="absolute", n=5000)
        b = synthesize("blinn", params, "hemisphere", noise=0.2, noise_kind="absolute", n=5000)
        c = synthesize("blinn", params, "hemisphere", noise=0.2, noise_kind="absolute", n=5000,
                       seed=1)  # fmt: skip
    np.testing.assert_array_equal(a.values, b.values)
    np.testing.assert_array_equal(a.wi, b.wi)
    assert not np.array_equal(a.values, c.values) and not np.array_equal(a.wi, c.wi)
    assert (a.sigma == 0.2).all()
    residual = a.values[:, 0] - 0.5 / math.pi
    assert abs(residual.std() - 0.2) < 5 * 0.2 / math.sqrt(2 * a.n)
    assert a.negative_count > 0  # absolute noise around 0.16 goes negative; kept


def test_hemisphere_pairs_are_uniform_in_solid_angle_and_above_the_horizon():
    data = synthesize("lambert", geometry="hemisphere", n=20000, seed=3)
    cos_i, cos_o = data.wi[:, 2], data.wo[:, 2]
    assert data.n == 20000 and data.below_horizon_count == 0
    # cos(theta) uniform on (0, 1]: mean 1/2, variance 1/12.
    for c in (cos_i, cos_o):
        assert abs(c.mean() - 0.5) < 5 * math.sqrt(1 / 12 / c.size)
    phi = data.angles()[1]
    assert abs(np.mean(phi < 180) - 0.5) < 5 * math.sqrt(0.25 / phi.size)


def test_gonio_grid_sees_the_mirror_direction_of_every_incidence():
    data = synthesize("blinn")
    ti, pi_, to, po = data.angles()
    assert set(np.unique(ti)) == {15.0, 30.0, 45.0, 60.0, 75.0} and (pi_ == 0).all()
    for t in np.unique(ti):
        mirror = (ti == t) & (to == t) & (po == 180.0)
        assert mirror.sum() == 1
    assert 300 <= data.n <= 1500
    assert len(set(zip(ti, pi_, to, po))) == data.n  # no duplicate pair


def test_gonio_grid_of_anisotropic_models_sees_the_anisotropy():
    params = {"kd": 0.1, "ks": 0.5, "alpha_x": 0.05, "alpha_y": 0.3}
    data = synthesize("ward_anisotropic", params)
    ti, pi_, to, po = data.angles()
    assert set(np.unique(pi_)) == {0.0, 45.0, 90.0}
    # The same pair rotated by 90 degrees about the normal gives other values.
    value = {
        (a, b, c, np.mod(d - b, 360)): v
        for a, b, c, d, v in zip(ti, pi_, to, po, data.values[:, 0])
    }
    ratios = [
        v / value[(a, 90.0, c, r)]
        for (a, b, c, r), v in value.items()
        if b == 0.0 and (a, 90.0, c, r) in value
    ]
    assert len(ratios) > 100 and max(ratios) / min(ratios) > 10
    assert 300 <= data.n <= 1500


def test_gonio_options_and_subsets():
    _, _, to, po = gonio_angles(theta_i=(40,), azimuths=(30,), theta_o=(0, 45), phi_step=90)
    assert set(zip(to, po)) >= {(0.0, 30.0), (45.0, 30.0), (45.0, 120.0), (40.0, 210.0)}
    data = synthesize("blinn", n=100, seed=2)
    full = synthesize("blinn")
    assert data.n == 100
    assert {tuple(r) for r in data.values.tolist()} <= {tuple(r) for r in full.values.tolist()}


def test_explicit_geometries_and_channel_names():
    data = synthesize("blinn")
    wi, wo = data.wi, data.wo
    params = {"kd": [0.1, 0.2], "ks": 1.0, "n": 20.0}
    a = synthesize("blinn", params, geometry=(wi, wo), channels=("450nm", "650nm"))
    np.testing.assert_array_equal(a.values, get_model("blinn").evaluate(wi, wo, params))
    assert a.wavelengths().tolist() == [450.0, 650.0]
    b = synthesize("blinn", params, geometry=data)
    np.testing.assert_array_equal(b.values, a.values)
    assert b.channels == ("c0", "c1")
    c = synthesize("blinn", geometry=data.angles())
    np.testing.assert_array_equal(c.angles()[3], data.angles()[3])


def test_merl_geometry_uses_the_merl_grid():
    merl = pytest.importorskip("brdffit.io.merl", reason="brdffit/io/merl.py is not written yet")
    data = synthesize("blinn", geometry="merl", step=10)
    wi, wo = merl.grid_directions(step=10)
    np.testing.assert_array_equal(data.wi, wi)
    np.testing.assert_array_equal(data.wo, wo)


def test_bad_requests_are_named():
    with pytest.raises(DataError, match="unknown geometry 'sphere'"):
        synthesize("blinn", geometry="sphere")
    with pytest.raises(DataError, match="noise_kind='percent'"):
        synthesize("blinn", noise=0.1, noise_kind="percent")
    with pytest.raises(DataError, match=r"noise=-0.1 must be"):
        synthesize("blinn", noise=-0.1)
    with pytest.raises(DataError, match=r"does not take the option.*step"):
        synthesize("blinn", geometry="gonio", step=2)
    with pytest.raises(DataError, match=r"n=5000 must be in"):
        synthesize("blinn", n=5000)
    with pytest.raises(ParameterError, match=r"n=0.5 is outside its bounds"):
        synthesize("blinn", {"n": 0.5})
    with pytest.raises(DataError, match="names 2 channel"):
        synthesize("blinn", channels=("a", "b"))
