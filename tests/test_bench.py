"""Benchmarks stay out of the suite; this smoke test runs them at tiny size and checks their contracts."""

import csv

import numpy as np

from conftest import small_scene
from harness.bench.methods import bench_python
from harness.bench.scaling import growth
from harness.cli import main


def test_bench_python_rows_are_consistent():
    scene = small_scene("damped_forced", T=0.5, n=32, every=25)
    rows = bench_python(scene, ks=[4], n_freezes=(1, 10), repeats=1)
    methods = [r["method"] for r in rows]
    assert methods[0] == "full SPH" and {"original", "linearized", "frozen", "exact"} <= set(methods)
    sph = rows[0]
    assert sph["speedup"] == 1.0 and np.isfinite(sph["err_v_ref"])
    fro = {r["n_freeze"]: r for r in rows if r["method"] == "frozen"}
    lin = [r for r in rows if r["method"] == "linearized"][0]
    assert abs(fro[1]["err_v_sph"] - lin["err_v_sph"]) <= 1e-10 * lin["err_v_sph"]   # n_freeze = 1: linearised
    for r in rows:
        assert r["online_s"] > 0 and np.isfinite(r["speedup"])


def test_bench_command_smoke(tmp_path, monkeypatch):
    scene_file = tmp_path / "s.toml"
    scene_file.write_text(small_scene("multimode", T=0.5, n=24, every=25).text)
    out = tmp_path / "bench"
    report = tmp_path / "B.md"
    assert main(["bench", str(scene_file), "--repeats", "1", "--sizes", "50,100", "--no-fmu",
                 "--out", str(out), "--report", str(report)]) == 0
    text = report.read_text()
    assert "CPU saving of the frozen model" in text and "Cost per step against N" in text
    with open(out / "scaling.csv") as fh:
        rows = [dict(r, n=int(r["n"]), us_per_step=float(r["us_per_step"])) for r in csv.DictReader(fh)]
    assert {r["method"] for r in rows} >= {"full SPH", "frozen (n_freeze = 10)"}
    assert np.isfinite(growth(rows, "full SPH"))
    assert (out / "multimode_time_error.png").stat().st_size > 5000
