"""The schedule's stratified draw compiled (brdffit.kernels.loops_schedule): the same
rows and weights as the numpy draw, bit for bit (issue 13)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import NEEDS_KERNELS, calls_of, hemisphere_pairs, make_data

import brdffit
from brdffit import Measurements, kernels
from brdffit.fitting import schedule
from brdffit.fitting.problem import Problem

pytestmark = NEEDS_KERNELS


@pytest.fixture
def compiled_calls(monkeypatch):
    """The calls of the compiled draw's walk (to tell which path ran)."""
    from brdffit.kernels import loops_schedule

    return calls_of(monkeypatch, loops_schedule, "draw")


def _both(geometry, targets, size, seed, calls) -> tuple:
    """The numpy draw and the compiled one (which must have run)."""
    before = len(calls)
    with kernels.use(False):
        numpy_draw = schedule._draw(geometry, targets, size, seed)
    assert len(calls) == before
    with kernels.use(True):
        compiled_draw = schedule._draw(geometry, targets, size, seed)
    assert len(calls) == before + 1
    return numpy_draw, compiled_draw


def _assert_equal(numpy_draw, compiled_draw):
    assert numpy_draw[0].size > 0
    assert np.array_equal(numpy_draw[0], compiled_draw[0])
    assert np.array_equal(numpy_draw[1], compiled_draw[1])
    assert compiled_draw[0].dtype.kind == "i" and compiled_draw[1].dtype == float


def _cells_and_probability(geometry, targets, size):
    """The numpy path's cell counts and the cells' inclusion probabilities."""
    cell = schedule._cells(geometry)
    counts = np.bincount(cell, minlength=schedule.BINS**2).astype(float)
    return counts, schedule._probability(size, counts, schedule._spread(cell, targets))


@pytest.fixture(scope="module")
def merl():
    """A whole MERL file's geometry (1,096,216 pairs), blinn with 1 % noise, RGB."""
    params = {"kd": [0.1, 0.08, 0.05], "ks": [0.6, 0.5, 0.4], "n": 80.0}
    data = brdffit.synthesize("blinn", params, geometry="merl", noise=0.01, seed=7)
    problem = Problem(data, "blinn", loss="l2")
    return problem.geometry, schedule._targets(problem)


@pytest.mark.parametrize(("size", "seed"), [(20_000, 0), (20_000, 1), (1000, 2), (400_000, 3)])
def test_the_compiled_draw_is_the_numpy_draw_on_a_merl_file(merl, size, seed, compiled_calls):
    geometry, targets = merl
    assert geometry.m == 1_096_216 and targets.shape == (geometry.m, 3)
    numpy_draw, compiled_draw = _both(geometry, targets, size, seed, compiled_calls)
    _assert_equal(numpy_draw, compiled_draw)
    assert abs(numpy_draw[0].size - size) <= 1


def _random_targets(n: int, channels: int, seed: int) -> np.ndarray:
    """Targets with a narrow peak (a few cells of large spread), and non-finite ones."""
    rng = np.random.default_rng(seed)
    t = rng.lognormal(0.0, 1.0, (n, channels)) * np.where(rng.random((n, 1)) < 0.01, 1e3, 1.0)
    t[rng.integers(0, n, 5), rng.integers(0, channels, 5)] = np.nan
    t[rng.integers(0, n, 3), 0] = np.inf
    return t


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize(("n", "channels"), [(30_000, 3), (12_000, 1), (3000, 2)])
def test_the_compiled_draw_is_the_numpy_draw_on_random_geometries(n, channels, seed,
                                                                  compiled_calls):  # fmt: skip
    """Random pairs over the hemisphere, sizes from a few pairs a cell to all of them
    (every cell's probability 1), 1-D targets too."""
    wi, wo = hemisphere_pairs(n, seed)
    geometry = Measurements(wi, wo, np.ones(len(wi))).geometry()
    targets = _random_targets(geometry.m, channels, seed)
    if channels == 1:
        targets = targets[:, 0]
    for size in (1000, geometry.m // 3, geometry.m - 7, geometry.m):
        _assert_equal(*_both(geometry, targets, size, seed + size, compiled_calls))
    counts, probability = _cells_and_probability(geometry, targets, geometry.m)
    assert np.all(probability[counts > 0] == 1.0) and np.any(counts == 0)


def test_empty_cells_and_cells_of_probability_one_draw_the_same(compiled_calls):
    """Pairs near the mirror direction leave most cells empty; a peak of large spread
    in small cells caps their allocation at all their pairs (probability 1)."""
    data = make_data("ward", {"kd": 0.1, "ks": 0.3, "alpha": 0.05}, n=20_000, seed=3)
    geometry = data.geometry()
    narrow = geometry.cos_h > np.cos(0.35)
    near = Measurements(data.wi[narrow], data.wo[narrow], data.values[narrow])
    geometry = near.geometry()
    targets = np.asarray(near.values, dtype=float).reshape(geometry.m, -1).copy()
    in_small = np.bincount(schedule._cells(geometry))[schedule._cells(geometry)] <= 30
    spread = np.random.default_rng(0).lognormal(0.0, 2.0, (in_small.sum(), 1))
    targets[in_small] *= 100.0 * spread  # Neyman's rule would give them more than all
    counts, probability = _cells_and_probability(geometry, targets, 3000)
    assert np.sum(counts == 0) > schedule.BINS**2 // 2
    assert np.any((probability == 1.0) & (counts > 1)) and np.any(probability < 1.0)
    for seed in range(4):
        _assert_equal(*_both(geometry, targets, 3000, seed, compiled_calls))
    flat = np.full_like(targets, 0.25)  # no spread anywhere: the proportional draw
    _assert_equal(*_both(geometry, flat, 3000, 0, compiled_calls))


def test_the_compiled_draw_runs_from_min_pairs_on(monkeypatch, compiled_calls):
    """By size (the default): numpy below kernels.MIN_PAIRS pairs, compiled from it."""
    monkeypatch.setattr(kernels, "_state", {**kernels._state, "on": None})
    for n, compiled in [(kernels.MIN_PAIRS - 100, False), (kernels.MIN_PAIRS + 100, True)]:
        wi, wo = hemisphere_pairs(n, 5, grazing=False)
        geometry = Measurements(wi, wo, np.ones(n)).geometry()
        before = len(compiled_calls)
        rows, weights = schedule._draw(geometry, _random_targets(n, 3, 5), 2000, 0)
        assert abs(rows.size - 2000) <= 1 and weights.mean() == pytest.approx(1.0)
        assert (len(compiled_calls) > before) == compiled


@pytest.mark.parametrize("start", [0.0, 0.5, 0.875])
def test_a_running_sum_equal_to_a_target_picks_that_pair(start):
    """Probabilities of a few bits sum exactly, so the running sum meets ``start + k``
    at some pairs: the walk picks that pair, as np.searchsorted (side 'left') does."""
    from brdffit.kernels import loops_schedule

    rng = np.random.default_rng(1)
    probability = rng.choice([0.125, 0.25, 0.5, 1.0], 16)
    counts = rng.integers(0, 40, 16) * (np.arange(16) % 5 != 2)  # some cells empty
    cell = rng.permutation(np.repeat(np.arange(16), counts)).astype(np.int16)
    rows, running = loops_schedule.draw(cell, probability, counts, start)
    order = np.argsort(cell, kind="stable")
    total = np.cumsum(probability[cell[order]])
    targets = start + np.arange(int(total[-1] - start) + 1)
    picks = np.searchsorted(total, targets)
    assert running == total[-1] and np.isin(targets, total).sum() >= 10
    assert np.array_equal(rows[: int(running - start) + 1], order[picks[picks < len(order)]])
