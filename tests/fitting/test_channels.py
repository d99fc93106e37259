"""Per-channel reductions (brdffit.fitting.channels) equal numpy's, and the losses'
per-channel scale uses them."""

import math

import numpy as np
import pytest

from brdffit.fitting import channels as channel_module
from brdffit.fitting.channels import abs_max_by_channel, dot_by_channel
from brdffit.fitting.losses import LossContext


@pytest.fixture(params=["transposed", "fold"])
def path(request, monkeypatch):
    """Both ways of abs_max_by_channel: small arrays' transposed copy, and the fold."""
    if request.param == "fold":
        monkeypatch.setattr(channel_module, "TRANSPOSED", -1)
    return request.param


@pytest.mark.parametrize("rows", [1, 7, 255, 256, 257, 1000, 100_003])
@pytest.mark.parametrize("channels", [1, 3, 31])
def test_abs_max_by_channel_is_numpys(rows, channels, path):
    a = np.random.default_rng(rows * channels).normal(size=(rows, channels))
    np.testing.assert_array_equal(abs_max_by_channel(a), np.abs(a).max(axis=0))


def test_abs_max_by_channel_finds_the_extreme_in_the_remainder_and_keeps_nan(path):
    a = np.random.default_rng(1).normal(size=(1000, 3))
    a[-1, 0] = -50.0  # in the rows after the last whole fold
    a[3, 2] = np.nan
    out = abs_max_by_channel(a)
    assert out[0] == 50.0
    assert out[1] == np.abs(a[:, 1]).max()
    assert np.isnan(out[2])


def test_abs_max_by_channel_of_a_strided_view(path):
    a = np.random.default_rng(2).normal(size=(3000, 6))[:, ::2]
    np.testing.assert_array_equal(abs_max_by_channel(a), np.abs(a).max(axis=0))


def test_y_scale_uses_it():
    y = np.random.default_rng(3).normal(size=(5000, 3))
    y[:, 1] = 0.0
    ctx = LossContext(cos_i=np.ones(5000), y=y, sigma=None, weights=None)
    expected = np.maximum(np.abs(y).max(axis=0), 1e-300)
    np.testing.assert_array_equal(ctx.y_scale, expected)


@pytest.mark.parametrize("rows", [3, 255, 256, 1000, 40_001])
def test_dot_by_channel_is_the_einsum(rows):
    rng = np.random.default_rng(rows)
    a, b = rng.normal(size=(rows, 3)), rng.normal(size=(rows, 3))
    got = dot_by_channel(a, b)
    exact = np.array([math.fsum(a[:, c] * b[:, c]) for c in range(3)])
    np.testing.assert_allclose(got, exact, rtol=1e-12, atol=1e-12 * np.abs(a * b).sum())
    strided = rng.normal(size=(rows, 6))[:, ::2]
    np.testing.assert_array_equal(
        dot_by_channel(strided, strided), np.einsum("mc,mc->c", strided, strided)
    )


@pytest.mark.parametrize("m, c", [(1, 1), (5, 3), (600, 3), (1439, 31), (21000, 3)])
def test_the_transposed_maximum_is_numpy_s_and_the_fold_s(m, c, monkeypatch):
    rng = np.random.default_rng(m + c)
    a = rng.standard_normal((m, c)) * 10.0 ** rng.uniform(-300, 300, (m, c))
    a[rng.random((m, c)) < 0.05] = rng.choice([np.nan, np.inf, -np.inf, -0.0, 0.0])
    got = channel_module.abs_max_by_channel(a)
    np.testing.assert_array_equal(got, np.abs(a).max(axis=0))
    monkeypatch.setattr(channel_module, "TRANSPOSED", -1)  # the fold (or the plain reductions)
    fold = channel_module.abs_max_by_channel(a)  # equal but for the sign of a zero, which every
    np.testing.assert_array_equal(np.maximum(got, 1e-300), np.maximum(fold, 1e-300))  # user clamps
