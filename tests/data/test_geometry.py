"""The prepared geometry's half-vector terms (brdffit.data.geometry.Geometry)."""

import numpy as np
import pytest
from helpers import gonio_pairs, hemisphere_pairs

from brdffit.data.geometry import MIN_COSINE, Geometry


@pytest.mark.parametrize("pairs", [lambda: hemisphere_pairs(5000, seed=1),
                                   lambda: gonio_pairs(3000, seed=2)])  # fmt: skip
def test_the_isotropic_terms_equal_the_half_vectors_and_do_not_form_it(pairs):
    """cos_h and sin2_h come from the half vector's components without the (M, 3) half
    vector kept (a MERL file's is 26 MB): bit for bit the values from it, which are
    checked here against the definition."""
    wi, wo = pairs()
    lazy, eager = Geometry(wi, wo), Geometry(wi, wo)
    h = (wi + wo) / np.linalg.norm(wi + wo, axis=1, keepdims=True)
    np.testing.assert_allclose(eager.half, h, rtol=0, atol=1e-15)
    for name in ("cos_h", "sin2_h", "tan2_h", "log_cos_h", "theta_h"):
        np.testing.assert_array_equal(getattr(lazy, name), getattr(eager, name), err_msg=name)
    assert "half" not in lazy.__dict__
    np.testing.assert_allclose(lazy.cos_h, np.clip(h[:, 2], MIN_COSINE, 1.0), rtol=1e-15)
    np.testing.assert_allclose(lazy.sin2_h, h[:, 0] ** 2 + h[:, 1] ** 2, atol=1e-15)
