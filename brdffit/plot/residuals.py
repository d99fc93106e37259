"""What the residual panel and the log axes of :mod:`.fit` draw, computed apart from
the drawing so that it can be checked (and reused) without reading pixels.

- :func:`residuals`: per sample and channel, ``(measured - fitted) / sigma`` when
  the data give sigma, else ``(measured - fitted) / fitted`` exactly as the
  label says; where the fitted value is 0 the relative residual has no value:
  it is not drawn and the samples are counted on the plot.
- :func:`robust_limits`: axis limits that a few outliers cannot flatten, Tukey's
  far-out fences (Tukey 1977, *Exploratory Data Analysis*, ch. 2: 3 interquartile
  ranges beyond the quartiles), never wider than the data; the points beyond them
  are drawn at the edge and counted.
- :func:`log_hidden`: how many values a log axis cannot show (zero, negative).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..words import plural

__all__ = ["Residuals", "log_hidden", "residuals", "robust_limits"]

#: Tukey's "far out" fence: this many interquartile ranges beyond the quartiles.
FENCE = 3.0
SIGMA_LABEL = "(measured − fitted) / σ"
RELATIVE_LABEL = "(measured − fitted) / fitted"


@dataclass(frozen=True)
class Residuals:
    """What the residual panel draws.

    Attributes
    ----------
    theta_h : ndarray, shape (N,)
        Half-vector angle of each sample (degrees), the horizontal axis.
    values : ndarray, shape (N, K)
        Residual of each sample in each shown channel; NaN where it has no value.
    label : str
        What ``values`` are (the axis label), :data:`SIGMA_LABEL` or :data:`RELATIVE_LABEL`.
    undefined : int
        Values with no residual: a fitted value of 0 (relative residual) or a
        non-finite measurement.
    limits : tuple of float
        The vertical axis limits (:func:`robust_limits`).
    outside : int
        Finite residuals beyond ``limits``, drawn at the edge.
    """

    theta_h: np.ndarray
    values: np.ndarray
    label: str
    undefined: int
    limits: tuple
    outside: int

    def notes(self) -> list[str]:
        """The sentences the panel writes under its title."""
        out = []
        if self.outside:
            out.append(
                f"{plural(self.outside, 'point')} beyond the axis limits (3 IQR past the "
                "quartiles),\ndrawn as triangles at the edge"
            )
        if self.undefined:
            why = "fitted value 0: relative residual undefined" if self.label == RELATIVE_LABEL \
                else "no finite residual"  # fmt: skip
            out.append(f"{plural(self.undefined, 'value')} not drawn ({why})")
        return out


def half_vector_angle(data) -> np.ndarray:
    """Polar angle (degrees) of the half vector ``wi + wo`` of each sample."""
    h = data.wi + data.wo
    norm = np.linalg.norm(h, axis=1)
    return np.degrees(np.arccos(np.clip(h[:, 2] / np.where(norm > 0, norm, 1), -1, 1)))


def residuals(data, pred, shown) -> Residuals:
    """The residuals of the channels ``shown`` (indices) of ``data`` against ``pred``.

    With sigma: ``(measured - fitted) / sigma``. Without: ``(measured - fitted) /
    fitted`` where the fitted value is not 0, no value (NaN, counted) where it is.
    """
    measured = np.asarray(data.values, dtype=float)[:, shown]
    fitted = np.asarray(pred, dtype=float)[:, shown]
    with np.errstate(divide="ignore", invalid="ignore"):
        if data.sigma is not None:
            sigma = np.broadcast_to(np.asarray(data.sigma, dtype=float), data.values.shape)
            values, label = (measured - fitted) / sigma[:, shown], SIGMA_LABEL
        else:
            values = np.where(fitted != 0, (measured - fitted) / fitted, np.nan)
            label = RELATIVE_LABEL
    values = np.where(np.isfinite(values), values, np.nan)
    finite = values[np.isfinite(values)]
    limits = robust_limits(finite, always=(-3.0, 3.0) if label == SIGMA_LABEL else ())
    outside = int(np.count_nonzero((finite < limits[0]) | (finite > limits[1])))
    return Residuals(
        half_vector_angle(data), values, label, int(np.isnan(values).sum()), limits, outside
    )


def robust_limits(values, always=()) -> tuple[float, float]:
    """Limits ``(low, high)`` for ``values``: Tukey's far-out fences, clipped to the data.

    The fences ``Q1 - 3 IQR`` and ``Q3 + 3 IQR`` keep a few outliers from
    squeezing every other point onto a line; where the data do not reach a
    fence the limit is the data's own extreme. Values in ``always`` (such as
    the +-3 sigma lines) are inside the limits. With no spread (IQR 0) the
    limits are the data's range.
    """
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    if values.size == 0:
        low, high = -1.0, 1.0
    else:
        q1, q3 = np.percentile(values, [25, 75])
        iqr = q3 - q1
        low, high = float(values.min()), float(values.max())
        if iqr > 0:
            low, high = max(low, q1 - FENCE * iqr), min(high, q3 + FENCE * iqr)
    for level in always:
        low, high = min(low, level), max(high, level)
    if high <= low:
        pad = max(abs(low), 1.0) * 0.5
        low, high = low - pad, high + pad
    return float(low), float(high)


def log_hidden(values) -> int:
    """How many of ``values`` a log axis cannot show (zero, negative; NaN excluded)."""
    values = np.asarray(values, dtype=float)
    return int(np.count_nonzero(values <= 0))
