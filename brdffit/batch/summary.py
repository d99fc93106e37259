"""The outcome of a batch: the best model of each source, a markdown report.

"Best" is read two ways, as :func:`brdffit.compare` ranks them: the lowest
BIC of the fit to all samples (``k ln n`` penalises parameters; Schwarz 1978,
"Estimating the dimension of a model", Ann. Stat. 6(2)), and the lowest RMSE
on held-out samples (scored by ``compare`` on its seeded split), which no
parameter count can game. When they disagree the table shows both.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

__all__ = ["Best", "best_per_source", "best_table", "write_report"]


@dataclass(frozen=True)
class Best:
    """The winners of one source among its successful rows."""

    source: str
    n_ok: int
    n_failed: int
    by_bic: str | None
    bic: float | None
    by_heldout: str | None
    heldout_rmse: float | None


def _argmin(rows, value):
    scored = [(value(r), r) for r in rows]
    scored = [(v, r) for v, r in scored if v is not None and math.isfinite(v)]
    if not scored:
        return None, None
    v, r = min(scored, key=lambda vr: vr[0])
    return r.model, v


def best_per_source(rows) -> list[Best]:
    """One :class:`Best` per source, in order of first appearance."""
    groups: dict[str, list] = {}
    for row in rows:
        groups.setdefault(row.source, []).append(row)
    out = []
    for source, group in groups.items():
        ok = [r for r in group if r.ok and r.result is not None]
        by_bic, bic = _argmin(ok, lambda r: r.result.metrics.get("bic"))
        by_held, held = _argmin(ok, lambda r: r.heldout_rmse)
        out.append(Best(source, len(ok), len(group) - len(ok), by_bic, bic, by_held, held))
    return out


def _g(value) -> str:
    return "-" if value is None else f"{value:.6g}"


def best_table(best) -> tuple[list[str], list[list[str]]]:
    """Header and cells of the table of winners (plain strings)."""
    header = ["source", "ok", "failed", "best by BIC", "BIC", "best held-out", "held-out rmse"]
    cells = [
        [b.source, str(b.n_ok), str(b.n_failed), b.by_bic or "-", _g(b.bic),
         b.by_heldout or "-", _g(b.heldout_rmse)]
        for b in best
    ]  # fmt: skip
    return header, cells


def _markdown(header, cells) -> list[str]:
    def esc(text):
        return str(text).replace("|", "\\|")

    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return lines + ["| " + " | ".join(esc(c) for c in row) + " |" for row in cells]


def write_report(path, rows, read=None, title: str = "brdffit batch") -> Path:
    """Write a markdown report: the table of winners, the failures, a fit plot per source.

    The plot of each source (:func:`brdffit.plot.fit.plot_fit`) shows the model
    best by held-out error (by BIC when there is no held-out score), drawn into
    ``<report stem>_plots/`` next to the report. ``read`` reads a source for
    the plot (default :func:`brdffit.read`); a source that cannot be read or
    plotted is named in the report instead of its plot.
    """
    import brdffit
    from brdffit.plot.fit import plot_fit

    read = read or brdffit.read
    path = Path(path)
    rows = list(rows)
    best = best_per_source(rows)
    lines = [f"# {title}", "", f"{len(rows)} pairs, {len(best)} sources.", ""]
    lines += [*_markdown(*best_table(best)), ""]
    failed = [r for r in rows if not r.ok]
    if failed:
        lines += ["## Failed pairs", ""]
        lines += [
            f"- `{r.source}` x `{r.model}`: {r.error.type}: {r.error.message}" for r in failed
        ]
        lines += [""]
    plots = path.parent / f"{path.stem}_plots"
    lines += ["## Fits", ""]
    for i, b in enumerate(best):
        model = b.by_heldout or b.by_bic
        if model is None:
            continue
        row = next(r for r in rows if r.source == b.source and r.model == model and r.ok)
        name = re.sub(r"[^A-Za-z0-9_.-]+", "_", f"{i:03d}_{Path(b.source).stem}_{model}") + ".png"
        try:
            plots.mkdir(parents=True, exist_ok=True)
            plot_fit(read(b.source), row.result, plots / name, title=b.source)
        except Exception as exc:  # a missing plot must not lose the report
            lines += [f"- `{b.source}`: no plot ({type(exc).__name__}: {exc})", ""]
            continue
        lines += [
            f"### {b.source}: {model}",
            "",
            f"![{model} on {b.source}]({plots.name}/{name})",
            "",
        ]
    path.write_text("\n".join(lines))
    return path
