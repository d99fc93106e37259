"""The CSV format of brdffit (read and write).

The format (DESIGN.md): one header row; columns ``theta_i, phi_i, theta_o,
phi_o`` in degrees (MODELS.md convention), every other numeric column is a
channel (``value``, or ``r,g,b``, or ``550nm``...), except ``sigma_<channel>``
columns, which give that channel's standard deviation per sample. Lines
starting with ``#`` are comments; before the header, the comments
``# source: ...`` and ``# units: ...`` give the source and units of the data,
and ``# angle_unit: radians`` (or ``degrees``; ``# units: radians`` says the
same) the unit of the angles. A column whose every entry is text (a sample
label, say) is ignored.

Files saved by a spreadsheet are read as well: a UTF-8 (or UTF-16) byte order
mark is skipped (:meth:`~brdffit.io.source.Source.text`), and the separator is
the one of comma, semicolon and tab that the header line uses most. With
semicolons or tabs, a comma inside a number is its decimal mark (``0,5``), as
spreadsheets write in many European locales; a number with both a comma and a
point is then refused, naming its line (the point would be a digit grouping).

Angles in degrees that look like radians (every theta within [0, pi/2], every
phi within [-2 pi, 2 pi]) are read as degrees with a note
(:mod:`brdffit.notes`), unless the unit is stated: ``angle_unit=`` of the
reader (``brdffit --angle-unit``), which wins over the file's comment.

Numbers are written with ``repr``, the shortest text that reads back to the
same double, so that writing and reading again loses nothing.
"""

from __future__ import annotations

import os

from ..data.measurements import Measurements
from ..errors import FormatError
from ..notes import note
from .limits import DEFAULT_MAX_SAMPLES, check_samples
from .source import as_source, put_bytes
from .table import SEPARATORS, angle_unit_option, from_table, text_rows

__all__ = ["ANGLE_UNITS", "format_csv", "parse_csv", "read_csv", "write_csv"]

#: The angle units a reader takes, and the words a file's comment may use for them.
ANGLE_UNITS = {"degrees": "degrees", "degree": "degrees", "deg": "degrees",
               "radians": "radians", "radian": "radians", "rad": "radians"}  # fmt: skip


def _separator(line: str) -> str:
    """The separator of a header line: the most frequent of comma, semicolon, tab."""
    counts = {sep: line.count(sep) for sep in SEPARATORS}
    best = max(counts, key=counts.get)
    return best if counts[best] else ","


def _header(lines: list, where: str):
    """Metadata comments, the header (names, line number, separator) and the data rows."""
    meta, header, rows, numbers = {}, None, [], []
    for number, raw in enumerate(lines, start=1):
        text = raw.strip()
        if not text:
            continue
        if text.startswith("#"):
            key, sep, value = text[1:].partition(":")
            key = key.strip().lower()
            if header is None and sep and key in ("source", "units", "angle_unit", "angles"):
                meta.setdefault(key, (value.strip(), number))
        elif header is None:
            sep = _separator(text)
            names = [name.strip().strip('"').strip() for name in text.split(sep)]
            header = (names, number, sep)
        else:
            rows.append(text)
            numbers.append(number)
    if header is None:
        raise FormatError(f"{where} has no header row; a CSV file needs one", "header")
    return meta, header, rows, numbers


def _decimal_commas(rows: list, lines: list, sep: str, where: str) -> list:
    """Rows with decimal commas made points, when the separator is not a comma."""
    if sep == "," or not any("," in row for row in rows):
        return rows
    for row, line in zip(rows, lines):
        for cell in row.split(sep):
            if "," in cell and "." in cell:
                raise FormatError(
                    f"{where}, line {line}: {cell.strip()!r} has both a comma and a point; with "
                    f"{SEPARATORS[sep]}-separated columns a comma is read as the decimal mark, "
                    "so a point cannot be one too (save the file without digit grouping)",
                    "data",
                )
    return [row.replace(",", ".") for row in rows]


def _file_unit(meta: dict, where: str) -> tuple:
    """The angle unit the file's comments state (or None), and the value units."""
    units = meta.get("units", ("1/sr", 0))[0]
    stated = None
    if units.lower() in ANGLE_UNITS:  # "# units: radians" can only mean the angles
        stated, units = meta["units"], "1/sr"
    stated = meta.get("angle_unit") or meta.get("angles") or stated
    if stated is None:
        return None, units
    word, line = stated
    if word.lower() not in ANGLE_UNITS:
        raise FormatError(
            f"{where}, line {line}: the angle unit {word!r} is not known; write "
            "'# angle_unit: degrees' or '# angle_unit: radians'",
            "angle_unit",
        )
    return ANGLE_UNITS[word.lower()], units


def parse_csv(text: str, where: str = "<csv text>", angle_unit: str | None = None,
              max_samples: int | None = DEFAULT_MAX_SAMPLES) -> Measurements:  # fmt: skip
    """Measurements from the text of a CSV file; ``where`` names it in errors.

    ``angle_unit`` ("degrees" or "radians") states the unit of the angles, over
    the file's ``# angle_unit:`` comment; with neither, degrees (module doc).
    """
    angle_unit = angle_unit_option(angle_unit, optional=True)
    meta, (names, header_line, sep), rows, lines = _header(text.splitlines(), where)
    check_samples(len(rows), max_samples, where, "counted in its rows")
    rows = _decimal_commas(rows, lines, sep, where)
    source = meta.get("source", (os.path.basename(str(where)), 0))[0]
    file_unit, units = _file_unit(meta, where)
    if angle_unit and file_unit and angle_unit != file_unit:
        note(f"{where}: the file says its angles are in {file_unit}; read as {angle_unit}, "
             "as angle_unit says", stacklevel=4)  # fmt: skip
    unit = angle_unit or file_unit
    degrees = None if unit is None else unit == "degrees"
    return from_table(where, names, header_line, rows, lines, degrees, source, units, sep)


def read_csv(source, angle_unit: str | None = None,
             max_samples: int | None = DEFAULT_MAX_SAMPLES) -> Measurements:  # fmt: skip
    """Read brdffit CSV from a path, bytes or a binary file object (module docstring)."""
    source = as_source(source)
    return parse_csv(source.text(), source.name, angle_unit, max_samples)


def format_csv(data: Measurements) -> str:
    """The CSV text of ``data``: angles in degrees, channels, then sigma_<channel>."""
    header, rows = text_rows(data, degrees=True)
    lines = ["# brdffit measurements: angles in degrees (theta from the normal)"]
    if data.source:
        lines.append("# source: " + " ".join(data.source.split()))
    lines.append("# units: " + " ".join(data.units.split()))
    lines.append(",".join(header))
    lines.extend(rows)
    return "\n".join(lines) + "\n"


def write_csv(target, data: Measurements) -> None:
    """Write ``data`` as brdffit CSV to a path or a binary file object; reading it back
    gives the same values bit for bit."""
    put_bytes(target, format_csv(data).encode("utf-8"))
