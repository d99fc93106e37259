"""Anisotropic models: Ward, Ashikhmin-Shirley, anisotropic Phong, Heidrich-Seidel,
Ohara, Wang, Fournier, and the anisotropic microfacet models.

The tangent ``T = (1, 0, 0)`` is the "x"/"u" direction of every model.
"""

from __future__ import annotations

import numpy as np

from ..geometry import Geometry
from .base import Classification, diffuse_plus_lobe
from .empirical import exponent

__all__ = ["MODELS"]

EMPIRICAL_ANISO = Classification("empirical", "anisotropic", "cosine", "light")


def wang_lobe(geometry: Geometry, m: float, zeta: float) -> np.ndarray:
    """``(N.H)^(m zeta / (m - (m - zeta) cos^2 phi_h))``."""
    power = (m * zeta) / (m - (m - zeta) * geometry.cos2_phi_h)
    return np.exp(power * geometry.log_cos_h)


WANG = diffuse_plus_lobe(
    "wang",
    wang_lobe,
    (exponent("m", doc="exponent along T"), exponent("zeta", doc="exponent along B")),
    EMPIRICAL_ANISO,
    "as cited by the classification paper (Romanyuk); lobe fixed by MODELS.md",
    """Wang: ``f = kd/pi + ks (N.H)^(m zeta / (m - (m - zeta) cos^2 phi_h))``.

Exponent ``m`` along T (phi_h = 0), ``zeta`` along B; equals Blinn with
``n = m`` when ``m = zeta``. The paper writes ``H.L`` where ``N.H`` is meant.
""",
)

MODELS = (WANG,)
