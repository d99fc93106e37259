"""What the ``brdffit`` command shows: progress lines, tables of models and of fitted
values with their uncertainties, CSV of evaluated models, and strict JSON
(:func:`brdffit.jsonable.dumps`: NaN and infinities as null)."""

from __future__ import annotations

import math
import sys
import time

import numpy as np

from ..fitting.misfit import describe
from ..jsonable import dumps
from ..words import plural
from .fittable import fit_rows, pm

__all__ = [
    "Progress",
    "evaluate_csv",
    "fit_text",
    "models_text",
    "print_json",
    "progress_for",
    "shout",
    "table",
]


# ----------------------------------------------------------------- progress
class Progress:
    """A progress line on stderr (a TTY), for FitProgress and PosteriorProgress reports."""

    def __init__(self, label: str, max_seconds: float | None = None):
        self.label, self.max_seconds = label, max_seconds
        self.last, self.shown = 0.0, False

    def __call__(self, p) -> None:
        now = time.monotonic()
        if now - self.last < 0.1:
            return
        self.last = now
        if hasattr(p, "n_evals"):
            text = (
                f"{self.label}: {p.stage:<10} {plural(f'{p.n_evals:>6}', 'evaluation')}, "
                f"best loss {p.best_loss:.4g}, {p.seconds:.1f} s"
            )
        else:
            budget = max(p.steps / p.max_steps, p.seconds / (self.max_seconds or math.inf))
            bar = "#" * round(20 * min(budget, 1.0))
            text = (
                f"sampling [{bar:<20}] {plural(p.steps, 'step')}, autocorrelation "
                f"{p.autocorr_time:.1f}, {plural(p.effective_samples, 'effective sample')}, "
                f"{p.seconds:.1f} s"
            )
        self.line(text)

    def line(self, text: str) -> None:
        sys.stderr.write("\r\x1b[2K" + text[:150])
        sys.stderr.flush()
        self.shown = True

    def done(self) -> None:
        if self.shown:
            sys.stderr.write("\r\x1b[2K")
            sys.stderr.flush()


def progress_for(args, label: str, max_seconds=None):
    if getattr(args, "json", False) or not sys.stderr.isatty():
        return None
    return Progress(label, max_seconds)


# ----------------------------------------------------------------- printing
def table(header, rows) -> str:
    widths = [max(len(str(x)) for x in column) for column in zip(header, *rows)]
    lines = [
        "  ".join(str(x).ljust(w) for x, w in zip(row, widths)).rstrip()
        for row in (header, ["-" * w for w in widths], *rows)
    ]
    return "\n".join(lines)


COMPACT_NOTE = (
    "per-channel parameters summarised over the {} channels: --every-channel prints "
    "one row per channel; --rgb fits the data in linear sRGB instead"
)
#: ``median +up -down`` of a posterior summary (:func:`.fittable.pm`).
_pm = pm


def fit_text(data, result, label: str, every_channel: bool = False) -> str:
    """The text of ``brdffit fit``: the header, the table (:mod:`.fittable`), the loss,
    the fit's and the posterior's messages."""
    channels = list(result.channels)
    post = result.posterior
    head, rows, compact = fit_rows(result, every_channel)
    kind = "median +(84th-50th) -(50th-16th) percentile" if post is not None else "best fit"
    if post is not None and not post.converged:
        kind += " of a posterior that DID NOT CONVERGE: not reliable"
    m = result.metrics
    lines = [
        f"{result.model} fitted to {label}: {plural(data.n, 'sample')}, "
        f"channels {', '.join(channels)}, sigma {'given' if data.sigma is not None else 'none'}",
        "",
        table(head, rows),
        "",
        f"values: {kind}",
        *([COMPACT_NOTE.format(len(channels))] if compact else []),
        f"{result.loss_name} loss {result.loss:.6g}, rmse {m['rmse']:.6g}, BIC {m['bic']:.6g}; "
        f"{plural(result.n_evals, 'evaluation')} in {result.seconds:.2f} s",
        f"fit: {result.message}",
        *describe(result),
    ]
    if result.unidentified:
        lines.append(unidentified_line(result.unidentified))
    if post is not None:
        lines.append(
            f"posterior: {post.message} ({post.seconds:.1f} s; noise: {post.noise_meaning})"
        )
    return "\n".join(lines)


def unidentified_line(unidentified) -> str:
    """One line: the parameters the data do not identify, grouped by reason."""
    by_reason: dict = {}
    for name, reasons in unidentified.items():
        for why in reasons.split("; "):
            by_reason.setdefault(why, []).append(name)
    return "NOT IDENTIFIED by these data (values not to be trusted): " + "; ".join(
        f"{', '.join(names)}: {why}" for why, names in by_reason.items()
    )


def shout(*lines: str) -> None:
    bar = "!" * 78
    sys.stderr.write("\n".join([bar, *lines, bar]) + "\n")


def print_json(obj) -> int:
    """Print ``obj`` as strict JSON (:func:`brdffit.jsonable.dumps`), indented; return 0."""
    print(dumps(obj, indent=2))
    return 0


def models_text(found: list, axes: list, properties: bool) -> str:
    """The table of ``brdffit models``: ``found`` are the models' ``to_dict()``, with
    ``properties`` (of :func:`~brdffit.models.properties.model_properties`) when measured."""
    header = ["model", *axes, "wave", "parameters"]
    header += ["max albedo", "albedo <= 1", "reciprocity error"] if properties else []
    rows = []
    for m in found:
        c, p = m["classification"], m.get("properties")
        rows.append([m["name"], *(c[axis] for axis in axes), "yes" if c["wave_optics"] else "no",
                     ", ".join(q["name"] for q in m["params"])])  # fmt: skip
        if p:
            rows[-1] += [f"{np.max(p['max_albedo']):.3g}", "yes" if p["energy_conserving"] else
                         "NO", f"{p['reciprocity_max']:.1e}"]  # fmt: skip
    text = table(header, rows) if rows else "no model matches these filters"
    if properties:
        text += ("\n\nat each model's default parameters; albedo over theta_i = 0..85 degrees; "
                 "reciprocity: largest |f(L,V) - f(V,L)| / max f")  # fmt: skip
    return text


def evaluate_csv(names, angles, values) -> str:
    """CSV of ``brdffit evaluate``: the angle columns, then one column per channel."""
    columns = values.reshape(len(values), -1)
    width = columns.shape[1]
    channels = {1: ["value"], 3: ["r", "g", "b"]}.get(width, [f"c{i}" for i in range(width)])
    lines = [",".join([*names, *channels])]
    lines += [",".join(repr(float(x)) for x in row) for row in zip(*angles, *columns.T)]
    return "\n".join(lines)
