"""Corner and trace plots say what they leave out and mark an unconverged posterior
(issue 17); the tests read the figures' texts and artists, not their pixels."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("matplotlib", reason="plots need the 'plot' extra")
pytest.importorskip("corner", reason="the corner plot needs the 'plot' extra")

import brdffit
from brdffit.plot.corner import corner_figure, trace_plot
from brdffit.plot.fit import fit_figure
from brdffit.posterior.result import Posterior

BANDS = tuple(f"{w}nm" for w in range(400, 701, 10))


def posterior(channels=BANDS, converged=True) -> Posterior:
    rng = np.random.default_rng(0)
    names = (*[f"kd[{c}]" for c in channels], *[f"ks[{c}]" for c in channels], "alpha")
    samples = 0.5 + 0.01 * rng.standard_normal((400, len(names)))
    return Posterior(
        model="ggx", loss="l2", noise="absolute", names=names, samples=samples,
        sampled=("alpha",), sampled_log=(True,), chain=rng.standard_normal((50, 8, 1)),
        burn=10, thin=1, n_walkers=8, n_steps=50, autocorr_time={"alpha": 5.0},
        effective_samples=80, acceptance_fraction=0.4, converged=converged,
        message="converged" if converged else "stopped after 50 steps: 8 autocorrelation "
        "times, fewer than 50", seconds=1.0, seed=0, channels=tuple(channels),
    )  # fmt: skip


def texts(fig, gid):
    return [t.get_text() for t in fig.texts if t.get_gid() == gid]


def shown(fig):
    """The parameter names on the diagonal panels' x labels."""
    return {ax.get_xlabel() for ax in fig.axes if ax.get_xlabel()}


def test_many_channels_say_which_channel_is_shown():
    fig = corner_figure(posterior())
    assert shown(fig) == {"kd[400nm]", "ks[400nm]", "alpha"}
    assert texts(fig, "omitted") == [
        "channel 400nm of 31 shown (60 parameters of the other channels left out; "
        "choose with channel=)"
    ]


def test_the_caller_chooses_the_channel():
    fig = corner_figure(posterior(), channel="550nm")
    assert shown(fig) == {"kd[550nm]", "ks[550nm]", "alpha"}
    with pytest.raises(brdffit.errors.FitError, match="channel='red' is not a channel"):
        corner_figure(posterior(), channel="red")


def test_few_channels_show_everything_without_a_note():
    fig = corner_figure(posterior(channels=("r", "g", "b")))
    assert len(shown(fig)) == 7 and texts(fig, "omitted") == []


def test_an_unconverged_posterior_is_marked(tmp_path):
    fig = corner_figure(posterior(converged=False))
    (mark,) = texts(fig, "unconverged")
    assert mark.startswith("NOT CONVERGED") and "8 autocorrelation times" in mark
    assert any(p.get_gid() == "unconverged" and p.get_edgecolor()[:3] == (1.0, 0.0, 0.0)
               for p in fig.patches)  # fmt: skip
    assert texts(corner_figure(posterior()), "unconverged") == []
    trace_plot(posterior(converged=False), tmp_path / "trace.png")  # draws with the mark


def test_an_unconverged_fit_is_marked():
    data = brdffit.synthesize("blinn", {"kd": 0.3, "ks": 0.5, "n": 40.0}, n=300,
                              geometry="hemisphere", seed=1)  # fmt: skip
    stopped = brdffit.fit(data, "blinn", seed=0, max_evals=3)
    assert not stopped.converged
    (mark,) = texts(fit_figure(data, stopped), "unconverged")
    assert mark.startswith("NOT CONVERGED: not reliable.")
    done = brdffit.fit(data, "blinn", seed=0)
    assert done.converged and texts(fit_figure(data, done), "unconverged") == []
