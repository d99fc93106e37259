"""ASTM E1392 text files (read and write).

ASTM E1392, as in the Cornell gonioreflectometer files: header lines of
``KEY value`` (``SAMPLE_NAME``, ``NUM_POINTS``, ``VARS theta_i,phi_i,theta_s,phi_s,
400nm,...``), blank lines allowed, then one comma-separated row per sample,
angles in radians. ``theta_s, phi_s`` (the scattered direction) are brdffit's
``theta_o, phi_o``; the other VARS are the channels. brdffit writes the same
layout, with two extensions that other readers ignore as unknown keys or
columns: a ``UNITS`` key, and ``sigma_<channel>`` columns when sigma is known.
"""

from __future__ import annotations

import os

from ..data.measurements import Measurements
from ..errors import FormatError
from .limits import DEFAULT_MAX_SAMPLES, check_samples
from .source import as_source, put_bytes
from .table import angle_unit_option, from_table, text_rows

__all__ = ["format_astm", "parse_astm", "read_astm", "write_astm"]

#: ASTM names of the angle columns, mapped to brdffit's.
_ASTM_ANGLES = {"theta_s": "theta_o", "phi_s": "phi_o"}


def _starts_a_number(text: str) -> bool:
    return text[0].isdigit() or (text[0] in "+-." and len(text) > 1)


def parse_astm(text: str, where: str = "<astm text>", angle_unit: str = "radians",
               max_samples: int | None = DEFAULT_MAX_SAMPLES):  # fmt: skip
    """Measurements from the text of an ASTM E1392 file; ``where`` names it in errors."""
    degrees = angle_unit_option(angle_unit) == "degrees"
    header, key_lines, rows, lines = {}, {}, [], []
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        if rows or _starts_a_number(line):
            rows.append(line)
            lines.append(number)
            continue
        key, _, value = line.partition(" ")
        header.setdefault(key, value.strip())
        key_lines.setdefault(key, number)
    if "VARS" not in header:
        raise FormatError(
            f"{where} has no VARS line; an ASTM E1392 file names its columns in a line "
            "'VARS theta_i,phi_i,theta_s,phi_s,...' before the data",
            "VARS",
        )
    check_samples(len(rows), max_samples, where, "counted in its rows")
    _check_count(header, key_lines, len(rows), where)
    names = [_ASTM_ANGLES.get(v.strip(), v.strip()) for v in header["VARS"].split(",")]
    source = header.get("SAMPLE_NAME") or os.path.basename(str(where))
    units = header.get("UNITS", "1/sr")
    return from_table(where, names, key_lines["VARS"], rows, lines, degrees, source, units)


def _check_count(header: dict, key_lines: dict, count: int, where: str) -> None:
    if "NUM_POINTS" not in header:
        return
    line = key_lines["NUM_POINTS"]
    try:
        expected = int(header["NUM_POINTS"])
    except ValueError:
        raise FormatError(
            f"{where}, line {line}: NUM_POINTS {header['NUM_POINTS']!r} is not a whole number",
            "NUM_POINTS",
        ) from None
    if expected != count:
        raise FormatError(
            f"{where}, line {line}: NUM_POINTS is {expected} but {count} data rows follow "
            "(a truncated or edited file?)",
            "NUM_POINTS",
        )


def read_astm(source, angle_unit: str = "radians",
              max_samples: int | None = DEFAULT_MAX_SAMPLES) -> Measurements:  # fmt: skip
    """Read ASTM E1392 text from a path, bytes or a binary file object (angles in
    radians unless ``angle_unit='degrees'``)."""
    source = as_source(source)
    return parse_astm(source.text(), source.name, angle_unit, max_samples)


def format_astm(data: Measurements) -> str:
    """ASTM E1392 text of ``data``: angles in radians, numbers written with ``repr``."""
    names, rows = text_rows(data, False, ("theta_i", "phi_i", "theta_s", "phi_s"))
    lines = [
        "SAMPLE_NAME " + " ".join((data.source or "unnamed").split()),
        "MEAS_NAME BRDF",
        "UNITS " + " ".join(data.units.split()),
        f"NUM_POINTS {data.n}",
        "VARS " + ",".join(names),
        "",
    ]
    lines.extend(rows)
    return "\n".join(lines) + "\n"


def write_astm(target, data: Measurements) -> None:
    """Write ``data`` as ASTM E1392 text to a path or a binary file object."""
    put_bytes(target, format_astm(data).encode("utf-8"))
