"""The shortcuts every small fit takes give what the plain ways give (issue 13).

A fit of a few hundred samples pays Python's overhead more than arithmetic; each cut
of it is held here to the code it replaces: the metrics' sums of one block against
the loop over blocks, ``1 / s`` of the scaled losses without a broadcast view, the
per-channel weights' test without one, the per-channel combination of a design,
the options' copies with changes without ``dataclasses.replace``, and the runs
of a few rows without a zero counted at once.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from helpers import calls_of
from numpy.testing import assert_array_equal

from brdffit import kernels
from brdffit.errors import FitError
from brdffit.fitting import losses, runs, solve, sums
from brdffit.fitting.losses import LOSSES, LossContext
from brdffit.fitting.options import FitOptions
from brdffit.models.base import Design, combine


def _context(rng, m: int, c: int, sigma: bool, weights: bool, noise: bool) -> LossContext:
    y = rng.uniform(0.01, 2.0, (m, c))
    return LossContext(
        cos_i=rng.uniform(0.0, 1.0, m),
        y=y,
        sigma=0.02 * y + 1e-3 if sigma else None,
        weights=rng.uniform(0.1, 3.0, m) if weights else None,
        noise_sigma=0.05 * y + 1e-3 if noise else None,
    )


@pytest.mark.parametrize("sigma, weights, noise", [
    (False, False, False), (True, False, False), (True, True, False), (False, True, True),
])  # fmt: skip
@pytest.mark.parametrize("m, c", [(1, 1), (600, 3), (500, 31)])  # 15,500 values: one block
def test_the_sums_of_one_block_are_those_of_the_loop_over_blocks(
    monkeypatch, m, c, sigma, weights, noise
):
    rng = np.random.default_rng(m + c)
    ctx = _context(rng, m, c, sigma, weights, noise)
    pred = ctx.y * rng.uniform(0.8, 1.2, ctx.y.shape)
    with kernels.use(False):  # numpy's path, where the one-block shortcut is
        loop = calls_of(monkeypatch, sums, "_by_blocks")
        got = sums.loss_sums(pred, ctx)
        assert loop == []  # every size here fits in one block
        names = sums._names(ctx)
        want = sums._by_blocks(pred, ctx.y, ctx, sums._whole(ctx, names), names)
    assert list(got) == list(want)  # the same losses in the same order
    assert got == want  # and the same numbers, bit for bit
    assert ("chi2" in got) == sigma and ("mixed" in got) == noise


def test_more_samples_than_a_block_go_through_the_loop(monkeypatch):
    rng = np.random.default_rng(3)
    ctx = _context(rng, sums.VALUES // 3 + 1, 3, True, False, False)
    with kernels.use(False):
        loop = calls_of(monkeypatch, sums, "_by_blocks")
        sums.loss_sums(ctx.y * 1.1, ctx)
    assert loop == [1]


@pytest.mark.parametrize("f_shape, s_shape", [
    ((50, 3), (50, 3)), ((50, 3), (50, 1)), ((50, 1), (50, 3)), ((50, 3), ()), ((), ()),
])  # fmt: skip
def test_the_inverse_scale_is_the_broadcast_one(f_shape, s_shape):
    rng = np.random.default_rng(len(f_shape) + len(s_shape))
    s = rng.uniform(0.5, 2.0, s_shape) if s_shape else 0.7
    f = rng.uniform(0.5, 2.0, f_shape) if f_shape else 1.3
    got = losses._inverse(s, f)
    want = np.broadcast_to(1.0 / s, np.broadcast_shapes(np.shape(f), np.shape(s)))
    assert np.shape(got) == want.shape
    assert_array_equal(got, want)
    if np.shape(s) == np.shape(got):  # returned as it is: a new array, not s
        assert not np.shares_memory(got, s)


def test_the_chi2_derivative_is_one_over_sigma_in_the_values_shape():
    rng = np.random.default_rng(2)
    ctx = _context(rng, 30, 3, True, False, False)
    got = LOSSES["chi2"].derivative(ctx.y, ctx)
    assert_array_equal(got, np.ones_like(ctx.y) / ctx.sigma)


@pytest.mark.parametrize("case", ["same", "head differs", "tail differs", "nan", "empty"])
def test_the_same_weights_in_every_channel_is_array_equal_of_the_broadcast(case):
    w = np.repeat(np.linspace(0.5, 2.0, 200)[:, None], 3, axis=1)
    if case == "head differs":
        w[3, 1] += 1e-12
    elif case == "tail differs":
        w[150, 2] *= 1.5
    elif case == "nan":
        w[100] = np.nan
    elif case == "empty":
        w = w[:, :0]
    got = solve._same_in_every_channel(w)
    head = w[:64]
    want = np.array_equal(head, np.broadcast_to(head[:, :1], head.shape)) and np.array_equal(
        w, np.broadcast_to(w[:, :1], w.shape)
    )
    assert got is want
    assert got == (case in ("same", "empty"))


@pytest.mark.parametrize("coefs", [
    [0.3, np.array([0.1, 0.2, 0.3])], [np.array([0.5]), 2], [[0.1, 0.2, 0.3], [1, 2, 3]],
])  # fmt: skip
def test_the_per_channel_combination_is_the_sum_of_its_terms(coefs):
    rng = np.random.default_rng(9)
    m = 40
    column = rng.uniform(0.0, 1.0, m)
    design = Design((1.0 / np.pi, column))
    got = combine(design, coefs, m)
    n = max(np.size(c) for c in coefs)
    c0, c1 = (np.broadcast_to(np.asarray(c, dtype=float), (n,)) for c in coefs)
    want = np.multiply.outer(column, c1) + (1.0 / np.pi) * c0
    assert got.shape == (m, n)
    assert_array_equal(got, want)


@pytest.mark.parametrize("changes", [
    {}, {"loss": "chi2"}, {"global_evals": 120, "local_evals": 200, "max_evals": 10**9},
    {"free": ("eta",), "seed": 3, "local_algorithm": "LN_SBPLX"},
])  # fmt: skip
def test_the_options_with_changes_are_dataclasses_replace(changes):
    opts = FitOptions(loss="l2", restarts=1, timeout=5.0, fixed={"kd": 0.1})
    got, want = opts._with(**changes), dataclasses.replace(opts, **changes)
    assert type(got) is FitOptions
    assert got == want
    assert list(vars(got)) == list(vars(want))  # the fields in their order
    assert [getattr(got, f.name) for f in dataclasses.fields(got)] == [
        getattr(want, f.name) for f in dataclasses.fields(want)
    ]
    assert got.record() == want.record()
    with pytest.raises(dataclasses.FrozenInstanceError):
        got.loss = "log"
    with pytest.raises(TypeError, match="no field 'not_an_option'"):
        opts._with(not_an_option=1)


def test_the_record_is_every_record_field():
    opts = FitOptions(loss="cbrt", seed=7, progress=print, uncertainty=True)
    want = {f.name: getattr(opts, f.name) for f in dataclasses.fields(opts)
            if f.metadata.get("record")}  # fmt: skip
    want["weights"] = None
    assert opts.record() == want
    assert "progress" not in want and "uncertainty" not in want and "seed" in want


def test_options_of_known_names_are_the_options_and_an_unknown_one_is_named():
    assert FitOptions.of({"loss": "l2", "seed": 2}) == FitOptions(loss="l2", seed=2)
    assert FitOptions.of({}) == FitOptions()
    with pytest.raises(FitError, match=r"'sed' is not an option of fit.*did you mean seed"):
        FitOptions.of({"loss": "l2", "sed": 2})


@pytest.mark.parametrize("c", [1, 3, runs.VECTOR_ROWS - 1])
@pytest.mark.parametrize("m", [1, 2, 600, runs.VECTOR_LENGTH])
def test_the_runs_of_a_few_rows_at_once_are_those_row_by_row(monkeypatch, c, m):
    rng = np.random.default_rng(c * m)
    codes = rng.integers(1, 3, (c, m)).astype(np.int8)
    codes[0, : m // 2] = 2  # a long run
    want = runs.runs_by_row(codes)
    by_row = calls_of(monkeypatch, runs, "runs_by_row")
    got = runs.runs(codes)
    assert by_row == []  # no zero: the rows' sums, not row by row
    for a, b in zip(got, want):
        assert a.dtype == b.dtype
        assert_array_equal(a, b)
    codes[-1, ::3] = 0  # an exact zero: row by row
    assert_array_equal(runs.runs(codes)[2], runs._statistics([runs._count(r) for r in codes])[2])
    assert by_row == [1]


@pytest.mark.parametrize("m, c", [(600, 3), (1, 1), (50, 31)])
def test_one_column_s_gram_under_per_channel_weights_is_the_pairs_one(m, c):
    from brdffit.fitting import linear

    rng = np.random.default_rng(m + c)
    columns, y = rng.uniform(0.0, 2.0, (m, 1)), rng.uniform(0.0, 1.0, (m, c))
    w = rng.uniform(0.1, 1e4, (m, c))
    got = linear.normal_equations(columns, y, w)
    iu = np.triu_indices(1)  # the pairs' way, which every K takes
    want = (w.T @ (columns[:, iu[0]] * columns[:, iu[1]])).reshape(c, 1, 1)
    assert_array_equal(got.gram, want)
    assert got.gram.shape == (c, 1, 1)


@pytest.mark.parametrize("shape", [(600, 3), (5, 1), (0, 3)])
def test_weights_told_apart_by_their_first_row_are_those_of_the_whole_test(shape):
    rng = np.random.default_rng(7)
    for w in (rng.uniform(1.0, 2.0, shape), np.repeat(rng.uniform(1.0, 2.0, shape[:1])[:, None],
                                                      shape[1], axis=1)):  # fmt: skip
        plain = bool((w == w[:, :1]).all())
        assert solve._same_in_every_channel(w) is plain
    if shape[0]:
        w = np.ones(shape)
        w[0, -1] = np.nan
        assert solve._same_in_every_channel(w) is bool((w == w[:, :1]).all())


@pytest.mark.parametrize("subscripts, shapes", [
    ("mc,mc->", [(600, 3), (600, 3)]), ("mc,mc,m->", [(600, 3), (600, 3), (600,)]),
    ("mc,mc->c", [(5000, 31), (5000, 31)]), ("ckl,...cl->...ck", [(3, 2, 2), (7, 3, 2)]),
    ("sck,ck->sc", [(9, 3, 2), (3, 2)]), ("bc,bc,b->", [(16384, 1), (16384, 1), (16384,)]),
])  # fmt: skip
def test_the_fitting_einsum_is_numpy_s(subscripts, shapes):
    from brdffit.fitting.channels import einsum

    rng = np.random.default_rng(len(subscripts))
    operands = [rng.standard_normal(shape) * 1e3 for shape in shapes]
    assert_array_equal(einsum(subscripts, *operands), np.einsum(subscripts, *operands))


def test_the_bounds_told_in_floats_are_those_of_the_arrays():
    from brdffit.fitting import linear

    rng = np.random.default_rng(11)
    lower, upper = np.array([0.0, 0.0, -1.0]), np.array([1.0, np.inf, 1.0])
    special = [0.0, -0.0, 1.0, -1.0, np.inf, -np.inf, np.nan, 1e-300, -1e-300, 1.0 + 2e-16]
    for _ in range(400):
        c = int(rng.integers(1, 5))
        x = rng.uniform(-0.2, 1.2, (c, 3))
        x[rng.random((c, 3)) < 0.2] = rng.choice(special)
        want = bool(linear._feasible(x, lower, upper, None).all())
        assert linear._inside(x.tolist(), lower.tolist(), upper.tolist()) is want
