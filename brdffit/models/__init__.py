"""The registry of reflectance models: a plain mapping built from explicit imports."""

from __future__ import annotations

import difflib

from ..errors import ModelError
from ..kernels import install as install_kernels
from . import (
    anisotropic,
    anisotropic_shapes,
    empirical,
    empirical_beyond,
    microfacet,
    mitsuba_plastic,
    mitsuba_principled,
    renderer_native,
    renderers,
    wave,
)
from .base import Classification, Design, Model, Param

__all__ = ["REGISTRY", "get_model", "list_models", "Model", "Param", "Classification", "Design"]

REGISTRY: dict[str, Model] = {
    m.name: m
    for m in (
        *empirical.MODELS,
        *empirical_beyond.MODELS,
        *microfacet.MODELS,
        *renderers.MODELS,
        *anisotropic.MODELS,
        *anisotropic_shapes.MODELS,
        *wave.MODELS,
        *renderer_native.MODELS,  # the renderers' own models, for exact exports
        *mitsuba_plastic.MODELS,
        *mitsuba_principled.MODELS,
    )
}

# The common models evaluate through compiled loops when numba is installed.
install_kernels(REGISTRY)

_AXES = ("origin", "symmetry", "operand", "highlight", "wave_optics")


def get_model(name) -> Model:
    """The registered model called ``name``; an unknown name lists close matches.

    A sum of registered names joined by ``+`` (``lambert+cook_torrance+cook_torrance``)
    gives a sum of lobes (see :mod:`brdffit.models.composite`).
    """
    if isinstance(name, Model):
        return name
    if not isinstance(name, str):
        raise ModelError(f"a model name must be a string, not {type(name).__name__}", "model")
    if "+" in name:
        from .composite import sum_of_lobes

        return sum_of_lobes([get_model(part.strip()) for part in name.split("+")])
    try:
        return REGISTRY[name]
    except KeyError:
        hint = _suggestion(name)
        raise ModelError(
            f"unknown model {name!r}{hint}; known models: {', '.join(sorted(REGISTRY))}",
            "model",
        ) from None


def _suggestion(name: str) -> str:
    """`` (did you mean ggx?)`` for ``GGX``: names equal but for case first, then
    close matches compared in lower case (difflib's ratio, as before)."""
    lower = {key.lower(): key for key in REGISTRY}
    same = [lower[name.lower()]] if name.lower() in lower else []
    close = difflib.get_close_matches(name.lower(), list(lower), n=3, cutoff=0.5)
    names = list(dict.fromkeys(same + [lower[c] for c in close]))[:3]
    return f" (did you mean {', '.join(names)}?)" if names else ""


def list_models(**filters) -> list[Model]:
    """Registered models whose classification matches every filter given.

    Filters are the classification axes: ``origin`` (empirical, physical),
    ``symmetry`` (isotropic, anisotropic), ``operand`` (cosine, angle),
    ``highlight`` (light, material), ``wave_optics`` (bool).
    """
    for axis in filters:
        if axis not in _AXES:
            raise ModelError(
                f"cannot filter on {axis!r}; the classification axes are {', '.join(_AXES)}",
                axis,
            )
    out = []
    for model in REGISTRY.values():
        cls = model.classification.to_dict()
        if all(cls[axis] == value for axis, value in filters.items()):
            out.append(model)
    return out
