"""pbrt-v2 measured ``.brdf`` text files (read only).

The format, as read by pbrt-v2 (``src/materials/measured.cpp``, "Irregularly
Sampled Isotropic BRDF"): a stream of numbers where ``#`` starts a comment to
the end of the line; the first number is the count W of wavelengths, then W wavelengths in nm, then
records of 4 + W numbers: ``theta_i, phi_i, theta_o, phi_o`` (radians) and W
BRDF values. pbrt builds directions as ``(sin t cos p, sin t sin p, cos t)``,
the convention of MODELS.md. Records need not follow line breaks.
"""

from __future__ import annotations

import os

import numpy as np

from ..data.measurements import Measurements
from ..errors import FormatError
from ..words import plural
from .limits import DEFAULT_MAX_SAMPLES, check_samples
from .source import as_source
from .table import angle_unit_option, build

__all__ = ["parse_pbrt", "read_pbrt"]


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
            f"NaN or inf in {plural(int(bad.sum()), 'number')} in all",
            "data",
        )
    return numbers


def parse_pbrt(text: str, where: str = "<pbrt text>", angle_unit: str = "radians",
               max_samples: int | None = DEFAULT_MAX_SAMPLES) -> Measurements:  # fmt: skip
    """Measurements from the text of a pbrt-v2 ``.brdf`` file; ``where`` names it in errors.

    The format's angles are radians; ``angle_unit="degrees"`` reads a file written
    in degrees.
    """
    angle_unit_option(angle_unit)
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
    check_samples(rest.size // size, max_samples, where, "counted in its records")
    records = rest.reshape(-1, size)
    record_lines = lines[1 + w :: size]
    channels = [f"{x:g}nm" for x in wavelengths]
    angles = tuple(records[:, j] for j in range(4))
    source = os.path.basename(str(where))
    degrees = angle_unit == "degrees"
    return build(where, angles, records[:, 4:], channels, None, record_lines, degrees, source,
                 "1/sr")  # fmt: skip


def read_pbrt(source, angle_unit: str = "radians",
              max_samples: int | None = DEFAULT_MAX_SAMPLES) -> Measurements:  # fmt: skip
    """Read a pbrt-v2 irregularly sampled isotropic ``.brdf`` file from a path, bytes or
    a binary file object (angles in radians unless ``angle_unit='degrees'``)."""
    source = as_source(source)
    return parse_pbrt(source.text(), source.name, angle_unit, max_samples)
