"""Fuzzing every reader with mutated real files (issue 18).

Each readable format's files (small ones written here, the synthetic CSV files of
data_synthetic/, and the real files of ../shared/data when present) are mutated
with a seeded generator: bit flips, bytes overwritten, truncation, and huge
integers written over header fields (binary) or numbers (text). Every outcome
must be a Measurements or a BrdfFitError naming the file, within the sample
limit and without a large allocation (tracemalloc's peak is bounded by a
multiple of what the intact file takes). Deterministic: the seed of each case is
its index.
"""

from __future__ import annotations

import re
import struct
import warnings
from pathlib import Path

import numpy as np
import pytest
from helpers import SHARED_DATA
from io_helpers import named, peak_of, small_files

import brdffit
from brdffit.errors import BrdfFitError

SYNTHETIC = Path(__file__).resolve().parents[2] / "data_synthetic"
LIMIT = 2_000_000  # the service's sample limit
HUGE = (0xFFFF, 0xFFFFFFFF, 2**31 - 1, 2**40, 2**63 - 1, 10**11)
REAL = {
    "garnet_red.astm": ("cornell", 60),
    "acryl_blue.brdf": ("cornell", 40),
    "carpaint_red.mbsdf": ("nvidia", 60),
    "satin_rosaline_rgb.bsdf": ("rgl", 60),
}


def mutate(raw: bytes, rng: np.random.Generator, text: bool) -> tuple[str, bytes]:
    """One seeded mutation of ``raw``: its kind and the mutated bytes."""
    kind = ["flip", "overwrite", "truncate", "huge"][int(rng.integers(4))]
    data = bytearray(raw)
    head = min(len(data), 512)  # header fields sit near the start
    if kind == "flip":
        for _ in range(int(rng.integers(1, 9))):
            where = int(rng.integers(head if rng.random() < 0.7 else len(data)))
            data[where] ^= 1 << int(rng.integers(8))
    elif kind == "overwrite":
        where, size = int(rng.integers(len(data))), int(rng.integers(1, 17))
        data[where : where + size] = bytes(rng.choice([0, 0xFF, 0x7F, 0x80], size).tolist())
    elif kind == "truncate":
        data = data[: int(rng.integers(len(data)))]
    elif text:
        numbers = [m.span() for m in re.finditer(rb"\d+(\.\d+)?", bytes(data[:4096]))]
        start, end = numbers[int(rng.integers(len(numbers)))]
        data[start:end] = str(HUGE[int(rng.integers(len(HUGE)))]).encode()
    else:
        value, fmt = HUGE[int(rng.integers(len(HUGE)))], "<Q"
        fmt = "<I" if value < 2**32 and rng.random() < 0.6 else fmt
        where = int(rng.integers(max(1, head - 8)))
        data[where : where + struct.calcsize(fmt)] = struct.pack(fmt, value)
    return kind, bytes(data)


def read_traced(name: str, raw: bytes):
    """What reading gives (Measurements or the exception) and the traced peak in bytes."""
    source = named(raw, name)

    def read():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return brdffit.read(source, max_samples=LIMIT)

    return peak_of(read)


def cases():
    """(id, file name, bytes or a path, mutations) for every source of files."""
    out = [(f"small-{k}", name, raw, 200 if k != "merl" else 12)
           for k, (name, raw) in small_files().items()]  # fmt: skip
    for name in ("ward.csv", "oren_nayar.csv"):
        out.append((f"synthetic-{name}", name, SYNTHETIC / name, 60))
    for name, (folder, count) in REAL.items():
        out.append((f"real-{name}", name, SHARED_DATA / folder / name, count))
    return out


@pytest.mark.parametrize("name, raw, count", [c[1:] for c in cases()], ids=[c[0] for c in cases()])
def test_mutated_files_give_measurements_or_a_brdffit_error(name, raw, count):
    if isinstance(raw, Path):
        if not raw.exists():
            pytest.skip(f"{raw} is absent: the real measured data live in ../shared/data")
        raw = raw.read_bytes()
    intact, intact_peak = read_traced(name, raw)
    assert isinstance(intact, brdffit.Measurements), repr(intact)
    bound = 3 * intact_peak + 16 * 2**20
    text = name.endswith((".csv", ".astm", ".brdf"))
    unforeseen = []
    for seed in range(count):
        kind, mutated = mutate(raw, np.random.default_rng(seed), text)
        outcome, peak = read_traced(name, mutated)
        where = f"{name} seed {seed} ({kind})"
        if isinstance(outcome, brdffit.Measurements):
            assert outcome.n <= LIMIT, where
        else:
            assert isinstance(outcome, BrdfFitError), f"{where}: {outcome!r}"
            assert name in str(outcome), f"{where}: {outcome}"
            if "reader failed with" in str(outcome):
                unforeseen.append(f"{where}: {outcome}")
        assert peak <= bound, f"{where}: peak {peak / 2**20:.0f} MiB > {bound / 2**20:.0f} MiB"
    assert not unforeseen, "\n".join(unforeseen)
