"""Line-numbered tables of numbers, shared by the text formats (CSV, ASTM, pbrt).

A text reader finds its header and its data lines; this module turns
comma-separated rows into a float table (:func:`number_table`), checks the
header's columns and the numbers (:func:`from_table`), and builds
:class:`~brdffit.data.measurements.Measurements` from four angle columns
(:func:`build`). Every error is a FormatError naming the file (``where``), the
line and, where there is one, the column. The writers of CSV and ASTM lay out
their rows with :func:`text_rows`.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..data.angle_units import radians_note, radians_suspected
from ..data.measurements import ANGLE_COLUMNS, Measurements
from ..errors import DataError, FormatError
from ..notes import note
from ..words import plural

__all__ = [
    "SEPARATORS",
    "angle_unit_option",
    "build",
    "from_table",
    "number_table",
    "require_finite",
    "text_rows",
]

#: The column separators a table may use, with the names messages give them.
SEPARATORS = {",": "comma", ";": "semicolon", "\t": "tab"}

#: How a user states the angle unit, for the note that angles look like radians.
STATE_UNIT = (
    "read(..., angle_unit='radians'), brdffit fit --angle-unit radians, or a line "
    "'# angle_unit: radians' before the CSV header"
)


def number_table(rows: list, lines: list, names: list, where: str, sep: str = ",") -> tuple:
    """Split rows on ``sep`` and convert them to a float table, naming any bad place.

    ``rows`` are the data lines, ``lines`` their 1-based line numbers in the
    file ``where``. Returns ``(table, text_columns)``: a column whose every
    entry is text (not an angle or sigma column) is listed in ``text_columns``
    and holds NaN in the table; a number column with text in it is an error at
    the first such line, as is a row with the wrong number of fields.
    """
    try:
        with warnings.catch_warnings():
            # loadtxt warns instead of failing on some malformed input; the slow path names it.
            warnings.simplefilter("error")
            table = np.loadtxt(rows, delimiter=sep, ndmin=2, dtype=float, comments=None)
        if table.shape[1] == len(names):
            return table, []
    except (ValueError, UserWarning):
        pass
    fields = [row.split(sep) for row in rows]
    for line, row in zip(lines, fields):
        if len(row) != len(names):
            raise FormatError(
                f"{where}, line {line}: {len(row)} {SEPARATORS.get(sep, repr(sep))}-separated "
                f"fields where the header names {len(names)} ({', '.join(names)})",
                "data",
            )
    columns = [np.full(len(rows), np.nan) for _ in names]
    text_columns = []
    for j, name in enumerate(names):
        cells = [row[j] for row in fields]
        try:
            columns[j] = np.array(cells, dtype=float)
        except ValueError:
            bad = [k for k, cell in enumerate(cells) if not _is_number(cell)]
            if len(bad) < len(cells) or name in ANGLE_COLUMNS or name.startswith("sigma_"):
                k = bad[0]
                raise FormatError(
                    f"{where}, line {lines[k]}, column {name}: {cells[k].strip()!r} is not a "
                    "number",
                    name,
                ) from None
            text_columns.append(name)
    return np.column_stack(columns), text_columns


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def angle_unit_option(angle_unit, optional: bool = False) -> str | None:
    """The readers' option ``angle_unit`` checked: "degrees" or "radians" (or None,
    when ``optional``: the CSV reader then reads the unit from the file)."""
    if angle_unit is None and optional:
        return None
    if angle_unit not in ("degrees", "radians"):
        raise FormatError(
            f"angle_unit={angle_unit!r} is not known; it must be 'degrees' or 'radians'",
            "angle_unit",
        )
    return angle_unit


def require_finite(table: np.ndarray, names: list, lines: list, where: str) -> None:
    """FormatError at the first NaN or inf of ``table``, naming line and column."""
    bad = ~np.isfinite(table)
    if bad.any():
        k, j = divmod(int(np.flatnonzero(bad)[0]), table.shape[1])
        raise FormatError(
            f"{where}, line {lines[k]}, column {names[j]}: {float(table[k, j])!r} is not a finite "
            f"number; NaN or inf in {plural(int(bad.sum()), 'entry', 'entries')} in all",
            names[j],
        )


def build(where, angles, values, channels, sigma, lines, degrees, source, units):
    """Measurements from four angle columns, with file-and-line errors for bad angles.

    ``degrees`` None reads degrees that nobody stated, and notes when they look
    like radians (:func:`~brdffit.data.measurements.radians_suspected`).
    """
    if degrees is None:
        if radians_suspected(*angles):
            largest = float(max(np.max(angles[0]), np.max(angles[2])))
            note(radians_note(where, largest, STATE_UNIT), stacklevel=6)
        degrees = True
    top = 180.0 if degrees else np.pi
    for name, column in zip(ANGLE_COLUMNS, angles):
        if name.startswith("theta"):
            out = (column < 0) | (column > top)
            if out.any():
                k = int(np.flatnonzero(out)[0])
                unit = "degrees" if degrees else "radians"
                hint = "" if degrees else "; read a file in degrees with angle_unit='degrees'"
                raise FormatError(
                    f"{where}, line {lines[k]}, column {name}: {float(column[k])!r} is outside "
                    f"[0, {top:g}] {unit}, the range of a polar angle{hint}",
                    name,
                )
    try:
        return Measurements.from_angles(
            *angles, values, channels=channels, sigma=sigma, degrees=degrees,
            source=source, units=units,
        )  # fmt: skip
    except DataError as exc:
        raise FormatError(f"{where}: {exc}", exc.field) from None


def _columns(names: list, line: int, where: str, sep: str = ","):
    """Indices of the angles, the channels and the sigma columns, checked."""
    problems = []
    if any(not name for name in names):
        problems.append("a column has an empty name")
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        problems.append(f"columns {dupes} appear more than once")
    missing = [n for n in ANGLE_COLUMNS if n not in names]
    if missing:
        problems.append(f"the angle column(s) {', '.join(missing)} are missing")
    channels = [n for n in names if n not in ANGLE_COLUMNS and not n.startswith("sigma_")]
    orphans = [n for n in names if n.startswith("sigma_") and n[6:] not in channels]
    if orphans:
        problems.append(f"{', '.join(orphans)} name(s) no channel")
    if problems:
        split = f"split on {SEPARATORS.get(sep, repr(sep))}s, it names {', '.join(names)!r}"
        if len(names) == 1:
            split = "it has no comma, semicolon or tab between column names"
        raise FormatError(
            f"{where}, line {line}: bad header ({'; '.join(problems)}; {split}); it must name "
            f"{', '.join(ANGLE_COLUMNS)}, the channels, and optionally sigma_<channel>",
            "header",
        )
    return channels


def from_table(where, names, header_line, rows, lines, degrees, source, units,
               sep=",") -> Measurements:  # fmt: skip
    """Measurements from named rows separated by ``sep`` (CSV and ASTM share this)."""
    channels = _columns(names, header_line, where, sep)
    if not rows:
        raise FormatError(f"{where} has a header but no data rows", "data")
    table, text_columns = number_table(rows, lines, names, where, sep)
    channels = [n for n in channels if n not in text_columns]
    if not channels:
        raise FormatError(f"{where}, line {header_line}: no numeric channel column", "header")
    with_sigma = [n for n in channels if "sigma_" + n in names]
    if with_sigma and len(with_sigma) != len(channels):
        without = [n for n in channels if n not in with_sigma]
        raise FormatError(
            f"{where}, line {header_line}: sigma is given for {', '.join(with_sigma)} but "
            f"not for {', '.join(without)}; give sigma for every channel or for none",
            "header",
        )
    order = [*ANGLE_COLUMNS, *channels, *("sigma_" + n for n in with_sigma)]
    table = table[:, [names.index(n) for n in order]]
    require_finite(table, order, lines, where)
    k = len(channels)
    sigma = table[:, 4 + k :] if with_sigma else None
    angles = tuple(table[:, j] for j in range(4))
    values = table[:, 4 : 4 + k]
    return build(where, angles, values, channels, sigma, lines, degrees, source, units)


def text_rows(data: Measurements, degrees: bool, angle_names=ANGLE_COLUMNS) -> tuple:
    """``(names, rows)`` of ``data`` for a text writer: the column names (angles,
    channels, then sigma_<channel>) and one comma-separated line per sample, each
    number written with ``repr`` so that it reads back bit for bit."""
    names = [*angle_names, *data.channels]
    columns = [np.asarray(a, dtype=float) for a in data.angles(degrees=degrees)]
    columns.append(data.values)
    if data.sigma is not None:
        names += ["sigma_" + c for c in data.channels]
        columns.append(data.sigma)
    return names, [",".join(map(repr, row)) for row in np.column_stack(columns).tolist()]
