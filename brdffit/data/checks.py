"""The checks of what a :class:`~brdffit.data.measurements.Measurements` is built
from: values per channel, channel names, sigma and angles, each failing with a
:class:`~brdffit.errors.DataError` that names the field, the value and what is
needed.
"""

from __future__ import annotations

import numpy as np

from ..errors import DataError
from ..words import plural

__all__ = ["ANGLE_COLUMNS"]

#: Column names of the angles in files; a channel may not take one of them.
ANGLE_COLUMNS = ("theta_i", "phi_i", "theta_o", "phi_o")


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float, copy=True)
    a.setflags(write=False)
    return a


def _as_values(values, n: int | None, field: str) -> np.ndarray:
    """``values`` as a float (N, C) array, or DataError naming ``field``."""
    try:
        a = np.asarray(values, dtype=float)
    except (TypeError, ValueError) as exc:
        raise DataError(f"{field} must be an array of numbers: {exc}", field) from None
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2:
        raise DataError(f"{field} has shape {a.shape}; it must be (N,) or (N, C)", field)
    if n is not None and a.shape[0] != n:
        raise DataError(
            f"{field} has {plural(a.shape[0], 'sample')} but there are "
            f"{plural(n, 'direction pair')}; "
            "they must have the same length",
            field,
        )
    return a


def _first_bad(mask: np.ndarray) -> tuple[int, int]:
    flat = int(np.flatnonzero(mask)[0])
    return divmod(flat, mask.shape[1])


def _check_channels(channels, c: int) -> tuple:
    if channels is None:
        return ("value",) if c == 1 else tuple(f"c{k}" for k in range(c))
    names = (channels,) if isinstance(channels, str) else tuple(channels)
    if len(names) != c:
        raise DataError(
            f"channels {list(names)} names {len(names)} channel(s) but values have {c} "
            "column(s); give one name per column",
            "channels",
        )
    for name in names:
        word = isinstance(name, str) and name and not any(ch.isspace() or ch == "," for ch in name)
        if not word or name in ANGLE_COLUMNS or name.startswith("sigma_"):
            raise DataError(
                f"channel name {name!r} is not allowed: a channel is a column of a file, named "
                "by one word without commas, other than the angle columns and sigma_<channel>",
                "channels",
            )
    dupes = sorted({x for x in names if names.count(x) > 1})
    if dupes:
        raise DataError(f"channel names must be unique; {dupes} appear more than once", "channels")
    return names


def _entries_are(n: int) -> str:
    """``"1 entry is"`` or ``"2 entries are"``."""
    return f"{plural(n, 'entry', 'entries')} {'is' if n == 1 else 'are'}"


def _check_sigma(sigma, shape: tuple) -> np.ndarray | None:
    if sigma is None:
        return None
    s = _as_values(sigma, shape[0], "sigma")
    if s.shape[1] == 1 and shape[1] > 1:
        # One sigma per sample, shared by every channel.
        s = np.repeat(s, shape[1], axis=1)
    if s.shape != shape:
        raise DataError(f"sigma has shape {s.shape}; it must match values, {shape}", "sigma")
    bad = ~np.isfinite(s) | (s <= 0)
    if bad.any():
        i, c = _first_bad(bad)
        raise DataError(
            f"sigma must be positive and finite; {_entries_are(int(bad.sum()))} not, "
            f"the first sigma[{i}, {c}] = {float(s[i, c])!r}",
            "sigma",
        )
    return s


def _check_angles(name: str, a, n: int | None, degrees: bool, polar: bool) -> np.ndarray:
    try:
        a = np.asarray(a, dtype=float).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise DataError(f"{name} must be an array of numbers: {exc}", name) from None
    if n is not None and a.size != n:
        raise DataError(f"{name} has {a.size} entries but theta_i has {n}", name)
    bad = ~np.isfinite(a)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise DataError(
            f"{name}[{i}] = {float(a[i])!r} is not finite; "
            f"{_entries_are(int(bad.sum()))} NaN or inf",
            name,
        )
    if polar:
        top = 180.0 if degrees else np.pi
        out = (a < 0) | (a > top)
        if out.any():
            i = int(np.flatnonzero(out)[0])
            unit = "degrees" if degrees else "radians"
            raise DataError(
                f"{name}[{i}] = {float(a[i])!r} is outside [0, {top:g}] {unit}; a polar angle is "
                f"measured from the normal (use phi + 180 for a direction on the other side)",
                name,
            )
    return a


def _validated(n: int, values, channels, sigma) -> tuple:
    """Checked ``(values, sigma, channels)`` for ``n`` direction pairs."""
    if n == 0:
        raise DataError("the data are empty; at least one sample is needed", "values")
    values = _as_values(values, n, "values")
    if values.shape[1] == 0:
        raise DataError("values have no channel; at least one column is needed", "values")
    bad = ~np.isfinite(values)
    if bad.any():
        i, c = _first_bad(bad)
        raise DataError(
            f"values contain {plural(int(bad.sum()), 'non-finite number')} (NaN or inf); "
            f"the first is values[{i}, {c}] = {float(values[i, c])!r}",
            "values",
        )
    channels = _check_channels(channels, values.shape[1])
    return values, _check_sigma(sigma, values.shape), channels
