"""Pictures of a fit: measured against fitted BRDF, and the residuals.

``plot_fit(data, result, path)`` writes one PNG:

- for each incidence direction of a gonioreflectometer-like dataset (up to
  six, spread over the polar angles measured), the plane of incidence: the
  measured values of each channel (points) and the fitted model (a line
  evaluated on a fine grid of outgoing angles), on a log scale, against the
  signed outgoing angle (negative on the side of the light, positive on the
  side of the mirror direction);
- when the data have no plane of incidence worth drawing (random directions,
  MERL tables), measured against fitted values of every sample, log-log;
- below, the residuals of every sample against the half-vector angle
  ``theta_h``: in units of sigma when the data give it, else relative to the
  fitted value.

The figure is drawn on a :class:`matplotlib.figure.Figure` with the Agg canvas,
never through ``pyplot``: the caller's backend is left as it is (a notebook keeps
its inline plots), no window opens and no global figure is kept.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ..data.geometry import directions_from_angles
from ..models import get_model
from ..words import plural
from .residuals import SIGMA_LABEL, Residuals, log_hidden, residuals

__all__ = [
    "PlaneSlice",
    "fit_figure",
    "plane_of_incidence",
    "plot_fit",
    "slice_note",
    "unconverged_mark",
]

#: Azimuth tolerance (degrees): a sample this close to the plane of incidence is in it.
PLANE_TOLERANCE = 0.5
#: Farthest (degrees) the nearest azimuth slice may lie from the plane of incidence
#: to stand for it: tabulated data (MBSDF cells: 2 degrees wide, centred 1 degree
#: off the plane) have no sample in the plane itself.
SLICE_TOLERANCE = 5.0
MAX_PANELS = 6
MAX_CHANNELS = 8
RGB = {
    "r": "tab:red",
    "g": "tab:green",
    "b": "tab:blue",
    "red": "tab:red",
    "green": "tab:green",
    "blue": "tab:blue",
}


class PlaneSlice(NamedTuple):
    """The samples drawn for one incidence direction (angles in degrees).

    ``index``: the samples; ``signed``: their outgoing polar angle, negative on the
    side of the light; ``backward``/``forward``: the azimuth ``phi_o - phi_i`` of the
    slice on each side (0 and 180 in the plane itself; None when that side has no
    slice); ``offset``: the largest distance of a drawn sample's azimuth from the plane.
    """

    theta_i: float
    phi_i: float
    index: np.ndarray
    signed: np.ndarray
    backward: float | None
    forward: float | None
    offset: float


def _nearest(distance: np.ndarray, tolerance: float) -> np.ndarray:
    """The samples of the azimuth slice nearest the plane (``distance`` from it), when
    that slice is within ``tolerance``: every sample within PLANE_TOLERANCE of it."""
    if distance.size == 0 or distance.min() > tolerance:
        return np.zeros(distance.shape, dtype=bool)
    return distance <= distance.min() + PLANE_TOLERANCE


def _slice(dphi, to, tolerance):
    """Masks (backward, forward, normal) of one incidence direction's samples."""
    normal = to < 1e-9
    upper = (to < 90) & ~normal
    d_forward = np.where(upper, np.abs(dphi - 180.0), np.inf)
    d_backward = np.where(upper, np.minimum(dphi, 360.0 - dphi), np.inf)
    return _nearest(d_backward, tolerance), _nearest(d_forward, tolerance), normal


def plane_of_incidence(data, tolerance: float = SLICE_TOLERANCE) -> list[PlaneSlice]:
    """Incidence directions with samples in (or next to) their plane of incidence.

    On each side of the normal (towards the light, towards the mirror direction) the
    azimuth slice nearest the plane is taken when it lies within ``tolerance``
    degrees of it. Returns one :class:`PlaneSlice` per incidence direction with at
    least five such samples, sorted by ``theta_i``.
    """
    ti, pi_, to, po = (np.asarray(a, dtype=float) for a in data.angles(degrees=True))
    key = np.round(np.column_stack([ti, np.mod(pi_, 360.0)]), 3)
    dphi = np.mod(po - pi_, 360.0)
    incidences, which = np.unique(key, axis=0, return_inverse=True)
    which = np.ravel(which)  # each sample's incidence direction, samples grouped below
    bounds = np.cumsum(np.bincount(which, minlength=len(incidences)))[:-1]
    samples = np.split(np.argsort(which, kind="stable"), bounds)
    groups = []
    for (theta_i, phi_i), same in zip(incidences, samples, strict=True):
        if len(same) < 5:
            continue
        group = _group(float(theta_i), float(phi_i), same, dphi[same], to[same], tolerance)
        if group is not None:
            groups.append(group)
    return groups


def _group(theta_i, phi_i, same, dphi, to, tolerance) -> PlaneSlice | None:
    """The slice of one incidence direction (``same``: its samples), if it has 5 samples."""
    back, fore, normal = _slice(dphi, to, tolerance)
    keep = back | fore | normal
    if keep.sum() < 5:
        return None
    signed = np.where(back[keep], -to[keep], to[keep])
    away_back = np.minimum(dphi[back], 360.0 - dphi[back])  # distance from the plane
    away_fore = np.abs(dphi[fore] - 180.0)
    backward = float(np.median(np.where(dphi[back] > 180, dphi[back] - 360, dphi[back]))) \
        if back.any() else None  # fmt: skip
    forward = float(np.median(dphi[fore])) if fore.any() else None
    offset = float(np.concatenate([away_back, away_fore, [0.0]]).max())
    return PlaneSlice(theta_i, phi_i, same[keep], signed, backward, forward, offset)


def _pick(groups: list, k: int) -> list:
    """Up to ``k`` groups spread over the incidence angles."""
    if len(groups) <= k:
        return groups
    return [groups[i] for i in np.unique(np.round(np.linspace(0, len(groups) - 1, k)).astype(int))]


def _channel_colours(channels, wavelengths) -> tuple[list[int], list]:
    """Channels to draw (at most MAX_CHANNELS, spread) and a colour for each."""
    import matplotlib

    shown = list(range(len(channels)))
    if len(shown) > MAX_CHANNELS:
        shown = sorted({round(x) for x in np.linspace(0, len(channels) - 1, MAX_CHANNELS)})
    if len(channels) == 1:
        return shown, ["black"]
    if all(channels[c].lower() in RGB for c in shown):
        return shown, [RGB[channels[c].lower()] for c in shown]
    cmap = matplotlib.colormaps["turbo"]
    if wavelengths is not None:
        lo, hi = float(np.min(wavelengths)), float(np.max(wavelengths))
        return shown, [
            cmap(0.05 + 0.9 * (wavelengths[c] - lo) / max(hi - lo, 1e-9)) for c in shown
        ]
    return shown, [cmap(0.05 + 0.9 * i / max(len(shown) - 1, 1)) for i in range(len(shown))]


def _curve(model, params, group: PlaneSlice):
    """The model along the slice, theta_o from -89 to 89 degrees, at the slice's azimuths."""
    signed = np.linspace(-89.0, 89.0, 357)
    back = 0.0 if group.backward is None else group.backward
    fore = 180.0 if group.forward is None else group.forward
    phi_o = group.phi_i + np.where(signed < 0, back, fore)
    wo = directions_from_angles(np.abs(signed), phi_o)
    wi = directions_from_angles(np.array([group.theta_i]), np.array([group.phi_i]))
    values = np.asarray(model.evaluate(np.repeat(wi, len(wo), 0), wo, params), dtype=float)
    return signed, values.reshape(len(signed), -1)


def _log_floor(values: np.ndarray) -> float:
    positive = values[values > 0]
    return float(positive.min()) / 2 if positive.size else 1e-6


def _corner_text(ax, lines, where="lower left") -> None:
    """Small text inside ``ax`` (what the axis does not show, how the slice was taken)."""
    if lines:
        x, ha = (0.01, "left") if where.endswith("left") else (0.99, "right")
        y, va = (0.02, "bottom") if where.startswith("lower") else (0.98, "top")
        text = ax.text(x, y, "\n".join(lines), transform=ax.transAxes, ha=ha, va=va,
                       fontsize=7, color="0.25", gid="note", wrap=True,
                       bbox={"fc": "white", "alpha": 0.8, "lw": 0})  # fmt: skip
        text.set_in_layout(False)


def slice_note(group: PlaneSlice) -> str:
    """What the panel of ``group`` says about its azimuth slice (a short line)."""
    if group.offset <= PLANE_TOLERANCE:
        return f"samples within {PLANE_TOLERANCE:g}° of the plane of incidence"
    return (
        f"nearest azimuth slice: φo − φi = {_side(group.backward)} | {_side(group.forward)}"
        f"\n(≤ {group.offset:.3g}° off the plane; tolerance {SLICE_TOLERANCE:g}°)"
    )


def _side(dphi) -> str:
    return "none" if dphi is None else f"{dphi:.4g}°"


def _plane_panel(ax, data, model, params, group, shown, colours, floor):
    x, curve = _curve(model, params, group)
    order = np.argsort(group.signed)
    measured = data.values[group.index][:, shown]
    for k, (c, colour) in enumerate(zip(shown, colours)):
        y = measured[:, k]
        ax.plot(group.signed[order], np.where(y > 0, y, np.nan)[order], "o", ms=3.5,
                color=colour, alpha=0.75, label=f"{data.channels[c]} measured")  # fmt: skip
        fit_c = curve[:, c] if curve.shape[1] > 1 else curve[:, 0]
        ax.plot(x, np.where(fit_c > floor / 10, fit_c, np.nan), "-", lw=1.4, color=colour)
    ax.axvline(-group.theta_i, color="0.6", lw=0.8, ls=":")
    ax.axvline(group.theta_i, color="0.6", lw=0.8, ls="--")
    ax.set_yscale("log")
    ax.set_ylim(bottom=floor)
    ax.set_xlim(-90, 90)
    ax.set_title(f"incidence θi = {group.theta_i:g}°, φi = {group.phi_i:g}°", fontsize=10)
    ax.set_xlabel(
        "outgoing θo in the plane of incidence (°)\n← light side | mirror side →", fontsize=8
    )
    ax.set_ylabel("BRDF (1/sr)")
    ax.grid(True, which="major", alpha=0.3)
    hidden = log_hidden(measured)
    notes = [slice_note(group)] if group.offset > PLANE_TOLERANCE else []
    if hidden:
        notes.append(f"{plural(hidden, 'measured value')} ≤ 0 not shown (log axis)")
    _corner_text(ax, notes)


def _scatter_panel(ax, data, pred, shown, colours, floor):
    for c, colour in zip(shown, colours):
        ax.loglog(pred[:, c], data.values[:, c], ".", ms=3, alpha=0.5, color=colour,
                  label=data.channels[c])  # fmt: skip
    top = max(float(np.max(data.values)), float(np.max(pred)))
    ax.plot([floor, top], [floor, top], "k-", lw=0.8, label="measured = fitted")
    ax.set_xlim(floor, top * 1.5)
    ax.set_ylim(floor, top * 1.5)
    ax.set_xlabel("fitted BRDF (1/sr)")
    ax.set_ylabel("measured BRDF (1/sr)")
    ax.set_title("every sample: measured against fitted", fontsize=10)
    ax.grid(True, alpha=0.3)
    hidden = int(np.count_nonzero((data.values[:, shown] <= 0) | (pred[:, shown] <= 0)))
    if hidden:
        _corner_text(ax, [f"{plural(hidden, 'point')} with a value ≤ 0 not shown (log axes)"],
                     "lower right")  # fmt: skip


def _residual_panel(ax, data, pred, shown, colours) -> Residuals:
    res = residuals(data, pred, shown)
    low, high = res.limits
    for k, colour in enumerate(colours):
        r = res.values[:, k]
        inside = (r >= low) & (r <= high)
        ax.plot(res.theta_h[inside], r[inside], ".", ms=2.5, alpha=0.5, color=colour,
                gid="residuals")  # fmt: skip
        for mask, edge, marker in ((r > high, high, "^"), (r < low, low, "v")):
            if mask.any():
                ax.plot(res.theta_h[mask], np.full(mask.sum(), edge), marker, ms=4, mfc="none",
                        color=colour, gid="outliers")  # fmt: skip
    if res.label == SIGMA_LABEL:
        for level in (-3, 3):
            ax.axhline(level, color="0.5", lw=0.8, ls="--")
    ax.axhline(0, color="k", lw=0.8)
    pad = 0.04 * (high - low)
    ax.set_ylim(low - pad, high + pad)
    ax.set_xlabel("half-vector angle θh (°)")
    ax.set_ylabel(res.label)
    ax.set_title("residuals of every sample", fontsize=10)
    ax.grid(True, alpha=0.3)
    _corner_text(ax, res.notes(), "upper right")
    return res


def fit_figure(data, result, title: str | None = None) -> Figure:
    """The figure of :func:`plot_fit`, not yet saved (its artists can be inspected).

    Parameters are as for :func:`plot_fit`.
    """
    model = get_model(result.model)
    params = dict(result.params)
    pred = np.asarray(model.evaluate(data.wi, data.wo, params), dtype=float)
    pred = np.broadcast_to(pred.reshape(data.n, -1), data.values.shape)
    shown, colours = _channel_colours(list(data.channels), data.wavelengths())
    groups = _pick(plane_of_incidence(data), MAX_PANELS)
    floor = _log_floor(data.values[:, shown])
    if groups:
        fig, residual_ax = _plane_figure(data, model, params, groups, shown, colours, floor)
    else:
        fig = Figure(figsize=(11, 4.8), layout="constrained")
        axes = fig.subplots(1, 2)
        _scatter_panel(axes[0], data, pred, shown, colours, floor)
        axes[0].legend(fontsize=8, loc="upper left")
        residual_ax = axes[1]
    _residual_panel(residual_ax, data, pred, shown, colours)
    status = "converged" if result.converged else "NOT CONVERGED"
    if not result.converged:
        unconverged_mark(fig, result.message)
    fig.suptitle(
        f"{result.model} fitted to {title or data.source or 'the data'}\n"
        f"{result.loss_name} loss {result.loss:.4g}, rmse {result.metrics['rmse']:.4g}, {status}",
        fontsize=11,
        x=0.01,
        ha="left",
    )
    FigureCanvasAgg(fig)
    return fig


def unconverged_mark(fig: Figure, message: str) -> None:
    """The mark of a result that did not converge: a red frame round the figure and a red
    line of text at its foot, kept out of the layout."""
    from matplotlib.patches import Rectangle

    frame = Rectangle((0.002, 0.002), 0.996, 0.996, transform=fig.transFigure, fill=False,
                      edgecolor="red", linewidth=4, gid="unconverged")  # fmt: skip
    fig.patches.append(frame)
    text = fig.text(0.01, 0.008, f"NOT CONVERGED: not reliable. {message}", color="red",
                    fontsize=9, fontweight="bold", ha="left", va="bottom", gid="unconverged",
                    wrap=True)  # fmt: skip
    text.set_in_layout(False)


def plot_fit(data, result, path, title: str | None = None) -> str:
    """Write the PNG described in the module docstring to ``path``; return ``path``.

    Parameters
    ----------
    data : Measurements
        The data the fit was made on.
    result : FitResult
    path : str or path-like
    title : str, optional
        What the data are called in the title (default: their ``source``).
    """
    fit_figure(data, result, title).savefig(path, dpi=110)
    return str(path)


def _plane_figure(data, model, params, groups, shown, colours, floor):
    """Panels of the planes of incidence above a wide residual panel."""
    from matplotlib.lines import Line2D

    cols = min(len(groups), 3)
    rows = -(-len(groups) // cols)
    fig = Figure(figsize=(max(4.6 * cols, 9.5), 3.6 * rows + 3.4), layout="constrained")
    grid = fig.add_gridspec(rows + 1, cols, height_ratios=[1] * rows + [0.85])
    axes = [fig.add_subplot(grid[i // cols, i % cols]) for i in range(len(groups))]
    for ax, group in zip(axes, groups):
        _plane_panel(ax, data, model, params, group, shown, colours, floor)
    handles, labels = axes[0].get_legend_handles_labels()
    handles += [
        Line2D([], [], color="0.3", lw=1.4),
        Line2D([], [], color="0.6", ls="--"),
        Line2D([], [], color="0.6", ls=":"),
    ]
    labels += ["fitted model", "mirror direction", "light direction"]
    fig.legend(
        handles, labels, loc="outside upper right", fontsize=8, ncols=(len(labels) + 1) // 2
    )
    return fig, fig.add_subplot(grid[rows, :])
