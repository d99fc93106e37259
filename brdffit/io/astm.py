"""ASTM E1392 text files (read and write) and pbrt-v2 ``.brdf`` files (read).

ASTM E1392, as in the Cornell gonioreflectometer files: header lines of
``KEY value`` (``SAMPLE_NAME``, ``NUM_POINTS``, ``VARS theta_i,phi_i,theta_s,phi_s,
400nm,...``), blank lines allowed, then one comma-separated row per sample,
angles in radians. ``theta_s, phi_s`` (the scattered direction) are brdffit's
``theta_o, phi_o``; the other VARS are the channels. brdffit writes the same
layout, with two extensions that other readers ignore as unknown keys or
columns: a ``UNITS`` key, and ``sigma_<channel>`` columns when sigma is known.

pbrt-v2 (``src/materials/measured.cpp``, "Irregularly Sampled Isotropic BRDF"):
a stream of numbers where ``#`` starts a comment to the end of the line; the
first number is the count W of wavelengths, then W wavelengths in nm, then
records of 4 + W numbers: ``theta_i, phi_i, theta_o, phi_o`` (radians) and W
BRDF values. pbrt builds directions as ``(sin t cos p, sin t sin p, cos t)``,
the convention of MODELS.md. Records need not follow line breaks.
"""

from __future__ import annotations

import os

import numpy as np

from ..data.measurements import Measurements
from ..errors import FormatError
from .csv_format import build, from_table, read_text

__all__ = ["format_astm", "parse_astm", "parse_pbrt", "read_astm", "read_pbrt", "write_astm"]

#: ASTM names of the angle columns, mapped to brdffit's.
_ASTM_ANGLES = {"theta_s": "theta_o", "phi_s": "phi_o"}


def _unit_is_degrees(angle_unit: str) -> bool:
    if angle_unit not in ("radians", "degrees"):
        raise FormatError(
            f"angle_unit={angle_unit!r} is not known; it must be 'radians' or 'degrees'",
            "angle_unit",
        )
    return angle_unit == "degrees"


def _starts_a_number(text: str) -> bool:
    return text[0].isdigit() or (text[0] in "+-." and len(text) > 1)


def parse_astm(text: str, where: str = "<astm text>", angle_unit: str = "radians"):
    """Measurements from the text of an ASTM E1392 file; ``where`` names it in errors."""
    degrees = _unit_is_degrees(angle_unit)
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


def read_astm(path, angle_unit: str = "radians") -> Measurements:
    """Read an ASTM E1392 file (angles in radians unless ``angle_unit='degrees'``)."""
    return parse_astm(read_text(path), str(path), angle_unit)


def format_astm(data: Measurements) -> str:
    """ASTM E1392 text of ``data``: angles in radians, numbers written with ``repr``."""
    names = ["theta_i", "phi_i", "theta_s", "phi_s", *data.channels]
    columns = [np.asarray(a, dtype=float) for a in data.angles(degrees=False)]
    columns.append(data.values)
    if data.sigma is not None:
        names += ["sigma_" + c for c in data.channels]
        columns.append(data.sigma)
    lines = [
        "SAMPLE_NAME " + " ".join((data.source or "unnamed").split()),
        "MEAS_NAME BRDF",
        "UNITS " + " ".join(data.units.split()),
        f"NUM_POINTS {data.n}",
        "VARS " + ",".join(names),
        "",
    ]
    lines.extend(",".join(map(repr, row)) for row in np.column_stack(columns).tolist())
    return "\n".join(lines) + "\n"


def write_astm(path, data: Measurements) -> None:
    """Write ``data`` as ASTM E1392 text."""
    with open(path, "w", encoding="utf-8", newline="\n") as f:
        f.write(format_astm(data))


def _tokens(text: str) -> tuple:
    """Whitespace-separated tokens outside ``#`` comments, with their line numbers."""
    tokens, lines = [], []
    for number, raw in enumerate(text.splitlines(), start=1):
        words = raw.split("#", 1)[0].split()
        tokens.extend(words)
        lines.extend([number] * len(words))
    return tokens, np.array(lines, dtype=int)


def _numbers(tokens: list, lines: np.ndarray, where: str) -> np.ndarray:
    try:
        numbers = np.array(tokens, dtype=float)
    except ValueError:
        for k, token in enumerate(tokens):
            try:
                float(token)
            except ValueError:
                raise FormatError(
                    f"{where}, line {lines[k]}: {token!r} is not a number", "data"
                ) from None
    bad = ~np.isfinite(numbers)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise FormatError(
            f"{where}, line {lines[k]}: {tokens[k]!r} is not a finite number; "
            f"{int(bad.sum())} numbers are NaN or inf",
            "data",
        )
    return numbers


def parse_pbrt(text: str, where: str = "<pbrt text>") -> Measurements:
    """Measurements from the text of a pbrt-v2 ``.brdf`` file; ``where`` names it in errors."""
    tokens, lines = _tokens(text)
    if not tokens:
        raise FormatError(f"{where} holds no numbers; a pbrt .brdf file starts with W", "data")
    numbers = _numbers(tokens, lines, where)
    w = numbers[0]
    if w != int(w) or not 1 <= w <= len(numbers) - 1:
        raise FormatError(
            f"{where}, line {lines[0]}: the first number, the count of wavelengths, is "
            f"{tokens[0]!r}; it must be a whole number of at least 1",
            "data",
        )
    w = int(w)
    wavelengths, rest = numbers[1 : 1 + w], numbers[1 + w :]
    size = 4 + w
    if rest.size == 0 or rest.size % size:
        raise FormatError(
            f"{where}, line {lines[-1]}: after the {w} wavelengths come {rest.size} numbers, "
            f"not a whole number of records of 4 + {w} = {size} (a truncated file?)",
            "data",
        )
    records = rest.reshape(-1, size)
    record_lines = lines[1 + w :: size]
    channels = [f"{x:g}nm" for x in wavelengths]
    angles = tuple(records[:, j] for j in range(4))
    source = os.path.basename(str(where))
    return build(where, angles, records[:, 4:], channels, None, record_lines, False, source,
                 "1/sr")  # fmt: skip


def read_pbrt(path) -> Measurements:
    """Read a pbrt-v2 irregularly sampled isotropic ``.brdf`` file."""
    return parse_pbrt(read_text(path), str(path))
