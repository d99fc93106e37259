"""The CSV format of brdffit (read and write).

The format (DESIGN.md): one header row; columns ``theta_i, phi_i, theta_o,
phi_o`` in degrees (MODELS.md convention), every other numeric column is a
channel (``value``, or ``r,g,b``, or ``550nm``...), except ``sigma_<channel>``
columns, which give that channel's standard deviation per sample. Lines
starting with ``#`` are comments; before the header, the comments
``# source: ...`` and ``# units: ...`` give the source and units of the data.
A column whose every entry is text (a sample label, say) is ignored.

Numbers are written with ``repr``, the shortest text that reads back to the
same double, so that writing and reading again loses nothing.
"""

from __future__ import annotations

import os

import numpy as np

from ..data.measurements import ANGLE_COLUMNS, Measurements
from ..errors import FormatError
from .source import as_source, put_bytes
from .table import from_table

__all__ = ["format_csv", "parse_csv", "read_csv", "write_csv"]


def _header(lines: list, where: str):
    """Metadata comments, the header (names, line number) and the data rows."""
    meta, header, rows, numbers = {}, None, [], []
    for number, raw in enumerate(lines, start=1):
        text = raw.strip()
        if not text:
            continue
        if text.startswith("#"):
            key, sep, value = text[1:].partition(":")
            if header is None and sep and key.strip() in ("source", "units"):
                meta.setdefault(key.strip(), value.strip())
        elif header is None:
            header = ([name.strip() for name in text.split(",")], number)
        else:
            rows.append(text)
            numbers.append(number)
    if header is None:
        raise FormatError(f"{where} has no header row; a CSV file needs one", "header")
    return meta, header, rows, numbers


def parse_csv(text: str, where: str = "<csv text>") -> Measurements:
    """Measurements from the text of a CSV file; ``where`` names it in errors."""
    meta, (names, header_line), rows, lines = _header(text.splitlines(), where)
    source = meta.get("source", os.path.basename(str(where)))
    units = meta.get("units", "1/sr")
    return from_table(where, names, header_line, rows, lines, True, source, units)


def read_csv(source) -> Measurements:
    """Read brdffit CSV from a path, bytes or a binary file object (module docstring)."""
    source = as_source(source)
    return parse_csv(source.text(), source.name)


def format_csv(data: Measurements) -> str:
    """The CSV text of ``data``: angles in degrees, channels, then sigma_<channel>."""
    header = list(ANGLE_COLUMNS) + list(data.channels)
    columns = [np.asarray(a, dtype=float) for a in data.angles(degrees=True)]
    columns.append(data.values)
    if data.sigma is not None:
        header += ["sigma_" + c for c in data.channels]
        columns.append(data.sigma)
    rows = np.column_stack(columns).tolist()
    lines = ["# brdffit measurements: angles in degrees (theta from the normal)"]
    if data.source:
        lines.append("# source: " + " ".join(data.source.split()))
    lines.append("# units: " + " ".join(data.units.split()))
    lines.append(",".join(header))
    lines.extend(",".join(map(repr, row)) for row in rows)
    return "\n".join(lines) + "\n"


def write_csv(target, data: Measurements) -> None:
    """Write ``data`` as brdffit CSV to a path or a binary file object; reading it back
    gives the same values bit for bit."""
    put_bytes(target, format_csv(data).encode("utf-8"))
