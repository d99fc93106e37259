"""Helpers shared by the tests: random direction pairs, parameter sets, the shared data folder.

Imported by name (`from helpers import ...`; pytest puts tests/ on the path), not
from conftest, so that a test module says where its helpers come from.
"""

from __future__ import annotations

import math
import zlib
from pathlib import Path

import numpy as np
import pytest

from brdffit import Measurements, get_model, kernels
from brdffit.data.geometry import directions_from_angles

SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"  # the first 8 bytes of every PNG file


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


def stable_seed(text: str) -> int:
    """A seed from a name that is the same in every process (``hash()`` of a str is
    salted per process, so tests seeded with it were not reproducible)."""
    return zlib.crc32(text.encode())


def gonio_pairs(n: int, seed: int = 0, max_theta: float = 80.0):
    rng = np.random.default_rng(seed)
    wi = directions_from_angles(rng.uniform(0, max_theta, n), rng.uniform(0, 360, n))
    wo = directions_from_angles(rng.uniform(0, max_theta, n), rng.uniform(0, 360, n))
    return wi, wo


def mirror_biased_pairs(n: int, seed: int = 0):
    """Half random, half near the mirror direction (where glossy lobes live)."""
    rng = np.random.default_rng(seed)
    wi, wo = gonio_pairs(n, seed)
    k = n // 2
    ti = np.degrees(np.arccos(wi[:k, 2]))
    pi_ = np.degrees(np.arctan2(wi[:k, 1], wi[:k, 0]))
    wo[:k] = directions_from_angles(
        np.clip(ti + rng.normal(0, 6, k), 0, 85), pi_ + 180 + rng.normal(0, 6, k)
    )
    return wi, wo


def make_data(model, params, n=1500, noise=0.01, seed=0, channels=None):
    model = get_model(model)
    wi, wo = mirror_biased_pairs(n, seed)
    y = np.asarray(model.evaluate(wi, wo, params))
    rng = np.random.default_rng(seed + 1)
    y = y * (1 + noise * rng.standard_normal(y.shape))
    per_channel = [p.name for p in model.params if p.per_channel]
    if channels is None and per_channel:  # wave optics: channels named by wavelength
        nm = np.broadcast_to(
            np.asarray(params[per_channel[0]], dtype=float), (y.reshape(len(y), -1).shape[1],)
        )
        channels = [f"{w:.6g}nm" for w in nm]
    return Measurements(wi, wo, y, channels=channels)


def mitsuba_eval(bsdf, wi, wo):
    """Mitsuba 3's ``bsdf.eval`` (scalar_rgb; f cos(theta_o), RGB) at each pair of unit
    vectors of the local frame; ``bsdf`` is a loaded BSDF or a dict for ``load_dict``.
    Skips the test when Mitsuba is absent."""
    mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 (pip install mitsuba) is absent")
    if isinstance(bsdf, dict):
        mi.set_variant("scalar_rgb")
        bsdf = mi.load_dict(bsdf)
    ctx = mi.BSDFContext()
    out = []
    for a, b in zip(wi, wo):
        si = mi.SurfaceInteraction3f()
        si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
        si.wi = mi.Vector3f(*a)
        out.append(list(bsdf.eval(ctx, si, mi.Vector3f(*b))))
    return np.array(out)


#: Skip a module of compiled-kernel tests when numba is absent.
NEEDS_KERNELS = pytest.mark.skipif(
    not kernels.available(),
    reason="numba is not installed: no compiled kernels to test",
)


@pytest.fixture
def compiled_for_every_size():
    """By default the kernels run from kernels.MIN_PAIRS pairs; these tests use fewer."""
    with kernels.use(True):
        yield


def calls_of(monkeypatch, owner, name: str) -> list:
    """Count the calls of ``owner.name`` (a list growing by one a call; the function
    still runs): to tell which of two paths ran."""
    calls, real = [], getattr(owner, name)
    monkeypatch.setattr(owner, name, lambda *a: calls.append(1) or real(*a))
    return calls


def run_cli(capsys, *argv):
    """``brdffit *argv`` in-process: the exit code, stdout and stderr."""
    from brdffit.cli.main import main

    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def rgb_data(model: str, n: int, seed: int, noise: float, grey: bool = False):
    """Three channels of ``model``'s defaults, its linear parameters scaled by 1, 0.7
    and 0.4 per channel (``grey``: the same noisy values in every channel), with
    relative ``noise``."""
    params = get_model(model).defaults()
    if grey:
        one = make_data(model, params, n=n, noise=noise, seed=seed)
        values = np.repeat(np.reshape(one.values, (n, 1)), 3, axis=1)
        return Measurements(one.wi, one.wo, values, channels=["r", "g", "b"])
    for p in get_model(model).linear_params:
        params[p.name] = params[p.name] * np.array([1.0, 0.7, 0.4])
    return make_data(model, params, n=n, noise=noise, seed=seed, channels=["r", "g", "b"])


def solve_both(problem, x) -> tuple:
    """``problem.solve(x)`` with the compiled kernels, then with numpy."""
    with kernels.use(True):
        compiled = problem.solve(x)
    with kernels.use(False):
        plain = problem.solve(x)
    return compiled, plain


def with_f32(base: float, name: str, compiled: bool = True) -> float:
    """A relative tolerance ``base`` plus what float32 inputs add to ``name``'s
    compiled loop (brdffit.kernels.inputs.F32_ERROR: 0 for the loops that read
    float64 only, and for the numpy path, ``compiled`` False)."""
    from brdffit.kernels import inputs

    return base + (inputs.F32_ERROR.get(name, 0.0) if compiled else 0.0)


def pairs_at_height(z: float) -> tuple:
    """Five pairs of L and V at height ``z`` above the horizon: opposite, equal,
    orthogonal and two in between (N.L, N.V and N.H at their clamps when ``z`` is
    below them; ``|L + V|`` as small as ``2 z``)."""
    r = math.sqrt(1.0 - z * z)
    phi_i = np.radians([0.0, 0.0, 0.0, 30.0, 0.0])
    phi_o = np.radians([180.0, 0.0, 90.0, 250.0, 179.0])
    wi = np.stack([r * np.cos(phi_i), r * np.sin(phi_i), np.full(5, z)], axis=1)
    wo = np.stack([r * np.cos(phi_o), r * np.sin(phi_o), np.full(5, z)], axis=1)
    return wi, wo


def plain_information(columns: list, sqrt_w: np.ndarray) -> np.ndarray:
    """``J^T W J`` of Jacobian columns, the plain way, column by column: (M, C) arrays
    (shape parameters) and ``(c, (M,))`` pairs (a coefficient of channel c, zero in
    the other channels); what brdffit.fitting.information.channel_information is held
    to (the identifiability check formed it so before issue 13)."""
    dense = [col * sqrt_w for col in columns if not isinstance(col, tuple)]
    sparse = [(c, v * sqrt_w[:, c]) for c, v in (x for x in columns if isinstance(x, tuple))]
    n_dense, size = len(dense), len(columns)
    info = np.zeros((size, size))
    if dense:
        flat = np.stack([d.ravel() for d in dense], axis=1)
        info[:n_dense, :n_dense] = flat.T @ flat
    for j, (c, v) in enumerate(sparse, n_dense):
        info[:n_dense, j] = info[j, :n_dense] = [float(d[:, c] @ v) for d in dense]
    for c in {c for c, _ in sparse}:
        idx = [j for j, (cc, _) in enumerate(sparse, n_dense) if cc == c]
        block = np.stack([sparse[j - n_dense][1] for j in idx], axis=1)
        info[np.ix_(idx, idx)] = block.T @ block
    return info
