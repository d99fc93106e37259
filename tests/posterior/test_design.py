"""The walkers' designs of a compiled lobe (brdffit.posterior.design.lobe_design): the
same columns and offset as the model's own batched design, for every such model."""

from __future__ import annotations

import numpy as np
import pytest

from brdffit import Measurements, kernels
from brdffit.fitting.problem import Problem
from brdffit.kernels.bind import SPECS, _Lobe
from brdffit.models import get_model
from brdffit.posterior.design import batched_design, compiled_lobe, dense, lobe_design

pytestmark = pytest.mark.skipif(not kernels.available(), reason="numba is not installed")


def problem_of(name: str, fixed: dict, n: int = 300) -> Problem:
    rng = np.random.default_rng(5)
    theta = np.degrees(np.arccos(rng.uniform(0.1, 1.0, (2, n))))
    phi = rng.uniform(0.0, 360.0, (2, n))
    data = Measurements.from_angles(theta[0], phi[0], theta[1], phi[1], rng.uniform(0.1, 1, n))
    return Problem(data, get_model(name), loss="l2", fixed=fixed)


LOBES = sorted(name for name, spec in SPECS.items() if isinstance(spec, _Lobe))


def test_the_lobes_are_found():
    assert {"ward", "ward_anisotropic", "ggx", "blinn"} <= set(LOBES)


#: Each lobe with its coefficients and shape free, ks or kd fixed, and, where it has
#: two shape parameters or more (fixing its only one leaves nothing to sample), its
#: last shape parameter fixed.
CASES = [(name, fix) for name in LOBES for fix in ("none", "ks", "kd")] + [
    (name, "shape") for name in LOBES if len(get_model(name).shape_params) >= 2
]


def test_some_lobes_have_a_shape_parameter_to_fix():
    assert sum(fix == "shape" for _, fix in CASES) >= 3


@pytest.mark.parametrize(("name", "fix"), CASES)
def test_lobe_design_is_the_batched_design(name, fix):
    model = get_model(name)
    fixed = {}
    if fix in ("ks", "kd"):
        fixed[fix] = 0.2
    elif fix == "shape":
        fixed[model.shape_params[-1].name] = model.shape_params[-1].default
    with kernels.use(True):
        problem = problem_of(name, fixed)
        lobe = compiled_lobe(problem)
        assert lobe is not None
        shape_params = list(problem.free_shape)
        rng = np.random.default_rng(1)
        lo = np.array([p.lower for p in shape_params])
        hi = np.array([min(p.upper, 1e3) for p in shape_params])
        shapes = rng.uniform(lo, hi, (4, len(shape_params)))
        fast = lobe_design(problem, lobe, shape_params, shapes)
        slow = batched_design(problem, shape_params, shapes)
    w, m, c = 4, problem.geometry.m, problem.n_channels
    assert len(fast[0]) == len(slow[0])
    for one, two in zip((*fast[0], fast[1]), (*slow[0], slow[1])):
        assert (one is None) == (two is None)
        if one is not None:
            np.testing.assert_array_equal(dense(one, w, m, c), dense(two, w, m, c))


@pytest.mark.parametrize("name", ["gltf_pbr", "ashikhmin_shirley", "oren_nayar"])
def test_other_designs_are_not_taken_for_a_lobe(name):
    """Renderer forms, Ashikhmin-Shirley's offset, and numpy models keep their own
    design."""
    with kernels.use(True):
        assert compiled_lobe(problem_of(name, {})) is None
