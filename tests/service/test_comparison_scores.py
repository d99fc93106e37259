"""A comparison's held-out RMSE is computed once, by the job's worker when its fit is
done, stored, and served by every GET /comparisons/{id} after that.

Before, every poll evaluated every finished model on the held-out samples again
(the page polls a comparison every few hundred milliseconds while it runs).
"""

from __future__ import annotations

import time

import pytest
from service_helpers import WARD_CSV

import brdffit
import brdffit_service.comparisons as comparisons
import brdffit_service.routes.comparisons as comparison_routes


def _finished(client, answer, seconds=60.0) -> dict:
    comparison, deadline = answer.json(), time.monotonic() + seconds
    while not comparison["done"]:
        assert time.monotonic() < deadline, comparison
        time.sleep(0.2)
        comparison = client.get(f"/comparisons/{comparison['id']}").json()
    return comparison


@pytest.fixture()
def counted(monkeypatch):
    """Counts the web process's evaluations of held-out RMSE."""
    calls = []
    real = comparisons.heldout_rmse

    def counting(*args, **kwargs):
        calls.append(args[0])
        return real(*args, **kwargs)

    for module in (comparisons, comparison_routes):
        monkeypatch.setattr(module, "heldout_rmse", counting, raising=False)
    return calls


def test_polling_a_finished_comparison_evaluates_nothing(client, counted):
    files = {"file": ("ward.csv", WARD_CSV.read_bytes())}
    answer = client.post("/comparisons/file", files=files,
                         data={"models": "ward,lambert", "options": '{"seed": 5}'})  # fmt: skip
    assert answer.status_code == 202, answer.text
    first = _finished(client, answer)
    counted.clear()
    polls = [client.get(f"/comparisons/{first['id']}").json() for _ in range(3)]
    assert counted == [], "a poll evaluated the models on the held-out samples again"
    assert all(p["entries"] == first["entries"] for p in polls)
    expected = brdffit.compare(brdffit.read(WARD_CSV), ["ward", "lambert"], test_fraction=0.2,
                               seed=5)  # fmt: skip
    by_model = {e.model: e.heldout_rmse for e in expected.entries}
    for entry in first["entries"]:
        assert entry["status"] == "done"
        assert entry["heldout_rmse"] == pytest.approx(by_model[entry["model"]], rel=1e-6)


def test_a_comparison_its_workers_did_not_score_is_scored_once_on_reading(client, counted):
    """A comparison stored before workers scored their fits (no comparison_jobs rows)."""
    files = {"file": ("ward.csv", WARD_CSV.read_bytes())}
    answer = client.post("/comparisons/file", files=files, data={"models": "lambert"})
    first = _finished(client, answer)
    store = comparisons.ComparisonStore(client.app.state.store.path)
    with store._connect() as db:
        db.execute("DELETE FROM comparison_jobs WHERE comparison_id = ?", (first["id"],))
    counted.clear()
    polls = [client.get(f"/comparisons/{first['id']}").json() for _ in range(3)]
    assert counted == ["lambert"]
    assert all(p["entries"] == first["entries"] for p in polls)
