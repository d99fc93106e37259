"""The post-fit checks' shortcuts give what the plain ways give (issue 13).

Each shortcut is held to the computation it replaces: the Fisher information from
per-channel sums of a few sources against the product of the Jacobian's columns;
the diagonal of the inverse by the Cholesky factor against the eigendecomposition;
the runs of every row at once against row by row; the misfit verdict of an l2 or
chi2 fit from its metrics against the test on its residuals; and the identifiability
verdicts of whole fits, each way.
"""

from __future__ import annotations

import numpy as np
import pytest
from helpers import make_data, plain_information, shared_file
from numpy.testing import assert_allclose, assert_equal

import brdffit
from brdffit.fitting import identifiability, information, misfit, runs
from brdffit.fitting.problem import Problem


def _columns(sources, layout):
    """The Jacobian's columns in the plain form of ``helpers.plain_information``."""
    return [sources[k] if c < 0 else (c, sources[k][:, c]) for k, c in layout]


@pytest.mark.parametrize("weighted", [False, True])
@pytest.mark.parametrize("layout", [
    [(0, -1), (1, -1), (2, 0), (2, 1), (2, 2), (3, 1), (3, 2)],
    [(0, -1), (1, 0), (1, 2), (2, 2), (2, 0)],  # the plain way puts shape columns first
    [(0, 0), (0, 1), (0, 2)],
    [(0, -1)],
])  # fmt: skip
def test_the_channel_sums_give_the_information_of_the_columns(layout, weighted):
    rng = np.random.default_rng(len(layout))
    m, c = 700, 3  # above the folding of the per-channel sums (2 x 128 rows)
    sources = [rng.standard_normal((m, c)) for _ in range(1 + max(k for k, _ in layout))]
    sqrt_w = rng.uniform(0.5, 2.0, (m, c)) if weighted else None
    want = plain_information(_columns(sources, layout), np.ones((m, c)) if sqrt_w is None
                                   else sqrt_w)  # fmt: skip
    got = information.channel_information(sources, layout, sqrt_w)
    assert_allclose(got, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())
    assert np.all(got[np.abs(want) == 0] == 0)  # channels that never meet: exactly 0


def test_the_cholesky_diagonal_is_the_eigendecomposition_s():
    rng = np.random.default_rng(2)
    for size in (1, 2, 7, 63):
        a = rng.standard_normal((size + 5, size)) * np.logspace(0, 3, size)
        info = a.T @ a
        scale = np.sqrt(np.diag(info))
        unit = info / np.outer(scale, scale)
        null, plain = information.null_and_variance(
            unit, identifiability.RANK_RTOL, shortcut=False
        )
        got = information.inverse_diagonal(unit, identifiability.RANK_RTOL)
        assert null == [] and got is not None
        assert_allclose(got, plain, rtol=1e-9)


@pytest.mark.parametrize("singular", ["exact", "near", "negative"])
def test_a_singular_information_goes_to_the_eigendecomposition(singular):
    rng = np.random.default_rng(4)
    a = rng.standard_normal((40, 6))
    a[:, 5] = a[:, 4] * 2.0 + a[:, 1] * (1e-9 if singular == "near" else 0.0)
    unit = a.T @ a
    unit /= np.sqrt(np.outer(np.diag(unit), np.diag(unit)))
    if singular == "negative":
        unit[0, 1] = unit[1, 0] = 1.5  # not positive definite
    assert information.inverse_diagonal(unit, identifiability.RANK_RTOL) is None
    null, _ = information.null_and_variance(unit, identifiability.RANK_RTOL)
    assert null  # "near": 1e-18 of the largest eigenvalue, null by eigh as well


def test_the_runs_of_every_row_at_once_are_those_row_by_row(monkeypatch):
    rng = np.random.default_rng(6)
    codes = rng.integers(1, 3, (31, 500)).astype(np.int8)
    codes[3, ::7] = 0  # rows with zeros, counted row by row
    codes[5] = 2  # one sign only
    codes[8, :400] = 0
    codes[9] = 0
    for rows in (codes, codes[:, :1], codes[:, :0], codes[[0, 1]]):
        assert_equal(runs.runs(rows), runs.runs_by_row(rows))
    calls = []
    monkeypatch.setattr(runs, "runs_by_row", lambda c: calls.append(c.shape) or ())
    runs.runs(codes)  # 31 rows of 500: counted together, not row by row
    assert calls == []


def _l2_and_chi2_fits():
    data = make_data("ward", {"kd": [0.2, 0.1], "ks": [0.3, 0.25], "alpha": 0.15}, n=900)
    sigma = 0.01 * np.abs(np.asarray(data.values)) + 1e-4
    with_sigma = brdffit.Measurements(data.wi, data.wo, data.values, sigma=sigma)
    return [(data, "ward", "l2"), (data, "blinn", "l2"), (with_sigma, "ward", "chi2"),
            (with_sigma, "blinn", "chi2")]  # fmt: skip


@pytest.mark.parametrize("case", range(4))
def test_the_verdict_from_the_metrics_is_the_test_on_the_residuals(case):
    data, model, loss = _l2_and_chi2_fits()[case]
    result = brdffit.fit(data, model, loss=loss)
    problem = Problem(data, model, loss=loss)
    z, keep = misfit.standardised(problem, dict(result.params), None)
    want = misfit.misfit_test(data, z, keep, result.n_params, loss == "chi2")
    got = misfit._from_metrics(problem, result, result.n_params)
    assert got.pop("reduced_chi2") == pytest.approx(want.pop("reduced_chi2"), rel=1e-12)
    assert got == want
    assert result.misfit["detected"] == want["detected"]


def test_a_weighted_or_transformed_fit_takes_its_residuals():
    data, model, _ = _l2_and_chi2_fits()[0]
    weights = np.ones(data.n)
    for loss, options in (("l2", {"weights": weights}), ("cosine", {})):
        problem = Problem(data, model, loss=loss, **options)
        result = brdffit.fit(data, model, loss=loss, **options)
        assert misfit._from_metrics(problem, result, result.n_params) is None


def _plain(monkeypatch):
    """The identifiability check with the column-by-column information, eigh, and the
    coefficients' columns by differences of two evaluations."""
    monkeypatch.setattr(
        identifiability,
        "channel_information",
        lambda s, layout, w: plain_information(
            _columns(s, layout), np.ones_like(s[0]) if w is None else w
        ),
    )
    monkeypatch.setattr(information, "inverse_diagonal", lambda unit, rtol: None)  # fmt: skip
    monkeypatch.setattr(identifiability, "EXACT_COEFFICIENTS", False)


def _in_plane():
    """ggx_anisotropic measured with wo in the plane of incidence at phi_i = 0 only."""
    theta_i = np.repeat([10.0, 30.0, 50.0], 40)
    theta_o = np.tile(np.linspace(0.0, 80.0, 20).repeat(2), 3)
    phi_o = np.tile([0.0, 180.0], theta_i.size // 2)
    angles = (theta_i, np.zeros_like(theta_i), theta_o, phi_o)
    truth = {"alpha_u": 0.1, "alpha_v": 0.3, "kd": 0.3, "ks": 0.8}
    return brdffit.synthesize("ggx_anisotropic", truth, geometry=angles, noise=0.01)


def _fits(case: int):
    if case >= 5:
        garnet = brdffit.read(shared_file("cornell", "garnet_red.astm"))
        return (garnet, "blinn" if case == 5 else "ward", "l2")
    aniso, unseen = _in_plane(), brdffit.synthesize("lambert", {"kd": [0.6, 0.35, 0.2]})
    rgb = make_data("ggx", {"kd": [0.0, 0.1, 0.2], "ks": [0.5, 0.6, 0.7], "alpha": 0.2,
                            "f0": 0.04}, n=800)  # fmt: skip
    return [(aniso, "ggx_anisotropic", "l2"), (aniso, "ggx", "l2"), (unseen, "blinn", "l2"),
            (rgb, "ggx", "l2"), (rgb, "cook_torrance", "log")][case]  # fmt: skip


@pytest.mark.parametrize("case", range(7))
def test_the_identifiability_verdicts_are_those_of_the_plain_way(case, monkeypatch):
    data, model, loss = _fits(case)
    result = brdffit.fit(data, model, loss=loss)
    problem = Problem(data, model, loss=loss)
    got = identifiability.unidentified(problem, dict(result.params))
    _plain(monkeypatch)
    assert got == identifiability.unidentified(problem, dict(result.params))


TRUTHS = {
    "ggx": {"kd": [0.2, 0.1, 0.3], "ks": [0.5, 0.6, 0.0], "alpha": 0.2, "f0": 0.04},
    "blinn": {"kd": [0.2, 0.1, 0.3], "ks": [0.5, 0.6, 0.7], "n": 40.0},
    "ward": {"kd": [0.0, 0.1, 0.3], "ks": [0.4, 0.5, 0.6], "alpha": 0.2},
}  # fmt: skip


@pytest.mark.parametrize("model", list(TRUTHS))
def test_the_design_s_columns_are_the_differences_of_two_evaluations(model):
    """A linear parameter's Jacobian column is its design column (the model is linear in
    it), what the difference of two evaluations gives up to its rounding."""
    data = make_data(model, TRUTHS[model], n=600)
    problem = Problem(data, model, loss="l2")
    params = dict(brdffit.fit(data, model, loss="l2").params)
    params = identifiability._at_their_bounds(problem, params)
    geometry = problem.geometry
    base = identifiability._predict(problem, params, geometry)
    design = identifiability._design(problem, params, geometry)
    assert design is not None
    checked = 0
    for p in problem.model.linear_params:
        exact = identifiability._coefficient_columns(problem, params, geometry, base, p, None,
                                                     design)  # fmt: skip
        plain = identifiability._coefficient_columns(problem, params, geometry, base, p, None)
        assert (exact is None) == (plain is None)
        if exact is None:
            continue
        assert exact[1] == plain[1]  # the same channels, labelled alike
        for _, c in exact[1]:
            scale = np.abs(base[:, c]).max() * 1e3  # the difference's rounding, over its step
            assert_allclose(exact[0][:, c], plain[0][:, c], rtol=0, atol=1e-13 * scale)
            checked += 1
    assert checked >= 5


def test_a_read_only_evaluation_is_copied_not_written(monkeypatch):
    """The differences are formed in the first evaluation's array; one a model hands out
    read-only is copied first (the check would have raised, and said nothing)."""
    data, model, loss = _fits(4)  # cook_torrance on RGB: differences for alpha-like shapes
    problem = Problem(data, model, loss=loss)
    params = dict(brdffit.fit(data, model, loss=loss).params)
    want = identifiability.unidentified(problem, params)
    original = type(problem.model).evaluate_prepared

    def read_only(self, geometry, values, check=True):
        out = np.array(original(self, geometry, values, check))
        out.setflags(write=False)
        return out

    monkeypatch.setattr(identifiability, "EXACT_COEFFICIENTS", False)  # every column
    plain = identifiability.unidentified(problem, params)
    monkeypatch.setattr(type(problem.model), "evaluate_prepared", read_only)
    assert identifiability.unidentified(problem, params) == plain == want


@pytest.mark.parametrize("weighted", [False, True])
@pytest.mark.parametrize("layout", [[(0, 0), (0, 1), (0, 2)], [(0, 2), (0, 0)], [(0, 1)]])
def test_one_linear_parameter_s_information_is_its_diagonal(layout, weighted):
    """Coefficients of one source in distinct channels never meet: the information is
    the diagonal of the channel sums, the same numbers, its other entries 0."""
    rng = np.random.default_rng(len(layout))
    source = rng.standard_normal((700, 3))
    sqrt_w = rng.uniform(0.5, 2.0, (700, 3)) if weighted else None
    full = information.channel_information([source], layout, sqrt_w)
    got = information.coefficient_diagonal([source], layout, sqrt_w)
    assert_equal(got, np.diag(full))
    assert np.all(full[~np.eye(len(layout), dtype=bool)] == 0)


@pytest.mark.parametrize("layout", [
    [(0, -1), (1, 0)], [(0, 0), (1, 1)], [(0, 0), (0, 0)], [(0, -1)],
])  # fmt: skip
def test_columns_that_meet_have_no_diagonal_shortcut(layout):
    sources = [np.ones((300, 2)) for _ in range(1 + max(k for k, _ in layout))]
    assert information.coefficient_diagonal(sources, layout, None) is None


@pytest.mark.parametrize("diagonal", [
    [1.0, 1.0, 1.0], [1.0 + 2e-16, 1.0 - 1e-16], [1.0, 0.0, 1.0], [1.0, -1e-300],
    [1.0, np.inf], [1.0, np.nan], [1.0], [1e-30, 1.0],
])  # fmt: skip
@pytest.mark.parametrize("rtol", [identifiability.RANK_RTOL, 0.004])  # 0.004: no proof
def test_a_diagonal_unit_gets_the_answer_of_its_matrix(diagonal, rtol):
    diagonal = np.array(diagonal)
    with np.errstate(invalid="ignore"):
        try:
            want = information.null_and_variance(np.diag(diagonal), rtol)
        except np.linalg.LinAlgError:
            with pytest.raises(np.linalg.LinAlgError):
                information.null_and_variance(diagonal, rtol)
            return
        got = information.null_and_variance(diagonal, rtol)
    assert len(got[0]) == len(want[0])
    for a, b in zip(got[0], want[0]):
        assert_equal(a, b)
    assert_allclose(got[1], want[1], rtol=1e-15)


def _one_linear_parameter(case: int):
    """Fits whose only free parameter is one linear parameter per channel."""
    rgb = brdffit.synthesize("lambert", {"kd": [0.6, 0.35, 0.2]}, noise=0.01)
    dark = brdffit.synthesize("lambert", {"kd": [0.6, 0.0, 0.2]}, noise=0.0)  # kd[g] at 0
    sigma = brdffit.Measurements(rgb.wi, rgb.wo, rgb.values,
                                 sigma=0.01 * np.abs(np.asarray(rgb.values)) + 1e-4)  # fmt: skip
    blinn = make_data("blinn", {"kd": [0.2, 0.1, 0.3], "ks": 0.5, "n": 40.0}, n=600)
    held = {"fixed": {"ks": 0.5, "n": 40.0}}  # kd alone, over blinn's lobe as an offset
    return [(rgb, "lambert", "l2", {}), (rgb, "lambert", "log", {}),
            (dark, "lambert", "l2", {}), (sigma, "lambert", "chi2", {}),
            (blinn, "blinn", "l2", held), (blinn, "blinn", "cosine", held)][case]  # fmt: skip


@pytest.mark.parametrize("case", range(6))
def test_one_linear_parameter_s_verdicts_are_those_of_the_plain_way(case, monkeypatch):
    data, model, loss, options = _one_linear_parameter(case)
    result = brdffit.fit(data, model, loss=loss, **options)
    problem = Problem(data, model, loss=loss, fixed=options.get("fixed"))
    params = dict(result.params)
    calls, taken = [], information._coefficients_dead
    monkeypatch.setattr(information, "_coefficients_dead",
                        lambda *a: calls.append(taken(*a)) or calls[-1])  # fmt: skip
    got = identifiability.unidentified(problem, params)
    assert calls and calls[-1] is not None  # the diagonal was taken, in floats
    # with the fit's prediction, every case but the log loss (not linear) and dark's (a
    # coefficient at a bound) takes the steps of _coefficients_only
    lean, taken_lean = [], identifiability._coefficients_only
    monkeypatch.setattr(identifiability, "_coefficients_only",
                        lambda *a: lean.append(taken_lean(*a)) or lean[-1])  # fmt: skip
    with_pred = identifiability.unidentified(problem, params, pred=problem.predict(params))
    assert (lean[-1] is None) == (case in (1, 2))
    _plain(monkeypatch)
    monkeypatch.setattr(information, "_coefficients_dead", lambda *a: None)
    monkeypatch.setattr(identifiability, "coefficient_diagonal", lambda *a: None)
    assert got == with_pred == identifiability.unidentified(problem, params)


@pytest.mark.parametrize("diagonal", [
    [1.0, 1.0, 1.0], [2.5, 0.0, 7.0], [0.0, 0.0], [1e-320, 1.0], [1e-320, 1e-320],
    [5e-324, 3.0], [1e300, 1e-10], [1.0, np.inf], [1.0, np.nan], [1.0, -0.0], [1.0],
    [3.0] * 7, [1e-300, 1e-300, 1.0],
])  # fmt: skip
@pytest.mark.parametrize("rtol", [identifiability.RANK_RTOL, 0.3])  # 0.3: the proof fails
def test_coefficients_alone_are_judged_in_floats_as_in_arrays(diagonal, rtol, monkeypatch):
    info = np.array(diagonal)
    names = [f"kd[{c}]" for c in "rgbcmyk"[: len(diagonal)]]
    kinds, params = ["coef"] * len(names), dict.fromkeys(names, 0.5)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        try:
            got = information.judge(names, kinds, info, params, rtol, 1.0)
        except np.linalg.LinAlgError:
            got = "raised"
        monkeypatch.setattr(information, "_coefficients_dead", lambda *a: None)
        try:
            want = information.judge(names, kinds, info, params, rtol, 1.0)
        except np.linalg.LinAlgError:
            want = "raised"
    assert got == want
