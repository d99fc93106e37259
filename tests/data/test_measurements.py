"""Measurements: construction, validation messages, read-only arrays, subsets, colour."""

from __future__ import annotations

import json
import math
import pickle
import warnings

import numpy as np
import pytest

from brdffit.data.geometry import Geometry
from brdffit.data.measurements import Measurements
from brdffit.errors import DataError


def direction(theta_deg: float, phi_deg: float) -> list:
    """MODELS.md: (sin t cos p, sin t sin p, cos t), with the math module."""
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return [math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)]


def sample(n=50, channels=3, seed=0, sigma=True):
    rng = np.random.default_rng(seed)
    ti, to = rng.uniform(0, 85, (2, n))
    pi_, po = rng.uniform(-180, 360, (2, n))
    values = rng.uniform(0.01, 2.0, (n, channels))
    s = values * 0.02 if sigma else None
    names = ["r", "g", "b"][:channels] if channels <= 3 else None
    return Measurements.from_angles(ti, pi_, to, po, values, channels=names, sigma=s,
                                    source="test")  # fmt: skip


def test_from_angles_builds_the_directions_of_models_md():
    angles = [(10.0, 0.0, 35.5, 180.0), (80.0, 45.0, 0.0, 0.0), (45.0, -30.0, 60.0, 400.0)]
    ti, pi_, to, po = (np.array(a) for a in zip(*angles))
    m = Measurements.from_angles(ti, pi_, to, po, [1.0, 2.0, 3.0])
    for k, (a, b, c, d) in enumerate(angles):
        np.testing.assert_allclose(m.wi[k], direction(a, b), atol=1e-15)
        np.testing.assert_allclose(m.wo[k], direction(c, d), atol=1e-15)
    # The angles come back exactly as given, so that files round-trip.
    for given, back in zip((ti, pi_, to, po), m.angles()):
        np.testing.assert_array_equal(given, back)
    np.testing.assert_allclose(m.angles(degrees=False)[0], np.radians(ti), rtol=1e-15)
    assert m.channels == ("value",) and m.values.shape == (3, 1)


def test_directions_give_angles_with_azimuth_in_0_360():
    wi = [direction(30, -90), direction(60, 10)]
    wo = [direction(20, 190), direction(5, 370)]
    ti, pi_, _, po = Measurements(wi, wo, [1.0, 1.0]).angles()
    np.testing.assert_allclose(ti, [30, 60], atol=1e-12)
    np.testing.assert_allclose(pi_, [270, 10], atol=1e-12)
    np.testing.assert_allclose(po, [190, 10], atol=1e-9)


def test_default_channel_names_and_shapes():
    wi = wo = [[0, 0, 1.0]] * 4
    assert Measurements(wi, wo, np.ones(4)).channels == ("value",)
    m = Measurements(wi, wo, np.ones((4, 3)))
    assert m.channels == ("c0", "c1", "c2")
    assert (m.n, m.n_channels, len(m)) == (4, 3, 4)
    assert m.sigma is None


def test_arrays_are_copies_and_read_only():
    values = np.array([1.0, 2.0])
    wi = np.array([[0, 0, 1.0], [0, 0, 1.0]])
    m = Measurements(wi, wi, values, sigma=[0.1, 0.2])
    values[0] = 99.0
    wi[0, 2] = -1.0
    assert m.values[0, 0] == 1.0 and m.wi[0, 2] == 1.0
    from_angles = Measurements.from_angles([10.0], [0.0], [20.0], [180.0], [1.0])
    for array in (m.wi, m.wo, m.values, m.sigma, from_angles.angles()[0], from_angles.wo):
        with pytest.raises(ValueError):
            array[0] = 0.0
    with pytest.raises(AttributeError):
        m.values = np.zeros(2)
    with pytest.raises(AttributeError):
        m.anything = 1


def test_pickle_and_copy_keep_everything():
    m = sample()
    back = pickle.loads(pickle.dumps(m))
    for name in ("wi", "wo", "values", "sigma"):
        np.testing.assert_array_equal(getattr(back, name), getattr(m, name))
        assert not getattr(back, name).flags.writeable
    assert (back.channels, back.source, back.units) == (m.channels, m.source, m.units)
    np.testing.assert_array_equal(back.angles()[1], m.angles()[1])


def test_sigma_per_sample_applies_to_every_channel():
    m = Measurements([[0, 0, 1.0]] * 2, [[0, 0, 1.0]] * 2, np.ones((2, 3)), sigma=[0.1, 0.2])
    np.testing.assert_array_equal(m.sigma, [[0.1] * 3, [0.2] * 3])


def bad(match, **kwargs):
    base = dict(theta_i=[10, 20, 30, 40], phi_i=[0] * 4, theta_o=[10, 20, 30, 40], phi_o=[0] * 4,
                values=np.ones((4, 2)), channels=["a", "b"])  # fmt: skip
    base.update(kwargs)
    with pytest.raises(DataError, match=match) as info:
        Measurements.from_angles(**base)
    return info.value


def test_validation_messages_name_the_field_and_the_value():
    values = np.ones((4, 2))
    values[2, 1] = np.nan
    values[3, 0] = np.inf
    error = bad(r"2 non-finite .* values\[2, 1\] = nan", values=values)
    assert error.field == "values"
    assert bad(r"theta_o\[1\] = 181\.0 is outside \[0, 180\]", theta_o=[10, 181, 0, 0]).field == (
        "theta_o"
    )
    bad(r"theta_i\[0\] = -5\.0 is outside", theta_i=[-5, 0, 0, 0])
    bad(r"phi_i\[3\] = nan is not finite", phi_i=[0, 0, 0, np.nan])
    bad(r"phi_o has 3 entries but theta_i has 4", phi_o=[0, 0, 0])
    bad(r"values has 3 samples but there are 4", values=np.ones((3, 2)))
    bad(r"sigma\[1, 0\] = 0\.0", sigma=[[1, 1], [0, 1], [1, 1], [1, -1]])
    bad(r"2 entries are not", sigma=[[1, 1], [0, 1], [1, 1], [1, -1]])
    bad(r"1 entry is not, the first sigma\[3, 1\]", sigma=[[1, 1], [1, 1], [1, 1], [1, -1]])
    bad(r"values contain 1 non-finite number \(", values=[[1, 1], [1, 1], [np.nan, 1], [1, 1]])
    bad(r"is not finite; 2 entries are NaN", phi_i=[0, np.inf, 0, np.nan])
    bad(r"sigma has shape \(4, 3\)", sigma=np.ones((4, 3)))
    bad(r"\['a'\] appear more than once", channels=["a", "a"])
    bad(r"names 3 channel\(s\) but values have 2", channels=["a", "b", "c"])
    bad(r"channel name 'theta_i' is not allowed", channels=["theta_i", "b"])
    bad(r"channel name 'sigma_b' is not allowed", channels=["sigma_b", "b"])
    bad(r"channel name 'r g' is not allowed", channels=["r g", "b"])
    bad(r"empty", theta_i=[], phi_i=[], theta_o=[], phi_o=[], values=[])
    with pytest.raises(DataError, match=r"wi\[1\] has length 2"):
        Measurements([[0, 0, 1.0], [0, 0, 2.0]], [[0, 0, 1.0]] * 2, [1.0, 1.0])


def test_negative_values_are_kept_counted_and_reported():
    values = np.array([[0.5, -0.01], [-0.2, 0.3], [0.1, 0.2]])
    with pytest.warns(UserWarning, match=r"2 of 6 values are negative"):
        m = Measurements.from_angles([10] * 3, [0] * 3, [20] * 3, [180] * 3, values)
    assert m.negative_count == 2
    np.testing.assert_array_equal(m.values, values)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        # Derived data do not warn again.
        assert m.subset([0, 1]).negative_count == 2
        assert m.select_channels("c1").negative_count == 1


def test_below_horizon_pairs_are_kept_and_counted():
    m = Measurements.from_angles([10, 90, 30, 100], [0] * 4, [20, 20, 90, 10], [0] * 4, np.ones(4))
    assert m.n == 4
    assert m.below_horizon_count == 3
    # Exactly 90 degrees is on the horizon (z = 0), not 6e-17 above it.
    assert m.wi[1, 2] == 0.0 and m.wo[2, 2] == 0.0
    assert m.geometry().m == 1


def test_wavelengths_from_channel_names():
    wi = [[0, 0, 1.0]]
    assert Measurements(
        wi, wi, [[1, 2, 3]], ["400nm", "550.5nm", "700"]
    ).wavelengths().tolist() == [
        400.0,
        550.5,
        700.0,
    ]
    assert Measurements(wi, wi, [[1, 2]], ["400nm", "r"]).wavelengths() is None
    assert Measurements(wi, wi, [[1, 2, 3]], ["r", "g", "b"]).wavelengths() is None


def test_select_channels_reorders_and_checks():
    m = sample()
    sub = m.select_channels(["b", "r"])
    assert sub.channels == ("b", "r")
    np.testing.assert_array_equal(sub.values, m.values[:, [2, 0]])
    np.testing.assert_array_equal(sub.sigma, m.sigma[:, [2, 0]])
    with pytest.raises(DataError, match=r"unknown channel\(s\) \['x'\]; the channels are"):
        m.select_channels(["x"])


def rows(m):
    return {tuple(row) for row in np.column_stack([m.wi, m.wo, m.values]).tolist()}


def test_subsample_is_seeded_ordered_and_a_subset():
    m = sample(n=200)
    a, b, c = m.subsample(n=50, seed=1), m.subsample(n=50, seed=1), m.subsample(n=50, seed=2)
    np.testing.assert_array_equal(a.values, b.values)
    assert rows(a) != rows(c)
    assert rows(a) <= rows(m) and a.n == 50
    # Original order is kept: the indices of the kept rows increase.
    index = [int(np.flatnonzero((m.values == v).all(axis=1))[0]) for v in a.values]
    assert index == sorted(index)
    assert m.subsample(fraction=0.25).n == 50
    for kwargs in ({}, {"n": 10, "fraction": 0.1}, {"n": 0}, {"n": 201}, {"fraction": 1.5}):
        with pytest.raises(DataError):
            m.subsample(**kwargs)


def test_split_is_disjoint_complete_and_seeded():
    m = sample(n=100)
    train, test = m.split(test_fraction=0.3, seed=4)
    assert (train.n, test.n) == (70, 30)
    assert rows(train) & rows(test) == set()
    assert rows(train) | rows(test) == rows(m)
    again = m.split(test_fraction=0.3, seed=4)[1]
    np.testing.assert_array_equal(again.values, test.values)
    assert rows(m.split(test_fraction=0.3, seed=5)[1]) != rows(test)
    np.testing.assert_array_equal(test.sigma, test.values * 0.02)
    with pytest.raises(DataError, match="test_fraction"):
        m.split(test_fraction=1.0)
    with pytest.raises(DataError, match="empty train or test"):
        sample(n=2).split(test_fraction=0.1)


def test_geometry_is_built_once_and_matches_the_directions():
    m = sample()
    g = m.geometry()
    assert isinstance(g, Geometry) and m.geometry() is g
    np.testing.assert_array_equal(g.wi, m.wi)
    assert m.subsample(n=10).geometry() is not g


def test_to_dict_is_json_ready_and_summary_counts():
    m = sample(n=20)
    d = m.to_dict()
    json.dumps(d)
    assert d["n"] == 20 and d["channels"] == ["r", "g", "b"] and d["has_sigma"]
    full = m.to_dict(include_data=True)
    json.dumps(full)
    assert full["theta_i"] == m.angles()[0].tolist() and len(full["values"]) == 20
    assert "20 samples" in m.summary()


def test_spectral_to_xyz_and_srgb_go_through_brdffit_colour():
    colour = pytest.importorskip(
        "brdffit.data.colour", reason="brdffit/colour.py is not written yet"
    )
    wavelengths = np.arange(400.0, 701.0, 10.0)
    rng = np.random.default_rng(3)
    values = rng.uniform(0.0, 1.0, (20, wavelengths.size))
    sigma = rng.uniform(0.01, 0.05, values.shape)
    names = [f"{w:g}nm" for w in wavelengths]
    m = Measurements([[0, 0, 1.0]] * 20, [[0, 0, 1.0]] * 20, values, names, sigma)
    xyz = m.to_xyz()
    assert xyz.channels == ("X", "Y", "Z")
    np.testing.assert_allclose(xyz.values, colour.spectral_to_xyz(values, wavelengths), rtol=1e-12)
    # Independent errors through a linear map: variances add with squared weights.
    columns = [colour.spectral_to_xyz(np.eye(wavelengths.size)[[k]], wavelengths)[0]
               for k in range(wavelengths.size)]  # fmt: skip
    expected = np.sqrt(
        sum(np.outer(sigma[:, k] ** 2, columns[k] ** 2) for k in range(len(columns)))
    )
    np.testing.assert_allclose(xyz.sigma, expected, rtol=1e-12)
    rgb = m.to_srgb()
    assert rgb.channels == ("r", "g", "b")
    np.testing.assert_allclose(rgb.values, colour.xyz_to_srgb(xyz.values), rtol=1e-12, atol=1e-15)
    with pytest.raises(DataError, match="spectral channels"):
        sample().select_channels(["r", "g"]).to_xyz()
