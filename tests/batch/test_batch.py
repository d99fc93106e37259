"""brdffit.batch and ``brdffit batch`` on a real LocalCluster of worker processes."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

distributed = pytest.importorskip(
    "distributed", reason="Dask distributed is absent: pip install 'brdffit[batch]'"
)

import brdffit  # noqa: E402
from brdffit.batch import fit_many  # noqa: E402
from brdffit.batch.task import run_pair, unwire  # noqa: E402
from brdffit.cli import main  # noqa: E402
from brdffit.cli.batch import read_rows  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
SYNTHETIC = ROOT / "data_synthetic"
FILES = [str(SYNTHETIC / f"{name}.csv") for name in ("ggx", "ward", "lambert", "blinn")]
MODELS = ["lambert", "ggx", "ward"]


def _cluster(n=2):
    return distributed.LocalCluster(
        n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
        dashboard_address="127.0.0.1:0",
    )  # fmt: skip


@pytest.fixture(scope="module")
def client():
    with _cluster() as cluster, distributed.Client(cluster) as c:
        yield c


def _same_fit(a, b):
    assert a.model == b.model and a.n_evals == b.n_evals and a.loss == b.loss
    assert a.params.keys() == b.params.keys()
    for name in a.params:
        np.testing.assert_array_equal(a.params[name], b.params[name])


def test_every_pair_once_and_equal_to_serial_fit(client):
    scattered = brdffit.synthesize("ggx", geometry="hemisphere", n=400, noise=0.01, seed=2)
    sources = [*sorted(map(str, SYNTHETIC.glob("*.csv"))), scattered]
    assert len(sources) > 20
    workers = set(client.run(os.getpid))  # the address of each worker
    rows = list(brdffit.fit_many(sources, MODELS, client=client, seed=5))
    keys = [row.key for row in rows]
    assert len(keys) == len(set(keys)) == len(sources) * len(MODELS)
    for row in rows:
        assert row.ok, row.error
        assert row.worker in workers
        data = scattered if row.source == scattered.source else brdffit.read(row.source)
        _same_fit(row.result, brdffit.fit(data, row.model, seed=5))
        json.dumps(row.to_dict(), allow_nan=False)


def test_same_seed_same_result_on_each_worker(client):
    workers = sorted(client.run(os.getpid))
    assert len(workers) == 2
    answers = []
    for w in workers:
        task = client.submit(run_pair, FILES[0], "ggx", False, 0.2, {"seed": 9}, workers=[w],
                             pure=False)  # fmt: skip
        answers.append(task.result())
    assert [a["worker"] for a in answers] == workers
    _same_fit(unwire(answers[0]["result"]), unwire(answers[1]["result"]))
    assert answers[0]["heldout_rmse"] == answers[1]["heldout_rmse"]
    entry = brdffit.compare(brdffit.read(FILES[0]), ["ggx"], seed=9).entries[0]
    assert answers[0]["heldout_rmse"] == entry.heldout_rmse


def test_a_corrupt_file_is_a_row_with_its_error(client, tmp_path):
    bad = tmp_path / "corrupt.csv"
    bad.write_text("theta_i,phi_i,theta_o,phi_o,value\n10,0,10,180,not-a-number\n")
    rows = list(fit_many([FILES[0], str(bad), FILES[1]], ["lambert", "ward"], client=client))
    assert len(rows) == 6
    failed = [r for r in rows if not r.ok]
    assert {r.key for r in failed} == {(str(bad), "lambert"), (str(bad), "ward")}
    assert all(r.error.type == "FormatError" and "corrupt.csv" in r.error.message for r in failed)
    assert all(r.result is not None for r in rows if r.source != str(bad))


def test_bad_arguments_fail_before_any_work(client):
    with pytest.raises(brdffit.ModelError):
        list(fit_many(FILES, ["ggx", "not_a_model"], client=client))
    with pytest.raises(brdffit.FitError) as err:
        list(fit_many(FILES, ["ggx"], client=client, max_evalz=3))
    assert err.value.field == "max_evalz"
    with pytest.raises(brdffit.FitError) as err:
        list(fit_many(FILES, ["ggx"], client=client, test_fraction=1.5))
    assert err.value.field == "test_fraction"
    with pytest.raises(brdffit.FitError) as err:
        list(fit_many(FILES, ["ggx"], workers=0))
    assert err.value.field == "workers"


def test_posterior_crosses_the_process(client):
    (row,) = fit_many(FILES[:1], ["ward"], client=client, uncertainty=True,
                      posterior_options={"steps": 40, "walkers": 16, "seed": 1})  # fmt: skip
    assert row.ok, row.error
    post = row.result.posterior
    assert post.samples.shape[1] == len(post.names) and post.n_steps == 40
    assert set(post.summary) == set(post.names)


@pytest.fixture(scope="module")
def big_files(tmp_path_factory):
    """Four files of 20 000 samples: fits long enough to be caught in the middle."""
    folder = tmp_path_factory.mktemp("big")
    paths = []
    for i, model in enumerate(["ggx", "ward", "blinn", "cook_torrance"]):
        data = brdffit.synthesize(model, geometry="hemisphere", n=20_000, noise=0.01, seed=i)
        paths.append(str(folder / f"{model}.csv"))
        brdffit.write(paths[-1], data)
    return paths


def test_a_worker_killed_mid_fit_the_pair_reruns_and_appears_once(big_files, monkeypatch):
    options = {"seed": 4, "global_evals": 3000}
    with _cluster() as cluster, distributed.Client(cluster) as c:
        monkeypatch.setenv("DASK_SCHEDULER_ADDRESS", cluster.scheduler_address)
        killed = []

        def kill_a_busy_worker():
            deadline = time.monotonic() + 30
            while time.monotonic() < deadline:
                busy = [w for w, keys in c.processing().items() if keys]
                if busy:
                    time.sleep(0.3)  # inside the fit: reading takes 30 ms, the fit over a second
                    pid = c.run(os.getpid, workers=busy[:1])[busy[0]]
                    killed.append(busy[0])
                    os.kill(pid, signal.SIGKILL)
                    return
                time.sleep(0.02)

        killer = threading.Thread(target=kill_a_busy_worker)
        killer.start()
        rows = list(fit_many(big_files[:1], ["ggx", "cook_torrance"], **options))
        killer.join()
    assert killed, "no worker was ever busy"
    assert sorted(r.key for r in rows) == [(big_files[0], "cook_torrance"), (big_files[0], "ggx")]
    assert all(r.ok for r in rows), [r.error for r in rows]
    assert killed[0] not in {r.worker for r in rows}  # the killed worker answered nothing
    data = brdffit.read(big_files[0])
    for row in rows:
        _same_fit(row.result, brdffit.fit(data, row.model, **options))


def test_a_pair_that_kills_its_workers_too_often_is_an_error_row(big_files):
    import dask

    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        cluster = _cluster()
    with cluster, distributed.Client(cluster) as c:
        rows = []
        pairs = fit_many(big_files[:1], ["ggx", "lambert"], client=c, seed=4, global_evals=3000)
        rows.append(next(pairs))  # lambert takes milliseconds, ggx over a second
        busy = [w for w, keys in c.processing().items() if keys]
        os.kill(c.run(os.getpid, workers=busy)[busy[0]], signal.SIGKILL)
        rows += list(pairs)
    by_model = {r.model: r for r in rows}
    assert len(rows) == 2 and by_model["lambert"].ok
    ggx = by_model["ggx"]
    assert not ggx.ok and ggx.error.type == "KilledWorker" and ggx.result is None


def _cli(*args, **popen):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("DASK_SCHEDULER_ADDRESS", None)
    command = [sys.executable, "-m", "brdffit.cli", "batch", *args]
    return subprocess.Popen(command, env=env, cwd=ROOT, start_new_session=True, **popen)


def _pairs(path):
    return [
        (d["source"], d["model"]) for d in map(json.loads, Path(path).read_text().splitlines())
    ]


def test_resume_after_the_batch_process_is_killed(big_files, tmp_path):
    out = tmp_path / "results.jsonl"
    args = [*big_files, "--models", "ggx,ward,lambert", "--workers", "1", "--out", str(out)]
    proc = _cli(*args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and proc.poll() is None:
            if out.exists() and out.read_text().count("\n") >= 2:
                break
            time.sleep(0.02)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
    finally:
        try:
            os.killpg(proc.pid, signal.SIGKILL)  # its worker processes, if any outlived it
        except ProcessLookupError:
            pass
    before = out.read_bytes()
    first = _pairs(out)
    assert 2 <= len(first) < 12, "the run must be killed in the middle"
    with out.open("ab") as f:
        f.write(b'{"source": "' + big_files[0].encode() + b'", "mod')  # a line cut short
    resumed = _cli(*args, "--resume", stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    stdout, stderr = resumed.communicate(timeout=120)
    assert resumed.returncode == 0, stderr.decode()
    pairs = _pairs(out)
    assert len(pairs) == len(set(pairs)) == 12
    assert set(pairs) == {(f, m) for f in big_files for m in ("ggx", "ward", "lambert")}
    assert out.read_bytes().startswith(before)  # the kept rows were not fitted again
    assert f"{12 - len(first)}/{12 - len(first)} done" in stderr.decode()
    assert "best by BIC" in stdout.decode()


def test_cli_rows_table_and_report(client, tmp_path):
    bad = tmp_path / "corrupt.csv"
    bad.write_bytes(b"\x00\x01garbage")
    out, report = tmp_path / "r.jsonl", tmp_path / "report.md"
    address = client.scheduler.address
    argv = ["batch", *FILES[:2], str(bad), "--models", "lambert,ggx", "--scheduler", address,
            "--out", str(out), "--report", str(report), "--seed", "3"]  # fmt: skip
    assert main(argv) == 1  # some pairs failed: they are rows, the others are there
    lines = out.read_text().splitlines()
    rows = [
        json.loads(line, parse_constant=lambda c: pytest.fail(f"{c} in JSON")) for line in lines
    ]
    assert len(rows) == 6 and sum(not r["ok"] for r in rows) == 2
    ggx = next(r for r in rows if r["source"] == FILES[0] and r["model"] == "ggx")
    serial = brdffit.fit(brdffit.read(FILES[0]), "ggx", seed=3).to_dict()
    serial["seconds"] = ggx["result"]["seconds"]
    assert ggx["result"] == json.loads(json.dumps(serial))
    assert math.isfinite(ggx["heldout_rmse"])
    text = report.read_text()
    assert "| source |" in text and "corrupt.csv" in text
    plots = sorted((tmp_path / "report_plots").glob("*.png"))
    assert len(plots) == 2 and all(p.stat().st_size > 1000 for p in plots)
    assert main(argv) == 2  # the results exist: --resume or remove them
    assert main([*argv, "--resume"]) == 1 and out.read_text().splitlines() == lines


def test_read_rows_refuses_a_damaged_middle_line(tmp_path):
    path = tmp_path / "r.jsonl"
    path.write_text('{"broken\n{"source": "a", "model": "b", "ok": true}\n')
    with pytest.raises(brdffit.BrdfFitError, match="line 1"):
        read_rows(path)


@pytest.mark.parametrize(
    "argv, says",
    [
        (["no_such_*.csv", "--models", "ward"], "matches no file"),
        ([FILES[0], "--models", "wardd"], "wardd"),
        ([FILES[0], "--models", "ward", "--test-fraction", "0.95"], "--test-fraction"),
        ([FILES[0], "--models", "ward", "--workers", "0"], "workers=0"),
    ],
)
def test_cli_bad_arguments_are_one_line_and_exit_2(argv, says, tmp_path, capsys):
    assert main(["batch", *argv, "--out", str(tmp_path / "r.jsonl")]) == 2
    err = capsys.readouterr().err
    assert says in err and "Traceback" not in err


def test_a_row_read_back_keeps_the_whole_result(tmp_path):
    # A resumed batch rebuilds its rows from the file: every field of the fit must survive.
    from brdffit.batch import BatchRow

    data = brdffit.read(FILES[1])
    result = brdffit.fit(data, "ward", seed=1)
    assert result.noise is not None and result.misfit is not None
    row = BatchRow(FILES[1], "ward", result, seconds=1.5, heldout_rmse=float("nan"))
    line = json.dumps(row.to_dict(), allow_nan=False)
    back = BatchRow.from_dict(json.loads(line))
    assert back.heldout_rmse is None and back.key == row.key
    assert back.result.to_dict() == json.loads(json.dumps(result.to_dict()))
