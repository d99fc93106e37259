"""plot_fit draws on its own Agg figure: the caller's matplotlib backend and pyplot
state are left alone, for both layouts (planes of incidence, measured vs fitted)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import PNG_SIGNATURE

import brdffit

matplotlib = pytest.importorskip("matplotlib", reason="plots need the 'plot' extra")
from brdffit.plot.fit import fit_figure, plane_of_incidence, plot_fit  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def pdf_backend():
    """The caller's backend is pdf (non-interactive, always available) for the test."""
    before = matplotlib.get_backend()
    matplotlib.use("pdf")
    yield
    matplotlib.use(before)


def _random_directions(n: int, seed: int):
    rng = np.random.default_rng(seed)
    theta = rng.uniform(5, 80, (2, n))
    phi = rng.uniform(0, 360, (2, n))
    model = brdffit.get_model("blinn")
    pairs = brdffit.Measurements.from_angles(theta[0], phi[0], theta[1], phi[1], np.zeros(n))
    values = model.evaluate(pairs.wi, pairs.wo, {"kd": 0.3, "ks": 0.5, "n": 40.0})
    return brdffit.Measurements(pairs.wi, pairs.wo, values[:, None], channels=["value"])


@pytest.mark.parametrize("kind", ["planes", "scatter"])
def test_plot_fit_keeps_the_callers_backend_and_no_pyplot_figure(tmp_path, pdf_backend, kind):
    if kind == "planes":
        data = brdffit.read(ROOT / "data_synthetic" / "blinn.csv")
        assert plane_of_incidence(data)  # this dataset draws the planes of incidence
    else:
        data = _random_directions(200, seed=3)
        assert not plane_of_incidence(data)  # random directions: measured vs fitted
    result = brdffit.fit(data, "blinn", seed=0)
    path = tmp_path / f"{kind}.png"
    assert plot_fit(data, result, path) == str(path)
    assert path.read_bytes()[:8] == PNG_SIGNATURE and path.stat().st_size > 20_000
    assert matplotlib.get_backend() == "pdf"
    pyplot = sys.modules.get("matplotlib.pyplot")
    assert pyplot is None or pyplot.get_fignums() == []


# ------------------------------------------------ what the panels draw (issue 17)
def _axis(fig, ylabel):
    return next(ax for ax in fig.axes if ax.get_ylabel() == ylabel)


def _drawn(ax, gid):
    """The (x, y) data of the lines of ``ax`` with this gid, one per channel."""
    return [(ln.get_xdata(), ln.get_ydata()) for ln in ax.lines if ln.get_gid() == gid]


def _notes(ax):
    return " ".join(t.get_text() for t in ax.texts if t.get_gid() == "note")


def _lambert_rgb(kd, n=300, seed=5):
    rng = np.random.default_rng(seed)
    theta_i, theta_o = rng.uniform(5, 80, (2, n))
    phi_o = rng.uniform(0, 360, n)
    return brdffit.synthesize(
        "lambert", {"kd": kd}, geometry=(theta_i, np.zeros(n), theta_o, phi_o),
        channels=["r", "b"],
    )  # fmt: skip


def test_relative_residuals_are_what_the_label_says_and_zero_fits_are_counted():
    data = _lambert_rgb([0.5, 0.0])
    values = np.array(data.values)
    values[:, 0] *= 1 + 0.02 * np.sin(np.arange(data.n))  # a visible misfit in r
    values[:, 1] = 1e-3 * np.cos(np.arange(data.n))  # b: data with no signal, kd fits to 0
    noisy = brdffit.Measurements(data.wi, data.wo, values, channels=data.channels)
    result = brdffit.fit(noisy, "lambert", seed=0)
    fitted = brdffit.get_model("lambert").evaluate(noisy.wi, noisy.wo, result.params)
    assert np.all(fitted[:, 1] == 0)  # the case of the issue: a channel fitted to 0
    ax = _axis(fit_figure(noisy, result), "(measured − fitted) / fitted")
    (_, y_r), (_, y_b) = _drawn(ax, "residuals")
    expected = (values[:, 0] - fitted[:, 0]) / fitted[:, 0]
    assert np.allclose(np.sort(y_r), np.sort(expected), rtol=1e-12)
    assert y_b.size == 0  # no relative residual where the fit is 0 (was drawn as ~0)
    assert f"{data.n} values not drawn (fitted value 0" in _notes(ax)


def test_the_log_axes_count_what_they_cannot_show():
    data = brdffit.read(ROOT / "data_synthetic" / "blinn.csv")
    result = brdffit.fit(data, "blinn", seed=0)
    first = plane_of_incidence(data)[0]
    values = np.array(data.values)
    values[first.index[:3], 0] = 0.0
    values[first.index[3:7], 0] = -1e-4
    changed = brdffit.Measurements(data.wi, data.wo, values, channels=data.channels)
    fig = fit_figure(changed, result)
    panels = [ax for ax in fig.axes if ax.get_title().startswith("incidence")]
    title = f"incidence θi = {first.theta_i:g}°, φi = {first.phi_i:g}°"
    panel = next(ax for ax in panels if ax.get_title() == title)
    assert "7 measured values ≤ 0 not shown (log axis)" in _notes(panel)


def test_residual_limits_are_robust_and_outliers_counted():
    data = brdffit.synthesize("blinn", {"kd": 0.3, "ks": 0.5, "n": 40.0}, noise=0.03, seed=2)
    result = brdffit.fit(data, "blinn", seed=0)
    values = np.array(data.values)
    values[[10, 20, 30], 0] *= 1000.0  # three wild samples
    spoiled = brdffit.Measurements(data.wi, data.wo, values, sigma=data.sigma)
    ax = _axis(fit_figure(spoiled, result), "(measured − fitted) / σ")
    low, high = ax.get_ylim()
    (_, inside), = _drawn(ax, "residuals")  # fmt: skip
    (_, edge), = _drawn(ax, "outliers")  # fmt: skip
    assert edge.size == 3 and np.all(edge <= high)
    assert high < 50  # the other residuals are not squeezed onto a line (was > 1e4)
    assert inside.size == data.n - 3 and np.ptp(inside) > 0.5 * (high - low)
    assert "3 points beyond the axis limits" in _notes(ax)


def _cells(theta_i, step=2.0):
    """An MBSDF-like table: azimuth cells centred step/2 off the plane of incidence."""
    theta_o = np.arange(step / 2, 90, step)
    dphi = np.arange(step / 2, 180, step)
    to, dp = (a.ravel() for a in np.meshgrid(theta_o, dphi))
    ti = np.full(to.size, theta_i)
    return ti, np.zeros(to.size), to, dp


def test_tabulated_cells_get_the_nearest_azimuth_slice_stated_on_the_plot():
    angles = [np.concatenate(a) for a in zip(*(_cells(t) for t in (15.0, 45.0)))]
    truth = {"kd": 0.3, "ks": 0.5, "n": 40.0}
    data = brdffit.synthesize("blinn", truth, geometry=tuple(angles))
    groups = plane_of_incidence(data)
    assert [g.theta_i for g in groups] == [15.0, 45.0]
    for g in groups:
        assert (g.backward, g.forward, g.offset) == (1.0, 179.0, 1.0)
        assert g.index.size == 2 * 45  # one cell per theta_o on each side
    result = brdffit.fit(data, "blinn", seed=0)
    fig = fit_figure(data, result)
    panel = next(ax for ax in fig.axes if ax.get_title().startswith("incidence θi = 45"))
    assert "nearest azimuth slice: φo − φi = 1° | 179°" in _notes(panel)
    # the model is drawn at the slice's azimuths: it passes through the measured points
    curve = panel.lines[1]
    x, y = curve.get_xdata(), curve.get_ydata()
    measured = dict(zip(np.round(groups[1].signed), data.values[groups[1].index, 0]))
    at = np.isin(np.round(x, 6), list(measured))
    assert at.sum() > 40
    assert np.allclose(y[at], [measured[round(v)] for v in x[at]], rtol=1e-3)


def test_the_car_paint_gets_in_plane_curves():
    from helpers import shared_file

    data = brdffit.read(shared_file("nvidia", "carpaint_red.mbsdf"))
    groups = plane_of_incidence(data)
    assert len(groups) == len(np.unique(data.angles()[0]))  # every incidence direction
    assert all(g.offset == pytest.approx(1.0) for g in groups)
