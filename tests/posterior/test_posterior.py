"""Posterior sampling: the marginal likelihood, the coefficient draws, calibration,
a known trade-off, diagnostics, reproducibility, budgets, options and plots.

Reference values are computed here independently: Ward's lobe in scalar code
with the math module from MODELS.md, the marginal likelihood by numerical
integration over (kd, ks) on a grid, posterior moments of a linear model in
closed form, autocorrelation times by emcee's own estimator and the AR(1)
formula, correlations from the Fisher information.
"""

from __future__ import annotations

import dataclasses
import json
import math

import emcee
import numpy as np
import pytest
from scipy.integrate import trapezoid
from scipy.stats import binom

from brdffit import FitError, Measurements, fit
from brdffit.data.geometry import directions_from_angles
from brdffit.fitting.problem import Problem
from brdffit.models import REGISTRY, get_model
from brdffit.models.properties import albedo
from brdffit.plot.corner import corner_plot, trace_plot
from brdffit.posterior.chain import integrated_time
from brdffit.posterior.sample import Posterior, _canonical_samples, sample_posterior
from brdffit.posterior.target import Target

# Noisy synthetic values below zero are expected here; Measurements warns about them.
pytestmark = pytest.mark.filterwarnings("ignore:.*values are negative:UserWarning")


# ------------------------------------------------------------------ helpers
def ward_lobe(wi, wo, alpha: float) -> float:
    """MODELS.md: exp(-tan^2(theta_h)/alpha^2) / (4 pi alpha^2 sqrt((N.L)(N.V)))."""
    h = [a + b for a, b in zip(wi, wo)]
    norm = math.sqrt(sum(c * c for c in h))
    h = [c / norm for c in h]
    tan2 = (h[0] ** 2 + h[1] ** 2) / h[2] ** 2
    return math.exp(-tan2 / alpha**2) / (4 * math.pi * alpha**2 * math.sqrt(wi[2] * wo[2]))


def ward_columns(data: Measurements, alpha: float) -> np.ndarray:
    """The design (N, 2) of ward, [1/pi, lobe], in scalar code."""
    lobe = [ward_lobe(a, b, alpha) for a, b in zip(data.wi, data.wo)]
    return np.column_stack([np.full(data.n, 1 / math.pi), lobe])


def near_specular(n: int, rng, spread_deg: float = 25.0):
    """Pairs with wo scattered around the mirror direction of wi (lobes are measured)."""
    ti = np.degrees(np.arccos(rng.uniform(math.cos(math.radians(70)), 1.0, n)))
    pi_ = rng.uniform(0, 360, n)
    off = rng.normal(0.0, spread_deg / 2, (n, 2))
    to = np.clip(np.abs(ti + off[:, 0]), 0.0, 85.0)
    po = pi_ + 180.0 + off[:, 1] / np.maximum(np.sin(np.radians(to)), 0.2)
    return directions_from_angles(ti, pi_), directions_from_angles(to, po)


def dataset(model: str, truth: dict, wi, wo, sigma: float, rng, give_sigma=True):
    """Values of a registered model plus Gaussian noise of standard deviation sigma."""
    f = get_model(model).evaluate(wi, wo, truth)
    y = f + sigma * rng.standard_normal(f.shape)
    return Measurements(wi, wo, y, sigma=np.full(f.shape, sigma) if give_sigma else None)


def log_uniform(rng, lo, hi) -> float:
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


@pytest.fixture(scope="module")
def ward_fit():
    rng = np.random.default_rng(11)
    wi, wo = near_specular(80, rng)
    data = dataset("ward", {"kd": 0.3, "ks": 0.2, "alpha": 0.15}, wi, wo, 0.01, rng)
    return data, fit(data, "ward")


# -------------------------------------------------- the marginal likelihood
def grid_marginal(data, alpha, noise):
    """log of the integral over the box kd in [0, 1], ks in [0, 10] of the Gaussian
    likelihood, by the trapezoid rule on a 601 x 601 grid spanning +-10 sd of the
    unconstrained least-squares solution (clipped to the box); also the
    conditional mean and sd of ks."""
    a = ward_columns(data, alpha)
    y = data.values[:, 0]
    beta, *_ = np.linalg.lstsq(a, y, rcond=None)
    sd = noise * np.sqrt(np.diag(np.linalg.inv(a.T @ a)))
    axes = [
        np.linspace(max(lo, b - 10 * s), min(hi, b + 10 * s), 601)
        for b, s, lo, hi in zip(beta, sd, (0.0, 0.0), (1.0, 10.0))
    ]
    kd, ks = np.meshgrid(*axes, indexing="ij")
    resid = y[None, None, :] - kd[..., None] * a[:, 0] - ks[..., None] * a[:, 1]
    loglik = -0.5 * (resid**2).sum(axis=2) / noise**2 - data.n * math.log(
        noise * math.sqrt(2 * math.pi)
    )
    peak = loglik.max()
    dens = np.exp(loglik - peak)
    mass = trapezoid(trapezoid(dens, axes[1], axis=1), axes[0])
    ks_marg = trapezoid(dens, axes[0], axis=0)
    ks_mean = trapezoid(ks_marg * axes[1], axes[1]) / trapezoid(ks_marg, axes[1])
    ks_var = trapezoid(ks_marg * (axes[1] - ks_mean) ** 2, axes[1]) / trapezoid(ks_marg, axes[1])
    return peak + math.log(mass), ks_mean, math.sqrt(ks_var)


@pytest.fixture(scope="module")
def faint_lobe():
    """A faint lobe: the posterior of ks reaches its bound 0, so the truncation matters."""
    rng = np.random.default_rng(5)
    wi, wo = near_specular(40, rng)
    return dataset("ward", {"kd": 0.4, "ks": 0.004, "alpha": 0.3}, wi, wo, 0.01, rng)


@pytest.mark.parametrize("noise", ["given", "absolute"])
def test_marginal_likelihood_matches_numerical_integration(faint_lobe, noise):
    problem = Problem(faint_lobe, "ward")
    target = Target(problem, noise, np.array([math.log10(0.3)]))
    points = [(0.25, 0.01), (0.3, 0.012), (0.4, 0.009)]
    theta = np.array(
        [[math.log10(a)] + ([math.log10(s)] if noise == "absolute" else []) for a, s in points]
    )
    if noise == "given":
        points = [(a, 0.01) for a, _ in points]
    ours = target.log_prob(theta)
    reference = np.array([grid_marginal(faint_lobe, a, s)[0] for a, s in points])
    # Only differences are defined: the target drops constants.
    np.testing.assert_allclose(ours - ours[0], reference - reference[0], atol=2e-4)


def test_marginal_with_a_fixed_coefficient(faint_lobe):
    """kd held fixed becomes an offset; ks alone is integrated, here on a 1-D grid."""
    problem = Problem(faint_lobe, "ward", fixed={"kd": 0.4})
    target = Target(problem, "given", np.array([math.log10(0.3)]))
    alphas = (0.25, 0.3, 0.4)
    ours = target.log_prob(np.log10(np.array(alphas))[:, None])
    y = faint_lobe.values[:, 0] - 0.4 / math.pi
    reference = []
    for alpha in alphas:
        lobe = ward_columns(faint_lobe, alpha)[:, 1]
        ks = np.linspace(0.0, 0.2, 20001)
        loglik = -0.5 * ((y[None, :] - ks[:, None] * lobe) ** 2).sum(axis=1) / 0.01**2
        reference.append(loglik.max() + math.log(trapezoid(np.exp(loglik - loglik.max()), ks)))
    reference = np.array(reference)
    np.testing.assert_allclose(ours - ours[0], reference - reference[0], atol=2e-4)


def test_walker_loop_agrees_with_the_batched_design(faint_lobe):
    """The design is evaluated for all walkers at once where the model broadcasts
    (ward), one walker at a time otherwise (ashikhmin_phong uses math.sqrt)."""
    target = Target(Problem(faint_lobe, "ward"), "absolute", np.array([math.log10(0.3)]))
    theta = np.column_stack([np.linspace(-0.8, -0.3, 5), np.full(5, -2.0)])
    assert target.batched
    batched = target.log_prob(theta)
    target.batched = False
    np.testing.assert_allclose(target.log_prob(theta), batched, rtol=1e-12)
    phong = Target(Problem(faint_lobe, "ashikhmin_phong"), "given", np.log10([100.0, 10.0]))
    assert not phong.batched
    assert np.isfinite(phong.log_prob(np.log10([[100.0, 10.0], [30.0, 300.0]]))).all()


def test_mapped_coefficients_with_an_offset_and_a_constraint():
    """ashikhmin_shirley: a design offset, the coefficients rd_eff = rd (1 - rs) and
    rs, and the constraint rd_eff + rs <= 1 (rd <= 1), which rd = 0.99 nearly meets."""
    rng = np.random.default_rng(4)
    wi, wo = near_specular(80, rng)
    truth = {"rd": 0.99, "rs": 0.3, "nu": 100.0, "nv": 20.0}
    data = dataset("ashikhmin_shirley", truth, wi, wo, 0.01, rng)
    result = fit(data, "ashikhmin_shirley", start={"nu": 100.0, "nv": 20.0}, global_algorithm=None)
    post = sample_posterior(data, result, seed=0)
    assert post.converged and post.names == ("rd_eff", "rs", "nu", "nv")
    rd_eff = truth["rd"] * (1 - truth["rs"])
    for name, value in (("rd_eff", rd_eff), ("rs", 0.3), ("nu", 100.0), ("nv", 20.0)):
        s = post.summary[name]
        assert abs(s["median"] - value) < 5 * s["std"], name
    total = post.samples[:, 0] + post.samples[:, 1]
    assert (total <= 1.0 + 1e-12).all()
    # The constraint cuts into the posterior: without it some draws would pass 1.
    assert total.max() > 1.0 - 0.5 * post.summary["rs"]["std"]


def test_coefficient_draws_follow_the_truncated_conditional(faint_lobe):
    problem = Problem(faint_lobe, "ward")
    target = Target(problem, "given", np.array([math.log10(0.3)]))
    draws = 20000
    theta = np.full((draws, 1), math.log10(0.3))
    coefs = target.draw_coefficients(theta, np.random.default_rng(0))[:, 0, :]
    _, ks_mean, ks_sd = grid_marginal(faint_lobe, 0.3, 0.01)
    assert (coefs >= 0).all()
    # The conditional mean of ks sits well above the unconstrained solution's
    # clipping: the draws must follow the truncated Gaussian, not clip it.
    assert abs(coefs[:, 1].mean() - ks_mean) < 5 * ks_sd / math.sqrt(draws)
    assert abs(coefs[:, 1].std() - ks_sd) < 5 * ks_sd / math.sqrt(2 * draws)


def test_linear_model_posterior_is_the_closed_form():
    """lambert with sigma: nothing to sample by MCMC; kd is Gaussian with mean
    pi sum(w y)/sum(w) and sd pi/sqrt(sum(w)), w = 1/sigma^2."""
    rng = np.random.default_rng(2)
    wi, wo = near_specular(50, rng)
    sigma = rng.uniform(0.005, 0.02, 50)
    y = 0.5 / math.pi + sigma * rng.standard_normal(50)
    data = Measurements(wi, wo, y, sigma=sigma)
    post = sample_posterior(data, fit(data, "lambert"), seed=1)
    w = 1 / sigma**2
    mean, sd = math.pi * (w * y).sum() / w.sum(), math.pi / math.sqrt(w.sum())
    s = post.summary["kd"]
    n = post.samples.shape[0]
    assert post.converged and post.sampled == () and post.names == ("kd",)
    assert abs(s["mean"] - mean) < 5 * sd / math.sqrt(n)
    assert abs(s["std"] - sd) < 5 * sd / math.sqrt(2 * n)


# -------------------------------------------------------------- calibration
def _coverage(model, draw_truth, n_sets, noise_given):
    """How often the 16-84 % interval of each parameter holds the truth."""
    hits: dict[str, int] = {}
    for i in range(n_sets):
        rng = np.random.default_rng(1000 + i)
        truth = draw_truth(rng)
        wi, wo = near_specular(60, rng)
        data = dataset(model, truth, wi, wo, 0.05, rng, give_sigma=noise_given)
        # The polish from the true shape finds the optimum fast; the posterior
        # does not depend on where the fit started.
        start = {k: v for k, v in truth.items() if k.startswith("alpha")}
        # Constant absolute noise: the l2 fit and its "absolute" noise are the right model.
        loss = None if noise_given else "l2"
        result = fit(data, model, start=start, global_algorithm=None, loss=loss)
        post = sample_posterior(data, result, seed=i)
        assert post.converged, post.message
        for name in post.names:
            value = truth.get(name, 0.05)
            s = post.summary[name]
            hits[name] = hits.get(name, 0) + int(s["p16"] <= value <= s["p84"])
    return hits


def _check_coverage(hits, n_sets):
    # Calibrated 68 % intervals hold the truth Binomial(n, 0.68) times; each
    # count must lie in that distribution's central 99 % interval.
    lo, hi = binom.interval(0.99, n_sets, 0.68)
    for name, count in hits.items():
        assert lo <= count <= hi, f"{name}: {count} of {n_sets} intervals hold the truth"


def test_calibration_isotropic_with_given_sigma():
    def truth(rng):
        return {
            "kd": rng.uniform(0.2, 0.6),
            "ks": rng.uniform(0.1, 0.5),
            "alpha": log_uniform(rng, 0.08, 0.3),
        }

    hits = _coverage("ward", truth, 40, noise_given=True)
    assert set(hits) == {"kd", "ks", "alpha"}
    _check_coverage(hits, 40)


def test_calibration_anisotropic_with_estimated_noise():
    assert "ward_anisotropic" in REGISTRY

    def truth(rng):
        return {
            "kd": rng.uniform(0.2, 0.6),
            "ks": rng.uniform(0.1, 0.5),
            "alpha_x": log_uniform(rng, 0.08, 0.3),
            "alpha_y": log_uniform(rng, 0.08, 0.3),
        }

    hits = _coverage("ward_anisotropic", truth, 40, noise_given=False)
    assert set(hits) == {"kd", "ks", "alpha_x", "alpha_y", "noise"}
    _check_coverage(hits, 40)


# ---------------------------------------------------------------- trade-off
def test_ks_alpha_tradeoff_shows_as_correlation():
    """In-plane samples near the mirror direction see the top of the lobe, whose
    height ks/alpha^2 they fix: ks and alpha then rise together. The Fisher
    information (scalar Ward, central differences) predicts the correlation."""
    to = np.concatenate([np.linspace(18, 42, 25), np.linspace(20, 70, 10)])
    po = np.concatenate([np.full(25, 180.0), np.zeros(10)])
    n = to.size
    wi, wo = directions_from_angles(np.full(n, 30.0), np.zeros(n)), directions_from_angles(to, po)
    truth, sigma = {"kd": 0.3, "ks": 0.4, "alpha": 0.3}, 0.01
    data = dataset("ward", truth, wi, wo, sigma, np.random.default_rng(3))

    def values(kd, ks, alpha):
        return ward_columns(data, alpha) @ np.array([kd, ks])

    base, eps = np.array([truth["kd"], truth["ks"], truth["alpha"]]), 1e-6
    grads = np.array(
        [(values(*(base + e)) - values(*(base - e))) / (2 * eps) for e in np.eye(3) * eps]
    )
    cov = np.linalg.inv(grads @ grads.T / sigma**2)
    expected = cov[1, 2] / math.sqrt(cov[1, 1] * cov[2, 2])
    post = sample_posterior(data, fit(data, "ward"), seed=4)
    rho = post.correlation[post.index("ks"), post.index("alpha")]
    assert post.converged
    assert expected > 0.8 and rho > 0.8
    assert abs(rho - expected) < 0.05


# ---------------------------------------------------------------- diagnostics
def test_autocorrelation_time_matches_emcee_and_ar1():
    rng = np.random.default_rng(8)
    phi = np.array([0.0, 0.6, 0.9])
    steps, walkers = 20000, 16
    chain = np.zeros((steps, walkers, 3))
    noise = rng.standard_normal(chain.shape)
    chain[0] = noise[0] / np.sqrt(1 - phi**2)
    for t in range(1, steps):
        chain[t] = phi * chain[t - 1] + noise[t]
    ours = integrated_time(chain)
    np.testing.assert_allclose(ours, emcee.autocorr.integrated_time(chain, tol=0), rtol=1e-10)
    # AR(1): tau = (1 + phi)/(1 - phi). Sokal (1997, eq. 3.19): the windowed
    # estimate has relative variance 2 (2M + 1) / N for a window M ~ 5 tau and
    # N = steps x walkers values; subtracting each walker's mean biases it by
    # about -2 M tau / steps relative to tau. Allow 4 sd plus that bias.
    tau = (1 + phi) / (1 - phi)
    window = 5 * tau
    allowed = 4 * np.sqrt(2 * (2 * window + 1) / (steps * walkers)) + 2 * window / steps
    assert (np.abs(ours / tau - 1) < allowed).all(), (ours, tau, allowed)


def test_converged_run_reports_its_diagnostics(ward_fit):
    data, result = ward_fit
    post = sample_posterior(data, result, seed=3)
    assert post.converged and post.message.startswith("converged")
    tau = max(post.autocorr_time.values())
    assert post.n_steps - post.burn >= 50 * tau
    assert post.effective_samples == pytest.approx(
        post.n_walkers * (post.n_steps - post.burn) / tau, rel=1e-6, abs=1.0
    )
    assert 0.1 < post.acceptance_fraction <= 1.0
    assert post.names == ("kd", "ks", "alpha") and post.noise == "given"
    for name, s in post.summary.items():
        assert s["p16"] < s["median"] < s["p84"]
        col = post.samples[:, post.index(name)]
        assert s["mean"] == pytest.approx(col.mean()) and s["std"] == pytest.approx(
            col.std(ddof=1)
        )
    np.testing.assert_allclose(post.covariance, np.cov(post.samples, rowvar=False))
    np.testing.assert_allclose(np.diag(post.correlation), 1.0)


def test_posterior_is_frozen_and_json_ready(ward_fit):
    data, result = ward_fit
    post = sample_posterior(data, result, seed=3, steps=60)
    with pytest.raises(dataclasses.FrozenInstanceError):
        post.converged = True
    with pytest.raises(ValueError):
        post.samples[0, 0] = 1.0
    with pytest.raises(TypeError):
        post.summary["kd"]["median"] = 1.0
    out = json.loads(json.dumps(post.to_dict(include_samples=True)))
    assert out["names"] == list(post.names)
    assert out["summary"]["alpha"]["median"] == post.summary["alpha"]["median"]
    assert len(out["samples"]) == post.samples.shape[0]
    assert out["converged"] is False and "not converged" in out["message"]


def test_rgb_names_and_estimated_noise():
    rng = np.random.default_rng(6)
    wi, wo = near_specular(60, rng)
    truth = {"kd": [0.2, 0.3, 0.4], "ks": [0.3, 0.2, 0.1], "alpha": 0.2}
    f = get_model("ward").evaluate(wi, wo, truth)
    data = Measurements(wi, wo, f + 0.02 * rng.standard_normal(f.shape), channels=["r", "g", "b"])
    post = sample_posterior(data, fit(data, "ward", loss="l2"), seed=0)  # constant noise
    assert post.noise == "absolute" and post.sampled == ("alpha", "noise")
    assert post.names == ("kd[r]", "kd[g]", "kd[b]", "ks[r]", "ks[g]", "ks[b]", "alpha", "noise")
    assert (
        post.summary["noise"]["p16"] < 0.02 * 1.25 and post.summary["noise"]["p84"] > 0.02 / 1.25
    )


def test_estimated_noise_scales_sigma_under_the_chi2_loss(ward_fit):
    """With the chi2 loss the noise is constant on (f - y)/sigma: a multiple of the
    data's sigma, which here is the true one, so the multiple is 1."""
    data, _ = ward_fit
    post = sample_posterior(data, fit(data, "ward", loss="chi2"), noise="absolute", seed=0)
    s = post.summary["noise"]
    assert post.loss == "chi2" and abs(s["median"] - 1.0) < 3 * s["std"]
    # 80 residuals less 3 fitted parameters: a scale estimated from nu = 77 degrees
    # of freedom has a relative sd of 1/sqrt(2 nu), to O(1/nu).
    assert s["std"] / s["median"] == pytest.approx(1 / math.sqrt(2 * 77), rel=0.1)


def test_fit_with_uncertainty_attaches_the_posterior(ward_fit):
    data, _ = ward_fit
    result = fit(data, "ward", uncertainty=True, posterior_options={"seed": 1, "steps": 40})
    assert isinstance(result.posterior, Posterior)
    assert result.to_dict()["posterior"]["n_steps"] == 40


def test_fit_weights_carry_into_the_likelihood():
    """A fit weighted 0 on half the samples: its posterior is that of the other half
    alone (the zero-weight samples leave the likelihood and lend nothing to the
    rest), and wider than that of all samples, whose information is twice as much."""
    rng = np.random.default_rng(23)
    wi, wo = near_specular(160, rng)
    data = dataset("ward", {"kd": 0.3, "ks": 0.2, "alpha": 0.15}, wi, wo, 0.01, rng)
    half = np.arange(data.n) < data.n // 2
    weighted = fit(data, "ward", weights=half.astype(float))
    assert weighted.weights.tolist() == half.astype(float).tolist()
    alone = fit(data.subset(np.flatnonzero(half)), "ward")
    both = fit(data, "ward")
    first = data.subset(np.flatnonzero(half))
    sd = {}
    for key, d, r in (("weighted", data, weighted), ("alone", first, alone), ("both", data, both)):
        post = sample_posterior(d, r, seed=4, steps=400)
        sd[key] = np.array([post.summary[n]["std"] for n in ("kd", "ks", "alpha")])
    # Monte Carlo error of a std from >= 1,000 effective samples is about 2 %.
    np.testing.assert_allclose(sd["weighted"], sd["alone"], rtol=0.1)
    assert (sd["weighted"] / sd["both"] > 1.2).all(), sd


def test_energy_conserving_fit_gives_a_posterior_within_the_bound():
    """Ward data whose true albedo peaks at 0.998: the plain posterior spills past 1,
    that of the energy-conserving fit keeps only draws with albedo <= 1, checked
    here by the adaptive quadrature of brdffit.models.properties, and says what it dropped."""
    rng = np.random.default_rng(3)
    n = 400
    wi = directions_from_angles(rng.uniform(0, 80, n), np.zeros(n))
    wo = directions_from_angles(rng.uniform(0, 85, n), rng.uniform(0, 360, n))
    truth = {"kd": 0.6, "ks": 0.445, "alpha": 0.2}
    data = dataset("ward", truth, wi, wo, 0.02, rng)
    angles = np.arange(0.0, 89.5, 2.5)

    def brightest(post, count=8):
        s = post.samples
        top = np.argsort(s[:, post.index("kd")] + s[:, post.index("ks")])[-count:]
        params = [dict(zip(post.names, s[i])) for i in top]
        return [float(albedo("ward", p, angles).value.max()) for p in params]

    plain = sample_posterior(data, fit(data, "ward"), seed=1, steps=60)
    bound = sample_posterior(data, fit(data, "ward", energy_conserving=True), seed=1, steps=60)
    assert max(brightest(plain)) > 1.005
    assert max(brightest(bound)) <= 1 + 1e-3
    assert "energy_conserving: kept" in bound.message
    assert len(bound.samples) < len(plain.samples)
    assert bound.effective_samples < plain.effective_samples


def test_repeated_lobes_are_relabelled_in_every_sample():
    """Two blinn lobes: samples drawn with the lobes swapped (as walkers that cross
    over would give) come back in the fit's order, smaller n first, each lobe's
    ks moving with its n and the shared diffuse term staying put."""
    rng = np.random.default_rng(8)
    wi, wo = near_specular(60, rng)
    data = Measurements(wi, wo, np.ones((60, 2)), channels=["r", "g"])
    problem = Problem(data, "lambert+blinn+blinn")
    names = ("lambert.kd[r]", "lambert.kd[g]", "blinn_1.ks[r]", "blinn_1.ks[g]",
             "blinn_2.ks[r]", "blinn_2.ks[g]", "blinn_1.n", "blinn_2.n")  # fmt: skip
    ordered = np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 10.0, 200.0])
    swapped = np.array([0.1, 0.2, 0.5, 0.6, 0.3, 0.4, 200.0, 10.0])
    out = _canonical_samples(problem, names, np.vstack([ordered, swapped]))
    np.testing.assert_array_equal(out, np.vstack([ordered, ordered]))


# ------------------------------------------------- reproducibility, budgets
def test_seeded_runs_are_reproducible(ward_fit):
    data, result = ward_fit
    one = sample_posterior(data, result, seed=5, steps=80)
    two = sample_posterior(data, result, seed=5, steps=80)
    other = sample_posterior(data, result, seed=6, steps=80)
    np.testing.assert_array_equal(one.samples, two.samples)
    np.testing.assert_array_equal(one.chain, two.chain)
    assert not np.array_equal(one.samples, other.samples)


def test_time_budget_stops_the_run():
    rng = np.random.default_rng(9)
    wi, wo = near_specular(3000, rng)
    truth = {"kd": 0.3, "ks": 0.3, "alpha_x": 0.1, "alpha_y": 0.2}
    data = dataset("ward_anisotropic", truth, wi, wo, 0.01, rng, give_sigma=False)
    result = fit(
        data, "ward_anisotropic", start={"alpha_x": 0.1, "alpha_y": 0.2}, global_algorithm=None
    )
    # Convergence needs at least 50 autocorrelation times of 32 walkers on 3000
    # samples: hundreds of steps, far more than 0.05 s on any machine here (a
    # clean CI run converged within 0.3 s, so the budget is this small).
    post = sample_posterior(data, result, max_seconds=0.05, max_steps=10**6)
    assert not post.converged
    assert "time limit" in post.message and "not converged" in post.message
    # The run may overrun by the step in progress and the coefficient draws of
    # the kept samples.
    assert post.seconds < 0.05 + 1.0
    assert post.samples.shape[0] > 0


def test_fixed_steps_are_run_and_judged(ward_fit):
    data, result = ward_fit
    post = sample_posterior(data, result, steps=30, seed=0)
    assert post.n_steps == 30 and post.chain.shape == (30, 32, 1)
    assert not post.converged and "ran the steps asked for" in post.message


@pytest.mark.parametrize(
    "option, value",
    [
        ("walkers", 0),
        ("walkers", 2.5),
        ("walkers", 4),
        ("steps", "forever"),
        ("steps", 0),
        ("max_steps", -1),
        ("max_seconds", 0),
        ("max_seconds", "soon"),
        ("seed", -1),
        ("seed", 1.5),
        ("noise", "poisson"),
        ("progress", 3),
        ("walker", 10),
    ],
)
def test_bad_options_name_the_option(ward_fit, option, value):
    data, result = ward_fit
    with pytest.raises(FitError) as info:
        sample_posterior(data, result, **{option: value})
    assert info.value.field == option
    assert option in str(info.value)
    if option == "walker":
        assert "did you mean walkers" in str(info.value)


def test_given_noise_needs_sigma_and_data_must_match(ward_fit):
    data, result = ward_fit
    bare = Measurements(data.wi, data.wo, data.values)
    with pytest.raises(FitError, match="needs per-sample sigma") as info:
        sample_posterior(bare, result, noise="given")
    assert info.value.field == "noise"
    with pytest.raises(FitError, match="not those of the fit") as info:
        sample_posterior(data.subset(np.arange(40)), result)
    assert info.value.field == "data"


def test_progress_is_reported(ward_fit):
    data, result = ward_fit
    seen = []
    post = sample_posterior(data, result, seed=2, progress=seen.append)
    assert seen and seen[-1].converged == post.converged
    assert [p.steps for p in seen] == sorted(p.steps for p in seen)


# ------------------------------------------------------------------- plots
def test_plots_write_png(ward_fit, tmp_path):
    data, result = ward_fit
    post = sample_posterior(data, result, seed=1, steps=60)
    for draw, name in ((corner_plot, "corner.png"), (trace_plot, "trace.png")):
        path = draw(post, tmp_path / name)
        head = path.read_bytes()[:8]
        assert head == b"\x89PNG\r\n\x1a\n"
    import matplotlib.image

    image = matplotlib.image.imread(tmp_path / "corner.png")
    assert image.shape[0] == image.shape[1] == 700  # (2 x 3 + 1) inches at 100 dpi
