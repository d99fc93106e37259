"""Optional parts (plots, the service, colour) name their extra when it is missing, and
the core (read, fit with uncertainty, the command line) needs none of them."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import brdffit
from brdffit.cli.main import main
from brdffit.errors import MissingExtraError
from brdffit.extras import EXTRAS, require

ROOT = Path(__file__).resolve().parents[1]
WARD = ROOT / "data_synthetic" / "ward.csv"
#: The modules of the extras: none is imported by the core.
OPTIONAL = ("matplotlib", "corner", "fastapi", "uvicorn", "starlette", "pydantic", "colour",
            "distributed", "dask", "mitsuba", "numba")  # fmt: skip


def missing(monkeypatch, *modules: str) -> None:
    """Make ``import module`` fail as if it were not installed, for this test only."""
    for module in modules:
        monkeypatch.setitem(sys.modules, module, None)


@pytest.mark.parametrize("extra", sorted(EXTRAS))
def test_require_names_the_extra_in_one_line(monkeypatch, extra):
    missing(monkeypatch, "some_absent_module")
    with pytest.raises(MissingExtraError) as caught:
        require("some_absent_module", extra)
    message = str(caught.value)
    assert message.startswith(EXTRAS[extra]) and "\n" not in message
    assert f"pip install 'brdffit[{extra}]'" in message and "some_absent_module" in message
    assert isinstance(caught.value, ImportError) and caught.value.extra == extra
    assert require("json", extra) is json  # present modules are returned


def test_fit_plot_without_matplotlib_is_one_line_naming_the_plot_extra(
    monkeypatch, capsys, tmp_path
):
    missing(monkeypatch, "matplotlib", "matplotlib.pyplot")
    for name in ("brdffit.plot", "brdffit.plot.fit", "brdffit.plot.corner"):
        monkeypatch.delitem(sys.modules, name, raising=False)
    png = tmp_path / "fit.png"
    code = main(["fit", str(WARD), "--model", "ward", "--plot", str(png)])
    out, err = capsys.readouterr()
    assert code == 2 and out == "" and not png.exists()
    assert err.strip() == (
        "brdffit fit: error: plots need the 'plot' extra (matplotlib is not installed): "
        "pip install 'brdffit[plot]'"
    )
    with pytest.raises(MissingExtraError, match=r"brdffit\[plot\]"):
        import brdffit.plot.fit  # noqa: F401


def test_serve_without_fastapi_is_one_line_naming_the_service_extra(monkeypatch, capsys):
    missing(monkeypatch, "fastapi")
    code = main(["serve", "--port", "8765"])
    out, err = capsys.readouterr()
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert "the service needs the 'service' extra" in err
    assert "pip install 'brdffit[service]'" in err


def test_colour_conversion_without_colour_science_names_the_colour_extra(monkeypatch):
    missing(monkeypatch, "colour")
    # Wavelengths no other test uses, so that no cached weights hide the import.
    channels = ["403nm", "413nm", "423nm", "433nm"]
    wi = wo = np.array([[0.0, 0.0, 1.0]])
    data = brdffit.Measurements(wi, wo, np.full((1, 4), 0.2), channels=channels)
    with pytest.raises(MissingExtraError, match=r"pip install 'brdffit\[colour\]'"):
        data.to_xyz()


def test_the_core_fits_with_uncertainty_without_any_extra(tmp_path):
    """``pip install .`` is enough for the README's first command: a fit with uncertainty
    from the command line, every optional module made unimportable."""
    script = (
        "import sys\n"
        f"for m in {OPTIONAL!r}: sys.modules[m] = None\n"
        "from brdffit.cli.main import main\n"
        f"code = main(['fit', {str(WARD)!r}, '--model', 'ward', '--uncertainty',\n"
        "             '--max-seconds', '3', '--walkers', '16', '--json'])\n"
        "sys.exit(code)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120, cwd=ROOT
    )
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    assert result["model"] == "ward" and result["posterior"]["summary"]


def test_importing_brdffit_and_its_command_line_imports_no_optional_module():
    script = (
        "import sys, brdffit, brdffit.cli.main, brdffit.io, brdffit.posterior\n"
        f"print([m for m in {OPTIONAL!r} if m in sys.modules])\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=60, cwd=ROOT
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"


def test_batch_without_dask_is_one_line_naming_the_batch_extra(monkeypatch, capsys, tmp_path):
    missing(monkeypatch, "distributed")
    code = main(["batch", str(ROOT / "data_synthetic" / "ward.csv"), "--models", "ward",
                 "--out", str(tmp_path / "rows.jsonl")])  # fmt: skip
    _, err = capsys.readouterr()
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert "pip install 'brdffit[batch]'" in err


def test_export_preview_without_mitsuba_names_the_export_extra(monkeypatch):
    from brdffit.export.preview import render_preview

    missing(monkeypatch, "mitsuba")
    with pytest.raises(MissingExtraError, match=r"pip install 'brdffit\[export\]'"):
        render_preview({"type": "diffuse"}, "unused.png")
