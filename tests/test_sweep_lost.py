"""sphrom sweep when workers die: a task whose worker process dies is submitted again (a bounded number of
times), then the sweep fails with one line naming the grid point, and the finished entries are kept.

The dying task is the real one (sphrom.sweep.worker.run_entry) behind a wrapper that kills its worker process
(os._exit) while a counter file allows it; the wrapper travels to the workers by value (cloudpickle).  The
scheduler's own rescheduling of a task whose worker died (distributed.scheduler.allowed-failures) is set to 0
here, so each death reaches the client at once as KilledWorker.
"""

import functools
import sys

import cloudpickle
import pytest

from conftest import small_scene
from sphrom.cli import main
from sphrom.sweep import study as study_module
from sphrom.sweep.table import read_results

SPEC = """
title = "lost workers"
scene = "scene.toml"
t_end = 0.2
step = 0.01
probes = [0.25, 0.66]

[grid]
shape = ["sine"]
amplitude = [1e-2]
frequency = [1.0, 2.0, 3.0]
k = [4]
"""

cloudpickle.register_pickle_by_value(sys.modules[__name__])


def dying_task(bundle, entry, counter=None, deaths=1, frequency=2.0):
    """run_entry, but the entry at ``frequency`` kills its worker process the first ``deaths`` times."""
    import os
    from pathlib import Path

    from sphrom.sweep.worker import run_entry
    if entry.frequency == frequency:
        path = Path(counter)
        done = int(path.read_text()) if path.exists() else 0
        if done < deaths:
            path.write_text(str(done + 1))
            os._exit(1)
    return run_entry(bundle, entry)


@pytest.fixture
def spec(tmp_path):
    (tmp_path / "scene.toml").write_text(small_scene("damped_forced", T=0.2, n=32).text)
    (tmp_path / "spec.toml").write_text(SPEC)
    return tmp_path / "spec.toml"


def _sweep(spec, out, monkeypatch, deaths):
    import dask
    import distributed  # noqa: F401  (its config defaults loaded first: the context below must not drop them)

    import sphrom.sweep.worker as worker
    counter = out.parent / "deaths.txt"
    monkeypatch.setattr(worker, "run_entry", functools.partial(dying_task, counter=str(counter), deaths=deaths))
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        code = main(["sweep", str(spec), "--workers", "2", "--out", str(out), "--quiet"])
    return code, int(counter.read_text())


def test_a_task_whose_worker_dies_once_is_retried(spec, tmp_path, monkeypatch, capsys):
    out = tmp_path / "r.h5"
    code, deaths = _sweep(spec, out, monkeypatch, deaths=1)
    captured = capsys.readouterr()
    assert code == 0 and deaths == 1, captured.err
    assert "3 run now (3 ok, 0 failed)" in captured.out, captured.out
    assert "sphrom sweep: failed" not in captured.err
    rows, attrs = read_results(out)
    assert sorted(r["status"] for r in rows) == ["ok"] * 3 and attrs["complete"] == 1


def test_a_task_that_always_kills_its_worker_fails_the_sweep_in_one_line(spec, tmp_path, monkeypatch, capsys):
    out = tmp_path / "r.h5"
    code, deaths = _sweep(spec, out, monkeypatch, deaths=100)
    captured = capsys.readouterr()
    assert code == 3
    assert deaths == study_module.LOST_RETRIES + 1            # bounded: the first run and LOST_RETRIES more
    failed = [line for line in captured.err.splitlines() if line.startswith("sphrom sweep: failed")]
    assert len(failed) == 1, captured.err
    assert "entry 1 (shape = sine" in failed[0] and "frequency = 2.0" in failed[0], failed[0]
    assert f"lost {deaths} times" in failed[0] and "Traceback" not in captured.err
    # the finished entries are kept; the lost one is recorded as failed with the same line
    rows, attrs = read_results(out)
    by_frequency = {r["frequency"]: r for r in rows}
    assert by_frequency[1.0]["status"] == by_frequency[3.0]["status"] == "ok"
    assert by_frequency[2.0]["status"] == "failed" and "entry 1 (" in by_frequency[2.0]["error"]
    assert attrs["ok"] == 2 and attrs["failed"] == 1
