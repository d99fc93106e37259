"""The checks of :func:`~brdffit.posterior.sample.sample_posterior`'s options: each
bad option fails with a :class:`~brdffit.errors.FitError` naming it, the value and
what is needed; the default noise model is the fit's own.
"""

from __future__ import annotations

import difflib

from ..errors import FitError
from ..fitting.options import _positive_number, _whole
from ..fitting.result import FitResult
from .target import NOISE_MODELS

__all__: list[str] = []

_OPTIONS = ("walkers", "steps", "max_steps", "max_seconds", "seed", "noise", "progress")


def _check_options(
    data, fit_result, walkers, steps, max_steps, max_seconds, seed, noise, progress, unknown
):
    if unknown:
        name = next(iter(unknown))
        close = difflib.get_close_matches(name, _OPTIONS, n=1)
        hint = f" (did you mean {close[0]}?)" if close else ""
        raise FitError(
            f"{name!r} is not an option of sample_posterior{hint}; the options are "
            f"{', '.join(_OPTIONS)}",
            name,
        )
    if not isinstance(fit_result, FitResult):
        raise FitError("fit_result must be the FitResult that brdffit.fit returned", "fit_result")
    if data.n != fit_result.n_samples or tuple(data.channels) != tuple(fit_result.channels):
        raise FitError(
            f"the data ({data.n} samples, channels {list(data.channels)}) are not those of the "
            f"fit ({fit_result.n_samples} samples, channels {list(fit_result.channels)})",
            "data",
        )
    _whole(walkers, "walkers", 1)
    if steps != "auto":
        _whole(steps, "steps", 1, alternative="or 'auto'")
    _whole(max_steps, "max_steps", 1)
    # The check of fit's timeout: inf is allowed and means no limit, as None does (fit
    # hands the posterior what its own timeout leaves: inf after timeout=inf).
    if max_seconds is not None and not _positive_number(max_seconds):
        raise FitError(
            f"max_seconds={max_seconds!r} must be a positive number of seconds "
            "(inf or None: no limit)",
            "max_seconds",
        )
    if seed is not None:
        _whole(seed, "seed", 0)
    if noise is None:
        noise = _default_noise(data, fit_result)
    if noise not in NOISE_MODELS:
        raise FitError(f"noise={noise!r} must be one of {', '.join(NOISE_MODELS)}", "noise")
    if noise == "given" and data.sigma is None:
        raise FitError(
            "noise='given' needs per-sample sigma in the data; these have none "
            "(use noise='absolute' or 'relative' to estimate it)",
            "noise",
        )
    if progress is not None and not callable(progress):
        raise FitError("progress must be a callable taking a PosteriorProgress", "progress")
    return noise


def _default_noise(data, fit_result) -> str:
    """The fit's own noise model: ``mixed`` after a mixed fit, ``given`` with sigma,
    else ``absolute`` (constant on the loss's transformed values)."""
    if fit_result.loss_name == "mixed":
        return "mixed"
    return "given" if data.sigma is not None else "absolute"
