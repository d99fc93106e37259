"""Posterior.to_dict() is strict JSON: non-finite numbers become null, matrices keep
their shape (brdffit.jsonable)."""

from __future__ import annotations

import json
import math
import warnings

import numpy as np

from brdffit.posterior.result import Posterior


def posterior_with(samples: np.ndarray, names=("a", "b", "c")) -> Posterior:
    steps, walkers = 4, 2
    return Posterior(
        model="test", loss="l2", noise="absolute", names=tuple(names), samples=samples,
        sampled=("a", "noise"), sampled_log=(False, False),
        chain=np.zeros((steps, walkers, 2)), burn=1, thin=1, n_walkers=walkers,
        n_steps=steps, autocorr_time={"a": math.inf, "noise": math.nan},
        effective_samples=0, acceptance_fraction=math.nan, converged=False,
        message="not converged", seconds=0.5, seed=0, channels=("value",),
    )  # fmt: skip


def test_non_finite_summary_values_are_null_in_strict_json():
    samples = np.array([[1.0, 2.0, 5.0], [2.0, 2.0, np.inf], [3.0, 2.0, 7.0], [4.0, 2.0, 8.0]])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # numpy on the infinite sample
        post = posterior_with(samples)
    assert math.isinf(post.summary["c"]["mean"]) and math.isnan(post.summary["c"]["std"])
    assert math.isnan(post.correlation[0, 1])  # "b" did not move: correlation 0/0
    out = post.to_dict(include_samples=True)
    text = json.dumps(out, allow_nan=False)  # raises on NaN or inf
    back = json.loads(text)
    assert back["summary"]["c"]["mean"] is None and back["summary"]["c"]["std"] is None
    assert back["summary"]["a"]["median"] == post.summary["a"]["median"]
    assert back["autocorr_time"] == {"a": None, "noise": None}
    assert back["acceptance_fraction"] is None
    assert back["samples"][1] == [2.0, 2.0, None]


def test_matrices_keep_their_shape():
    rng = np.random.default_rng(0)
    post = posterior_with(rng.normal(size=(40, 3)))
    out = post.to_dict(include_samples=True)
    assert np.shape(out["covariance"]) == (3, 3) and np.shape(out["correlation"]) == (3, 3)
    assert np.shape(out["samples"]) == (40, 3)
    np.testing.assert_allclose(np.array(out["covariance"]), post.covariance)
    one = rng.normal(size=(10, 1))
    single = posterior_with(one, names=("a",)).to_dict()
    assert np.shape(single["covariance"]) == (1, 1)  # one parameter: still a matrix
    np.testing.assert_allclose(single["covariance"], [[np.var(one[:, 0], ddof=1)]], rtol=1e-12)
