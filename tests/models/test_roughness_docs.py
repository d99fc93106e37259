"""Every roughness-like parameter says exactly which width it is and how renderers
name it (issue 17: ggx's alpha was documented as an "rms slope", which GGX has not)."""

from __future__ import annotations

import pytest

from brdffit.models import REGISTRY
from brdffit.models.params import roughness

#: Parameter names that are a microfacet width or a perceptual roughness.
WIDTHS = {"alpha", "alpha_u", "alpha_v", "alpha_x", "alpha_y", "m", "roughness"}


def _roughness_like():
    out = []
    for model in REGISTRY.values():
        for p in model.params:
            slope = any(w in p.doc.lower() for w in ("rough", "slope"))
            if (p.name in WIDTHS and not p.linear and p.upper <= 1.0) or slope:
                out.append(pytest.param(model.name, p, id=f"{model.name}.{p.name}"))
    return out


CASES = _roughness_like()


def _family(model: str, doc: str) -> str:
    """The distribution the parameter belongs to, from the model's name."""
    if model.startswith(("ggx", "mitsuba_", "gltf_")):
        return "ggx"
    if model.startswith(("beckmann", "cook_torrance", "ward")):
        return "beckmann"
    return "other"


def test_the_registry_has_the_roughness_parameters_of_the_issue():
    ids = {c.id for c in CASES}
    assert {"ggx.alpha", "beckmann.alpha", "cook_torrance.m", "ward.alpha"} <= ids
    assert {"gltf_pbr.roughness", "mitsuba_roughconductor.alpha", "oren_nayar.sigma"} <= ids


@pytest.mark.parametrize(("model", "param"), CASES)
def test_every_roughness_doc_says_what_it_is_and_its_renderer_mapping(model, param):
    doc = param.doc
    assert "Renderers:" in doc or "renderers:" in doc, doc
    family = _family(model, doc)
    if family == "ggx":
        # no rms slope claimed for GGX (its slopes have no finite variance) ...
        assert "rms slope" not in doc.replace("not an rms slope", ""), doc
        # ... and the glTF/Disney convention roughness = sqrt(alpha) is stated
        assert "alpha = roughness^2" in doc or "sqrt(alpha" in doc or "roughness^2" in doc, doc
        assert "Mitsuba" in doc and "pbrt-v4" in doc, doc
    elif family == "beckmann":
        assert "sqrt(2) x the rms slope" in doc, doc  # Beckmann alpha = sqrt(2) x rms slope
        assert "Mitsuba 3" in doc and "GGX" in doc, doc  # and why glTF has no equivalent


def test_the_roughness_factory_refuses_a_parameter_without_its_meaning():
    with pytest.raises(ValueError, match="needs a doc"):
        roughness("alpha")
