"""What the ``brdffit`` command shows: progress lines, tables of fitted values
with their uncertainties, and JSON with NaN and infinities as null."""

from __future__ import annotations

import json
import math
import sys
import time

import numpy as np

__all__ = ["Progress", "fit_text", "plain", "print_json", "progress_for", "shout", "table"]


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
                f"{self.label}: {p.stage:<10} {p.n_evals:>6} evaluations, best loss "
                f"{p.best_loss:.4g}, {p.seconds:.1f} s"
            )
        else:
            budget = max(p.steps / p.max_steps, p.seconds / (self.max_seconds or math.inf))
            bar = "#" * round(20 * min(budget, 1.0))
            text = (
                f"sampling [{bar:<20}] {p.steps} steps, autocorrelation {p.autocorr_time:.1f}"
                f", {p.effective_samples} effective samples, {p.seconds:.1f} s"
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


def _pm(summary) -> str:
    """``median +up -down`` (84th and 16th percentiles), to two digits of the error."""
    med, up, down = (
        summary["median"],
        summary["p84"] - summary["median"],
        summary["median"] - summary["p16"],
    )
    err = min(e for e in (up, down, math.inf) if e > 0)
    if not (math.isfinite(err) and math.isfinite(med)):
        return f"{med:.6g}"
    scale = math.floor(math.log10(abs(med))) if med else math.floor(math.log10(err))
    digits = max(scale - math.floor(math.log10(err)) + 2, 2)
    # "#" keeps trailing zeros: 0.35030 says the fifth digit is known to be 0.
    return f"{med:#.{digits}g} +{up:.2g} -{down:.2g}"


def _value_cells(result, name, channels):
    """Cells of one parameter: one per channel for per-channel values."""
    post = result.posterior
    if post is not None:
        keys = [name] if name in post.names else [f"{name}[{c}]" for c in channels]
        if all(k in post.summary for k in keys):
            return [_pm(post.summary[k]) for k in keys]
    value = np.atleast_1d(np.asarray(result.params[name], dtype=float))
    return [f"{v:.6g}" for v in value]


def fit_text(data, result, label: str) -> str:
    channels = list(result.channels)
    wide = 1 < len(channels) <= 4
    rows = []
    for name in result.params:
        cells = _value_cells(result, name, channels)
        note = (
            "fixed" if name in result.fixed else ("at a bound" if name in result.at_bounds else "")
        )
        if wide or len(cells) == 1:
            rows.append([name, *cells, *[""] * (len(channels) - len(cells)), note])
        else:
            rows += [[f"{name}[{c}]", cell, note] for c, cell in zip(channels, cells)]
    post = result.posterior
    if post is not None and "noise" in post.summary:
        rows.append(
            ["noise", _pm(post.summary["noise"]), *[""] * (len(channels) - 1) * wide, post.noise]
        )
    head = ["parameter", *(channels if wide else ["value"]), ""]
    kind = "median +(84th-50th) -(50th-16th) percentile" if post is not None else "best fit"
    if post is not None and not post.converged:
        kind += " of a posterior that DID NOT CONVERGE: not reliable"
    m = result.metrics
    lines = [
        f"{result.model} fitted to {label}: {data.n} samples, "
        f"channels {', '.join(channels)}, sigma {'given' if data.sigma is not None else 'none'}",
        "",
        table(head, rows),
        "",
        f"values: {kind}",
        f"{result.loss_name} loss {result.loss:.6g}, rmse {m['rmse']:.6g}, BIC {m['bic']:.6g}; "
        f"{result.n_evals} evaluations in {result.seconds:.2f} s",
        f"fit: {result.message}",
    ]
    if post is not None:
        lines.append(
            f"posterior: {post.message} ({post.seconds:.1f} s; noise: {post.noise_meaning})"
        )
    return "\n".join(lines)


def shout(*lines: str) -> None:
    bar = "!" * 78
    sys.stderr.write("\n".join([bar, *lines, bar]) + "\n")


def plain(value):
    """JSON-ready: arrays as lists, NaN and infinities as null (JSON has neither)."""
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [plain(v) for v in value]
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value.item() if isinstance(value, np.generic) else value


def print_json(obj) -> int:
    print(json.dumps(plain(obj), indent=2, allow_nan=False))
    return 0
