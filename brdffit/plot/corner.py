"""Figures as PNG files: the posterior's corner plot and trace plot.

Every figure is drawn on a :class:`matplotlib.figure.Figure` with the Agg
canvas directly, never through ``pyplot``: the library does not switch the
caller's matplotlib backend, opens no window and keeps no global figure state
(so a server can draw from several threads). The corner plot uses the
``corner`` package (Foreman-Mackey 2016, JOSS 1(2), 24).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ..errors import FitError
from ..extras import require
from ..words import plural

__all__ = ["corner_figure", "corner_plot", "trace_plot"]

#: Above this many parameters the corner plot shows a subset by default.
CORNER_MAX = 8


def _save(fig: Figure, path, dpi: int) -> Path:
    path = Path(path)
    FigureCanvasAgg(fig)
    fig.savefig(path, dpi=dpi, format="png")
    return path


def _corner_names(posterior, names, channel) -> tuple[list[str], str]:
    """The parameters shown, and a sentence on what is left out ("" when nothing)."""
    omitted = ""
    if names is None:
        names = list(posterior.names)
        if channel is not None or len(names) > CORNER_MAX:
            # Many channels: the sampled coordinates and one channel's coefficients.
            chosen = posterior.channels[0] if channel is None else channel
            if chosen not in posterior.channels:
                raise FitError(
                    f"channel={chosen!r} is not a channel of this posterior; they are "
                    f"{', '.join(posterior.channels)}",
                    "channel",
                )
            names = [n for n in names if n in posterior.sampled or n.endswith(f"[{chosen}]")]
            left = len(posterior.names) - len(names)
            if left:
                omitted = (
                    f"channel {chosen} of {len(posterior.channels)} shown "
                    f"({plural(left, 'parameter')} of the other channels left out; "
                    "choose with channel=)"
                )
    for name in names:
        posterior.index(name)
    if not names:
        raise FitError("a corner plot needs at least one parameter name", "names")
    return list(names), omitted


def _unconverged_mark(fig: Figure, posterior) -> None:
    """The mark of :func:`.fit.unconverged_mark` on a posterior that did not converge."""
    if not posterior.converged:
        from .fit import unconverged_mark

        unconverged_mark(fig, f"the posterior: {posterior.message}")


def corner_figure(posterior, names=None, channel=None) -> Figure:
    """The figure of :func:`corner_plot`, not yet saved (its texts can be inspected)."""
    corner = require("corner", "plot")
    names, omitted = _corner_names(posterior, names, channel)
    data = posterior.samples[:, [posterior.index(n) for n in names]]
    # corner needs some spread in every shown column; a parameter with none gets a
    # range of its own value +- 1e-12 relative so the histogram has a width.
    span = [
        (lo, hi) if hi > lo else (lo - 1e-12 * max(abs(lo), 1.0), hi + 1e-12 * max(abs(hi), 1.0))
        for lo, hi in zip(data.min(axis=0), data.max(axis=0))
    ]
    size = 2.0 * len(names) + 1.0
    fig = Figure(figsize=(size, size))
    corner.corner(
        data,
        labels=names,
        quantiles=[0.16, 0.5, 0.84],
        show_titles=True,
        title_fmt=".3g",
        range=span,
        fig=fig,
    )
    # room for the notes: 0.45 inch above the panels, 0.35 inch below for the mark
    pars = fig.subplotpars
    fig.subplots_adjust(top=pars.top - 0.45 / size * bool(omitted),
                        bottom=pars.bottom + 0.35 / size * (not posterior.converged))  # fmt: skip
    if omitted:
        fig.text(0.01, 0.995, omitted, fontsize=9, ha="left", va="top", gid="omitted", wrap=True)
    _unconverged_mark(fig, posterior)
    return fig


def corner_plot(posterior, path, names=None, dpi: int = 100, channel=None) -> Path:
    """Write the corner plot (histograms and pairwise densities) of a posterior as PNG.

    Parameters
    ----------
    posterior : Posterior
    path : str or Path
    names : sequence of str, optional
        The parameters to show. Default: all when there are at most
        :data:`CORNER_MAX`, else the sampled ones and one channel's coefficients
        (the figure says which channel, and how many parameters it leaves out).
    dpi : int
    channel : str, optional
        The channel whose coefficients are shown when not all are (default: the first).

    The dashed lines are the 16th, 50th and 84th percentiles, as in the summary.
    A posterior that did not converge is marked in red across the top.
    """
    return _save(corner_figure(posterior, names, channel), path, dpi)


def trace_plot(posterior, path, dpi: int = 100) -> Path:
    """Write the trace of every walker for each sampled coordinate as PNG.

    One panel per sampled coordinate, in the search space (``log10`` for
    log-scale parameters and the noise), every walker a thin line; the grey
    band is the burn-in that the summary discards.
    """
    chain = posterior.chain
    if chain.shape[0] == 0 or chain.shape[2] == 0:
        raise FitError(
            "this posterior has no chain to plot: nothing was sampled by MCMC "
            "(the coefficients were drawn independently)",
            "posterior",
        )
    dim = chain.shape[2]
    fig = Figure(figsize=(8.0, 1.8 * dim + 0.6))
    axes = fig.subplots(dim, 1, sharex=True, squeeze=False)[:, 0]
    steps = np.arange(chain.shape[0])
    for i, ax in enumerate(axes):
        ax.plot(steps, chain[:, :, i], color="k", alpha=max(0.05, 3.0 / chain.shape[1]), lw=0.6)
        ax.axvspan(0, posterior.burn, color="0.85", zorder=0)
        ax.set_ylabel(_axis_label(posterior, i))
        tau = posterior.autocorr_time.get(posterior.sampled[i])
        if tau is not None and np.isfinite(tau):
            ax.set_title(f"tau = {tau:.3g} steps", fontsize=8, loc="right")
    axes[-1].set_xlabel("step")
    fig.suptitle(posterior.message, fontsize=8)
    fig.tight_layout()
    _unconverged_mark(fig, posterior)
    return _save(fig, path, dpi)


def _axis_label(posterior, i: int) -> str:
    name = posterior.sampled[i]
    return f"log10 {name}" if posterior.sampled_log[i] else name
