"""The coarse-to-fine schedule of large fits, the prediction formed once, and the
metrics from one residual (issue 13)."""

from __future__ import annotations

import gc
import math
import weakref

import numpy as np
import pytest
from helpers import calls_of, make_data

from brdffit import FitError, Measurements, fit, kernels
from brdffit.fitting import sums
from brdffit.fitting.losses import LOSSES, LossContext
from brdffit.fitting.options import COARSE_ABOVE
from brdffit.fitting.problem import Problem
from brdffit.fitting.result import metrics_of
from brdffit.fitting.schedule import BINS, stratified_rows, subproblem

WARD = {"kd": [0.1, 0.2], "ks": [0.3, 0.5], "alpha": 0.12}
#: The schedule on a small problem: 6000 samples searched on a subsample of 1500.
SMALL_SCHEDULE = {"coarse_above": 4000, "coarse_samples": 1500}


@pytest.fixture(scope="module")
def ward_data():
    return make_data("ward", WARD, n=6000, channels=["r", "g"], seed=4)


def _old_metrics(pred, y, ctx, n_params):
    """The metrics as they were computed before issue 13: every loss's own value."""
    out = {}
    for name, loss in LOSSES.items():
        if (loss.needs_sigma and ctx.sigma is None) or (
            loss.needs_noise and ctx.noise_sigma is None
        ):
            continue
        out[name] = loss.value(pred, ctx)
    resid = pred - y
    n = y.size
    rss = float(np.sum(resid * resid))
    out["rmse"] = math.sqrt(rss / n)
    base = out["chi2"] if ctx.sigma is not None else n * math.log(max(rss, 1e-300) / n)
    out["aic"] = base + 2 * n_params
    out["bic"] = base + n_params * math.log(n)
    return out


def _context(data, pred, y, extras: str, seed: int) -> LossContext:
    """The loss context of ``data`` with ``extras``: none, random weights, or sigma and
    a noise level."""
    rng = np.random.default_rng(seed)
    both = extras == "sigma and noise"
    return LossContext(
        cos_i=np.maximum(data.wi[:, 2], 0.0),
        y=y,
        sigma=0.01 + 0.05 * np.abs(y) if both else None,
        weights=rng.uniform(0.0, 2.0, data.n) if extras == "weights" else None,
        noise_sigma=0.02 + 0.1 * np.abs(pred) if both else None,
    )


@pytest.mark.parametrize("compiled", [False, True], ids=["numpy", "compiled"])
@pytest.mark.parametrize("block", [16_384, 1000])
@pytest.mark.parametrize("extras", ["none", "weights", "sigma and noise"])
def test_metrics_from_one_residual_equal_the_old_formula(
    ward_data, extras, block, compiled, monkeypatch
):
    """The metrics summed over blocks of samples (several blocks with 1000) equal every
    loss's own value on all the samples at once, by numpy and by the compiled sums of
    the linear losses (brdffit.kernels.loops_sums, used on large data)."""
    if compiled and not kernels.available():
        pytest.skip("numba is not installed: no compiled sums")
    monkeypatch.setattr(sums, "BLOCK", block)
    calls = []
    if compiled:
        monkeypatch.setattr(kernels, "_state", {**kernels._state, "on": True})
        calls = calls_of(monkeypatch, sums, "_compiled")
    result = fit(ward_data, "ward", loss="l2")
    problem = Problem(ward_data, "ward")
    pred = np.asarray(problem.predict(dict(result.params)))
    y = np.asarray(ward_data.values)
    ctx = _context(ward_data, pred, y, extras, seed=1)
    new, old = metrics_of(pred, y, ctx, 7), _old_metrics(pred, y, ctx, 7)
    assert sorted(new) == sorted(old)
    assert len(old) >= 8
    for name in old:
        assert new[name] == pytest.approx(old[name], rel=1e-12, abs=1e-300), name
    assert bool(calls) == compiled


class _Counting:
    """A model that counts its evaluations."""

    def __init__(self, model, calls):
        self._model, self._calls = model, calls

    def __getattr__(self, name):
        return getattr(self._model, name)

    def evaluate_prepared(self, *args, **kwargs):
        self._calls.append(1)
        return self._model.evaluate_prepared(*args, **kwargs)


def test_the_prediction_at_the_same_params_is_formed_once(ward_data):
    problem = Problem(ward_data, "ward")
    params = {"kd": np.array([0.1, 0.2]), "ks": np.array([0.3, 0.5]), "alpha": 0.12}
    first = problem.predict(params)
    calls = []
    problem.model = _Counting(problem.model, calls)
    assert problem.predict(dict(params)) is first and not calls
    assert not first.flags.writeable
    moved = problem.predict({**params, "alpha": 0.12000000001})
    assert calls == [1] and moved is not first
    assert not np.array_equal(moved, first)
    # A changed value in one channel is another prediction too.
    other = problem.predict({**params, "ks": np.array([0.3, 0.5000001])})
    assert calls == [1, 1] and not np.array_equal(other[:, 1], first[:, 1])
    # The problem does not keep a prediction alive that no caller holds.
    gone = weakref.ref(other)
    del other
    gc.collect()
    assert gone() is None
    problem.predict({**params, "ks": np.array([0.3, 0.5000001])})
    assert calls == [1, 1, 1]


def _cells_of(g) -> np.ndarray:
    h = g.wi + g.wo
    norm = np.linalg.norm(h, axis=1)
    theta_h, theta_d = np.arccos(h[:, 2] / norm), np.arccos(np.clip(norm / 2, 0, 1))
    cell = np.minimum((theta_h / (np.pi / 2) * BINS).astype(int), BINS - 1) * BINS
    return cell + np.minimum((theta_d / (np.pi / 2) * BINS).astype(int), BINS - 1)


def test_stratified_rows_give_each_cell_its_allocation_and_keep_the_seed():
    """Half proportional, half Neyman (cell size times the spread of y): every cell of
    the (theta_h, theta_d) grid within one sample of its allocation, weighted by the
    inverse of its probability (computed here from the definition)."""
    data = make_data("ward", {"kd": 0.1, "ks": 0.3, "alpha": 0.12}, n=20000, seed=2)
    problem = Problem(data, "ward", loss="l2")
    g = problem.geometry
    rows, weights = stratified_rows(problem, 2000, seed=5)
    assert abs(rows.size - 2000) <= 1 and np.all(np.diff(rows) > 0) and rows[-1] < g.m
    assert np.array_equal(rows, stratified_rows(problem, 2000, seed=5)[0])
    assert not np.array_equal(rows, stratified_rows(problem, 2000, seed=6)[0])
    cell = _cells_of(g)
    counts = np.bincount(cell, minlength=BINS * BINS)
    y = np.asarray(data.values, dtype=float)
    spread = np.zeros(BINS * BINS)
    for h in np.flatnonzero(counts >= 2):
        spread[h] = np.sqrt(np.var(y[cell == h], axis=0, ddof=1).sum())
    share = 0.5 * counts / counts.sum() + 0.5 * counts * spread / np.sum(counts * spread)
    allocation = 2000 * share
    while np.any(allocation > counts + 1e-9):  # cells that would get more give it back
        full = allocation >= counts - 1e-9
        rest = (2000 - counts[full].sum()) * share / share[~full].sum()
        allocation = np.where(full, counts, rest)
    drawn = np.bincount(cell[rows], minlength=BINS * BINS)
    assert np.max(np.abs(drawn - allocation)) <= 1.0 + 1e-9
    expected = counts[cell[rows]] / allocation[cell[rows]]
    np.testing.assert_allclose(weights, expected / expected.mean(), rtol=1e-12)
    # The highlight's cells (the largest spread) get more than their proportional share.
    top = np.argsort(counts * spread)[-5:]
    assert np.all(drawn[top] > counts[top] * 2000 / g.m)


def test_targets_without_spread_draw_in_proportion(ward_data):
    """Where no cell's targets vary, Neyman's half is the proportional half: every cell
    its share, every weight 1."""
    flat = Measurements(ward_data.wi, ward_data.wo, np.full(ward_data.values.shape, 0.25))
    problem = Problem(flat, "ward", loss="l2")
    rows, weights = stratified_rows(problem, 1500, seed=1)
    cell = _cells_of(problem.geometry)
    share = np.bincount(cell, minlength=BINS * BINS) * 1500 / flat.n
    drawn = np.bincount(cell[rows], minlength=BINS * BINS)
    assert np.max(np.abs(drawn - share)) <= 1.0 + 1e-9
    np.testing.assert_allclose(weights, 1.0, rtol=1e-12)


def test_subproblem_keeps_weights_noise_and_fixed_of_the_rows(ward_data):
    weights = np.linspace(0.5, 2.0, ward_data.n)
    problem = Problem(ward_data, "ward", loss="mixed", weights=weights, fixed={"alpha": 0.2})
    problem = problem.reweighted(np.full((ward_data.n, 2), 3.0))
    rows = np.array([0, 5, 17, 400])
    index = np.flatnonzero(problem.geometry.valid)[rows]
    sub = subproblem(problem, rows)
    assert sub.data.n == 4 or sub.geometry.m == 4
    assert np.array_equal(sub.data.values, ward_data.values[index])
    assert np.array_equal(sub.user_weights, weights[index])
    drawn = subproblem(problem, rows, np.array([1.0, 2.0, 0.5, 1.0]))
    assert np.array_equal(drawn.user_weights, weights[index] * [1.0, 2.0, 0.5, 1.0])
    assert np.all(sub.noise_sigma == 3.0) and sub.fixed["alpha"] == 0.2
    assert sub.loss.name == "mixed" and sub.energy is None


def test_large_data_run_coarse_to_fine_and_answer_the_full_minimum(ward_data):
    full = fit(ward_data, "ward", loss="l2", coarse_above=10**9)
    staged = fit(ward_data, "ward", loss="l2", **SMALL_SCHEDULE)
    assert "coarse to fine" not in full.message
    assert "coarse to fine: " in staged.message and "of the 6,000 samples" in staged.message
    assert staged.options["coarse_above"] == 4000 and staged.options["coarse_samples"] == 1500
    assert staged.converged and staged.n_samples == 6000
    assert staged.params["alpha"] == pytest.approx(full.params["alpha"], rel=1e-5)
    assert np.allclose(staged.params["ks"], full.params["ks"], rtol=1e-5)
    assert staged.loss == pytest.approx(full.loss, rel=1e-9)
    for name in ("l2", "rmse", "aic"):
        assert staged.metrics[name] == pytest.approx(full.metrics[name], rel=1e-9)


def test_coarse_to_fine_with_the_default_loss_weights_and_a_start(ward_data):
    """The mixed loss's reweighting rounds and user weights go through the schedule."""
    weights = np.where(np.arange(ward_data.n) % 3 == 0, 0.0, 1.0)
    options = {"weights": weights, "start": {"alpha": 0.3}}
    full = fit(ward_data, "ward", coarse_above=10**9, **options)
    staged = fit(ward_data, "ward", **SMALL_SCHEDULE, **options)
    assert full.noise["model"] == staged.noise["model"] == "mixed"
    assert "coarse to fine" in staged.message
    assert staged.params["alpha"] == pytest.approx(full.params["alpha"], rel=1e-4)
    assert staged.noise["b"] == pytest.approx(full.noise["b"], rel=1e-3)


def test_small_data_run_as_without_the_schedule(ward_data):
    """At or below coarse_above (and by default, at or below 50,000 samples) nothing changes."""
    at = fit(ward_data, "ward", loss="l2", coarse_above=6000, coarse_samples=1500)
    off = fit(ward_data, "ward", loss="l2", coarse_above=10**9)
    assert at.n_evals == off.n_evals and at.loss == off.loss
    assert at.params["alpha"] == off.params["alpha"]
    default = fit(ward_data, "ward", loss="l2")
    assert default.n_evals == off.n_evals and "coarse to fine" not in default.message
    assert default.options["coarse_above"] == COARSE_ABOVE == 50_000


def test_a_budget_used_up_on_the_subsample_still_answers_on_all_samples(ward_data):
    result = fit(ward_data, "ward", loss="l2", max_evals=30, **SMALL_SCHEDULE)
    assert not result.converged and "evaluation budget used up" in result.message
    assert result.n_evals == 31  # the subsample's 30, and its best point on all samples
    assert result.loss == pytest.approx(result.metrics["l2"], rel=1e-9)


@pytest.mark.parametrize(
    ("name", "value", "needs"),
    [
        ("coarse_samples", 999, "a whole number >= 1000"),
        ("coarse_samples", 2.5e4, "a whole number >= 1000"),
        ("coarse_above", -1, "a whole number >= 0"),
        ("coarse_above", True, "a whole number >= 0"),
    ],
)
def test_schedule_options_are_checked(ward_data, name, value, needs):
    with pytest.raises(FitError, match=f"{name}={value!r} must be {needs}") as info:
        fit(ward_data, "ward", **{name: value})
    assert info.value.field == name


def test_a_subsample_larger_than_the_data_is_all_the_data():
    data = make_data("blinn", {"kd": 0.2, "ks": 1.0, "n": 40.0}, n=1200, seed=3)
    staged = fit(data, "blinn", loss="l2", coarse_above=1000, coarse_samples=5000)
    plain = fit(data, "blinn", loss="l2", coarse_above=10**9)
    assert isinstance(staged.n_samples, int) and "coarse to fine" not in staged.message
    assert staged.n_evals == plain.n_evals


def test_invalid_samples_are_left_out_of_the_subsample():
    data = make_data("ward", {"kd": 0.1, "ks": 0.3, "alpha": 0.12}, n=6000, seed=6)
    wo = np.array(data.wo)
    wo[::4, 2] = -np.abs(wo[::4, 2])  # a quarter below the horizon
    below = Measurements(data.wi, wo, data.values)
    problem = Problem(below, "ward")
    sub = subproblem(problem, *stratified_rows(problem, 1500, seed=0))
    assert sub.geometry.all_valid and abs(sub.geometry.m - 1500) <= 1
    result = fit(below, "ward", loss="l2", **SMALL_SCHEDULE)
    assert "of the 4,500 samples" in result.message and result.converged


@pytest.mark.skipif(not kernels.available(), reason="numba is not installed: no compiled sums")
@pytest.mark.parametrize("channels", [["r", "g", "b"], ["y"], ["a", "b", "c", "d"]])
@pytest.mark.parametrize("extras", ["none", "weights", "sigma and noise"])
def test_the_compiled_metrics_of_rgb_one_and_four_channels_equal_the_old_formula(channels, extras):
    """The compiled pass unrolls three channels (RGB) and loops over others: each way,
    with negative values (under the log loss's floor), every loss's own value."""
    params = {"kd": [0.1] * len(channels), "ks": [0.4] * len(channels), "alpha": 0.2}
    data = make_data("ward", params, n=5000, channels=channels, seed=9)
    pred = np.asarray(Problem(data, "ward").predict(params))
    y = np.asarray(data.values).reshape(pred.shape).copy()
    y[::97] = -3.0 * np.abs(y[::97]) - 2.0  # 1 + y cos below 1e-12 at some
    ctx = _context(data, pred, y, extras, seed=2)
    with kernels.use(True):
        new = metrics_of(pred, y, ctx, 5)
    old = _old_metrics(pred, y, ctx, 5)
    assert sorted(new) == sorted(old)
    for name in old:
        assert new[name] == pytest.approx(old[name], rel=1e-12, abs=1e-300), name


def test_the_fits_blocks_are_whole_blocks_of_the_compiled_sums():
    """The compiled sums add blocks of loops_sums.BLOCK from each call's ``start``; the
    fit calls them every sums.BLOCK samples, so for its blocks to be the same blocks
    whatever the call (the sums' rounding with them) one must divide the other."""
    if not kernels.available():
        pytest.skip("numba is not installed: no compiled sums")
    from brdffit.kernels import loops_sums

    assert sums.BLOCK % loops_sums.BLOCK == 0, (sums.BLOCK, loops_sums.BLOCK)
