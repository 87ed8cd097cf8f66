"""sphrom sweep: a tiny study on a LocalCluster of 2 workers, failures
recorded, resume, FMU once per worker, agreement with a direct FMU run and
with an independent full SPH comparison, bad specs.

The study: the damped_forced scene shrunk to N = 32, T = 0.5; d in {5, 10}
(two FMUs: ``parametric = false``, the per-value path), F in {1, 3} Hz, two shapes, one of which sends the FMU into a
runaway at F = 3 (the deliberately failing entries, one per FMU); the full
SPH is run for the sine at F = 1.
"""

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from conftest import small_scene
from sphrom.cli import main
from sphrom.scene import derive_scene
from sphrom.sweep.spec import load_spec, parse_spec
from sphrom.sweep.table import read_results

FAILING = "A*sin(2*pi*F*t)*(1 + 1e300*(F > 2))"
SPEC = f"""
title = "tiny"
scene = "scene.toml"
t_end = 0.5
step = 0.01
probes = [0.25, 0.66]
compare_sph = {{ shape = ["sine"], frequency = [1.0] }}
parametric = false

[grid]
shape = ["sine", "{FAILING}"]
amplitude = [1e-2]
frequency = [1.0, 3.0]
d = [5.0, 10.0]
k = [4]
"""


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    folder = tmp_path_factory.mktemp("sweep")
    (folder / "scene.toml").write_text(small_scene("damped_forced", T=0.5, n=32).text)
    (folder / "spec.toml").write_text(SPEC)
    return folder


@pytest.fixture(scope="module")
def cluster():
    """An existing cluster (2 worker processes) for the --scheduler path."""
    import logging

    from distributed import Client, LocalCluster
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=logging.ERROR) as cl, Client(cl) as client:
        yield cl, client


def worker_stats(client):
    from sphrom.sweep.worker import cache_stats
    return client.run(cache_stats)


def same(a, b):
    """Rows equal, nan equal to nan."""
    def eq(x, y):
        return x == y or (isinstance(x, float) and isinstance(y, float) and math.isnan(x) and math.isnan(y))
    return a.keys() == b.keys() and all(eq(a[k], b[k]) for k in a)


def rows_by_index(path):
    rows, attrs = read_results(path)
    return {r["index"]: r for r in rows}, attrs


# ---------------------------------------------------------------------------
# the spec
# ---------------------------------------------------------------------------

def test_entries_ids_and_compare_subset(study):
    spec = load_spec(study / "spec.toml")
    assert len(spec.entries) == 8
    assert len({e.id for e in spec.entries}) == 8
    assert len({e.variant_inputs() for e in spec.entries}) == 2
    assert [e.compare_sph for e in spec.entries].count(True) == 2
    assert all(e.compare_sph == (e.shape == "sine" and e.frequency == 1.0) for e in spec.entries)
    # ids hash the inputs, not the order of the grids
    reordered = SPEC.replace("[1.0, 3.0]", "[3.0, 1.0]").replace("[5.0, 10.0]", "[10.0, 5.0]")
    again = parse_spec(reordered, "reordered", spec_path=study / "spec.toml")
    assert {e.id for e in again.entries} == {e.id for e in spec.entries}
    other = parse_spec(SPEC.replace("amplitude = [1e-2]", "amplitude = [2e-2]"), "x", spec_path=study / "spec.toml")
    assert not {e.id for e in other.entries} & {e.id for e in spec.entries}


def test_committed_specs():
    """The measured spec has 1000 entries on 5 FMUs; the SPH one is the same but compare_sph."""
    root = Path(__file__).resolve().parents[1] / "validation" / "sweeps"
    plain, sph = load_spec(root / "tenmode_forces.toml"), load_spec(root / "tenmode_forces_sph.toml")
    assert len(plain.entries) == len(sph.entries) == 1000
    assert len({e.variant_inputs() for e in plain.entries}) == 5
    assert sum(e.compare_sph for e in sph.entries) == 100
    a, b = (tomllib.loads((root / f).read_text()) for f in ("tenmode_forces.toml", "tenmode_forces_sph.toml"))
    a.pop("compare_sph"), b.pop("compare_sph")
    assert a == b


@pytest.mark.parametrize("change, field", [
    (("amplitude = [1e-2]", "amplitude = [nan]"), "grid.amplitude[0]"),
    (("frequency = [1.0, 3.0]", "frequency = [1.0, -3.0]"), "grid.frequency[1]"),
    (("d = [5.0, 10.0]", "d = [-1.0]"), "grid.d[0]"),
    (("k = [4]", "k = [400]"), "grid.k[0]"),
    (("k = [4]", "k = [4]\nmodel = [\"fast\"]"), "grid.model[0]"),
    (("k = [4]", "k = [4]\nn_freeze = [0]"), "grid.n_freeze[0]"),
    (("k = [4]", "k = [4]\nspeed = [1]"), "grid.speed"),
    (("step = 0.01", "step = 0.03"), "step"),
    (("t_end = 0.5", "t_end = 0.5\nwindow = [0.2, 0.9]"), "window"),
    (("probes = [0.25, 0.66]", "probes = [0.25, 1.5]"), "probes[1]"),
    (("frequency = [1.0] }", "frequency = [2.0] }"), "compare_sph.frequency"),
    (('shape = ["sine", ', 'shape = ["sine", "A*__import__(t)", '), "grid.shape[1]"),
    (('scene = "scene.toml"', 'scene = "nowhere.toml"'), "scene"),
    (("amplitude = [1e-2]", "amplitude = []"), "grid.amplitude"),
    (("amplitude = [1e-2]", "amplitude = { start = 1, stop = 2 }"), "grid.amplitude.count"),
    (("title", "titel"), "titel"),
])
def test_bad_spec_is_one_line_exit_2_nothing_written(study, tmp_path, capsys, change, field):
    (tmp_path / "scene.toml").write_text((study / "scene.toml").read_text())
    spec = tmp_path / "bad.toml"
    spec.write_text(SPEC.replace(*change))
    out = tmp_path / "r.h5"
    assert main(["sweep", str(spec), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and str(spec) in err and f"{field}:" in err, err
    assert "allowed" in err or "missing" in err or "unknown" in err or "not allowed" in err
    assert not any(tmp_path.glob("r.*"))


@pytest.mark.parametrize("argv, expect", [
    (["--workers", "0"], "--workers"),
    (["--workers", "two"], "--workers"),
    (["--workers", "2", "--scheduler", "tcp://127.0.0.1:8786"], "--workers"),
])
def test_bad_options(study, tmp_path, capsys, argv, expect):
    out = tmp_path / "r.h5"
    assert main(["sweep", str(study / "spec.toml"), "--out", str(out), *argv]) == 2
    assert capsys.readouterr().err.startswith(f"sphrom sweep: error: {expect}")
    assert main(["sweep", str(study / "spec.toml"), "--out", str(tmp_path / "r.txt")]) == 2
    foreign = tmp_path / "foreign.h5"
    foreign.write_bytes(b"not hdf5")
    assert main(["sweep", str(study / "spec.toml"), "--out", str(foreign)]) == 2
    assert foreign.read_bytes() == b"not hdf5"
    assert not out.exists()


def test_unreachable_scheduler_is_exit_2(study, tmp_path, capsys, monkeypatch):
    import sphrom.sweep.study as st
    monkeypatch.setattr(st, "CONNECT_TIMEOUT", 1.0)
    out = tmp_path / "r.h5"
    assert main(["sweep", str(study / "spec.toml"), "--scheduler", "tcp://127.0.0.1:9", "--out", str(out),
                 "--quiet"]) == 2
    assert "--scheduler: cannot connect" in capsys.readouterr().err
    assert not out.exists()


# ---------------------------------------------------------------------------
# the study on a LocalCluster of 2 workers, then resumed on an existing cluster
# ---------------------------------------------------------------------------

@pytest.fixture(scope="module")
def first_run(study, tmp_path_factory):
    """``sphrom sweep spec.toml --workers 2``: the default path, a LocalCluster made by the command."""
    out = tmp_path_factory.mktemp("run") / "results.h5"
    assert main(["sweep", str(study / "spec.toml"), "--workers", "2", "--out", str(out), "--quiet"]) == 0
    return out


def test_failures_recorded_and_table_complete(first_run):
    rows, attrs = rows_by_index(first_run)
    assert len(rows) == 8
    failed = {i for i, r in rows.items() if r["status"] == "failed"}
    assert failed == {i for i, r in rows.items() if r["shape"] == FAILING and r["frequency"] == 3.0}
    assert len(failed) == 2                      # the deliberately failing entry of each FMU
    for i in failed:
        assert "ran away" in rows[i]["error"] and "t = " in rows[i]["error"]
        assert math.isnan(rows[i]["v_max_1"])
    for i, r in rows.items():
        if i not in failed:
            assert r["status"] == "ok" and r["error"] == ""
            assert all(np.isfinite(r[f"{s}_{j}"]) for s in ("v_max", "v_rms", "v_final") for j in (1, 2))
            assert r["v_max_1"] >= r["v_rms_1"] > 0
    assert attrs["workers"] == 2 and attrs["complete"] == 1 and attrs["entries"] == 8
    assert attrs["ok"] == 6 and attrs["failed"] == 2 and attrs["throughput_runs_per_s"] > 0
    assert attrs["scheduler"].startswith("LocalCluster") and "spec.text" in attrs
    csv_lines = first_run.with_suffix(".csv").read_text().splitlines()
    assert len(csv_lines) == 9 and csv_lines[0].startswith("id,index,scene,c,d")
    assert first_run.with_suffix(".png").stat().st_size > 1000


def test_fmu_loaded_once_per_worker(first_run):
    rows, _ = rows_by_index(first_run)
    assert {r["fmu_loads"] for r in rows.values()} == {1}
    loaded = [(r["worker"], r["fmu"]) for r in rows.values() if r["load_s"] > 0]
    assert len(loaded) == len(set(loaded))       # one instantiation per (worker, FMU)
    assert {r["worker"] for r in rows.values()} <= {"0", "1"}


def test_agrees_with_a_direct_slave_run(first_run):
    """The study's probe statistics equal those of the same entry run by hand on a fresh FMU."""
    from sphrom.fmu.run.driver import FMU
    from sphrom.sweep.fmus import sweep_dir
    from sphrom.sweep.worker import probe_stats
    rows, _ = rows_by_index(first_run)
    checked = 0
    for r in rows.values():
        if r["status"] != "ok" or r["frequency"] != 3.0:
            continue
        t = np.arange(51) * 0.01
        f = 1e-2 * np.sin(2 * np.pi * 3.0 * t[:-1])
        with FMU(sweep_dir() / f"fmu-{r['fmu']}.fmu") as s:
            s.initialize(n_freeze=10, initial_state_scale=1)
            out = s.run([0.01] * 50, f)
        stats = probe_stats(t, out[:, :2], (0.0, 0.5))
        for name in ("v_max", "v_rms", "v_final"):
            for j in (1, 2):
                assert r[f"{name}_{j}"] == stats[name][j - 1]          # bitwise
        assert stats["v_max"][0] == np.abs(out[:, 0]).max()
        checked += 1
    assert checked == 2


def test_sph_comparison_agrees_with_an_independent_run(first_run, study):
    """sph_err_v: the full SPH run here with the held force written as a scene expression."""
    from sphrom.norms import time_weights
    from sphrom.sph.solver import run_sph
    from sphrom.scene import load_scene
    rows, _ = rows_by_index(first_run)
    compared = [r for r in rows.values() if r["compare_sph"]]
    assert len(compared) == 2
    base = load_scene(study / "scene.toml")
    for r in compared:
        assert r["status"] == "ok" and r["sph_wall_s"] > 0
        scene = derive_scene(base, {"fields": {"d": repr(r["d"])},
                                    "force": {"f": "1e-2*sin(2*pi*1.0*(0.01*floor(t/0.01 + 1e-9)))"}})
        sph = run_sph(scene, sample_steps=np.arange(51) * 50, progress=False)
        xp = np.append(sph.x, sph.x[0] + 1.0)
        v_sph = np.array([np.interp([0.25, 0.66], xp, np.append(v, v[0])) for v in sph.v])
        t = np.arange(51) * 0.01
        f = 1e-2 * np.sin(2 * np.pi * 1.0 * t[:-1])
        from sphrom.fmu.run.driver import FMU
        from sphrom.sweep.fmus import sweep_dir
        with FMU(sweep_dir() / f"fmu-{r['fmu']}.fmu") as s:
            s.initialize(n_freeze=10, initial_state_scale=1)
            v_fmu = s.run([0.01] * 50, f)[:, :2]
        w = time_weights(t)[:, None]
        err = math.sqrt(np.sum(w * (v_fmu - v_sph) ** 2) / np.sum(w * v_sph**2))
        assert r["sph_err_v"] == pytest.approx(err, rel=1e-9)
        assert 0 < err < 0.05


def test_resume_on_an_existing_cluster_skips_done_entries(study, first_run, cluster, tmp_path, capsys):
    """Rerun via --scheduler: no finished entry runs again; the failed ones are retried."""
    cl, client = cluster
    out = tmp_path / first_run.name
    out.write_bytes(first_run.read_bytes())
    before, _ = rows_by_index(out)
    calls0 = sum(s["calls"].get("runs", 0) for s in worker_stats(client).values())
    assert main(["sweep", str(study / "spec.toml"), "--scheduler", cl.scheduler_address, "--out", str(out),
                 "--quiet"]) == 0
    assert "6 already done, 2 run now (0 ok, 2 failed)" in capsys.readouterr().out
    after, attrs = rows_by_index(out)
    stats = worker_stats(client)
    assert sum(s["calls"].get("runs", 0) for s in stats.values()) - calls0 == 2
    for i, r in before.items():
        if r["status"] == "ok":
            assert same(after[i], r)                  # untouched: same start time, worker, values
        else:
            assert after[i]["attempts"] == 2 and after[i]["session"] == 2 and after[i]["status"] == "failed"
    assert attrs["scheduler"] == cl.scheduler_address and attrs["workers"] == 2
    for s in stats.values():                          # each worker instantiated each FMU at most once
        assert all(n == 1 for n in s["loads"].values())
    # the spec changed: the new entries run, the finished ones are skipped, the old rows are kept
    fixed = study / "fixed.toml"
    fixed.write_text(SPEC.replace(FAILING, "cosine"))
    calls1 = sum(s["calls"].get("runs", 0) for s in worker_stats(client).values())
    assert main(["sweep", str(fixed), "--scheduler", cl.scheduler_address, "--out", str(out), "--quiet"]) == 0
    assert "4 already done, 4 run now (4 ok, 0 failed); 4 rows of earlier specs kept" in capsys.readouterr().out
    assert sum(s["calls"].get("runs", 0) for s in worker_stats(client).values()) - calls1 == 4
    rows, attrs = read_results(out)
    assert len(rows) == 12 and attrs["ok"] == 8 and attrs["failed"] == 0 and attrs["complete"] == 1
    # nothing left to run: the file is left alone
    mtime = out.stat().st_mtime_ns
    assert main(["sweep", str(fixed), "--scheduler", cl.scheduler_address, "--out", str(out), "--quiet"]) == 0
    assert "nothing to run" in capsys.readouterr().out and out.stat().st_mtime_ns == mtime


def test_interrupted_study_keeps_finished_entries(study, cluster, tmp_path, capsys, monkeypatch):
    """KeyboardInterrupt after 3 results: those 3 are written; a rerun does the other 5."""
    import sphrom.sweep.study as st
    cl, client = cluster
    real = st.input_row
    calls = []

    def interrupting(*args):
        calls.append(1)
        if len(calls) == 4:
            raise KeyboardInterrupt
        return real(*args)
    monkeypatch.setattr(st, "input_row", interrupting)
    out = tmp_path / "r.h5"
    assert main(["sweep", str(study / "spec.toml"), "--scheduler", cl.scheduler_address, "--out", str(out),
                 "--quiet"]) == 130
    assert "interrupted (SIGINT); 3 finished runs kept" in capsys.readouterr().err
    rows, attrs = read_results(out)
    assert len(rows) == 3 and attrs["complete"] == 0
    done = sum(r["status"] == "ok" for r in rows)
    monkeypatch.setattr(st, "input_row", real)
    assert main(["sweep", str(study / "spec.toml"), "--scheduler", cl.scheduler_address, "--out", str(out),
                 "--quiet"]) == 0
    assert f"{done} already done, {8 - done} run now" in capsys.readouterr().out
    rows, attrs = read_results(out)
    assert len(rows) == 8 and attrs["complete"] == 1
