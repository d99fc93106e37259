"""What `import brdffit` and a small fit load (issue 13's cold start).

A command-line fit of a small file paid 1.3 s of imports before it read a byte:
scipy.stats (emcee imports it, the misfit threshold used it), scipy.optimize,
scipy.interpolate and scipy.special, none needed by such a fit. They are now
imported where first needed; this keeps it so (each check in a fresh interpreter).
"""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("scipy.stats", "scipy.optimize", "scipy.interpolate", "scipy.special", "emcee", "numba")


def _printed(code: str):
    """The JSON value on the last line ``code`` prints, run in a fresh interpreter."""
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def _loaded(code: str) -> list:
    """The HEAVY modules loaded after running ``code`` in a fresh interpreter."""
    report = f"print(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))"
    return _printed(f"{code}\nimport json, sys\n{report}")


def test_importing_brdffit_loads_none_of_the_heavy_modules():
    assert _loaded("import brdffit") == []


def test_a_small_ward_fit_loads_none_of_them():
    code = (
        "import brdffit\n"
        "r = brdffit.fit(brdffit.read('data_synthetic/ward.csv'), 'ward')\n"
        "assert r.converged and r.misfit is not None"
    )
    assert _loaded(code) == []


def test_they_load_where_needed():
    """The modules still come when their work does: a Beckmann fit (erf), a posterior;
    but not scipy.stats, which emcee imports for a move brdffit does not use."""
    code = (
        "import brdffit\n"
        "d = brdffit.read('data_synthetic/beckmann.csv')\n"
        "r = brdffit.fit(d, 'beckmann', uncertainty=True,"
        " posterior_options={'steps': 20, 'walkers': 8})"
    )
    loaded = _loaded(code)
    assert "scipy.special" in loaded and "emcee" in loaded
    assert "scipy.stats" not in loaded


def test_a_fit_of_many_channels_on_few_pairs_loads_none_of_them():
    """The compiled kernels (numba) come from MIN_PAIRS direction pairs on, not values:
    3,000 pairs of 8 channels (24,000 values) fit as a small fit does."""
    code = (
        "import brdffit\n"
        "d = brdffit.synthesize('ward', {'kd': [0.1] * 8, 'ks': [0.3] * 8, 'alpha': 0.2},"
        " geometry='hemisphere', n=3000, noise=0.01, seed=1)\n"
        "assert d.values.size > brdffit.kernels.MIN_PAIRS > d.n\n"
        "assert brdffit.fit(d, 'ward').converged"
    )
    assert _loaded(code) == []


@pytest.mark.skipif(importlib.util.find_spec("numba") is None, reason="numba is not installed")
def test_a_compiled_fit_imports_only_the_loops_its_model_needs():
    """A first compiled fit imported all six loop modules (25 to 55 ms of its 0.5 s);
    a ward fit needs :mod:`brdffit.kernels.loops` (its lobe and the normal
    equations' sums), :mod:`brdffit.kernels.loops_geometry` (its inputs) and
    :mod:`brdffit.kernels.loops_sums` (its metrics) only."""
    code = (
        "import sys, brdffit\n"
        "from brdffit import kernels\n"
        "with kernels.use(True):\n"
        "    brdffit.fit(brdffit.read('data_synthetic/ward.csv'), 'ward', loss='l2')\n"
        "print(json.dumps(sorted(m for m in sys.modules if m.startswith('brdffit.kernels.loops')"
        " or m == 'brdffit.kernels.plastic_table')))"
    )
    loaded = _printed(f"import json\n{code}")
    assert loaded == [
        "brdffit.kernels.loops",
        "brdffit.kernels.loops_geometry",
        "brdffit.kernels.loops_sums",
    ]
