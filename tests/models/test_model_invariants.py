"""Invariants of every registered model, parametrised over the whole registry.

A model is tested by each of these the moment it is registered.
"""

from __future__ import annotations

import numpy as np
import pytest
from helpers import hemisphere_pairs, random_params, stable_seed

from brdffit import DataError, ModelError, ParameterError, get_model, list_models
from brdffit.data.geometry import Geometry, directions_from_angles
from brdffit.models import REGISTRY

# Every test here runs on the compiled kernels and on the numpy formulas.
pytestmark = pytest.mark.usefixtures("evaluation_path")

MODELS = sorted(REGISTRY)


def param_sets(model, count: int = 6):
    rng = np.random.default_rng(stable_seed(model.name))
    yield model.defaults()
    yield random_params(model, rng, "lower")
    yield random_params(model, rng, "upper")
    for _ in range(count):
        yield random_params(model, rng)


@pytest.mark.parametrize("name", MODELS)
def test_finite_and_non_negative_everywhere(name):
    model = get_model(name)
    wi, wo = hemisphere_pairs(3000, seed=1)
    geometry = Geometry(wi, wo)
    for params in param_sets(model):
        f = model.evaluate_prepared(geometry, params)
        assert f.shape == (len(wi),)
        assert np.isfinite(f).all(), (params, wi[~np.isfinite(f)][:3], wo[~np.isfinite(f)][:3])
        assert (f >= 0).all(), (params, f.min())


@pytest.mark.parametrize("name", MODELS)
def test_zero_below_the_horizon(name):
    model = get_model(name)
    wi, wo = hemisphere_pairs(500, seed=2, grazing=False)
    below = wo * np.array([1, 1, -1])
    params = model.defaults()
    assert (model.evaluate(wi, below, params) == 0).all()
    assert (model.evaluate(below, wo, params) == 0).all()
    horizon = directions_from_angles(np.full(len(wi), 90.0), np.zeros(len(wi)))
    horizon[:, 2] = 0.0
    assert (model.evaluate(wi, horizon, params) == 0).all()


@pytest.mark.parametrize("name", MODELS)
def test_prepared_equals_unprepared_and_channels_broadcast(name):
    model = get_model(name)
    wi, wo = hemisphere_pairs(400, seed=3)
    params = model.defaults()
    geometry = model.prepare(wi, wo)
    np.testing.assert_array_equal(
        model.evaluate(wi, wo, params), model.evaluate_prepared(geometry, params)
    )
    # A second evaluation on the same prepared geometry gives the same values.
    np.testing.assert_array_equal(
        model.evaluate_prepared(geometry, params), model.evaluate(wi, wo, params)
    )
    # Per-channel linear params give one column per channel, each the scalar result.
    per_channel = dict(params)
    scales = (0.25, 0.5, 1.0)
    for p in model.linear_params:
        per_channel[p.name] = [p.lower + s * (p.default - p.lower) for s in scales]
    f = model.evaluate(wi, wo, per_channel)
    assert f.shape == (len(wi), 3)
    for c, s in enumerate(scales):
        one = dict(
            params, **{p.name: p.lower + s * (p.default - p.lower) for p in model.linear_params}
        )
        np.testing.assert_allclose(f[:, c], model.evaluate(wi, wo, one), rtol=1e-12, atol=1e-300)


ISOTROPIC = [m.name for m in list_models(symmetry="isotropic")]


@pytest.mark.parametrize("name", ISOTROPIC)
def test_isotropic_models_are_invariant_under_rotation_about_the_normal(name):
    model = get_model(name)
    wi, wo = hemisphere_pairs(1000, seed=4, grazing=False)
    angle = np.radians(37.0)
    rot = np.array(
        [[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]]
    )
    for params in param_sets(model, 2):
        f0 = model.evaluate(wi, wo, params)
        f1 = model.evaluate(wi @ rot.T, wo @ rot.T, params)
        np.testing.assert_allclose(f1, f0, rtol=1e-7, atol=1e-12 * max(1.0, f0.max()))


@pytest.mark.parametrize("name", MODELS)
def test_reciprocity_where_the_model_is_reciprocal(name):
    """f(L, V) = f(V, L) for reciprocal models; a measured violation for the others
    (so the ``reciprocal`` flag is checked, not just typed)."""
    model = get_model(name)
    wi, wo = hemisphere_pairs(2000, seed=5, grazing=False)
    worst = 0.0
    for params in param_sets(model, 3):
        a = model.evaluate(wi, wo, params)
        b = model.evaluate(wo, wi, params)
        scale = max(a.max(), 1e-300)
        worst = max(worst, float(np.max(np.abs(a - b)) / scale))
    if model.reciprocal:
        assert worst < 1e-9
    else:
        assert worst > 1e-3, f"{name} is flagged non-reciprocal but its violation is {worst:g}"


def test_anisotropic_models_see_their_anisotropy():
    """Every model classified anisotropic changes under rotation about N at some params."""
    wi, wo = hemisphere_pairs(1000, seed=6, grazing=False)
    angle = np.radians(60.0)
    rot = np.array(
        [[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]]
    )
    for model in list_models(symmetry="anisotropic"):
        rng = np.random.default_rng(0)
        changed = 0.0
        for _ in range(5):
            params = random_params(model, rng)
            f0 = model.evaluate(wi, wo, params)
            f1 = model.evaluate(wi @ rot.T, wo @ rot.T, params)
            changed = max(changed, float(np.max(np.abs(f1 - f0)) / max(f0.max(), 1e-300)))
        assert changed > 1e-3, model.name


@pytest.mark.parametrize("name", MODELS)
def test_bad_params_are_named(name):
    model = get_model(name)
    wi, wo = hemisphere_pairs(5, seed=7, grazing=False)
    params = model.defaults()
    shape = model.shape_params[0] if model.shape_params else model.params[0]
    with pytest.raises(ParameterError, match=shape.name):
        model.evaluate(wi, wo, {**params, shape.name: shape.upper * 2 + 1})
    with pytest.raises(ParameterError, match=shape.name):
        model.evaluate(wi, wo, {**params, shape.name: float("nan")})
    with pytest.raises(ParameterError, match="bogus"):
        model.evaluate(wi, wo, {**params, "bogus": 1.0})
    missing = dict(params)
    del missing[model.params[0].name]
    with pytest.raises(ParameterError, match=model.params[0].name):
        model.evaluate(wi, wo, missing)


def test_bad_directions_are_named():
    model = get_model("blinn")
    wi, wo = hemisphere_pairs(5, seed=8, grazing=False)
    params = model.defaults()
    with pytest.raises(DataError, match=r"wi has shape \(5, 2\)"):
        model.evaluate(wi[:, :2], wo, params)
    bad = wo.copy()
    bad[3, 1] = np.nan
    with pytest.raises(DataError, match=r"wo\[3\]"):
        model.evaluate(wi, bad, params)
    with pytest.raises(DataError, match="unit vectors"):
        model.evaluate(wi * 2, wo, params)
    with pytest.raises(DataError, match="pair up"):
        model.evaluate(wi, wo[:4], params)


def test_unknown_model_lists_close_matches():
    with pytest.raises(ModelError, match="did you mean cook_torrance"):
        get_model("cook_torance")
    with pytest.raises(ModelError, match="classification axes"):
        list_models(colour="red")


def test_every_model_carries_its_classification_and_reference():
    for model in REGISTRY.values():
        cls = model.classification.to_dict()
        assert set(cls) == {"origin", "symmetry", "operand", "highlight", "wave_optics"}
        assert model.reference and model.doc
        assert model.params[0].linear, f"{model.name}: linear params come first"
        assert all(p.doc for p in model.params), model.name
    physical = {m.name for m in list_models(origin="physical")}
    assert physical.isdisjoint({m.name for m in list_models(origin="empirical")})
