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

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ..data.geometry import directions_from_angles
from ..models import get_model

__all__ = ["plot_fit", "plane_of_incidence"]

#: Azimuth tolerance (degrees) for a sample to count as in the plane of incidence.
PLANE_TOLERANCE = 0.5
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


def plane_of_incidence(data) -> list[tuple[float, float, np.ndarray, np.ndarray]]:
    """Incidence directions with samples in their plane of incidence.

    Returns a list of ``(theta_i, phi_i, index, signed_theta_o)`` (degrees), one per
    incidence direction with at least five in-plane samples, sorted by ``theta_i``;
    ``signed_theta_o`` is negative on the side of the light.
    """
    ti, pi_, to, po = (np.asarray(a, dtype=float) for a in data.angles(degrees=True))
    key = np.round(np.column_stack([ti, np.mod(pi_, 360.0)]), 3)
    dphi = np.mod(po - pi_, 360.0)
    forward = np.abs(dphi - 180.0) < PLANE_TOLERANCE
    backward = np.minimum(dphi, 360.0 - dphi) < PLANE_TOLERANCE
    normal = to < 1e-9
    groups = []
    for theta_i, phi_i in np.unique(key, axis=0):
        same = (key[:, 0] == theta_i) & (key[:, 1] == phi_i)
        index = np.flatnonzero(same & (forward | backward | normal) & (to < 90))
        if len(index) >= 5:
            signed = np.where(backward[index] & ~normal[index], -to[index], to[index])
            groups.append((float(theta_i), float(phi_i), index, signed))
    return groups


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


def _curve(model, params, theta_i, phi_i):
    """The model along the plane of incidence, theta_o from -89 to 89 degrees."""
    signed = np.linspace(-89.0, 89.0, 357)
    phi_o = np.where(signed < 0, phi_i, phi_i + 180.0)
    wo = directions_from_angles(np.abs(signed), phi_o)
    wi = np.repeat(directions_from_angles(np.array([theta_i]), np.array([phi_i])), len(wo), 0)
    values = np.asarray(model.evaluate(wi, wo, params), dtype=float)
    return signed, values.reshape(len(signed), -1)


def _log_floor(values: np.ndarray) -> float:
    positive = values[values > 0]
    return float(positive.min()) / 2 if positive.size else 1e-6


def _plane_panel(ax, data, model, params, group, shown, colours, floor):
    theta_i, phi_i, index, signed = group
    x, curve = _curve(model, params, theta_i, phi_i)
    order = np.argsort(signed)
    for c, colour in zip(shown, colours):
        label = data.channels[c]
        y = data.values[index, c]
        ax.plot(
            signed[order],
            np.where(y > 0, y, np.nan)[order],
            "o",
            ms=3.5,
            color=colour,
            alpha=0.75,
            label=f"{label} measured",
        )
        fit_c = curve[:, c] if curve.shape[1] > 1 else curve[:, 0]
        ax.plot(x, np.where(fit_c > floor / 10, fit_c, np.nan), "-", lw=1.4, color=colour)
    ax.axvline(-theta_i, color="0.6", lw=0.8, ls=":")
    ax.axvline(theta_i, color="0.6", lw=0.8, ls="--")
    ax.set_yscale("log")
    ax.set_ylim(bottom=floor)
    ax.set_xlim(-90, 90)
    ax.set_title(f"incidence θi = {theta_i:g}°, φi = {phi_i:g}°", fontsize=10)
    ax.set_xlabel(
        "outgoing θo in the plane of incidence (°)\n← light side | mirror side →", fontsize=8
    )
    ax.set_ylabel("BRDF (1/sr)")
    ax.grid(True, which="major", alpha=0.3)


def _scatter_panel(ax, data, pred, shown, colours, floor):
    for c, colour in zip(shown, colours):
        ax.loglog(
            pred[:, c],
            data.values[:, c],
            ".",
            ms=3,
            alpha=0.5,
            color=colour,
            label=data.channels[c],
        )
    top = max(float(np.max(data.values)), float(np.max(pred)))
    ax.plot([floor, top], [floor, top], "k-", lw=0.8, label="measured = fitted")
    ax.set_xlim(floor, top * 1.5)
    ax.set_ylim(floor, top * 1.5)
    ax.set_xlabel("fitted BRDF (1/sr)")
    ax.set_ylabel("measured BRDF (1/sr)")
    ax.set_title("every sample: measured against fitted", fontsize=10)
    ax.grid(True, alpha=0.3)


def _residual_panel(ax, data, pred, shown, colours):
    h = data.wi + data.wo
    norm = np.linalg.norm(h, axis=1)
    theta_h = np.degrees(np.arccos(np.clip(h[:, 2] / np.where(norm > 0, norm, 1), -1, 1)))
    if data.sigma is not None:
        resid, label = (data.values - pred) / data.sigma, "(measured − fitted) / σ"
        for level in (-3, 3):
            ax.axhline(level, color="0.5", lw=0.8, ls="--")
    else:
        scale = np.maximum(np.abs(pred), 1e-3 * np.max(np.abs(pred)))
        resid, label = (data.values - pred) / scale, "(measured − fitted) / fitted"
    for c, colour in zip(shown, colours):
        ax.plot(theta_h, resid[:, c], ".", ms=2.5, alpha=0.5, color=colour)
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xlabel("half-vector angle θh (°)")
    ax.set_ylabel(label)
    ax.set_title("residuals of every sample", fontsize=10)
    ax.grid(True, alpha=0.3)


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
    fig.suptitle(
        f"{result.model} fitted to {title or data.source or 'the data'}\n"
        f"{result.loss_name} loss {result.loss:.4g}, rmse {result.metrics['rmse']:.4g}, {status}",
        fontsize=11,
        x=0.01,
        ha="left",
    )
    FigureCanvasAgg(fig)
    fig.savefig(path, dpi=110)
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
