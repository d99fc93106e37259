"""The front end of a fit: FitOptions, check_fit, what a result records, strict JSON."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
from helpers import make_data

import brdffit
from brdffit import FitError, check_fit, fit, get_model
from brdffit.fitting import FitOptions, FitResult

BLINN = {"kd": 0.2, "ks": 1.0, "n": 30.0}


@pytest.fixture(scope="module")
def blinn_data():
    return make_data("blinn", BLINN, n=200)


def _unevaluable(name: str):
    """The registered model with a design that fails if anything evaluates it."""

    def design(geometry, shape):
        raise AssertionError(f"{name} was evaluated")

    return dataclasses.replace(get_model(name), design=design)


BAD = [
    ({"loss": "l3"}, "loss"),
    ({"global_algorithm": "LN_BOBYQA"}, "global_algorithm"),
    ({"local_algorithm": "GN_DIRECT"}, "local_algorithm"),
    ({"global_evals": 0}, "global_evals"),
    ({"local_evals": 2.5}, "local_evals"),
    ({"max_evals": -5}, "max_evals"),
    ({"timeout": -1}, "timeout"),
    ({"timeout": True}, "timeout"),
    ({"seed": 1.5}, "seed"),
    ({"seed": -1}, "seed"),
    ({"seed": 2**32}, "seed"),
    ({"restarts": -1}, "restarts"),
    ({"start": {"kd": 0.1}}, "start"),
    ({"start": [("n", 10.0)]}, "start"),
    ({"weights": np.ones(3)}, "weights"),
    ({"weights": -np.ones(200)}, "weights"),
    ({"fixed": {"n": 0.5}}, "fixed.n"),
    ({"start": {"n": 0.5}}, "start.n"),
    ({"fixed": {"nope": 1.0}}, "fixed.nope"),
    ({"free": ["n"]}, "free"),
    ({"free": "eta"}, "free"),
    ({"free": 5}, "free"),
    ({"fixed": 3}, "fixed"),
    ({"progress": 3}, "progress"),
    ({"energy_conserving": 1}, "energy_conserving"),
    ({"uncertainty": "yes"}, "uncertainty"),
    ({"posterior_options": 5}, "posterior_options"),
    ({"restart": 1}, "restart"),
]


@pytest.mark.parametrize("options, field", BAD)
def test_check_fit_raises_what_fit_raises(blinn_data, options, field):
    with pytest.raises(brdffit.BrdfFitError) as by_fit:
        fit(blinn_data, "blinn", **options)
    with pytest.raises(brdffit.BrdfFitError) as by_check:
        check_fit(blinn_data, "blinn", **options)
    assert type(by_check.value) is type(by_fit.value)
    assert str(by_check.value) == str(by_fit.value)
    assert by_check.value.field == by_fit.value.field == field


def test_check_fit_refuses_bad_models_and_data_as_fit_does(blinn_data):
    small = make_data("cook_torrance", {"kd": 0.2, "ks": 0.6, "m": 0.12, "eta": 1.7}, n=4)
    cases = [(blinn_data, "blin"), (small, "cook_torrance"), (blinn_data.values, "blinn")]
    for data, model in cases:
        with pytest.raises(brdffit.BrdfFitError) as by_fit:
            fit(data, model)
        with pytest.raises(brdffit.BrdfFitError) as by_check:
            check_fit(data, model)
        assert (type(by_check.value), str(by_check.value)) == (
            type(by_fit.value),
            str(by_fit.value),
        )


def test_check_fit_does_not_evaluate_the_model(blinn_data):
    """A model that fails when evaluated passes check_fit (energy rows and all) and
    fails in fit: the check prepares the fit without running any of it."""
    model = _unevaluable("blinn")
    options = {"energy_conserving": True, "start": {"n": 50.0}, "weights": np.ones(200)}
    assert check_fit(blinn_data, model, **options) is None
    with pytest.raises(AssertionError, match="blinn was evaluated"):
        fit(blinn_data, model, **options)


def test_the_seed_range_is_nlopts(blinn_data):
    """Seeds are 32-bit in nlopt: the largest is accepted, one more is refused in words
    (nlopt.srand itself raises OverflowError only for negative or 64-bit seeds)."""
    top = 2**32 - 1
    assert fit(blinn_data, "blinn", seed=top, max_evals=30).options["seed"] == top
    with pytest.raises(FitError, match=r"seed=4294967296 must be a whole number in \[0, "):
        check_fit(blinn_data, "blinn", seed=top + 1)


def test_one_wording_for_whole_numbers(blinn_data):
    messages = []
    for name, value in (("global_evals", 0), ("local_evals", -1), ("restarts", -1)):
        with pytest.raises(FitError) as info:
            check_fit(blinn_data, "blinn", **{name: value})
        messages.append(str(info.value).split(" must be ")[1])
    assert messages == ["a whole number >= 1", "a whole number >= 1", "a whole number >= 0"]


def test_an_unknown_option_is_named_with_the_closest(blinn_data):
    with pytest.raises(FitError, match=r"'timout' is not an option of fit \(did you mean timeout"):
        fit(blinn_data, "blinn", timout=3)


def test_fit_shows_every_option_in_its_signature():
    import inspect

    names = list(inspect.signature(fit).parameters)
    assert names == ["data", "model"] + [f.name for f in dataclasses.fields(FitOptions)]
    assert inspect.signature(check_fit).parameters["seed"].default == 0


def test_options_record_what_reproduces_the_fit(blinn_data):
    weights = np.linspace(0.0, 2.0, blinn_data.n)
    given = dict(global_evals=90, local_evals=150, restarts=1, seed=5, timeout=30.0)
    first = fit(blinn_data, "blinn", weights=weights, **given)
    recorded = dict(first.options)
    assert {k: recorded[k] for k in given} == given
    # No sigma: the default is the noise model estimated with the fit.
    assert recorded["loss"] == "mixed" and recorded["max_evals"] >= 90 + 150 * 2
    summary = recorded.pop("weights")
    assert summary == {"count": blinn_data.n, "min": 0.0, "max": 2.0, "zeros": 1}
    again = fit(blinn_data, "blinn", weights=first.weights, **recorded)
    assert again.params == first.params and again.n_evals == first.n_evals


def test_weights_stay_on_the_result_read_only_and_out_of_its_json(blinn_data):
    weights = np.ones(blinn_data.n)
    weights[:10] = 0.0
    result = fit(blinn_data, "blinn", weights=weights, max_evals=40)
    weights[:] = 7.0  # the caller's array changing later does not change the result
    assert result.weights.tolist() == [0.0] * 10 + [1.0] * (blinn_data.n - 10)
    with pytest.raises(ValueError):
        result.weights[0] = 1.0
    out = result.to_dict()
    assert "weights" not in out
    assert out["options"]["weights"] == {"count": blinn_data.n, "min": 0.0, "max": 1.0,
                                         "zeros": 10}  # fmt: skip
    assert fit(blinn_data, "blinn", max_evals=40).to_dict()["options"]["weights"] is None


def test_to_dict_is_strict_json_when_metrics_are_not_finite(blinn_data):
    """A result whose loss, metrics and a per-channel parameter are inf or NaN (numpy
    scalars and arrays as the engine makes them) gives JSON with null there."""
    real = fit(blinn_data, "blinn", max_evals=40)
    broken = dataclasses.replace(
        real,
        loss=math.inf,
        params={**real.params, "kd": np.array([0.2, np.nan])},
        metrics={**real.metrics, "rmse": np.float64(np.inf), "aic": np.float64(np.nan)},
    )
    assert isinstance(broken, FitResult)
    back = json.loads(json.dumps(broken.to_dict(), allow_nan=False))
    assert back["loss"] is None and back["params"]["kd"] == [0.2, None]
    assert back["metrics"]["rmse"] is None and back["metrics"]["aic"] is None
    assert back["metrics"]["l2"] == pytest.approx(real.metrics["l2"])
    json.dumps(real.to_dict(), allow_nan=False)
