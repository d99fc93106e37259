"""The ``brdffit`` command line: JSON that matches the library, errors, plots, progress.

Commands run in-process through ``brdffit.cli.main.main`` (fast); one test runs the
installed console script in a subprocess. Expected values come from the library
called directly with the same arguments; directions from angles are computed
here with the math module (MODELS.md convention).
"""

from __future__ import annotations

import io
import json
import math
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import PNG_SIGNATURE, run_cli

import brdffit
from brdffit.cli.main import main
from brdffit.cli.text import _pm

ROOT = Path(__file__).resolve().parents[2]
WARD = ROOT / "data_synthetic" / "ward.csv"
BLINN = ROOT / "data_synthetic" / "blinn.csv"


def without_seconds(value):
    if isinstance(value, dict):
        return {k: without_seconds(v) for k, v in value.items() if k != "seconds"}
    if isinstance(value, list):
        return [without_seconds(v) for v in value]
    return value


def plain_json(value):
    """What a library to_dict() becomes once written as JSON and read back."""
    return json.loads(json.dumps(value))


def direction(theta_deg, phi_deg):
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return [math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)]


# ---------------------------------------------------------------------- fit
def test_fit_json_matches_the_library(capsys):
    code, out, err = run_cli(capsys, "fit", WARD, "--model", "ward", "--seed", 4, "--json")
    assert code == 0, err
    expected = brdffit.fit(brdffit.read(WARD), "ward", seed=4).to_dict()
    assert without_seconds(json.loads(out)) == without_seconds(plain_json(expected))
    assert err == ""


def test_fit_json_with_fixed_and_channels_and_loss(capsys):
    argv = [
        "fit",
        BLINN,
        "--model",
        "blinn",
        "--fixed",
        "n=80",
        "--channels",
        "g,b",
        "--loss",
        "log",
        "--json",
    ]
    code, out, err = run_cli(capsys, *argv)
    assert code == 0, err
    data = brdffit.read(BLINN).select_channels(["g", "b"])
    expected = brdffit.fit(data, "blinn", fixed={"n": 80.0}, loss="log").to_dict()
    got = json.loads(out)
    assert got["params"] == plain_json(expected["params"]) and got["params"]["n"] == 80.0
    assert got["channels"] == ["g", "b"] and got["loss_name"] == "log"


def test_fit_uncertainty_json_matches_the_library(capsys):
    code, out, err = run_cli(capsys, "fit", WARD, "--model", "ward", "--uncertainty", "--json")
    assert code == 0, err
    got = json.loads(out)
    expected = brdffit.fit(brdffit.read(WARD), "ward", uncertainty=True).to_dict()
    assert got["posterior"]["converged"] == expected["posterior"]["converged"]
    assert got["posterior"]["summary"] == plain_json(expected["posterior"]["summary"])


def parse_pm(cell: str):
    match = re.fullmatch(r"(\S+) \+(\S+) -(\S+)", cell.strip())
    assert match, cell
    return tuple(float(x) for x in match.groups())


def test_fit_uncertainty_text_shows_median_and_percentiles(capsys):
    code, out, err = run_cli(capsys, "fit", WARD, "--model", "ward", "--uncertainty")
    assert code == 0, err
    post = brdffit.fit(brdffit.read(WARD), "ward", uncertainty=True).posterior
    rows = {line.split()[0]: line for line in out.splitlines() if line.strip()}
    for name, column in (("alpha", 0), ("kd", 1)):
        # Cells are "median +up -down", two spaces apart.
        cells = re.split(r"\s{2,}", rows[name].strip())[1:]
        key = "alpha" if name == "alpha" else "kd[g]"
        med, up, down = parse_pm(cells[column])
        s = post.summary[key]
        assert med == pytest.approx(s["median"], abs=0.06 * (s["p84"] - s["p16"]))
        assert up == pytest.approx(s["p84"] - s["median"], rel=0.06)
        assert down == pytest.approx(s["median"] - s["p16"], rel=0.06)
    assert "converged" in out and "DID NOT CONVERGE" not in err


def test_an_unconverged_posterior_says_so_loudly(capsys):
    code, out, err = run_cli(
        capsys, "fit", WARD, "--model", "ward", "--uncertainty", "--max-seconds", "0.01"
    )
    assert code == 0
    assert "THE POSTERIOR DID NOT CONVERGE" in err
    assert "DID NOT CONVERGE: not reliable" in out


@pytest.mark.parametrize(
    ("value", "expected"),
    [
        ({"median": 0.29985, "p16": 0.29970, "p84": 0.29999}, "0.29985 +0.00014 -0.00015"),
        ({"median": 1234.5678, "p16": 1222.0, "p84": 1240.0}, "1234.6 +5.4 -13"),
        ({"median": 2.5e-7, "p16": 2.38e-7, "p84": 2.62e-7}, "2.50e-07 +1.2e-08 -1.2e-08"),
        ({"median": 0.3503, "p16": 0.35013, "p84": 0.35046}, "0.35030 +0.00016 -0.00017"),
    ],
)
def test_median_and_percentiles_keep_two_digits_of_the_error(value, expected):
    assert _pm(value) == expected


def test_plot_writes_pngs_matplotlib_reads_back(capsys, tmp_path):
    from matplotlib.image import imread

    path = tmp_path / "fit.png"
    code, _out, err = run_cli(
        capsys, "fit", WARD, "--model", "ward", "--uncertainty", "--plot", path
    )
    assert code == 0, err
    assert path.read_bytes()[:8] == PNG_SIGNATURE
    image = imread(path)
    assert image.ndim == 3 and image.shape[0] > 300 and image.shape[1] > 300
    # Not a blank canvas: many distinct colours are drawn.
    assert len(np.unique(image.reshape(-1, image.shape[2]), axis=0)) > 50
    pytest.importorskip(
        "brdffit.plot.corner", reason="brdffit.plot.corner (corner_plot) is not there yet"
    )
    corner = tmp_path / "fit_corner.png"
    assert corner.read_bytes()[:8] == PNG_SIGNATURE and imread(corner).shape[0] > 300
    assert "fit_corner.png" in err


def test_fit_energy_conserving_matches_the_library(capsys, tmp_path):
    """Bright phong data (albedo up to 3.5) fitted with --energy-conserving: the JSON is
    the library's energy-conserving fit, whose albedo stays at most 1."""
    rng = np.random.default_rng(2)
    n = 300
    wi = np.array([direction(t, 0.0) for t in rng.uniform(0, 80, n)])
    wo = np.array([direction(t, p) for t, p in zip(rng.uniform(0, 85, n), rng.uniform(0, 360, n))])
    values = brdffit.get_model("phong").evaluate(wi, wo, {"kd": 0.8, "ks": 3.0, "n": 5.0})
    path = tmp_path / "bright.npz"
    brdffit.write(path, brdffit.Measurements(wi, wo, values[:, None], channels=["v"]))
    code, out, err = run_cli(
        capsys, "fit", path, "--model", "phong", "--energy-conserving", "--json"
    )
    assert code == 0, err
    got = json.loads(out)
    expected = brdffit.fit(brdffit.read(path), "phong", energy_conserving=True).to_dict()
    assert without_seconds(got) == without_seconds(plain_json(expected))
    assert got["options"]["energy_conserving"] is True
    assert got["metrics"]["max_albedo"] <= 1 + 1e-4


# ------------------------------------------------------------------ errors
@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["fit", "missing.csv", "--model", "ward"], "no such file"),
        (["fit", str(WARD), "--model", "wardd"], "did you mean ward"),
        (["fit", str(WARD)], "--model"),
        (["fit", str(WARD), "--model", "ward", "--fixed", "alpha"], "name=value"),
        (["fit", str(WARD), "--model", "ward", "--fixed", "alpha=x"], "must be a number"),
        (["fit", str(WARD), "--model", "ward", "--fixed", "alpha=7"], "outside its bounds"),
        (["fit", str(WARD), "--model", "ward", "--channels", "q"], "unknown channel"),
        (["fit", str(WARD), "--model", "ward", "--seed", "-3"], "--seed"),
        (["fit", str(WARD), "--model", "ward", "--timeout", "0"], "positive"),
        (["fit", str(ROOT / "pyproject.toml"), "--model", "ward"], "format"),
        (["fit", str(WARD), "--model", "ward", "--subsample", "2"], "does not take"),
        (["fit", str(WARD), "--model", "ward", "--format", "merl"], "90 x 90 x 180"),
        (["fit", str(WARD), "--model", "ward", "--format", "xyz"], "format"),
        (["evaluate", "--model", "ward", "--angles", "1,2,3"], "four numbers"),
        (["evaluate", "--model", "ward"], "--angles or with --file"),
        (["evaluate", "--model", "ward", "--angles", "200,0,0,0"], "outside [0, 180]"),
        (["synth", "--model", "ward", "--out", "x.csv", "--params", "kd=2"], "outside"),
        (["compare", str(WARD), "--models", "ward,nope"], "unknown model"),
        (["models", "--origin", "alien"], "invalid choice"),
        (["frobnicate"], "invalid choice"),
        (["serve", "--port", "99999"], "not a port number"),
        (["serve", "--workers", "0"], "whole number >= 1"),
    ],
)
def test_bad_input_is_one_line_on_stderr_and_exit_2(capsys, argv, words):
    code, out, err = run_cli(capsys, *argv)
    assert code == 2
    assert len(err.strip().splitlines()) == 1, err
    assert err.startswith("brdffit") and "error:" in err
    assert words.lower() in err.lower()
    assert "Traceback" not in err and out == ""


def test_bad_service_settings_from_the_environment_exit_2(capsys, monkeypatch):
    monkeypatch.setenv("BRDFFIT_FIT_TIMEOUT", "soon")
    code, _out, err = run_cli(capsys, "serve")
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "fit_timeout='soon' is not a valid setting" in err and "BRDFFIT_FIT_TIMEOUT" in err


def test_console_script_reports_errors_without_traceback(tmp_path):
    script = shutil.which("brdffit")
    argv = [script] if script else [sys.executable, "-m", "brdffit.cli.main"]
    done = subprocess.run(
        [*argv, "fit", str(tmp_path / "none.csv"), "--model", "ward"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2
    assert done.stderr.strip().count("\n") == 0 and "No such file" in done.stderr


def test_a_closed_pipe_on_stdout_stops_quietly():
    """``brdffit models --json | head -1``: the reader goes away before the output is
    written; the command stops without a traceback (it printed one before)."""
    script = shutil.which("brdffit")
    argv = [script] if script else [sys.executable, "-m", "brdffit.cli"]
    process = subprocess.Popen(
        [*argv, "models", "--json"], stdout=subprocess.PIPE, stderr=subprocess.PIPE
    )
    process.stdout.close()  # before the command has imported brdffit, let alone printed
    stderr = process.stderr.read().decode()
    assert process.wait(timeout=60) == 141
    assert stderr == ""


# ---------------------------------------------------------------- progress
class FakeTerminal(io.StringIO):
    def isatty(self):
        return True


def test_progress_shows_on_a_terminal_and_never_under_json(capsys, monkeypatch):
    terminal = FakeTerminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    assert main(["fit", str(WARD), "--model", "ward", "--uncertainty"]) == 0
    assert "evaluations, best loss" in terminal.getvalue()
    assert "sampling [" in terminal.getvalue()
    quiet = FakeTerminal()
    monkeypatch.setattr(sys, "stderr", quiet)
    assert main(["fit", str(WARD), "--model", "ward", "--uncertainty", "--json"]) == 0
    assert quiet.getvalue() == ""
    capsys.readouterr()


def test_fit_passes_the_coarse_to_fine_options(capsys, tmp_path):
    """--coarse-above and --coarse-samples reach the fit (3,000 samples run coarse to
    fine on 1,000 when asked; the library's default starts above 50,000); a subsample
    below the least is refused naming it."""
    data = brdffit.synthesize(
        "blinn", {"kd": 0.1, "ks": 0.4, "n": 60.0}, geometry="hemisphere", n=3000, seed=2
    )
    path = tmp_path / "blinn3000.csv"
    brdffit.write(str(path), data)
    fit = ["fit", path, "--model", "blinn", "--loss", "l2", "--json"]
    code, out, _ = run_cli(capsys, *fit, "--coarse-above", 1000, "--coarse-samples", 1000)
    staged = json.loads(out)
    assert code == 0 and "1,000 of the 3,000 samples" in staged["message"]
    assert staged["options"]["coarse_samples"] == 1000
    code, out, _ = run_cli(capsys, *fit)
    assert code == 0 and "coarse to fine" not in json.loads(out)["message"]
    code, _, err = run_cli(capsys, *fit, "--coarse-samples", 10)
    assert code != 0 and "coarse_samples=10" in err


# ------------------------------------------------------------------ models
def test_models_lists_every_model_with_its_axes(capsys):
    code, out, _err = run_cli(capsys, "models")
    assert code == 0
    lines = out.splitlines()
    for model in brdffit.list_models():
        row = next(line for line in lines if line.split()[0] == model.name)
        c = model.classification
        assert row.split()[1:5] == [c.origin, c.symmetry, c.operand, c.highlight]


def test_models_filters_and_json_match_the_library(capsys):
    _code, out, _err = run_cli(
        capsys, "models", "--symmetry", "anisotropic", "--highlight", "material", "--json"
    )
    expected = brdffit.list_models(symmetry="anisotropic", highlight="material")
    assert json.loads(out) == plain_json([m.to_dict() for m in expected])


def test_models_properties_match_model_properties(capsys):
    from brdffit.models.properties import model_properties

    _code, out, _err = run_cli(
        capsys,
        "models",
        "--origin",
        "physical",
        "--symmetry",
        "anisotropic",
        "--properties",
        "--json",
    )
    got = json.loads(out)
    expected = brdffit.list_models(origin="physical", symmetry="anisotropic")
    assert [m["name"] for m in got] == [m.name for m in expected]
    for entry in got:
        assert entry["properties"] == plain_json(model_properties(entry["name"]))


# ------------------------------------------------------- synth, evaluate...
def test_synth_writes_what_synthesize_makes(capsys, tmp_path):
    out_path = tmp_path / "blinn.csv"
    code, _out, err = run_cli(
        capsys,
        "synth",
        "--model",
        "blinn",
        "--params",
        "kd=0.3,0.2,0.1",
        "n=120",
        "--geometry",
        "hemisphere",
        "--n",
        300,
        "--noise",
        0.02,
        "--seed",
        9,
        "--out",
        out_path,
    )
    assert code == 0, err
    written = brdffit.read(out_path)
    made = brdffit.synthesize(
        "blinn",
        {"kd": [0.3, 0.2, 0.1], "n": 120.0},
        geometry="hemisphere",
        n=300,
        noise=0.02,
        seed=9,
    )
    np.testing.assert_array_equal(written.values, made.values)
    np.testing.assert_array_equal(written.sigma, made.sigma)
    assert written.channels == ("r", "g", "b")


def test_evaluate_angles_match_the_model(capsys):
    pairs = [(30, 0, 30, 180), (45, 10, 20, 200), (0, 0, 60, 90)]
    argv = ["evaluate", "--model", "ward", "--params", "kd=0.4", "alpha=0.2", "--json"]
    for p in pairs:
        argv += ["--angles", ",".join(str(a) for a in p)]
    code, out, err = run_cli(capsys, *argv)
    assert code == 0, err
    model = brdffit.get_model("ward")
    wi = np.array([direction(p[0], p[1]) for p in pairs])
    wo = np.array([direction(p[2], p[3]) for p in pairs])
    params = model.defaults() | {"kd": 0.4, "alpha": 0.2}
    np.testing.assert_allclose(
        json.loads(out)["values"], model.evaluate(wi, wo, params), rtol=1e-12
    )


def test_evaluate_on_the_pairs_of_a_file_prints_csv(capsys):
    code, out, err = run_cli(capsys, "evaluate", "--model", "ward", "--file", WARD)
    assert code == 0, err
    lines = out.strip().splitlines()
    assert lines[0] == "theta_i,phi_i,theta_o,phi_o,value"
    data = brdffit.read(WARD)
    assert len(lines) == data.n + 1
    model = brdffit.get_model("ward")
    first = [float(x) for x in lines[1].split(",")]
    expected = model.evaluate(data.wi[:1], data.wo[:1], model.defaults())[0]
    assert first[4] == pytest.approx(expected, rel=1e-12)


def test_compare_json_matches_the_library(capsys):
    code, out, err = run_cli(capsys, "compare", WARD, "--models", "ward,blinn", "--json")
    assert code == 0, err
    expected = brdffit.fitting.compare(brdffit.read(WARD), ["ward", "blinn"]).to_dict()
    assert without_seconds(json.loads(out)) == without_seconds(plain_json(expected))


def test_compare_text_names_the_winners(capsys):
    code, out, err = run_cli(capsys, "compare", WARD, "--models", "ward,lambert")
    assert code == 0, err
    assert "best by BIC: ward; best on the held-out samples: ward" in out
