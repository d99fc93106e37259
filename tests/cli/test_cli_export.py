"""``brdffit export`` and ``brdffit fit --export``: the files equal the library's
export of the same result, a result JSON is enough, errors are one line."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from helpers import PNG_SIGNATURE, run_cli

import brdffit

ROOT = Path(__file__).resolve().parents[2]
GLTF = ROOT / "data_synthetic" / "gltf_pbr.csv"


@pytest.fixture(scope="module")
def result_json(tmp_path_factory):
    path = tmp_path_factory.mktemp("fit") / "result.json"
    result = brdffit.fit(brdffit.read(GLTF), "gltf_pbr")
    path.write_text(json.dumps(result.to_dict(), allow_nan=False))
    return path


def test_export_writes_what_the_library_exports(capsys, tmp_path, result_json):
    out = tmp_path / "m.gltf"
    code, stdout, err = run_cli(capsys, "export", result_json, "--to", "gltf", "--out", out)
    assert code == 0, err
    expected = brdffit.export(json.loads(result_json.read_text()), "gltf")
    assert json.loads(out.read_text()) == expected.document
    assert "gltf: exact" in stdout and "RMS of ln(1 + f cos)" in stdout


def test_export_json_and_data(capsys, tmp_path, result_json):
    out = tmp_path / "m.mtlx"
    code, stdout, err = run_cli(
        capsys, "export", result_json, "--to", "openpbr", "--out", out, "--data", GLTF, "--json"
    )
    assert code == 0, err
    answer = json.loads(stdout)
    assert answer["target"] == "openpbr" and answer["document"] == out.read_text()
    assert answer["conversion_error"]["against"] == "data"
    assert answer["conversion_error"]["n_directions"] == brdffit.read(GLTF).n


def test_fit_with_export_keeps_stdout_json(capsys, tmp_path):
    gltf, pbrt = tmp_path / "a.gltf", tmp_path / "a.pbrt"
    argv = ["fit", GLTF, "--model", "gltf_pbr", "--json", "--export", f"gltf:{gltf}",
            "--export", f"pbrt:{pbrt}"]  # fmt: skip
    code, stdout, err = run_cli(capsys, *argv)
    assert code == 0, err
    result = json.loads(stdout)
    assert result["model"] == "gltf_pbr"
    factors = json.loads(gltf.read_text())["materials"][0]["pbrMetallicRoughness"]
    assert factors["roughnessFactor"] == pytest.approx(result["params"]["roughness"], 1e-12)
    assert '"bool remaproughness" false' in pbrt.read_text()  # the closest pbrt form
    assert f"wrote {gltf}" in err and f"wrote {pbrt}" in err


def test_preview_is_a_png(capsys, tmp_path, result_json):
    pytest.importorskip("mitsuba", reason="Mitsuba 3 (pip install mitsuba) is absent")
    png = tmp_path / "p.png"
    code, _, err = run_cli(capsys, "export", result_json, "--to", "gltf", "--out",
                           tmp_path / "m.gltf", "--preview", png)  # fmt: skip
    assert code == 0, err
    assert png.read_bytes()[:8] == PNG_SIGNATURE


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--to", "maya"], "invalid choice: 'maya'"),
        (["--to", "gltf", "--data", "nope.csv"], "nope.csv"),
    ],
)
def test_bad_arguments_are_one_line(capsys, tmp_path, result_json, argv, message):
    code, _, err = run_cli(capsys, "export", result_json, "--out", tmp_path / "x", *argv)
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1


def test_not_a_result_is_named(capsys, tmp_path):
    code, _, err = run_cli(capsys, "export", GLTF, "--to", "gltf", "--out", tmp_path / "x")
    assert code == 2 and "is not JSON" in err and "brdffit fit --json" in err
    bad = tmp_path / "r.json"
    bad.write_text(json.dumps({"model": "gltf_pbr", "params": {"roughness": 5}}))
    code, _, err = run_cli(capsys, "export", bad, "--to", "gltf", "--out", tmp_path / "x")
    assert code == 2 and "gltf_pbr needs a value for base_color" in err
    code, _, err = run_cli(capsys, "fit", GLTF, "--model", "gltf_pbr", "--export", "gltf")
    assert code == 2 and "TARGET:FILE" in err


def test_fit_refuses_an_unknown_export_target_before_reading_the_data(capsys, tmp_path):
    missing = tmp_path / "nope.csv"  # read first, it would be the error
    code, _, err = run_cli(capsys, "fit", missing, "--model", "lambert", "--export", "maya:m.ma")
    assert code == 2 and "'maya' is not an export target" in err and "gltf" in err
    assert len(err.strip().splitlines()) == 1


def test_preview_beside_mitsubas_measured_rendering_of_an_rgl_file(tmp_path):
    pytest.importorskip("mitsuba", reason="Mitsuba 3 (pip install mitsuba) is absent")
    from helpers import shared_file
    from PIL import Image

    from brdffit.export.preview import render_preview

    rgl = shared_file("rgl", "satin_rosaline_rgb.bsdf")
    bsdf = {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.5, 0.5, 0.5]}}
    one = render_preview(bsdf, tmp_path / "one.png", size=32, spp=4)
    two = render_preview(bsdf, tmp_path / "two.png", size=32, spp=4, measured=rgl)
    assert Image.open(one).size == (32, 32) and Image.open(two).size == (64, 32)
    left, right = np.asarray(Image.open(two))[:, :32], np.asarray(Image.open(two))[:, 32:]
    np.testing.assert_array_equal(left, np.asarray(Image.open(one)))  # same seed, same scene
    assert np.abs(right.astype(float) - left).mean() > 1  # the measured satin is not grey Lambert
