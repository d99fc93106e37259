"""plot_fit draws on its own Agg figure: the caller's matplotlib backend and pyplot
state are left alone, for both layouts (planes of incidence, measured vs fitted)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import brdffit

matplotlib = pytest.importorskip("matplotlib", reason="plots need the 'plot' extra")
from brdffit.plot.fit import plane_of_incidence, plot_fit  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


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
