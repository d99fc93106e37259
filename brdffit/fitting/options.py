"""The options of a fit: one frozen :class:`FitOptions`, checked by one ``validate()``.

:func:`brdffit.fit` and :func:`brdffit.check_fit` take the options as keyword
arguments, gather them here, and ask :meth:`FitOptions.validate` whether they
can be used; every error names the option (``FitError.field``), its value and
what is needed. The options that refer to a dataset (``loss``, ``weights``,
``fixed``) are checked where the dataset is bound to the model
(:class:`~brdffit.fitting.problem.Problem`).

The options that a :class:`~brdffit.fitting.result.FitResult` records, to
reproduce the fit, are the fields marked ``record`` below
(:meth:`FitOptions.record`); the per-sample weights are recorded as a summary
(:func:`weights_summary`), the array itself stays on the result.
"""

from __future__ import annotations

import difflib
import inspect
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, fields
from functools import cache
from typing import Any

import nlopt
import numpy as np

from ..errors import FitError

__all__ = [
    "DEFAULT_GLOBAL",
    "DEFAULT_LOCAL",
    "SEED_LIMIT",
    "FitOptions",
    "weights_summary",
]

DEFAULT_GLOBAL = "GN_CRS2_LM"
DEFAULT_LOCAL = "LN_BOBYQA"
#: Seeds are 0 <= seed < SEED_LIMIT: nlopt's Mersenne Twister keeps the low 32 bits
#: of its seed (``nlopt_init_genrand`` in nlopt's src/util/mt19937ar.c), so larger
#: seeds would repeat smaller ones, and ``nlopt.srand`` refuses negative ones.
SEED_LIMIT = 2**32
#: Evaluations when no cap is given.
NO_CAP = 10**9
#: Default ``coarse_samples``: samples of the coarse-to-fine schedule's subsample.
COARSE_SAMPLES = 20_000
#: Default ``coarse_above``: above this many samples the coarse-to-fine schedule runs
#: (measured on random subsets of a MERL file, benchmarks/README.md: at 25,000 samples
#: the schedule's search costs what the search on all samples does, from 50,000 less).
COARSE_ABOVE = 50_000
#: The smallest ``coarse_samples``: fewer samples would not show a narrow highlight.
MIN_COARSE_SAMPLES = 1000

_RECORD = {"record": True}


@dataclass(frozen=True)
class FitOptions:
    """Every option of :func:`brdffit.fit` and :func:`brdffit.check_fit`.

    ``None`` for ``loss`` and the budgets means "the default for this problem",
    filled in by :meth:`with_loss` and :meth:`with_budgets` once it is known.

    Attributes
    ----------
    loss : str, optional
        ``l2``, ``cosine``, ``log``, ``cbrt``, ``relative``, ``chi2`` or ``mixed``
        (:mod:`brdffit.fitting.losses`). Default: ``chi2`` when the data give
        per-sample sigma (weighted least squares, the maximum-likelihood fit for
        Gaussian noise of that sigma), ``mixed`` otherwise: the noise
        ``sigma^2 = a^2 + (b f)^2`` estimated with the fit
        (:mod:`brdffit.fitting.noise`), as measured data without sigma need.
    weights : array_like (N,), optional
        Per-sample weights (finite, >= 0, not all 0).
    fixed : mapping, optional
        Parameters held at given values.
    free : sequence of str
        Parameters that the model holds by default (``Model.held``: material
        constants and instrument properties of ``he``) to search anyway.
    start : mapping, optional
        An initial guess of shape parameters; polished locally besides the
        global stage.
    global_algorithm, local_algorithm : str
        nlopt algorithm names (``GN_...``, ``LN_...``); ``global_algorithm=None``
        skips the global stage.
    global_evals, local_evals : int, optional
        Budgets of the stages (defaults grow with the number of shape params).
    restarts : int
        Further local polishes from distinct good points of the global stage.
    max_evals : int, optional
        Cap on all objective evaluations.
    timeout : float, optional
        Seconds; the fit returns its best point when it is reached.
    seed : int
        Seeds nlopt's stochastic algorithms and the subsample of large data;
        the same seed gives the same result. 0 <= seed < 2**32.
    coarse_above : int
        Samples above the horizon above which the coarse-to-fine schedule runs
        (>= 0; :mod:`brdffit.fitting.schedule`): the global stage and the polishes
        on a seeded subsample of ``coarse_samples`` samples stratified over
        ``(theta_h, theta_d)`` (half in proportion, half by Neyman's allocation on
        the spread of the loss's targets, weighted by the inverse of each sample's
        probability of being drawn), then one polish on all the samples, whose minimum
        the answer is; the result's message says so. At or below it the fit runs
        as without the schedule (every polish on all the samples; the global
        stage scouts a uniform 20,000 of more than 20,000 samples).
    coarse_samples : int
        Samples of the coarse-to-fine schedule's subsample (>= 1000). (Not
        :func:`brdffit.read`'s ``subsample``, which keeps every k-th MERL cell.)
    energy_conserving : bool
        Constrain the directional albedo to at most 1 at every incidence angle
        from 0 to 89 degrees: enforced exactly on the linear coefficients at
        every step at 0 to 85 degrees by 5, 87.5 and 89; the result is then
        checked with the full-accuracy quadrature every 2.5 degrees and at 89,
        and where it passes ``1 + 1e-5`` those angles are enforced too and the fit
        polished again (:mod:`brdffit.fitting.energy`). ``metrics["max_albedo"]``
        and the message say what the last check found, and whether the bound
        is met.
    progress : callable, optional
        Called with a :class:`~brdffit.fitting.engine.FitProgress` now and then.
        Raising :class:`~brdffit.fitting.engine.StopFit` or returning ``False``
        stops the fit (its best point so far, not converged, "stopped" in its
        message); any other exception it raises propagates.
    uncertainty : bool
        Also sample the posterior (:func:`brdffit.sample_posterior`) with
        ``posterior_options``; the result's ``posterior`` holds it.
    posterior_options : mapping, optional
        Keyword arguments of :func:`brdffit.sample_posterior`.
    """

    loss: str | None = field(default=None, metadata=_RECORD)
    weights: Any = None
    fixed: Mapping | None = None
    free: Sequence[str] = ()
    start: Mapping | None = None
    global_algorithm: str | None = field(default=DEFAULT_GLOBAL, metadata=_RECORD)
    local_algorithm: str = field(default=DEFAULT_LOCAL, metadata=_RECORD)
    global_evals: int | None = field(default=None, metadata=_RECORD)
    local_evals: int | None = field(default=None, metadata=_RECORD)
    restarts: int = field(default=2, metadata=_RECORD)
    max_evals: int | None = field(default=None, metadata=_RECORD)
    timeout: float | None = field(default=None, metadata=_RECORD)
    seed: int = field(default=0, metadata=_RECORD)
    coarse_above: int = field(default=COARSE_ABOVE, metadata=_RECORD)
    coarse_samples: int = field(default=COARSE_SAMPLES, metadata=_RECORD)
    energy_conserving: bool = field(default=False, metadata=_RECORD)
    progress: Callable | None = None
    uncertainty: bool = False
    posterior_options: Mapping | None = None

    def validate(self) -> FitOptions:
        """Check every option on its own; return them normalised (plain ints, ``"none"``
        as ``None``). Raises :class:`~brdffit.errors.FitError` naming the option."""
        for name in ("energy_conserving", "uncertainty"):
            if not isinstance(getattr(self, name), bool):
                raise FitError(f"{name}={getattr(self, name)!r} must be True or False", name)
        free = self.free
        if not isinstance(free, (list, tuple)) or not all(isinstance(n, str) for n in free):
            raise FitError("free must be a list of parameter names", "free")
        for name in ("fixed", "start", "posterior_options"):
            if getattr(self, name) is not None and not isinstance(getattr(self, name), Mapping):
                raise FitError(f"{name} must be a mapping of names to values", name)
        if self.progress is not None and not callable(self.progress):
            raise FitError("progress must be a callable taking a FitProgress", "progress")
        if self.timeout is not None and not _positive_number(self.timeout):
            raise FitError(
                f"timeout={self.timeout!r} must be a positive number of seconds", "timeout"
            )
        local = _algorithm(self.local_algorithm, "local_algorithm", ("LN_",))
        if local is None:
            raise FitError(
                "local_algorithm is needed: the polish is what converges", "local_algorithm"
            )
        return self._with(
            global_algorithm=_algorithm(
                self.global_algorithm, "global_algorithm", ("GN_", "G_MLSL", "GD_")
            ),
            local_algorithm=local,
            global_evals=_whole(self.global_evals, "global_evals", 1, optional=True),
            local_evals=_whole(self.local_evals, "local_evals", 1, optional=True),
            max_evals=_whole(self.max_evals, "max_evals", 1, optional=True),
            restarts=_whole(self.restarts, "restarts", 0),
            seed=_whole(self.seed, "seed", 0, below=SEED_LIMIT),
            coarse_samples=_whole(self.coarse_samples, "coarse_samples", MIN_COARSE_SAMPLES),
            coarse_above=_whole(self.coarse_above, "coarse_above", 0),
            free=tuple(self.free),
        )

    def with_loss(self, has_sigma: bool) -> FitOptions:
        """The loss's default filled in: ``chi2`` when the data give sigma, else ``mixed``."""
        if self.loss is not None:
            return self
        return self._with(loss="chi2" if has_sigma else "mixed")

    def with_budgets(self, dim: int) -> FitOptions:
        """The budgets' defaults filled in; they grow with the ``dim`` free shape
        parameters of the problem."""
        return self._with(
            global_evals=self.global_evals or 60 + 60 * dim,
            local_evals=self.local_evals or 100 + 100 * dim,
            max_evals=self.max_evals or NO_CAP,
        )

    def _with(self, **changes) -> FitOptions:
        """``dataclasses.replace(self, **changes)`` without running ``__init__`` again (a
        field's setting through a frozen ``__setattr__``: 4 us, against 1): the class has
        no ``__post_init__`` and every field is an ``__init__`` one, so the same options."""
        unknown = changes.keys() - self.__dataclass_fields__.keys()
        if unknown:
            raise TypeError(f"FitOptions has no field {sorted(unknown)[0]!r}")
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__, **changes)
        return new

    @classmethod
    def of(cls, options: Mapping) -> FitOptions:
        """FitOptions from keyword arguments; an unknown name is a FitError naming it
        (and the closest option name)."""
        if options.keys() <= cls.__dataclass_fields__.keys():
            return cls(**options)  # every name an option (checked at once: 5 us less)
        names = [f.name for f in fields(cls)]
        for name in options:
            if name not in names:
                close = difflib.get_close_matches(str(name), names, n=1)
                hint = f" (did you mean {close[0]}?)" if close else ""
                raise FitError(
                    f"{name!r} is not an option of fit{hint}; the options are {', '.join(names)}",
                    str(name),
                )
        return cls(**options)

    @classmethod
    def signature(cls, function) -> inspect.Signature:
        """``function(data, model, **options)``'s signature with every option spelt
        out as a keyword (what ``help()`` and editors show)."""
        first = [
            inspect.Parameter(name, inspect.Parameter.POSITIONAL_OR_KEYWORD)
            for name in ("data", "model")
        ]
        keywords = [
            inspect.Parameter(
                f.name, inspect.Parameter.KEYWORD_ONLY, default=f.default, annotation=f.type
            )
            for f in fields(cls)
        ]
        returns = inspect.signature(function).return_annotation
        return inspect.Signature(first + keywords, return_annotation=returns)

    def record(self) -> dict:
        """The options a result keeps to reproduce the fit: every ``record`` field, and
        the weights as :func:`weights_summary`."""
        out = {name: getattr(self, name) for name in _recorded(type(self))}
        out["weights"] = weights_summary(self.weights)
        return out


@cache
def _recorded(cls) -> tuple:
    """The names of ``cls``'s ``record`` fields (once: ``fields`` takes 4 us a call)."""
    return tuple(f.name for f in fields(cls) if f.metadata.get("record"))


def weights_summary(weights) -> dict | None:
    """``count``, ``min``, ``max`` and ``zeros`` (how many are 0) of per-sample weights,
    or None without weights: what a result's options say about them (the array can
    be as long as the data)."""
    if weights is None:
        return None
    w = np.asarray(weights, dtype=float).ravel()
    if w.size == 0:
        return {"count": 0, "min": None, "max": None, "zeros": 0}
    return {
        "count": int(w.size),
        "min": float(w.min()),
        "max": float(w.max()),
        "zeros": int(np.count_nonzero(w == 0)),
    }


def _positive_number(value) -> bool:
    return (
        isinstance(value, (int, float, np.integer, np.floating))
        and not isinstance(value, bool)
        and not math.isnan(value)
        and value > 0
    )


def _whole(
    value,
    name: str,
    least: int,
    *,
    below: int | None = None,
    optional: bool = False,
    alternative: str = "",
):
    """``value`` as an int if it is a whole number in [least, below); the one wording of
    "a whole number >= 1" errors in fitting and the posterior (``alternative``, e.g.
    "or 'auto'", ends the message when the option takes another value too)."""
    if value is None and optional:
        return None
    ok = isinstance(value, (int, np.integer)) and not isinstance(value, bool) and value >= least
    if ok and (below is None or value < below):
        return int(value)
    need = f"a whole number >= {least}"
    if below is not None:
        need = f"a whole number in [{least}, {below - 1}]"
    if alternative:
        need += f" {alternative}"
    raise FitError(f"{name}={value!r} must be {need}", name)


def _algorithm(name, field_name: str, prefix: tuple) -> str | None:
    if name is None or name == "none":
        return None
    if not isinstance(name, str) or not hasattr(nlopt, name) or not name.startswith(prefix):
        kinds = (
            "global (GN_...)" if prefix[0].startswith("G") else "local derivative-free (LN_...)"
        )
        raise FitError(f"{field_name}={name!r} is not an nlopt {kinds} algorithm name", field_name)
    return name
