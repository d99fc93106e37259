"""The export preview: one picture with the fit's plot beside Mitsuba's sphere of the
export (and of the measured RGL file), each panel where the layout says, none blank."""

from __future__ import annotations

import importlib
import json
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import PNG_SIGNATURE, run_cli, shared_file

import brdffit
from brdffit.errors import MissingExtraError

pytest.importorskip("mitsuba", reason="Mitsuba 3 (pip install mitsuba) is absent")
pytest.importorskip("matplotlib", reason="matplotlib (the plot extra) is absent")
Image = pytest.importorskip("PIL.Image", reason="Pillow (with matplotlib) is absent")

from brdffit.export.preview import (  # noqa: E402
    NO_DATA,
    preview_figure,
    tonemap,
    write_preview,
)

ROOT = Path(__file__).resolve().parents[2]
CONDUCTOR = ROOT / "data_synthetic" / "mitsuba_roughconductor.csv"
SMALL = {"size": 32, "spp": 4}  # seconds, not minutes: the layout does not need more


@pytest.fixture(scope="module")
def conductor():
    data = brdffit.read(CONDUCTOR)
    result = brdffit.fit(data, "mitsuba_roughconductor")
    return data, result, brdffit.export(result, "mitsuba", data=data)


def _panels(fig, png: Path) -> dict:
    """Each axes' pixels in the written PNG, by gid (the PNG must be the figure's size)."""
    image = np.asarray(Image.open(png).convert("RGB"), dtype=float)
    width, height = fig.get_size_inches() * fig.dpi
    assert image.shape[:2] == (round(height), round(width))
    out = {}
    for ax in fig.axes:
        x0, y0, x1, y1 = np.round(ax.get_window_extent().extents).astype(int)
        assert 0 <= x0 < x1 <= image.shape[1] and 0 <= y0 < y1 <= image.shape[0]
        out[ax.get_gid()] = image[image.shape[0] - y1 : image.shape[0] - y0, x0:x1]
    return out


def _not_blank_sphere(pixels: np.ndarray) -> None:
    """The centre (the sphere) differs from the corner (the environment) and from white."""
    h, w = pixels.shape[:2]
    centre = pixels[h // 2 - 2 : h // 2 + 3, w // 2 - 2 : w // 2 + 3].mean(axis=(0, 1))
    corner = pixels[:3, :3].mean(axis=(0, 1))
    assert np.abs(centre - corner).max() > 10, (centre, corner)
    assert np.abs(corner - 255).max() > 10  # the environment is grey, not the page


def test_fit_plot_beside_the_rendered_export(tmp_path, conductor):
    data, result, mitsuba = conductor
    png = write_preview(tmp_path / "p.png", mitsuba, result, data, title="synthetic", **SMALL)
    assert png.read_bytes()[:8] == PNG_SIGNATURE
    fig = preview_figure(mitsuba, result, data, title="synthetic", **SMALL)
    panels = _panels(fig, png)
    assert list(panels) == ["fit", "export"]
    fit, sphere = panels["fit"], panels["export"]
    assert fit.shape[1] > sphere.shape[1]  # the plot at its own size, the sphere beside it
    assert (fit < 200).mean() > 0.01  # lines and points drawn, not an empty panel
    _not_blank_sphere(sphere)
    captions = " ".join(t.get_text() for t in fig.texts)
    rms = mitsuba.conversion_error["rms_log_target"]
    assert f"Mitsuba export, rendered: exact, RMS {rms:.4g}" in captions


def test_rgl_file_gives_three_panels(tmp_path):
    rgl = shared_file("rgl", "satin_rosaline_rgb.bsdf")
    data = brdffit.read(rgl)
    result = brdffit.fit(data, "gltf_pbr", loss="log")
    gltf = brdffit.export(result, "gltf", data=data)
    mitsuba = brdffit.export(result, "mitsuba", data=data)
    kwargs = {"targets": [gltf, mitsuba], "measured": rgl, **SMALL}
    png = write_preview(tmp_path / "p.png", mitsuba, result, data, **kwargs)
    fig = preview_figure(mitsuba, result, data, **kwargs)
    panels = _panels(fig, png)
    assert list(panels) == ["fit", "export", "measured"]
    for name in ("export", "measured"):
        _not_blank_sphere(panels[name])
    assert np.abs(panels["export"] - panels["measured"]).mean() > 1  # two materials
    captions = " ".join(t.get_text() for t in fig.texts)
    assert f"gltf export: exact, RMS {gltf.conversion_error['rms_log_target']:.4g}" in captions
    assert "Mitsuba export, rendered: approximate" in captions
    assert "measured (Mitsuba measured plugin)" in captions


def test_without_data_the_picture_says_so(tmp_path, conductor):
    _, result, mitsuba = conductor
    fig = preview_figure(mitsuba, result, None, **SMALL)
    notes = [t for ax in fig.axes for t in ax.texts if t.get_gid() == "no-data"]
    assert [" ".join(t.get_text().split()) for t in notes] == [NO_DATA]
    assert not fig.axes[0].images  # no fit plot drawn


def test_cli_export_without_data_says_what_is_missing(capsys, tmp_path, conductor):
    _, result, _ = conductor
    path = tmp_path / "r.json"
    path.write_text(json.dumps(result.to_dict()))
    png = tmp_path / "p.png"
    code, _, err = run_cli(capsys, "export", path, "--to", "gltf", "--out",
                           tmp_path / "m.gltf", "--preview", png)  # fmt: skip
    assert code == 0, err
    assert png.exists() and f"wrote {png}; {NO_DATA} (give --data FILE" in err


def test_cli_fit_preview_draws_the_fit(capsys, tmp_path):
    png, out = tmp_path / "p.png", tmp_path / "m.json"
    code, _, err = run_cli(capsys, "fit", CONDUCTOR, "--model", "mitsuba_roughconductor",
                           "--export", f"mitsuba:{out}", "--preview", png)  # fmt: skip
    assert code == 0, err
    assert out.exists() and f"wrote {png}\n" in err and NO_DATA not in err
    assert Image.open(png).size[0] > 1000  # the fit's plot is in it


@pytest.mark.parametrize("module, extra", [("mitsuba", "export"), ("matplotlib", "plot")])
def test_missing_extra_is_one_line_before_the_fit(monkeypatch, capsys, tmp_path, module, extra):
    monkeypatch.setitem(sys.modules, module, None)
    out = tmp_path / "m.json"
    argv = ["fit", CONDUCTOR, "--model", "mitsuba_roughconductor", "--export",
            f"mitsuba:{out}", "--preview", tmp_path / "p.png"]  # fmt: skip
    code, _, err = run_cli(capsys, *argv)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert f"pip install 'brdffit[{extra}]'" in err
    assert not out.exists()  # refused before the fit, not after it


def test_missing_matplotlib_names_the_plot_extra(monkeypatch, conductor):
    _, result, mitsuba = conductor
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    with pytest.raises(MissingExtraError, match=r"pip install 'brdffit\[plot\]'"):
        preview_figure(mitsuba, result, None, **SMALL)


def test_tonemap_is_the_inverse_of_the_srgb_decoding():
    # IEC 61966-2-1 decoding: v / 12.92 up to 0.04045, else ((v + 0.055) / 1.055) ** 2.4
    x = np.linspace(0.0, 1.0, 1001)
    v = tonemap(x)
    decoded = np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)
    np.testing.assert_allclose(decoded, x, atol=1e-12)
    clipped = tonemap([-1.0, 2.0, np.inf, np.nan])
    np.testing.assert_allclose(clipped, [0.0, 1.0, 1.0, 0.0], atol=1e-12)


@pytest.fixture
def recorded(monkeypatch):
    """The calls of write_preview that the command line makes (nothing rendered)."""
    module = importlib.import_module("brdffit.export.preview")
    calls = []
    monkeypatch.setattr(module, "write_preview", lambda *a, **k: calls.append((a, k)))
    return calls


def test_cli_passes_an_rgl_file_as_measured_and_a_csv_not(capsys, tmp_path, recorded, conductor):
    rgl = shared_file("rgl", "satin_rosaline_rgb.bsdf")
    _, result, _ = conductor
    path = tmp_path / "r.json"
    path.write_text(json.dumps(result.to_dict()))
    for source in (CONDUCTOR, rgl):
        argv = ["export", path, "--to", "mitsuba-xml", "--out", tmp_path / "m.xml", "--data",
                source, "--preview", "p.png"]  # fmt: skip
        code, _, err = run_cli(capsys, *argv)
        assert code == 0, err
    (_, first), (args, second) = recorded
    assert first["measured"] is None and second["measured"] == str(rgl)
    assert [e.target for e in second["targets"]] == ["mitsuba-xml"] and args[1].target == "mitsuba"
    assert args[3].source and second["title"] == str(rgl)  # the data, for the fit's plot


def test_cli_fit_preview_without_export_renders_a_mitsuba_export(capsys, recorded):
    code, _, err = run_cli(capsys, "fit", CONDUCTOR, "--model", "mitsuba_roughconductor",
                           "--preview", "p.png")  # fmt: skip
    assert code == 0, err
    ((args, kwargs),) = recorded
    assert args[1].target == "mitsuba" and args[1].conversion_error["exact"]
    assert args[2].model == "mitsuba_roughconductor" and kwargs["targets"] == []
