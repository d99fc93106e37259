"""The identifiability check evaluates the model on the samples it uses only (issue 13).

On large data the Fisher check keeps a seeded subset of the samples
(:data:`brdffit.fitting.identifiability.MAX_ENTRIES`). The first test failed before:
every evaluation of its Jacobian ran on all the samples above the horizon and the
subset was taken afterwards (on a whole MERL file, six evaluations of 1.1 M pairs).
"""

from __future__ import annotations

import numpy as np
import pytest

import brdffit
from brdffit.fitting import identifiability
from brdffit.fitting.problem import Problem

PARAMS = {"alpha": 0.2, "f0": 0.04, "kd": [0.3, 0.2, 0.1], "ks": [0.8, 0.7, 0.6]}


@pytest.fixture(scope="module")
def problem():
    """20,000 random pairs of ggx in RGB, a tenth of them with wo below the horizon."""
    rng = np.random.default_rng(1)
    n = 20_000
    angles = (rng.uniform(0, 89, n), rng.uniform(0, 360, n), rng.uniform(0, 100, n),
              rng.uniform(0, 360, n))  # fmt: skip
    with pytest.warns(UserWarning, match="negative"):
        data = brdffit.synthesize("ggx", PARAMS, geometry=angles, noise=0.01)
    return Problem(data, "ggx", loss="l2")


def test_the_fisher_check_evaluates_the_model_on_its_subset_only(problem, monkeypatch):
    # 2 shape + 2 x 3 coefficient columns, 3 channels: a subset of 1000 samples.
    monkeypatch.setattr(identifiability, "MAX_ENTRIES", 8 * 3 * 1000)
    rows = identifiability._rows(problem)
    assert len(rows) == 1000 < problem.geometry.m
    evaluated = []
    model_type = type(problem.model)
    original = model_type.evaluate_prepared

    def spy(self, geometry, params, check=True):
        evaluated.append(geometry.n)
        return original(self, geometry, params, check)

    monkeypatch.setattr(model_type, "evaluate_prepared", spy)
    assert identifiability.unidentified(problem, PARAMS) == {}
    # The base point and two per shape parameter (a linear parameter's column is the
    # model's design at the fitted shape since issue 13's fifth stop; one more
    # evaluation each before).
    assert evaluated == [len(rows)] * (1 + 2 * 2)


def test_the_subset_geometry_gives_the_values_at_those_samples(problem, monkeypatch):
    monkeypatch.setattr(identifiability, "MAX_ENTRIES", 8 * 3 * 1000)
    rows = identifiability._rows(problem)
    geometry = identifiability._geometry(problem, rows)
    values = identifiability._predict(problem, PARAMS, geometry)
    full = problem.model.evaluate_prepared(problem.geometry, PARAMS)[problem.geometry.valid]
    assert values.shape == (len(rows), 3)
    np.testing.assert_allclose(values, full[rows], rtol=1e-12, atol=0.0)


def test_all_the_samples_use_the_problem_s_own_geometry(problem):
    rows = identifiability._rows(problem)
    assert len(rows) == problem.geometry.m
    assert identifiability._geometry(problem, rows) is problem.geometry


def test_the_rows_the_check_uses():
    """All of a 31-band Cornell-sized set (1439 x 63 x 31 entries, under MAX_ENTRIES):
    a 1 M cap made it a subset on a fresh geometry, slower and less exact; at most
    MAX_ROWS of a MERL-sized set."""
    from types import SimpleNamespace

    from brdffit.fitting.identifiability import MAX_ROWS, _rows

    def problem(m, shape, coefs, channels):
        return SimpleNamespace(
            geometry=SimpleNamespace(m=m),
            free_shape=[None] * shape,
            free_coefs=[None] * coefs,
            n_channels=channels,
        )

    assert len(_rows(problem(1439, 1, 2, 31))) == 1439
    many = _rows(problem(1_096_216, 1, 2, 3))
    assert len(many) == MAX_ROWS and np.all(np.diff(many) > 0)


def test_the_rows_of_a_size_are_drawn_once_and_are_the_seeded_draw():
    """The subset of a MERL-sized set is kept for further fits of data of the same size
    (every MERL file's): the seeded draw itself, formed here the plain way, read-only
    (no caller can change what the next fit takes; brdffit.fitting.schedule.seeded_rows)."""
    from types import SimpleNamespace

    from brdffit.fitting.identifiability import MAX_ROWS, _rows

    problem = SimpleNamespace(geometry=SimpleNamespace(m=1_000_003), free_shape=[None],
                              free_coefs=[None, None], n_channels=3)  # fmt: skip
    first, again = _rows(problem), _rows(problem)
    plain = np.sort(np.random.default_rng(0).choice(1_000_003, MAX_ROWS, replace=False))
    assert again is first and np.array_equal(first, plain)
    assert not first.flags.writeable
