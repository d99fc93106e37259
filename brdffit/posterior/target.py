"""The log-posterior that :mod:`brdffit.posterior.sample` samples, with the linear coefficients
integrated out analytically.

The statistical model
---------------------
For shape parameters ``x`` (the fit's search space: log10 for log-scale ones)
every model is linear in its coefficients ``b_c`` (kd, ks... of channel ``c``):
``f_mc = offset_m(x) + sum_k A_mk(x) b_ck``. The likelihood is Gaussian on the
residuals in the space of the fit's loss, linearised about the data (the delta
method, exact for the losses whose transform is linear: l2, cosine, relative,
chi2): ``t(f) - t(y) ~ t'(y) (f - y)``. Each value then has a precision
``lam * w_mc`` with known base weights ``w`` and a scale ``lam = 1 / noise^2``:

* ``given``: the data's sigma, ``w = u_m / sigma_mc^2`` and ``lam = 1`` (the
  transform cancels: ``t'(y) (f - y) / (t'(y) sigma) = (f - y) / sigma``);
* ``absolute``: the noise is constant on the loss's transformed values,
  ``w = u_m t'(y_mc)^2`` (the loss's own Gauss-Newton weights), so that the
  loss is the negative log-likelihood; ``noise`` is in the units of ``t``
  (1/sr for l2 and cosine; a multiple of sigma for chi2);
* ``relative``: the noise is proportional to the measured value,
  ``w = u_m / max(|y_mc|, 1e-3 max_m |y_mc|)^2``; ``noise`` is a fraction.
* ``mixed``: the fit's own noise model (the ``mixed`` loss, the default
  without sigma: :mod:`brdffit.fitting.noise`), ``w = u_m / s_mc^2`` with
  ``s^2 = a^2 + (b f)^2`` at the fitted ``a``, ``b`` and prediction ``f``;
  its shape (the ratio of ``a`` to ``b``) is profiled at the fit's estimate
  and ``noise``, the multiple of ``s``, is sampled (near 1 when the fit's
  estimate holds).

``u_m`` are the fit's sample weights (1 without). Estimated noise is one extra
sampled parameter, ``log10(noise)``, shared by all channels.

Marginalising the coefficients
------------------------------
With a flat prior on the box ``lo <= b_c <= hi`` (the parameters' bounds), the
integral over ``b_c`` is Gaussian: with the weighted Gram ``G_c = A^T W_c A``,
the least-squares solution ``bhat_c = G_c^-1 A^T W_c (y_c - offset)`` and its
residual sum of squares ``R_c``,

    log p(y_c | x, lam) = -lam R_c / 2 + (n_c - K)/2 log(lam) - 1/2 log det G_c
                          + K/2 log(2 pi) + log P_c + const,

``n_c`` the observations of channel ``c`` with positive weight, ``K`` the free
coefficients, and ``P_c`` the Gaussian mass ``N(bhat_c, G_c^-1 / lam)`` inside
the box (the non-negativity truncation) and inside the model's linear
constraints on its coefficients, if any (Ashikhmin-Shirley's
``rd_eff + rs <= 1``). ``P_c`` is computed as the product of the
one-dimensional masses of each bound and each constraint: exact for one
coefficient and whenever at most one bound or constraint is near (the usual
case: a kd or ks near 0), an approximation when several are (Gelman et al.,
Bayesian Data Analysis, 3rd ed., sec. 14.2 for the Gaussian integral). A
relative ridge of 1e-12 keeps ``G`` invertible where a column vanishes (a lobe
that misses every sample); it acts as a very broad Gaussian prior on that
coefficient, so the marginal stays finite even for a coefficient without an
upper bound.

Given a sampled ``(x, lam)`` the coefficients are drawn exactly from the
Gaussian ``N(bhat_c, G_c^-1 / lam)`` restricted to that region (rejection, then
Gibbs sweeps when it holds little mass: :mod:`brdffit.posterior.truncnorm`), so
they are reported like every other parameter. Not sampled by emcee: they are
``K x C`` dimensions (6 for RGB, 60 for 30 spectral bands), exactly Gaussian
given the shape, and the affine-invariant ensemble slows down with dimension.

Samples below the horizon, where every model is 0, enter with ``f = 0``.
"""

from __future__ import annotations

import numpy as np

from ..errors import FitError
from ..fitting.channels import abs_max_by_channel
from ..fitting.losses import LossContext
from .design import (
    batched_design,
    batches_agree,
    compiled_lobe,
    lobe_design,
    lobe_runs,
    looped_design,
)
from .gram import statistics
from .truncnorm import LOG_2PI, draw_box_gaussian, log_mass

__all__ = ["Target", "NOISE_MODELS"]

NOISE_MODELS = ("given", "absolute", "relative", "mixed")
#: Walkers per vectorised design call: (64, 10^4) arrays stay a few MB.
BATCH = 64
#: Decades either side of the fit's residual scale that the noise prior spans.
NOISE_DECADES = 3.0


class Target:
    """Log-posterior of ``(x, log10 noise)`` for a :class:`~brdffit.fitting.problem.Problem`.

    Parameters
    ----------
    problem : Problem
    noise : {"given", "absolute", "relative", "mixed"}
    x_fit : (n_shape,) array
        The fitted shape parameters in search space; they centre the noise prior.
    weights : (N,) array or None
        The fit's sample weights.

    Attributes
    ----------
    n_shape, n_sampled, n_coefficients : int
        Free shape parameters (the first columns of a sampled point); sampled
        dimensions (``n_shape``, plus ``log10(noise)`` when it is estimated);
        free linear coefficients per channel (integrated out, then drawn).
    """

    def __init__(self, problem, noise: str, x_fit, weights=None):
        self.problem = problem
        self.noise = noise
        self.shape_params = list(problem.free_shape)
        self.n_shape = len(self.shape_params)
        self.log_scale = np.array([p.log_scale for p in self.shape_params], dtype=bool)
        self.n_coefficients = len(problem.free_coefs)
        self.coef_lower, self.coef_upper = problem.coef_lower, problem.coef_upper
        # The model's rows @ b <= bounds on its coefficients (rd_eff + rs <= 1), as fitted.
        self.rows, self.bounds = problem.coef_constraints or (None, None)
        self._set_data(weights)
        self.batched = self._check_batched()
        self.lobe = compiled_lobe(problem) if self.batched else None
        self.estimates_noise = noise != "given"
        lower, upper = list(problem.lower), list(problem.upper)
        if self.estimates_noise:
            centre = self._noise_scale(np.asarray(x_fit, dtype=float))
            lower.append(centre - NOISE_DECADES)
            upper.append(centre + NOISE_DECADES)
        self.lower, self.upper = np.array(lower), np.array(upper)
        self.n_sampled = len(self.lower)
        self.theta_fit = np.append(x_fit, centre) if self.estimates_noise else np.array(x_fit)
        #: A :class:`~brdffit.posterior.recall.Recall` while a run keeps its points'
        #: statistics for the coefficient draws, else None.
        self.recall = None

    # ------------------------------------------------------------------ data
    def _set_data(self, weights):
        p = self.problem
        data, g = p.data, p.geometry
        y = np.asarray(data.values, dtype=float)
        u = np.ones(data.n) if weights is None else np.asarray(weights, dtype=float)
        if self.noise == "given":
            w = u[:, None] / np.asarray(data.sigma) ** 2
        elif self.noise == "mixed":
            if p.noise_sigma is None:
                raise FitError(
                    "noise='mixed' needs a fit with the mixed loss (its noise model)", "noise"
                )
            w = u[:, None] / p.noise_sigma**2
        elif self.noise == "relative":
            floor = 1e-3 * np.maximum(abs_max_by_channel(y), 1e-300)
            w = u[:, None] / np.maximum(np.abs(y), floor) ** 2
        else:
            cos_i = np.maximum(data.wi[:, 2], 0.0)
            cos_i[g.valid] = g.cos_i
            ctx = LossContext(cos_i=cos_i, y=y, sigma=data.sigma, weights=u)
            w = np.broadcast_to(p.loss.linearised(y, ctx)[0], y.shape).copy()
        if not (np.isfinite(w).all() and (w >= 0).all()):
            raise FitError(
                f"noise={self.noise!r} gives non-finite weights for these data", "noise"
            )
        valid = g.valid
        self.w, self.y = w[valid], y[valid]
        self.wy = self.w * self.y
        self.yy = np.einsum("mc,mc->c", self.wy, self.y)
        self.w_sum = self.w.sum(axis=0)
        self.w_t, self.wy_t = np.ascontiguousarray(self.w.T), np.ascontiguousarray(self.wy.T)
        self.y_t = np.ascontiguousarray(self.y.T)
        # Below the horizon f = 0: a constant residual sum of squares per channel.
        self.rss_invalid = np.einsum("mc,mc->c", w[~valid], y[~valid] ** 2)
        self.n_obs = (w > 0).sum(axis=0).astype(float)

    def _noise_scale(self, x) -> float:
        """log10 of the rms weighted residual at ``x``: the centre of the noise prior."""
        stats = self._stats(self.shape_values(x[None, :]))
        rss = float((stats[3] + self.rss_invalid).sum())
        scale = np.sqrt(rss / max(self.n_obs.sum(), 1.0))
        if not np.isfinite(scale) or scale <= 0:
            # A perfect fit: centre the prior far below the data's own scale.
            scale = 1e-8 * np.sqrt(float((self.yy + self.rss_invalid).sum()) / self.n_obs.sum())
        return float(np.log10(max(scale, 1e-300)))

    # ------------------------------------------------------------ parameters
    def shape_values(self, x: np.ndarray) -> np.ndarray:
        """Natural shape values (W, n_shape) from search-space points, clipped to bounds."""
        out = np.where(self.log_scale, 10.0 ** np.where(self.log_scale, x, 0.0), x)
        lo = np.array([p.lower for p in self.shape_params])
        hi = np.array([p.upper for p in self.shape_params])
        return np.clip(out, lo, hi)

    def lam(self, theta: np.ndarray) -> np.ndarray:
        """The precision scale ``1 / noise^2`` of each point (1 for given noise)."""
        if not self.estimates_noise:
            return np.ones(len(theta))
        return 10.0 ** (-2.0 * theta[:, self.n_shape])

    # ---------------------------------------------------------------- design
    def _check_batched(self) -> bool:
        """Whether the design broadcasts over (W, 1) shape values, checked on three points
        against one-at-a-time calls (models need not support it; the loop is the fallback)."""
        if self.n_shape == 0:
            return False
        rng = np.random.default_rng(12345)
        shapes = self.shape_values(
            rng.uniform(self.problem.lower, self.problem.upper, (3, self.n_shape))
        )
        return batches_agree(self.problem, self.shape_params, shapes)

    def designs(self, shapes: np.ndarray):
        if self.lobe is not None and lobe_runs(self.problem, self.lobe):
            return lobe_design(self.problem, self.lobe, self.shape_params, shapes)
        if self.batched:
            return batched_design(self.problem, self.shape_params, shapes)
        return looped_design(self.problem, self.shape_params, shapes)

    # ------------------------------------------------------------ statistics
    def _stats(self, shapes: np.ndarray):
        """``log |det|`` of the Gram matrices (W, C) with their ridge, their inverses
        (W, C, K, K), the least-squares coefficients (W, C, K), the residual sums of
        squares (W, C), and a mask of walkers whose design is not finite."""
        cols, offset = self.designs(shapes)
        return statistics(self, cols, offset, len(shapes))

    # ------------------------------------------------------------ log-density
    def log_prob(self, theta) -> np.ndarray:
        """Log-posterior (up to a constant) of each row of ``theta`` (W, n_sampled); -inf
        outside."""
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        out = np.full(len(theta), -np.inf)
        inside = np.isfinite(theta).all(axis=1)
        inside &= ((theta >= self.lower) & (theta <= self.upper)).all(axis=1)
        index = np.flatnonzero(inside)
        for start in range(0, len(index), BATCH):
            rows = index[start : start + BATCH]
            out[rows] = self._log_prob_inside(theta[rows])
        out[~np.isfinite(out)] = -np.inf
        return out

    def _log_prob_inside(self, theta: np.ndarray) -> np.ndarray:
        logdet, inv, beta, rss, bad = self._stats(self.shape_values(theta[:, : self.n_shape]))
        if self.recall is not None:
            self.recall.add(theta, beta, inv)
        lam = self.lam(theta)[:, None]
        k = self.n_coefficients
        logp = -0.5 * lam * (rss + self.rss_invalid) + 0.5 * (self.n_obs - k) * np.log(lam)
        logp += -0.5 * logdet + 0.5 * k * LOG_2PI
        if k:
            sd = np.sqrt(np.diagonal(inv, axis1=2, axis2=3) / lam[..., None])
            lo = (self.coef_lower - beta) / sd
            hi = (self.coef_upper - beta) / sd
            logp += log_mass(lo, hi).sum(axis=2)
        if self.rows is not None:
            # Each half-space adds its own one-dimensional mass, as the bounds do.
            mean = beta @ self.rows.T
            var = np.einsum("rk,wckl,rl->wcr", self.rows, inv, self.rows) / lam[..., None]
            from scipy.special import log_ndtr  # here: 0.4 s to import

            logp += log_ndtr((self.bounds - mean) / np.sqrt(var)).sum(axis=2)
        total = logp.sum(axis=1)
        total[bad] = -np.inf
        return total

    # ---------------------------------------------------------- coefficients
    def draw_coefficients(self, theta: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """One draw of the coefficients (S, C, K) given each row of ``theta``; the
        statistics of rows the run evaluated are taken from ``recall`` (a
        :class:`~brdffit.posterior.recall.Recall`, or None), the others computed."""
        theta = np.atleast_2d(theta)
        c, k = self.y.shape[1], self.n_coefficients
        out = np.empty((len(theta), c, k))
        if self.recall is not None and len(theta):
            found, betas, invs = self.recall.find(theta)
        else:
            found, betas, invs = np.zeros(len(theta), dtype=bool), None, None
        for start in range(0, len(theta), BATCH):
            part = slice(start, start + BATCH)
            miss = np.flatnonzero(~found[part])
            if len(miss) == len(found[part]):
                _, inv, beta, _, _ = self._stats(self.shape_values(theta[part, : self.n_shape]))
            else:
                beta, inv = betas[part], invs[part]
                if len(miss):
                    shapes = self.shape_values(theta[part][miss, : self.n_shape])
                    _, inv[miss], beta[miss], _, _ = self._stats(shapes)
            cov = inv / self.lam(theta[part])[:, None, None, None]
            out[part] = draw_box_gaussian(
                beta, cov, self.coef_lower, self.coef_upper, rng, self.rows, self.bounds
            )
        return out
