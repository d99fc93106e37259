"""The misfit test's sample orders, sorted once per geometry (issue 13).

The runs test orders the samples by (theta_h, theta_d) and (theta_d, theta_h) on
every fit; the two orders depend on the directions only and are now sorted once
per :class:`~brdffit.data.geometry.Geometry` and the sign runs counted on int8
codes. The records must be those of the computation before, bit for bit:
:func:`reference` is that computation (per call: the angles of the kept samples,
two lexsorts, the runs of each column's signs), compared on data with ties of
both angles, below-horizon pairs, exact zeros, a NaN, weights of 0 and a real file.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from helpers import gonio_pairs, hemisphere_pairs, make_data, shared_file
from numpy.testing import assert_equal
from scipy.stats import norm

import brdffit
from brdffit.data.geometry import directions_from_angles
from brdffit.fitting import misfit
from brdffit.fitting.misfit import ALPHA, _message, misfit_test
from brdffit.fitting.runs import lexsort


def _reference_runs(z):
    out_r, out_mu, out_z = [], [], []
    for col in z.T:
        signs = col[col != 0] > 0
        n = signs.size
        n1 = int(signs.sum())
        n2 = n - n1
        runs = 1 + int(np.count_nonzero(signs[1:] != signs[:-1])) if n else 0
        mu = 2.0 * n1 * n2 / max(n, 1) + 1.0
        var = 2.0 * n1 * n2 * (2.0 * n1 * n2 - n) / max(n * n * (n - 1), 1)
        out_r.append(runs)
        out_mu.append(mu)
        out_z.append((mu - runs) / math.sqrt(var) if var > 0 else 0.0)
    return np.array(out_r), np.array(out_mu), np.array(out_z)


def reference(data, z, keep, n_params, chi2_known):
    """``misfit_test`` as it was before the orders were cached (commit 6f433e4), on the
    sort keys of the angles (:func:`test_the_keys_order_the_samples_by_their_angles`)."""
    theta_h, theta_d = misfit._keys(data)
    z, theta_h, theta_d = z[keep], theta_h[keep], theta_d[keep]
    c = z.shape[1]
    best = (-np.inf, 1.0, "theta_h")
    for name, order in (
        ("theta_h", np.lexsort((theta_d, theta_h))),
        ("theta_d", np.lexsort((theta_h, theta_d))),
    ):
        runs, expected, stat = _reference_runs(z[order])
        i = int(np.argmax(stat))
        if stat[i] > best[0]:
            best = (float(stat[i]), float(runs[i] / max(expected[i], 1.0)), name)
    threshold = misfit._upper_quantile(ALPHA / (2 * c))
    dof = max(z.size - n_params, 1)
    reduced = float(np.sum(z * z) / dof)
    chi2_bad = chi2_known and reduced > 1.0 + misfit._upper_quantile(ALPHA) * math.sqrt(2.0 / dof)
    detected = bool(best[0] > threshold or chi2_bad)
    return {
        "detected": detected,
        "runs_ratio": best[1],
        "runs_z": best[0],
        "threshold_z": threshold,
        "ordered_by": best[2],
        "reduced_chi2": reduced,
        "chi2_tested": bool(chi2_known),
        "refit_loss": None,
        "message": _message(detected, best, threshold, reduced, chi2_bad),
    }


def tied_pairs():
    """A coarse grid of angles, every pair twice, some below the horizon: ties of
    theta_h, of theta_d and of both (which the samples' order breaks)."""
    t = np.array([0.0, 20.0, 40.0, 60.0, 95.0])
    p = np.array([0.0, 90.0, 180.0, 270.0])
    ti, pi_, to, po = (a.ravel() for a in np.meshgrid(t, p, t, p, indexing="ij"))
    wi, wo = directions_from_angles(ti, pi_), directions_from_angles(to, po)
    return np.concatenate([wi, wi[::-1]]), np.concatenate([wo, wo[::-1]])


def cases():
    """(data, z) pairs: systematic and random residuals on three geometries."""
    rng = np.random.default_rng(3)
    data = make_data("ggx", {"kd": 0.1, "ks": 0.6, "alpha": 0.2, "f0": 0.04}, n=1200)
    ward = brdffit.get_model("ward").evaluate(
        data.wi, data.wo, {"kd": 0.1, "ks": 0.5, "alpha": 0.3}
    )
    systematic = (ward - np.asarray(data.values).reshape(ward.shape)) / 0.01
    out = [(data, systematic.reshape(-1, 1)), (data, rng.standard_normal((data.n, 1)))]
    for wi, wo in (tied_pairs(), hemisphere_pairs(700, seed=4), gonio_pairs(500, seed=5)):
        d = brdffit.Measurements(wi, wo, np.ones((len(wi), 3)))
        z = np.round(rng.standard_normal((d.n, 3)), 1)  # exact zeros
        z[: d.n // 2, 0] = np.abs(z[: d.n // 2, 0])  # one channel systematic
        z[5, 1] = np.nan
        out.append((d, z))
    return out


@pytest.mark.parametrize("index", range(5))
def test_the_records_are_those_of_the_computation_before(index):
    data, z = cases()[index]
    rng = np.random.default_rng(index)
    some = rng.uniform(size=data.n) > 0.3
    for keep in (np.ones(data.n, dtype=bool), some, some):  # twice: from the cache
        for n_params, chi2_known in ((4, True), (6, False)):
            got = misfit_test(data, z, keep, n_params, chi2_known)
            want = reference(data, z, keep, n_params, chi2_known)
            assert_equal(got, want)  # exactly; a NaN (the NaN residual's chi2) equals NaN


def test_the_records_on_a_real_file_are_those_before():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the reader's notes
        data = brdffit.read(shared_file("cornell", "garnet_red.astm"))
    y = np.asarray(data.values, dtype=float)
    z = (y - y.mean(axis=0)) / y.std(axis=0)  # systematic: the lobe itself
    keep = np.arange(data.n) % 7 != 0
    for k in (np.ones(data.n, dtype=bool), keep):
        assert_equal(misfit_test(data, z, k, 5, True), reference(data, z, k, 5, True))


@pytest.mark.parametrize("runs_samples", [1000, 1500, 3000])
def test_more_samples_than_runs_samples_test_a_systematic_sample(monkeypatch, runs_samples):
    """Of more than RUNS_SAMPLES samples the runs test takes one in k (the smallest k
    that is enough): the record of the test on those samples, the reduced chi-square
    on all of them, and a message that says so."""
    data, z = cases()[1]
    assert data.n > 1000
    monkeypatch.setattr(misfit, "RUNS_SAMPLES", runs_samples)
    step = -(-data.n // runs_samples)
    keep = np.random.default_rng(4).uniform(size=data.n) > 0.2
    got = misfit_test(data, z, keep, 5, True)
    rows = np.arange(0, data.n, step)
    want = reference(data.subset(rows), z[rows], keep[rows], 5, True)
    full = reference(data, z, keep, 5, True)
    for name in ("runs_ratio", "runs_z", "ordered_by"):
        assert got[name] == want[name]
    assert got["reduced_chi2"] == full["reduced_chi2"]
    sample = f"on one in {step} of the {data.n:,} samples"
    assert (sample in got["message"]) == (step > 1)


def test_a_second_test_on_the_same_geometry_does_not_sort_again(monkeypatch):
    wi, wo = tied_pairs()
    data = brdffit.Measurements(wi, wo, np.ones((len(wi), 2)))
    rng = np.random.default_rng(8)
    noise = rng.standard_normal((data.n, 2))
    lobe = np.cos(np.arange(data.n) / 40.0)[:, None] + 0.1 * noise
    every, some = np.ones(data.n, dtype=bool), np.arange(data.n) % 3 != 0
    other = data.subset(np.arange(data.n)[::-1])  # other directions' own orders
    runs = [(data, noise, every), (data, lobe, some), (other, lobe, every), (data, lobe, every)]
    want = [reference(d, z, k, 4, True) for d, z, k in runs]
    calls = []
    angles = misfit._keys
    monkeypatch.setattr(misfit, "_keys", lambda d, step=1: calls.append(d) or angles(d, step))
    for (d, z, k), w in zip(runs, want):
        assert_equal(misfit_test(d, z, k, 4, True), w)
    assert [want[0]["detected"], want[3]["detected"]] == [False, True]
    assert calls == [data, other]  # each geometry's angles once


def test_a_fit_and_its_refit_sort_once(monkeypatch):
    calls = []
    angles = misfit._keys
    monkeypatch.setattr(
        misfit, "_keys", lambda data, step=1: calls.append(data) or angles(data, step)
    )
    data = make_data("ward", {"kd": 0.2, "ks": 0.3, "alpha": 0.15}, n=600)
    for model in ("ward", "blinn"):
        result = brdffit.fit(data, model, loss="l2", global_evals=200, local_evals=200)
        assert result.misfit["ordered_by"] in ("theta_h", "theta_d")
    assert len(calls) == 1


@pytest.mark.parametrize("pairs", [tied_pairs, lambda: hemisphere_pairs(900, seed=6)])
def test_the_keys_order_the_samples_by_their_angles(pairs):
    """The orders sort by the angles themselves, computed here from their definitions
    (arccos of N.H and of L.H, H the unit half vector), ties by the other angle."""
    wi, wo = pairs()
    h = wi + wo
    length = np.linalg.norm(h, axis=1, keepdims=True)
    wi, wo, h = wi[length[:, 0] > 1e-6], wo[length[:, 0] > 1e-6], h / np.maximum(length, 1e-300)
    h = h[length[:, 0] > 1e-6]  # L = -V: no half vector, no angles
    data = brdffit.Measurements(wi, wo, np.ones((len(wi), 1)))
    theta_h = np.arccos(np.clip(h[:, 2], -1, 1))
    theta_d = np.arccos(np.clip(np.sum(wi * h, axis=1), -1, 1))
    by_h, by_d = misfit._sort_orders(data)
    key_h, key_d = misfit._keys(data)
    assert sorted(by_h) == list(range(data.n)) and sorted(by_d) == list(range(data.n))
    for first, second, key, order in ((theta_h, theta_d, key_h, by_h),
                                      (theta_d, theta_h, key_d, by_d)):  # fmt: skip
        assert np.all(np.diff(first[order]) >= -1e-12)
        tied = np.diff(key[order]) == 0  # equal keys: equal angles, by the other angle
        assert tied.sum() > (10 if pairs is tied_pairs else -1)
        assert np.all(np.diff(second[order])[tied] >= -1e-12)


def test_the_complex_sort_is_numpys_lexsort():
    """Ties of the first key, of both keys (kept in the samples' order), negative
    zeros and keys of every sign: the same order as ``np.lexsort``."""
    rng = np.random.default_rng(3)
    primary = rng.integers(-5, 5, 20_000) * 0.25
    secondary = rng.integers(-3, 3, 20_000) * 0.5
    primary[::7] = -0.0
    for a, b in ((primary, secondary), (secondary, primary)):
        assert np.array_equal(lexsort(a, b), np.lexsort((b, a)))
    smooth = rng.random(5000)
    assert np.array_equal(lexsort(smooth, -smooth), np.argsort(smooth))


@pytest.mark.parametrize("p", [ALPHA, ALPHA / 2, ALPHA / 6, ALPHA / 62, 0.05, 0.5])
def test_the_threshold_is_the_normal_upper_quantile(p):
    """The thresholds come from the standard library (scipy.stats is not imported with
    brdffit); they are scipy's ``norm.isf`` to round-off."""
    assert misfit._upper_quantile(p) == pytest.approx(norm.isf(p), rel=1e-14, abs=1e-15)


@pytest.mark.parametrize("below", [False, True])
def test_the_keys_of_every_step_th_sample_are_those_of_all_the_samples(below):
    """``_keys(data, step)``, which the runs test's subsample sorts (it negates only
    the samples it keeps), is every ``step``-th key of all the samples, bit for bit,
    both where the geometry's cosines serve (every pair above the horizon) and where
    the keys come from ``L + V`` (a pair below it)."""
    wi, wo = hemisphere_pairs(3001, seed=5)
    if below:
        wo = wo.copy()
        wo[10] = (0.6, 0.0, -0.8)
    data = brdffit.Measurements(wi, wo, np.ones((len(wi), 1)))
    assert data.geometry().all_valid is not below
    every = misfit._keys(data)
    for step in (1, 3, 4, 7):
        for part, whole in zip(misfit._keys(data, step), every):
            assert_equal(part, whole[::step])
