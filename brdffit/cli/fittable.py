"""The table of fitted values that ``brdffit fit`` prints.

- every column has a heading, the last one ``note`` (``fixed``, ``at a bound``);
- with a posterior every value is ``median +up -down`` (84th and 16th
  percentiles), rounded to two significant digits of its smaller error
  (:func:`pm`), including parameters that the posterior samples through other
  coordinates (Ashikhmin-Shirley's ``rd``, sampled as ``rd_eff = rd (1 - rs)``:
  each sample is mapped back with the model's ``from_coefficients``);
- with up to :data:`WIDE_MAX` channels, one column per channel; with more
  (spectral data: 31 bands), a per-channel parameter is one row summarising its
  bands (:func:`band_summary`) unless every row is asked for.
"""

from __future__ import annotations

import math

import numpy as np

from ..models import get_model
from ..words import plural

__all__ = ["COMPACT_ABOVE", "WIDE_MAX", "band_summary", "fit_rows", "pm"]

#: Up to this many channels, one column per channel.
WIDE_MAX = 4
#: Above this many channels, a per-channel parameter is summarised in one row.
COMPACT_ABOVE = 8


def _two_digits(x: float) -> tuple[float, int]:
    """``x`` rounded to two significant digits, and the decimals that shows them."""
    exponent = math.floor(math.log10(abs(x)))
    decimals = 1 - exponent
    return round(x, decimals), max(decimals, 0)


def pm(summary) -> str:
    """``median +up -down`` (84th and 16th percentiles), to two digits of the error.

    Between 1e-3 and 1e6 in fixed notation, the median rounded where its smaller
    error's second digit is (``2027.3 +14 -12`` prints ``2027 +14 -12``);
    elsewhere in scientific notation with as many digits.
    """
    med = summary["median"]
    up, down = summary["p84"] - med, med - summary["p16"]
    err = min(e for e in (up, down, math.inf) if e > 0)
    if not (math.isfinite(err) and math.isfinite(med)):
        return f"{med:.6g}"
    if med == 0 or 1e-3 <= abs(med) < 1e6:
        _, decimals = _two_digits(err)
        step = 10.0 ** (math.floor(math.log10(err)) - 1)
        value = round(med / step) * step if decimals == 0 else med
        cells = [f"{value:.{decimals}f}"]
        for e in (up, down):
            e2, d2 = _two_digits(e) if e > 0 else (0.0, 0)
            cells.append(f"{e2:.{d2}f}")
        return f"{cells[0]} +{cells[1]} -{cells[2]}"
    digits = max(math.floor(math.log10(abs(med))) - math.floor(math.log10(err)) + 2, 2)
    return f"{med:.{digits - 1}e} +{up:.2g} -{down:.2g}"


def _plain(value: float) -> str:
    return f"{value:.6g}"


def _derived(result, name: str, channels) -> list | None:
    """Summaries of ``name`` (per channel) from the posterior's samples mapped back
    through the model's ``from_coefficients``, when the posterior samples it in other
    coordinates; None when it cannot."""
    post, model = result.posterior, get_model(result.model)
    if model.from_coefficients is None:
        return None
    out = []
    for c in channels:
        coefs = {}
        for k in model.coefficients:
            key = k if k in post.names else f"{k}[{c}]"
            if key not in post.names:
                return None
            coefs[k] = post.samples[:, post.index(key)]
        values = np.asarray(model.from_coefficients(coefs).get(name), dtype=float)
        if values.shape != (post.samples.shape[0],):
            return None
        p16, p50, p84 = np.percentile(values, [16, 50, 84])
        out.append({"median": float(p50), "p16": float(p16), "p84": float(p84)})
    return out


def _summaries(result, name, channels) -> list | None:
    """The posterior's summary of ``name`` (one per channel, or one), or None."""
    post = result.posterior
    if post is None:
        return None
    keys = [name] if name in post.names else [f"{name}[{c}]" for c in channels]
    if all(k in post.summary for k in keys):
        return [post.summary[k] for k in keys]
    return _derived(result, name, channels)


def _cells(result, name, channels) -> tuple[list[str], list[float]]:
    """Printed cells of one parameter (one per channel for per-channel values) and
    the values they stand for (medians, or the best fit)."""
    found = _summaries(result, name, channels)
    if found is not None:
        return [pm(s) for s in found], [s["median"] for s in found]
    value = np.atleast_1d(np.asarray(result.params[name], dtype=float))
    return [_plain(v) for v in value], [float(v) for v in value]


def _note(result, name) -> str:
    if name in result.fixed:
        return "fixed"
    return "at a bound" if name in result.at_bounds else ""


def band_summary(values, cells, channels) -> str:
    """One cell for a per-channel parameter over many channels: its range, where it
    is reached, and the median; ``cells`` are the channels' printed values."""
    values = np.asarray(values, dtype=float)
    lo, hi = int(np.nanargmin(values)), int(np.nanargmax(values))
    return (
        f"{plural(len(values), 'channel')}: min {cells[lo]} ({channels[lo]}), "
        f"max {cells[hi]} ({channels[hi]}), median {_plain(float(np.nanmedian(values)))}"
    )


def fit_rows(result, every_channel: bool = False) -> tuple[list, list, bool]:
    """``(header, rows, compact)`` of the table of ``result``."""
    channels = list(result.channels)
    wide = 1 < len(channels) <= WIDE_MAX
    compact = len(channels) > COMPACT_ABOVE and not every_channel
    rows = []
    for name in result.params:
        cells, values = _cells(result, name, channels)
        note = _note(result, name)
        if len(cells) == 1:
            rows.append([name, cells[0], *[""] * (len(channels) - 1) * wide, note])
        elif wide:
            rows.append([name, *cells, note])
        elif compact:
            rows.append([name, band_summary(values, cells, channels), note])
        else:
            rows += [[f"{name}[{c}]", cell, note] for c, cell in zip(channels, cells)]
    post = result.posterior
    if post is not None and "noise" in post.summary:
        pad = [""] * (len(channels) - 1) * wide
        rows.append(["noise", pm(post.summary["noise"]), *pad, post.noise])
    header = ["parameter", *(channels if wide else ["value"]), "note"]
    return header, rows, compact
