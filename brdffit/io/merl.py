"""The MERL BRDF binary format (Matusik et al. 2003, "A data-driven reflectance model").

Layout, as read by MERL's reference reader ``BRDFRead.cpp`` (``read_brdf``,
``lookup_brdf_val``, ``std_coords_to_half_diff_coords``; checked in its copies
inside public renderers, in Dupuy's ``dj_brdf.h`` and in the Python port
``fastmerl.py``):

- a header of three int32 dimensions, normally ``90 90 180``; the reference
  only checks that their product is ``90 * 90 * 360 / 2 = 1 458 000``, and so
  does this reader (the layout below is fixed whatever their order);
- then ``3 * 1 458 000`` doubles, channel-major (all red, then green, then
  blue), each channel indexed
  ``phi_d_index + 180 * (theta_d_index + 90 * theta_h_index)``;
- both little-endian (the files were written by ``fwrite`` on x86 and every
  reader we checked reads them natively on x86; this module says ``<i4`` and
  ``<f8`` explicitly so that it also works on a big-endian machine);
- stored values times the channel scale ``(1, 1.15, 1.66) / 1500`` are the BRDF
  in 1/sr (``RED_SCALE``, ``GREEN_SCALE``, ``BLUE_SCALE``);
- a negative stored value marks a cell without a measurement (the reference
  prints "Below horizon." when any channel is negative): such cells are dropped.

Indices (reference, truncation towards zero, clamped to the table):

- ``theta_h``: ``floor(sqrt(theta_h / (pi/2)) * 90)``, non-linear so that the
  specular peak near ``theta_h = 0`` gets more cells; ``theta_h <= 0`` is 0;
- ``theta_d``: ``floor(theta_d / (pi/2) * 90)``;
- ``phi_d``: ``phi_d + pi`` when negative (reciprocity: the BRDF is unchanged
  under ``phi_d -> phi_d + pi``, which swaps the two directions), then
  ``floor(phi_d / pi * 180)``, so ``phi_d`` is in ``[0, pi)``.

Cell centre vs cell edge: the reference looks a direction up by truncation, so
index ``i`` holds every angle of ``[edge_i, edge_{i+1})``. Some ports
(``fastmerl.py``) give a cell the angle of its lower edge; this module gives it
the centre in index space, ``theta_h = ((i + 1/2) / 90)^2 pi/2``,
``theta_d = (j + 1/2) / 90 * pi/2``, ``phi_d = (k + 1/2) / 180 * pi``, because
the reference lookup of the centre returns that same cell (an edge angle can
round into the previous cell) and the centre halves the largest angular error.

Half/difference angles to directions (the inverse of
``std_coords_to_half_diff_coords``, which rotates ``wi`` by ``-phi_h`` about N and
then by ``-theta_h`` about B = y): with ``phi_h = 0`` (isotropy) and
``d = (sin td cos pd, sin td sin pd, cos td)``, ``wi = R_y(theta_h) d`` and
``wo = R_y(theta_h) (-d_x, -d_y, d_z)`` (the mirror of ``wi`` about
``H = (sin theta_h, 0, cos theta_h)``), where ``R_y(a)`` maps
``(x, y, z)`` to ``(x cos a + z sin a, y, z cos a - x sin a)``. A cell is used
when both directions of its centre are above the horizon.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..errors import DataError, FormatError
from ..words import plural
from .limits import DEFAULT_MAX_SAMPLES, check_samples
from .source import as_source, put_bytes

__all__ = [
    "CHANNELS",
    "RES_PHI_D",
    "RES_THETA_D",
    "RES_THETA_H",
    "SCALE",
    "MerlSamples",
    "cell_indices",
    "grid_directions",
    "half_diff_to_directions",
    "merl_table",
    "read_merl",
    "read_merl_arrays",
    "write_merl",
    "write_merl_table",
]

RES_THETA_H = 90
RES_THETA_D = 90
RES_PHI_D = 180  # 360 / 2: reciprocity folds phi_d into [0, pi)
N_CELLS = RES_THETA_H * RES_THETA_D * RES_PHI_D
SCALE = (1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0)
CHANNELS = ("r", "g", "b")
HEADER_BYTES = 12
DATA_BYTES = 3 * N_CELLS * 8
INVALID = -1.0


class MerlSamples(NamedTuple):
    """The valid cells of a MERL file, as plain arrays."""

    wi: np.ndarray  #: (N, 3) directions towards the light, cell centres
    wo: np.ndarray  #: (N, 3) directions towards the viewer
    values: np.ndarray  #: (N, 3) BRDF in 1/sr (stored value times SCALE)
    n_cells: int  #: cells looked at (after subsampling)
    n_negative: int  #: cells dropped because a channel is negative (no measurement)
    n_below_horizon: int  #: cells dropped because a direction of the centre is below it


def _check_step(step, name: str) -> int:
    if step is None:
        return 1
    if isinstance(step, bool) or not isinstance(step, (int, np.integer)) or step < 1:
        raise DataError(f"{name}={step!r} is not allowed; it must be a whole number >= 1", name)
    return int(step)


def _centre_angles(step: int):
    """Cell-centre angles of the kept indices (every ``step``-th from 0), as 3-D grids."""
    i = np.arange(0, RES_THETA_H, step) + 0.5
    j = np.arange(0, RES_THETA_D, step) + 0.5
    k = np.arange(0, RES_PHI_D, step) + 0.5
    theta_h = (i / RES_THETA_H) ** 2 * (math.pi / 2)
    theta_d = j / RES_THETA_D * (math.pi / 2)
    phi_d = k / RES_PHI_D * math.pi
    return theta_h[:, None, None], theta_d[None, :, None], phi_d[None, None, :]


def half_diff_to_directions(theta_h, theta_d, phi_d) -> tuple[np.ndarray, np.ndarray]:
    """Directions ``(wi, wo)`` of half/difference angles with ``phi_h = 0`` (module doc)."""
    theta_h, theta_d, phi_d = np.broadcast_arrays(theta_h, theta_d, phi_d)
    st, ct = np.sin(theta_d), np.cos(theta_d)
    dx, dy, dz = st * np.cos(phi_d), st * np.sin(phi_d), ct
    sh, ch = np.sin(theta_h), np.cos(theta_h)
    wi = np.stack([dx * ch + dz * sh, dy, dz * ch - dx * sh], axis=-1)
    wo = np.stack([-dx * ch + dz * sh, -dy, dz * ch + dx * sh], axis=-1)
    return wi, wo


def _horizon_mask(step: int) -> np.ndarray:
    """Cells whose two centre directions are both strictly above the horizon."""
    theta_h, theta_d, phi_d = _centre_angles(step)
    a = np.cos(theta_h) * np.cos(theta_d)
    b = np.sin(theta_h) * np.sin(theta_d) * np.cos(phi_d)
    return (a - b > 0.0) & (a + b > 0.0)


def _directions_of(mask: np.ndarray, step: int) -> tuple[np.ndarray, np.ndarray]:
    """Centre directions of the cells selected by a boolean mask, in C order."""
    theta_h, theta_d, phi_d = _centre_angles(step)
    i, j, k = np.nonzero(mask)
    return half_diff_to_directions(theta_h[i, 0, 0], theta_d[0, j, 0], phi_d[0, 0, k])


def grid_directions(step: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Centre directions of every usable MERL cell, keeping every ``step``-th index per axis.

    Returns ``(wi, wo)``, each (N, 3), in the order :func:`read_merl` returns the
    cells of a file filled everywhere (C order over ``theta_h, theta_d, phi_d``).
    """
    step = _check_step(step, "step")
    return _directions_of(_horizon_mask(step), step)


def cell_indices(wi, wo) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The reference's ``(theta_h, theta_d, phi_d)`` indices of direction pairs.

    Follows ``std_coords_to_half_diff_coords`` and the three index functions of
    ``BRDFRead.cpp``; the polar angles come from ``atan2`` rather than ``acos``
    so that angles near 0 (the specular peak) keep their precision.
    """
    wi = np.asarray(wi, dtype=float)
    wo = np.asarray(wo, dtype=float)
    h = wi + wo
    h = h / np.linalg.norm(h, axis=1)[:, None]
    theta_h = np.arctan2(np.hypot(h[:, 0], h[:, 1]), h[:, 2])
    phi_h = np.arctan2(h[:, 1], h[:, 0])
    # rotate wi by -phi_h about N, then by -theta_h about B
    c, s = np.cos(phi_h), np.sin(phi_h)
    tx, ty, tz = c * wi[:, 0] + s * wi[:, 1], c * wi[:, 1] - s * wi[:, 0], wi[:, 2]
    c, s = np.cos(theta_h), np.sin(theta_h)
    dx, dy, dz = tx * c - tz * s, ty, tz * c + tx * s
    theta_d = np.arctan2(np.hypot(dx, dy), dz)
    phi_d = np.arctan2(dy, dx)
    phi_d = np.where(phi_d < 0.0, phi_d + math.pi, phi_d)
    i = np.floor(np.sqrt(np.maximum(theta_h, 0.0) / (math.pi / 2)) * RES_THETA_H)
    j = np.floor(theta_d / (math.pi / 2) * RES_THETA_D)
    k = np.floor(phi_d / math.pi * RES_PHI_D)
    return (
        np.clip(i, 0, RES_THETA_H - 1).astype(np.intp),
        np.clip(j, 0, RES_THETA_D - 1).astype(np.intp),
        np.clip(k, 0, RES_PHI_D - 1).astype(np.intp),
    )


# ------------------------------------------------------------------ reading
def _read_table(raw: bytes, path: str) -> np.ndarray:
    """The stored doubles as a (3, 90, 90, 180) array, after checking header and size."""
    size = len(raw)
    if size < HEADER_BYTES:
        raise FormatError(
            f"{path}: the file has {size} bytes; a MERL file starts with a "
            f"{HEADER_BYTES}-byte header of three int32 dimensions at byte 0",
            "source",
        )
    dims = np.frombuffer(raw, dtype="<i4", count=3).tolist()
    if min(dims) <= 0 or math.prod(dims) != N_CELLS:
        raise FormatError(
            f"{path}: the dimensions {dims} at byte 0 multiply to {math.prod(dims)}; "
            f"a MERL table needs {RES_THETA_H} x {RES_THETA_D} x {RES_PHI_D} = {N_CELLS} "
            "cells (a table over the full phi_d range of 360 is not this format)",
            "source",
        )
    expected = HEADER_BYTES + DATA_BYTES
    if size != expected:
        what = "is truncated: it ends" if size < expected else "has extra data: it ends"
        raise FormatError(
            f"{path} {what} at byte {size}, but the header's 3 x {N_CELLS} doubles "
            f"from byte {HEADER_BYTES} end at byte {expected}",
            "source",
        )
    table = np.frombuffer(raw, dtype="<f8", count=3 * N_CELLS, offset=HEADER_BYTES)
    if not np.isfinite(table).all():
        first = int(np.flatnonzero(~np.isfinite(table))[0])
        raise FormatError(
            f"{path}: the value {table[first]} at byte {HEADER_BYTES + 8 * first} is not "
            "finite; MERL values are finite, negative where a cell has no measurement",
            "source",
        )
    return table.reshape(3, RES_THETA_H, RES_THETA_D, RES_PHI_D)


def read_merl_arrays(source, subsample: int | None = None,
                     max_samples: int | None = DEFAULT_MAX_SAMPLES) -> MerlSamples:  # fmt: skip
    """Read a MERL ``.binary`` file into arrays of its valid cells.

    Parameters
    ----------
    source : str, Path, bytes or binary file object
    subsample : int, optional
        Keep every ``subsample``-th cell along each of the three axes, starting
        at index 0 (so the cells nearest the specular peak are kept): about
        ``1 / subsample^3`` of the cells, the same cells as
        ``grid_directions(subsample)``. None or 1 keeps them all.
    max_samples : int, optional
        The most cells to keep (:mod:`brdffit.io.limits`), checked before the
        directions are built.

    Notes
    -----
    A full file (35 MB) gives about 1.1 million cells; reading it takes about
    1.7 s and peaks at about 225 MB above the interpreter's own memory
    (measured with ``tracemalloc`` and ``ru_maxrss``).
    """
    step = _check_step(subsample, "subsample")
    source = as_source(source)
    table = _read_table(source.read(), source.name)[:, ::step, ::step, ::step]
    negative = (table < 0.0).any(axis=0)
    above = _horizon_mask(step)
    keep = above & ~negative
    kept = int(keep.sum())
    if kept == 0:
        raise FormatError(
            f"{source.name}: no cell holds a measurement: of the {negative.size} cells looked "
            f"at, {int(negative.sum())} are negative (no measurement) and the others lie "
            "below the horizon",
            "source",
        )
    check_samples(kept, max_samples, source.name, "its measured cells",
                  "; read it with a larger subsample")  # fmt: skip
    wi, wo = _directions_of(keep, step)
    values = np.empty((wi.shape[0], 3))
    for c in range(3):
        values[:, c] = table[c][keep] * SCALE[c]
    return MerlSamples(
        wi,
        wo,
        values,
        n_cells=int(negative.size),
        n_negative=int(negative.sum()),
        n_below_horizon=int((~above & ~negative).sum()),
    )


def read_merl(source, subsample: int | None = None,
              max_samples: int | None = DEFAULT_MAX_SAMPLES):  # fmt: skip
    """Read a MERL file as :class:`~brdffit.data.measurements.Measurements` (channels r, g, b).

    See :func:`read_merl_arrays` for ``subsample``; cells without a measurement
    (negative) and cells whose centre has a direction below the horizon are dropped.
    """
    from ..data.measurements import Measurements

    source = as_source(source)
    s = read_merl_arrays(source, subsample, max_samples)
    return Measurements(s.wi, s.wo, s.values, channels=CHANNELS, source=source.name, units="1/sr")


# ------------------------------------------------------------------ writing
def merl_table(wi, wo, values) -> np.ndarray:
    """Bin RGB samples into the stored (3, 90, 90, 180) table; empty cells are -1.

    Each sample goes to the cell the reference lookup gives its directions; the
    stored value is the mean of the samples of a cell divided by the channel
    scale. Samples away from a cell centre are thus attributed to the centre.
    """
    values = np.asarray(values, dtype=float)
    if values.ndim != 2 or values.shape[1] != 3:
        raise DataError(
            f"values have shape {values.shape}; the MERL format stores exactly 3 channels "
            "(r, g, b), so it needs shape (N, 3)",
            "values",
        )
    if (values < 0).any():
        first = int(np.flatnonzero((values < 0).any(axis=1))[0])
        raise DataError(
            f"values[{first}] = {values[first].tolist()} is negative; the MERL format marks "
            "cells without a measurement by negative values, so it cannot store them",
            "values",
        )
    wi = np.asarray(wi, dtype=float)
    wo = np.asarray(wo, dtype=float)
    below = (wi[:, 2] <= 0) | (wo[:, 2] <= 0)
    if below.any():
        first = int(np.flatnonzero(below)[0])
        raise DataError(
            f"sample {first} has a direction at or below the horizon (wi = "
            f"{wi[first].tolist()}, wo = {wo[first].tolist()}); MERL cells lie above it",
            "wi",
        )
    i, j, k = cell_indices(wi, wo)
    flat = np.ravel_multi_index((i, j, k), (RES_THETA_H, RES_THETA_D, RES_PHI_D))
    counts = np.bincount(flat, minlength=N_CELLS)
    filled = counts > 0
    table = np.full((3, N_CELLS), INVALID)
    for c in range(3):
        sums = np.bincount(flat, weights=values[:, c], minlength=N_CELLS)
        table[c, filled] = sums[filled] / counts[filled] / SCALE[c]
    return table.reshape(3, RES_THETA_H, RES_THETA_D, RES_PHI_D)


def write_merl_table(target, table: np.ndarray) -> None:
    """Write a stored (3, 90, 90, 180) table with its header, little-endian, to a path
    or a binary file object."""
    table = np.asarray(table, dtype="<f8")
    if table.shape != (3, RES_THETA_H, RES_THETA_D, RES_PHI_D):
        raise DataError(
            f"a MERL table has shape (3, {RES_THETA_H}, {RES_THETA_D}, {RES_PHI_D}), "
            f"not {table.shape}",
            "table",
        )
    header = np.array([RES_THETA_H, RES_THETA_D, RES_PHI_D], dtype="<i4")
    put_bytes(target, header.tobytes() + table.tobytes())


def write_merl(target, data) -> None:
    """Write 3-channel measurements on MERL cells as a full MERL file.

    Samples are binned with :func:`merl_table` (the mean of a cell's samples);
    cells without a sample are written as -1 and dropped again on reading.
    Raises DataError when ``data`` has not 3 channels, has negative values or a
    direction below the horizon.
    """
    values = np.asarray(data.values, dtype=float)
    if values.ndim != 2 or values.shape[1] != 3:
        names = ", ".join(getattr(data, "channels", ()) or ())
        raise DataError(
            f"data has {plural(values.shape[1] if values.ndim == 2 else 1, 'channel')} ({names}); "
            "the MERL format stores exactly 3 (r, g, b)",
            "channels",
        )
    write_merl_table(target, merl_table(data.wi, data.wo, values))
