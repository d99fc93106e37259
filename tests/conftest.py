"""Shared fixtures: random direction pairs, parameter sets, the shared data folder."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from brdffit.data.geometry import directions_from_angles

SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


def shared_file(*parts: str) -> Path:
    """A file of ../shared/data, or skip the test saying why."""
    path = SHARED_DATA.joinpath(*parts)
    if not path.exists():
        pytest.skip(f"{path} is absent: the real measured data live in ../shared/data")
    return path


def hemisphere_pairs(n: int, seed: int = 0, grazing: bool = True):
    """Random pairs over the upper hemisphere, plus the hard cases of MODELS.md:
    grazing angles, H = N (mirror pairs), L = V, and L nearly opposite V."""
    rng = np.random.default_rng(seed)
    theta = np.degrees(np.arccos(rng.uniform(0, 1, (2, n))))
    phi = rng.uniform(0, 360, (2, n))
    ti, to, pi_, po = theta[0], theta[1], phi[0], phi[1]
    extra_t = [0.0, 45.0, 89.999, 90 - 1e-9, 60.0, 89.999, 30.0]
    extra_p = [0.0, 10.0, 20.0, 0.0, 0.0, 0.0, 33.0]
    extra_to = [0.0, 45.0, 89.999, 90 - 1e-9, 60.0, 89.999, 30.0]
    extra_po = [0.0, 190.0, 200.0, 180.0, 0.0, 180.5, 33.0]  # mirror pairs and L = V
    if grazing:
        ti = np.concatenate([ti, extra_t])
        pi_ = np.concatenate([pi_, extra_p])
        to = np.concatenate([to, extra_to])
        po = np.concatenate([po, extra_po])
    return directions_from_angles(ti, pi_), directions_from_angles(to, po)


def random_params(model, rng, corner: str | None = None) -> dict:
    """Parameters drawn within bounds (log-uniform for log-scale ones), or a corner."""
    out = {}
    for p in model.params:
        if corner == "lower":
            out[p.name] = p.lower
        elif corner == "upper":
            out[p.name] = p.upper
        elif p.log_scale:
            out[p.name] = float(np.exp(rng.uniform(np.log(p.lower), np.log(p.upper))))
        else:
            out[p.name] = float(rng.uniform(p.lower, p.upper))
    return out
