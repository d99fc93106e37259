"""A small picture of an exported material: a sphere rendered by Mitsuba 3.

The sphere carries the Mitsuba export of the material (:mod:`.mitsuba`), lit
by a point light and a uniform grey environment, seen by a perspective camera,
rendered with Mitsuba's ``path`` integrator in the ``scalar_rgb`` variant
(Mitsuba 3 documentation: "Scene format", plugins ``sphere``, ``point``,
``constant``, ``perspective``, ``hdrfilm``, ``path``). It takes seconds at the
default 128 x 128 pixels and 32 samples per pixel. For an RGL ``.bsdf`` file
the same sphere can carry Mitsuba's ``measured`` BSDF of the file instead
(Dupuy and Jakob, "An Adaptive Parameterization for Efficient Material
Acquisition and Rendering", ACM TOG 37(6), 2018), for comparison.

:func:`render_preview` writes the spheres alone (the ``export`` extra);
:func:`write_preview` composes one picture (also the ``plot`` extra): the fit's
plot (:func:`brdffit.plot.fit.fit_figure`) beside the rendered spheres, with a
title under each panel. The spheres' linear RGB is shown after :func:`tonemap`
(clipped, sRGB transfer function).
"""

from __future__ import annotations

import io
import textwrap
from pathlib import Path

import numpy as np

from ..extras import require

__all__ = ["NO_DATA", "preview_figure", "render_preview", "render_spheres", "tonemap",
           "write_preview"]  # fmt: skip

#: What the picture says in place of the fit's plot when no data were given.
NO_DATA = "no fit plot: the data the fit was made on were not given"
DPI = 100  # pixels per inch of the composed picture
FIT_DPI = 72  # of the fit's plot inside it (its fonts stay legible at this size)
MARGIN, GAP, TITLE = 10, 24, 100  # pixels: around, between panels, under a panel


def _scene(mi, bsdf: dict, size: int, spp: int) -> dict:
    return {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 4},
        "sensor": {
            "type": "perspective",
            "fov": 30,
            "to_world": mi.ScalarTransform4f().look_at(
                origin=[0, -4.2, 1.2], target=[0, 0, 0], up=[0, 0, 1]
            ),
            "film": {"type": "hdrfilm", "width": size, "height": size},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "sphere": {"type": "sphere", "radius": 1.0, "bsdf": bsdf},
        "light": {
            "type": "point",
            "position": [2.5, -3.0, 3.0],
            "intensity": {"type": "rgb", "value": [25.0, 25.0, 25.0]},
        },
        "environment": {"type": "constant", "radiance": {"type": "rgb", "value": [0.25] * 3}},
    }


def render_spheres(
    bsdf: dict, size: int = 128, spp: int = 32, seed: int = 0, measured=None
) -> list[np.ndarray]:
    """The sphere carrying the Mitsuba BSDF dict ``bsdf``, as linear RGB (size, size, 3).

    With ``measured`` (an RGL ``.bsdf`` file), a second image: the same sphere, light
    and seed carrying Mitsuba's ``measured`` BSDF of that file.
    """
    mi = require("mitsuba", "export")
    mi.set_variant("scalar_rgb")
    bsdfs = [bsdf] + ([{"type": "measured", "filename": str(measured)}] if measured else [])
    return [
        np.asarray(mi.render(mi.load_dict(_scene(mi, b, size, spp)), seed=seed))[:, :, :3]
        for b in bsdfs
    ]


def render_preview(
    bsdf: dict, path, size: int = 128, spp: int = 32, seed: int = 0, measured=None
) -> Path:
    """Render a sphere with the Mitsuba BSDF dict ``bsdf`` to a PNG at ``path``.

    With ``measured`` (an RGL ``.bsdf`` file), the same sphere carrying Mitsuba's
    ``measured`` BSDF of that file is rendered beside it (left: export, right:
    measurement), in the same light.
    """
    mi = require("mitsuba", "export")
    image = np.concatenate(render_spheres(bsdf, size, spp, seed, measured), axis=1)
    path = Path(path)
    mi.util.write_bitmap(str(path), image, write_async=False)
    return path


def tonemap(linear) -> np.ndarray:
    """Linear RGB to display values in [0, 1]: clipped, then the sRGB transfer function.

    IEC 61966-2-1:1999 (sRGB): ``12.92 x`` for ``x <= 0.0031308``, else
    ``1.055 x^(1/2.4) - 0.055``.
    """
    x = np.clip(np.nan_to_num(np.asarray(linear, dtype=float)), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)


def _caption(exports) -> str:
    """One line per Export (what, exact or not, its error), then what the error is."""
    lines = []
    for what, e in exports:
        err = e.conversion_error
        kind = "exact" if err["exact"] else "approximate"
        lines.append(f"{what}: {kind}, RMS {err['rms_log_target']:.4g}")
    err = exports[-1][1].conversion_error
    lines += [f"RMS of ln(1 + f cos) against the {err['against']}",
              f"(the fit's own: {err['rms_log_fit']:.4g})"]  # fmt: skip
    return "\n".join(lines)


def _fit_raster(result, data, title) -> np.ndarray:
    """The fit's plot (:func:`fit_figure`) as RGBA pixels at FIT_DPI."""
    from ..fitting.result import FitResult
    from ..plot.fit import fit_figure

    if isinstance(result, dict):
        result = FitResult.from_dict(result)
    buffer = io.BytesIO()
    fit_figure(data, result, title).savefig(buffer, format="png", dpi=FIT_DPI)
    buffer.seek(0)
    import matplotlib.image

    return matplotlib.image.imread(buffer, format="png")


def _panels(spheres, mitsuba, targets, fit_image):
    """(image or text, caption, gid) per panel, left to right."""
    exports = [(f"{e.target} export", e) for e in targets if e is not mitsuba]
    exports.append(("Mitsuba export, rendered", mitsuba))
    panels = [(tonemap(spheres[0]), _caption(exports), "export")]
    if len(spheres) > 1:
        panels.append((tonemap(spheres[1]), "measured (Mitsuba measured plugin)\nsame light",
                       "measured"))  # fmt: skip
    return [(fit_image, "the fit against the data (brdffit)", "fit"), *panels]


def preview_figure(mitsuba, result=None, data=None, *, targets=(), measured=None,
                   title=None, size=192, spp=64, seed=0):  # fmt: skip
    """The picture of :func:`write_preview`, not yet saved (its axes carry gids
    ``fit``, ``export``, ``measured``). Parameters are as for :func:`write_preview`."""
    require("matplotlib", "plot")
    spheres = render_spheres(mitsuba.document, size, spp, seed, measured)
    have_data = result is not None and data is not None
    fit_image = _fit_raster(result, data, title) if have_data else None
    return _compose(_panels(spheres, mitsuba, targets, fit_image))


def _compose(panels):
    """A Figure laying ``panels`` out in pixels: the fit's plot at its own size on the
    left, the spheres in a column beside it, each caption under its panel."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fit, spheres = panels[0], panels[1:]
    n = len(spheres)
    fit_h, fit_w = fit[0].shape[:2] if fit[0] is not None else (360, 320)
    side = int(np.clip((fit_h + TITLE) / n - TITLE, 256, 400))
    height = 2 * MARGIN + max(fit_h + TITLE, n * (side + TITLE))
    width = 2 * MARGIN + fit_w + GAP + side
    fig = Figure(figsize=(width / DPI, height / DPI), dpi=DPI)
    FigureCanvasAgg(fig)
    boxes = [(MARGIN, MARGIN, fit_w, fit_h)]
    boxes += [(MARGIN + fit_w + GAP, MARGIN + k * (side + TITLE), side, side) for k in range(n)]
    for (image, caption, gid), (x, y, w, h) in zip(panels, boxes):
        ax = fig.add_axes((x / width, 1 - (y + h) / height, w / width, h / height))
        ax.set_gid(gid)
        ax.set_axis_off()
        if image is None:
            ax.text(0.5, 0.5, textwrap.fill(NO_DATA, 30),
                    ha="center", va="center", fontsize=11, color="0.3", wrap=True,
                    transform=ax.transAxes, gid="no-data")  # fmt: skip
            caption = "the fit's plot needs the data"
        else:
            interpolation = "nearest" if gid == "fit" else "antialiased"
            ax.imshow(image, interpolation=interpolation, aspect="auto")
        fig.text((x + w / 2) / width, 1 - (y + h + 4) / height, caption, ha="center",
                 va="top", fontsize=8.5)  # fmt: skip
    return fig


def write_preview(path, mitsuba, result=None, data=None, *, targets=(), measured=None,
                  title=None, size=192, spp=64, seed=0) -> Path:  # fmt: skip
    """Write one PNG: the fit's plot beside a sphere rendered with the Mitsuba export.

    Parameters
    ----------
    path : str or path-like
    mitsuba : Export
        The ``mitsuba`` export of the fit (:func:`brdffit.export`); its document is
        rendered, its conversion error is written under the sphere.
    result : FitResult or dict, optional
        The fit; with ``data``, its plot (:func:`brdffit.plot.fit.fit_figure`) is
        the left panel. Without either, the panel says :data:`NO_DATA`.
    data : Measurements, optional
        The data the fit was made on.
    targets : sequence of Export
        The exports the user asked for: the error of each that is not the rendered
        Mitsuba export is written too.
    measured : path, optional
        An RGL ``.bsdf`` file: a third panel, Mitsuba's ``measured`` BSDF of it.
    title : str, optional
        What the data are called in the fit's plot.
    size, spp, seed : int
        Pixels per side of a sphere, samples per pixel, Mitsuba's seed.
    """
    fig = preview_figure(mitsuba, result, data, targets=targets, measured=measured, title=title,
                         size=size, spp=spp, seed=seed)  # fmt: skip
    path = Path(path)
    _save_small(fig, path)
    return path


def _save_small(fig, path: Path) -> None:
    """Save as an indexed-colour PNG (256 colours): a third of the RGB file's size."""
    from PIL import Image

    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=DPI)
    buffer.seek(0)
    with Image.open(buffer) as image:
        image.convert("RGB").quantize(256).save(path, format="PNG", optimize=True)
