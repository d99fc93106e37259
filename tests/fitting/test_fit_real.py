"""Fits to the real Cornell measurements in ../shared/data (all 31 bands).

Each fit must put its highlight at the mirror direction, keep its linear
parameters non-negative, and reach a loss no worse than a careful
scipy.optimize.least_squares fit from several starts (tests/scipy_baseline.py).
"""

from __future__ import annotations

import numpy as np
import pytest
from helpers import shared_file
from scipy_baseline import projected_baseline_fit

import brdffit
from brdffit.data.geometry import directions_from_angles

FILES = ["garnet_red.astm", "krylon_blue.astm", "acryl_blue.brdf"]
MODELS = ["blinn", "ward", "cook_torrance", "ashikhmin_shirley"]


@pytest.fixture(scope="module", params=FILES)
def cornell(request):
    return brdffit.read(shared_file("cornell", request.param))


def peak_offsets(model, params, incidences) -> np.ndarray:
    """theta_o - theta_i (degrees) of the model's maximum in the plane of incidence,
    negative angles standing for the backward half (phi_o = phi_i)."""
    theta_o = np.arange(-89.75, 90.0, 0.25)
    wo = directions_from_angles(np.abs(theta_o), np.where(theta_o < 0, 0.0, 180.0))
    out = []
    for ti in incidences:
        wi = directions_from_angles(np.full(theta_o.size, ti), np.zeros(theta_o.size))
        f = np.asarray(model.evaluate(wi, wo, params)).mean(axis=1)
        out.append(theta_o[np.argmax(f)] - ti)
    return np.array(out)


@pytest.mark.parametrize("name", MODELS)
def test_real_fit_is_sound_and_beats_scipy(cornell, name):
    model = brdffit.get_model(name)
    result = brdffit.fit(cornell, name, loss="l2")  # the scipy baseline is least squares
    assert result.n_channels == 31 and result.n_samples == 1439
    for p in model.linear_params:
        assert np.all(np.asarray(result.params[p.name]) >= 0), p.name
    incidences = np.unique(np.round(cornell.angles()[0], 3))
    offsets = peak_offsets(model, dict(result.params), incidences)
    # The highlight is forward, at the mirror direction; broad microfacet lobes move
    # their peak towards grazing at large incidence (off-specular peak), never before it.
    assert np.all(offsets >= -0.5), offsets
    assert np.all(np.abs(offsets[incidences <= 30]) <= 3.0), offsets
    _, scipy_loss = projected_baseline_fit(cornell, name, starts=4)
    assert result.loss <= scipy_loss * (1 + 1e-6), (result.loss, scipy_loss)


def test_cook_torrance_describes_the_paints_better_than_blinn(cornell):
    """A measured property of the data: the Fresnel-based model fits the grazing
    peaks of the paints that Blinn cannot."""
    comparison = brdffit.fitting.compare(cornell, ["blinn", "cook_torrance"], test_fraction=0.2)
    assert comparison.best_by_heldout == "cook_torrance"
    assert comparison.best_by_bic == "cook_torrance"


def test_he_on_garnet_trails_cook_torrance_for_the_reasons_given():
    """Issue 7 asks for a He fit to a Cornell file no worse than cook_torrance, or an
    account of why not; the account is in brdffit/models/wave.py and the README: He
    predicts the specular magnitude from its index (no free scale), with one index
    for every wavelength, and a paint's layered subsurface scattering is not in it.
    What must hold: a converged fit that describes the gloss (far below a diffuse
    surface's loss), its highlight forward of the mirror, not behind it, and a loss
    above cook_torrance's but within twice it. Four of the 31 bands (400 to 700 nm)
    keep the He fit to about 20 s."""
    data = brdffit.read(shared_file("cornell", "garnet_red.astm"))
    data = data.select_channels(list(data.channels[::10]))
    # The losses are compared in l2 (as measured for issue 7).
    he = brdffit.fit(data, "he", loss="l2")
    cook = brdffit.fit(data, "cook_torrance", loss="l2")
    diffuse = brdffit.fit(data, "lambert", loss="l2")
    assert he.converged, he.message
    assert he.loss < 0.01 * diffuse.loss
    assert cook.loss < he.loss < 2 * cook.loss, (he.loss, cook.loss)
    incidences = np.unique(np.round(data.angles()[0], 3))
    offsets = peak_offsets(brdffit.get_model("he"), dict(he.params), incidences)
    assert np.all(offsets >= -0.5), offsets
    assert np.all(np.abs(offsets[incidences <= 20]) <= 2.0), offsets
