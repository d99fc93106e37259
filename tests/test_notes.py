"""Notes about data (brdffit.notes): warned, and collected per thread where asked."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from brdffit import Measurements
from brdffit.notes import collecting, note


def test_a_note_warns_and_is_collected_inside_the_block_only():
    with pytest.warns(UserWarning, match="first"), collecting() as inside:
        note("first")
    with pytest.warns(UserWarning, match="second"):
        note("second")
    assert inside == ["first"]


def test_nested_blocks_collect_their_own():
    with pytest.warns(UserWarning), collecting() as outer:
        note("a")
        with collecting() as inner:
            note("b")
        note("c")
    assert outer == ["a", "c"] and inner == ["b"]


def test_threads_collecting_at_once_keep_their_own_notes():
    """Two threads inside collecting() at the same time (a barrier holds both there),
    each making notes: each list holds its own thread's notes and no other's."""
    barrier = threading.Barrier(2)
    got: dict[str, list[str]] = {}

    def work(name: str):
        with collecting() as mine:
            barrier.wait()
            for k in range(50):
                note(f"{name} {k}")
            barrier.wait()
        got[name] = mine

    with pytest.warns(UserWarning):
        threads = [threading.Thread(target=work, args=(n,)) for n in ("left", "right")]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    assert got["left"] == [f"left {k}" for k in range(50)]
    assert got["right"] == [f"right {k}" for k in range(50)]


def test_negative_values_are_a_note_naming_the_source():
    wi = np.array([[0.0, 0.0, 1.0]] * 3)
    with pytest.warns(UserWarning), collecting() as notes:
        Measurements(wi, wi, [0.1, -0.2, -0.3], source="lab.csv")
    assert notes == [
        "lab.csv: 2 of 3 values are negative (measurement noise); they are kept and "
        "counted, and no model can reach them"
    ]
