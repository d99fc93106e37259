"""The restarts' distinct starting points (engine._distinct_starts), vectorised for
issue 13, choose what the plain loop over the sorted history chose."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from brdffit.fitting import engine


def _loop(search, count, exclude):
    """The choice as a loop: in the order of the losses, each point at least 0.1 of
    the box from every point excluded or chosen before it."""
    p = search.problem
    width = np.where(p.upper > p.lower, p.upper - p.lower, 1.0)
    chosen, out = list(exclude), []
    for _, x in sorted(search.history, key=lambda t: t[0]):
        if len(out) >= count:
            break
        if all(np.max(np.abs((x - c) / width)) > 0.1 for c in chosen):
            chosen.append(x)
            out.append(x)
    return out


def test_distinct_starts_choose_what_the_loop_chooses():
    rng = np.random.default_rng(0)
    chose_some = 0
    for _ in range(500):
        d = int(rng.integers(1, 4))
        upper = np.where(rng.random(d) < 0.2, 0.0, 1.0)  # a zero-width range too
        problem = SimpleNamespace(lower=np.zeros(d), upper=upper)
        # Tied losses (whole numbers) test the order among equals.
        history = [(float(rng.integers(0, 5)), rng.random(d) * 0.4)
                   for _ in range(int(rng.integers(0, 40)))]  # fmt: skip
        search = SimpleNamespace(problem=problem, history=history)
        exclude = [rng.random(d) * 0.4 for _ in range(int(rng.integers(0, 3)))]
        count = int(rng.integers(0, 4))
        expected = _loop(search, count, exclude)
        got = engine._distinct_starts(search, count, exclude)
        assert len(got) == len(expected)
        assert all(a is b for a, b in zip(got, expected))
        chose_some += len(got) >= 2
    assert chose_some > 50
