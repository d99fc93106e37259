"""Progress callbacks of a fit: StopFit or False stops it, any other error propagates."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import make_data

import brdffit
from brdffit import StopFit, fit

COOK = {"kd": 0.2, "ks": 0.6, "m": 0.12, "eta": 1.7}


@pytest.fixture(scope="module")
def data():
    return make_data("cook_torrance", COOK, n=400)


class Calls:
    """A progress callback that does ``action`` at its ``at``-th call and counts calls."""

    def __init__(self, action, at: int = 2):
        self.action, self.at, self.seen = action, at, []

    def __call__(self, report):
        self.seen.append(report)
        if len(self.seen) == self.at:
            return self.action()
        return None


def _raise(exc):
    def action():
        raise exc

    return action


@pytest.mark.parametrize("error", [ValueError("bad callback"), KeyError("bad callback"),
                                   brdffit.FitError("bad callback", "x")])  # fmt: skip
def test_an_error_in_the_callback_reaches_the_caller(data, error):
    """Before, a ValueError (and so every brdffit error) raised in a callback was taken
    for a request to stop, and the fit returned as if stopped."""
    calls = Calls(_raise(error))
    with pytest.raises(type(error), match="bad callback"):
        fit(data, "cook_torrance", progress=calls)
    assert len(calls.seen) == 2  # the fit ended at the raising call


@pytest.mark.parametrize("action", [_raise(StopFit()), lambda: False])
def test_stopfit_or_false_stops_the_fit_with_its_best_point(data, action):
    calls = Calls(action)
    result = fit(data, "cook_torrance", progress=calls)
    full = fit(data, "cook_torrance")
    assert not result.converged
    assert result.message.startswith("not converged: stopped by the progress callback")
    assert len(calls.seen) == 2  # no report after the stop
    assert calls.seen[-1].n_evals <= result.n_evals < full.n_evals
    assert result.loss >= full.loss and np.isfinite(result.loss)
    assert brdffit.StopFit is brdffit.fitting.StopFit


def test_a_callback_returning_none_or_true_does_not_stop(data):
    quiet = fit(data, "cook_torrance", progress=lambda report: True)
    assert quiet.converged and quiet.n_evals == fit(data, "cook_torrance").n_evals


def test_stop_during_the_global_stage_on_a_subsample_still_answers(monkeypatch, data):
    """Large data: the global stage scouts a subsample; stopped there, before any
    polish on the full data, the fit answers the scout's best point evaluated on all
    samples (not "stopped before its first evaluation")."""
    import brdffit.fitting.engine as engine

    monkeypatch.setattr(engine, "GLOBAL_SAMPLES", 100)
    calls = Calls(_raise(StopFit()), at=1)
    result = fit(data, "cook_torrance", progress=calls, loss="l2")
    assert calls.seen[0].stage == "global"
    assert not result.converged and "stopped by the progress callback" in result.message
    assert result.n_samples == data.n and result.n_evals == calls.seen[0].n_evals + 1
    assert result.loss == pytest.approx(result.metrics["l2"], rel=1e-9)


def test_an_error_in_the_callback_of_the_scout_reaches_the_caller(monkeypatch, data):
    import brdffit.fitting.engine as engine

    monkeypatch.setattr(engine, "GLOBAL_SAMPLES", 100)
    with pytest.raises(ZeroDivisionError):
        fit(data, "cook_torrance", progress=Calls(lambda: 1 / 0, at=1))
