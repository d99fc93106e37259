"""emcee imported without scipy.stats (brdffit.posterior.emcee_import): each check
that depends on what a process has imported runs in a fresh interpreter."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from brdffit.posterior.emcee_import import _Refuse

ROOT = Path(__file__).resolve().parents[2]


def _run(code: str, path: Path = ROOT) -> dict:
    """The JSON object the last line of ``code`` prints, run in a fresh interpreter with
    ``path`` (then this tree) first on the path."""
    env_path = f"{path}:{ROOT}" if path != ROOT else str(ROOT)
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": env_path},
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_emcee_comes_without_scipy_stats_and_its_kde_move_still_works():
    code = (
        "import json, sys\n"
        "import numpy as np\n"
        "from brdffit.posterior.emcee_import import import_emcee\n"
        "emcee = import_emcee()\n"
        "before = 'scipy.stats' in sys.modules\n"
        "emcee.moves.KDEMove()  # raised 'you need scipy.stats' if gaussian_kde were None\n"
        "kde = sys.modules['emcee.moves.kde'].gaussian_kde(np.ones((2, 1)) + np.eye(2, 9))\n"
        "print(json.dumps([before, type(kde).__module__, 'scipy.stats' in sys.modules]))"
    )
    assert _run(code) == [False, "scipy.stats._kde", True]


def test_the_posterior_is_the_same_with_scipy_stats_imported_first():
    """Same data, seed and options: the same draws, to the bit, whether or not emcee
    found scipy.stats."""
    fit = (
        "import brdffit\n"
        "r = brdffit.fit(brdffit.read('data_synthetic/ward.csv'), 'ward', uncertainty=True,"
        " posterior_options={'steps': 40, 'walkers': 12})\n"
        "print(json.dumps([r.posterior.samples.tolist(), 'scipy.stats' in sys.modules]))"
    )
    lazily = _run(f"import json, sys\n{fit}")
    eagerly = _run(f"import json, sys\nimport scipy.stats\n{fit}")
    assert lazily[1] is False and eagerly[1] is True
    assert lazily[0] == eagerly[0]


def test_only_the_importing_thread_is_refused():
    finder = _Refuse()
    with pytest.raises(ModuleNotFoundError, match=r"scipy\.stats"):
        finder.find_spec("scipy.stats")
    assert finder.find_spec("scipy.special") is None
    seen = []
    other = threading.Thread(target=lambda: seen.append(finder.find_spec("scipy.stats")))
    other.start()
    other.join()
    assert seen == [None]


def test_an_emcee_that_needs_scipy_stats_is_imported_as_it_is(tmp_path):
    """Should emcee's import need scipy.stats (the refusal raising), it is imported again
    with nothing refused."""
    package = tmp_path / "emcee"
    package.mkdir()
    (package / "__init__.py").write_text("import scipy.stats\nfrom scipy.stats import norm\n")
    code = (
        "import json, sys\n"
        "from brdffit.posterior.emcee_import import import_emcee\n"
        "emcee = import_emcee()\n"
        "print(json.dumps([emcee.__file__, hasattr(emcee, 'norm')]))"
    )
    path, has_norm = _run(code, tmp_path)
    assert path == str(package / "__init__.py") and has_norm
