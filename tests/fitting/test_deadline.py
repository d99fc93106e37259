"""A fit honours its timeout in every stage (issue 18).

Behaviour, not a benchmark: the margins are wide (a 2 s timeout must return
within 15 s) so that a loaded machine cannot make them flake; before, the slow
sum below took minutes (its energy check alone 33 s, measured), and the
posterior ran to its own 60 s.
"""

from __future__ import annotations

from pathlib import Path
from time import perf_counter

import brdffit

REPO = Path(__file__).resolve().parents[2]
SLOW_SUM = "lambert+" + "+".join(["ggx_anisotropic"] * 4)


def test_the_slow_energy_conserving_sum_returns_at_its_timeout():
    data = brdffit.read(REPO / "data_synthetic" / "ggx_anisotropic.csv")
    start = perf_counter()
    result = brdffit.fit(data, SLOW_SUM, energy_conserving=True, timeout=2, loss="l2")
    assert perf_counter() - start < 15
    assert not result.converged
    assert "timeout" in result.message
    assert "energy: max directional albedo" in result.message


def test_the_posterior_of_a_fit_shares_its_timeout():
    data = brdffit.synthesize("ggx", {"kd": 0.3, "ks": 0.5, "alpha": 0.2}, noise=0.01)
    start = perf_counter()
    result = brdffit.fit(
        data, "ggx", timeout=2, uncertainty=True, posterior_options={"steps": 10**6}
    )
    assert perf_counter() - start < 15
    assert result.posterior is not None
    assert result.posterior.n_steps < 10**6  # cut by the time left, not its own 60 s


def test_no_time_left_means_no_posterior_and_says_so():
    data = brdffit.read(REPO / "data_synthetic" / "ggx_anisotropic.csv")
    result = brdffit.fit(data, SLOW_SUM, timeout=0.5, uncertainty=True, loss="l2")
    assert result.posterior is None
    assert "posterior not sampled: the timeout was reached" in result.message
