"""The weighted sums of the posterior's designs (brdffit.posterior.gram): the compiled
pass and the numpy contractions against a dense reference written out here."""

from __future__ import annotations

import numpy as np
import pytest

from brdffit import kernels
from brdffit.posterior.gram import statistics, weighted_sums

W, M = 5, 700


def fake_target(channels: int, rng):
    """What weighted_sums reads of a Target: the data and weights by sample and channel."""

    class Data:
        pass

    t = Data()
    t.y = rng.normal(1.0, 0.5, (M, channels))
    t.w = rng.uniform(0.0, 2.0, (M, channels))
    t.w[::7] = 0.0
    t.wy = t.w * t.y
    t.yy = (t.wy * t.y).sum(axis=0)
    t.w_sum = t.w.sum(axis=0)
    t.w_t, t.wy_t, t.y_t = (np.ascontiguousarray(a.T) for a in (t.w, t.wy, t.y))
    return t


def reference(t, cols, offset):
    """Dense (W, M, K) design and residuals, each sum written as its definition."""
    dense = [np.broadcast_to(np.asarray(c, dtype=float), (W, M)) for c in cols]
    a = np.stack(dense, axis=-1) if cols else np.zeros((W, M, 0))
    off = np.zeros((W, M)) if offset is None else np.broadcast_to(offset, (W, M))
    r = t.y[None] - off[..., None]  # (W, M, C)
    gram = np.einsum("mc,wmk,wml->wckl", t.w, a, a)
    rhs = np.einsum("mc,wmc,wmk->wck", t.w, r, a)
    yy = np.einsum("mc,wmc,wmc->wc", t.w, r, r)
    return gram, rhs, yy


CASES = {
    "ward": lambda rng: ([1 / np.pi, rng.uniform(0, 3, (W, M))], None),
    "offset": lambda rng: ([1 / np.pi, rng.uniform(0, 3, (W, M))], rng.uniform(0, 1, (W, M))),
    "shared column": lambda rng: ([rng.uniform(0, 1, M), rng.uniform(0, 3, (W, M))], None),
    "two lobes": lambda rng: ([0.3, rng.uniform(0, 3, (W, M)), rng.uniform(0, 2, (W, M))], None),
    "constant offset": lambda rng: ([rng.uniform(0, 3, (W, M))], 0.25),
    "no coefficient": lambda rng: ([], rng.uniform(0, 1, (W, M))),
}


@pytest.mark.parametrize("channels", [1, 3])
@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("compiled", [False, True])
def test_sums_match_their_definitions(case, channels, compiled):
    if compiled and not kernels.available():
        pytest.skip("numba is not installed")
    rng = np.random.default_rng(len(case) + channels)
    t = fake_target(channels, rng)
    cols, offset = CASES[case](rng)
    with kernels.use(compiled):
        gram, rhs, yy = weighted_sums(t, cols, offset, W)
    want = reference(t, cols, offset)
    for got, expected in zip((gram, rhs, yy), want):
        assert got.shape == expected.shape
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=0)


def test_a_column_that_is_not_finite_gives_sums_that_are_not():
    """The walker is then marked bad by the target: the compiled sums must not assume
    finite values."""
    rng = np.random.default_rng(3)
    t = fake_target(2, rng)
    lobe = rng.uniform(0, 3, (W, M))
    lobe[1, 10], lobe[3, 20] = np.nan, np.inf
    with kernels.use(True):
        gram, rhs, _ = weighted_sums(t, [1 / np.pi, lobe], None, W)
    finite = np.isfinite(gram).all(axis=(1, 2, 3)) & np.isfinite(rhs).all(axis=(1, 2))
    assert finite.tolist() == [True, False, True, False, True]


@pytest.mark.parametrize("case", sorted(CASES))
def test_compiled_solve_is_numpys(case):
    """log |det|, inverse, coefficients and residual sums of the compiled elimination
    against numpy's inv, slogdet and einsum on the same sums, three channels, within
    1e-12 of each array's largest value (a coefficient near 0 has the others' error)."""
    if not kernels.available():
        pytest.skip("numba is not installed")
    rng = np.random.default_rng(11)
    t = fake_target(3, rng)
    cols, offset = CASES[case](rng)
    results = {}
    for on in (False, True):
        with kernels.use(on):
            results[on] = statistics(t, cols, offset, W)
    for numpy_part, compiled_part in zip(results[False], results[True]):
        assert numpy_part.shape == compiled_part.shape
        scale = np.abs(numpy_part).max() if numpy_part.size else 0.0
        np.testing.assert_allclose(compiled_part, numpy_part, rtol=0, atol=1e-12 * scale)


@pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")
def test_a_walker_that_is_not_finite_is_bad_in_both():
    rng = np.random.default_rng(4)
    t = fake_target(3, rng)
    lobe = rng.uniform(0, 3, (W, M))
    lobe[2, 5] = np.inf
    for on in (False, True):
        with kernels.use(on):
            log_det, inv, beta, _, bad = statistics(t, [1 / np.pi, lobe], None, W)
        assert bad.tolist() == [False, False, True, False, False]
        np.testing.assert_array_equal(inv[2], np.broadcast_to(np.eye(2), (3, 2, 2)))
        assert (beta[2] == 0).all() and (log_det[2] == 0).all()


def test_every_case_calls_one_compiled_signature():
    """Writable C-contiguous arrays only: numba compiles, and loads from its cache, a
    signature apart for a read-only, strided or Fortran-ordered argument."""
    if not kernels.available():
        pytest.skip("numba is not installed")
    from brdffit.kernels import loops_posterior

    for case in sorted(CASES):
        for channels in (1, 3):
            rng = np.random.default_rng(channels)
            t = fake_target(channels, rng)
            cols, offset = CASES[case](rng)
            with kernels.use(True):
                statistics(t, cols, offset, W)
    assert len(loops_posterior.weighted_gram.signatures) == 1
    assert len(loops_posterior.solve_gram.signatures) == 1
