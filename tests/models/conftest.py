"""The models' reference tests run on both evaluation paths: the compiled kernels
(brdffit.kernels, when numba is installed) and the numpy formulas."""

from __future__ import annotations

import pytest

from brdffit import kernels


@pytest.fixture(params=["compiled", "numpy"])
def evaluation_path(request):
    """Run the test with the compiled kernels on, then off."""
    compiled = request.param == "compiled"
    if compiled and not kernels.available():
        pytest.skip("numba is not installed, so there are no compiled kernels to test")
    with kernels.use(compiled):
        yield request.param
