"""A small picture of an exported material: a sphere rendered by Mitsuba 3.

The sphere carries the Mitsuba export of the material (:mod:`.mitsuba`), lit
by a point light and a uniform grey environment, seen by a perspective camera,
rendered with Mitsuba's ``path`` integrator in the ``scalar_rgb`` variant
(Mitsuba 3 documentation: "Scene format", plugins ``sphere``, ``point``,
``constant``, ``perspective``, ``hdrfilm``, ``path``). It takes seconds at the
default 128 x 128 pixels and 32 samples per pixel.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..extras import require

__all__ = ["render_preview"]


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


def render_preview(
    bsdf: dict, path, size: int = 128, spp: int = 32, seed: int = 0, measured=None
) -> Path:
    """Render a sphere with the Mitsuba BSDF dict ``bsdf`` to a PNG at ``path``.

    With ``measured`` (an RGL ``.bsdf`` file), the same sphere carrying Mitsuba's
    ``measured`` BSDF of that file is rendered beside it (left: export, right:
    measurement), in the same light.
    """
    mi = require("mitsuba", "export")
    mi.set_variant("scalar_rgb")
    images = [np.asarray(mi.render(mi.load_dict(_scene(mi, bsdf, size, spp)), seed=seed))]
    if measured is not None:
        other = {"type": "measured", "filename": str(measured)}
        images.append(np.asarray(mi.render(mi.load_dict(_scene(mi, other, size, spp)), seed=seed)))
    image = np.concatenate(images, axis=1)
    path = Path(path)
    mi.util.write_bitmap(str(path), image[:, :, :3], write_async=False)
    return path
