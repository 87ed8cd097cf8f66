"""Benchmarks stay out of the suite; this smoke test runs them at tiny size and checks their contracts."""

import csv
import dataclasses

import numpy as np
import pytest

from conftest import small_scene
from sphrom.bench.lib.methods import bench_python
from sphrom.bench.lib.scaling import growth
from sphrom.cli import main


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
    assert main(["bench", str(scene_file), "--repeats", "1", "--sizes", "50,100", "--scaling-ks", "4,8",
                 "--sph-sizes", "50,100", "--no-fmu",
                 "--no-stress", "--out", str(out), "--report", str(report)]) == 0
    text = report.read_text()
    assert "CPU saving of the frozen model" in text and "Cost per step against N" in text
    assert "Cost per step against k" in text and (out / "scaling_k.png").stat().st_size > 1000
    assert "How the force direction enters the frozen model" in text and "The full SPH step against N" in text
    with open(out / "input_direction.csv") as fh:
        choices = {r["choice"]: r for r in csv.DictReader(fh)}
    # multimode's v has zero mean: the modes miss the whole uniform profile, and appending adds one mode
    assert float(choices["project"]["input_error"]) > 0.99 and choices["project"]["fmu_rule"] == "augment"
    assert int(choices["augment"]["k_v"]) == int(choices["project"]["k_v"]) + 1
    with open(out / "scaling.csv") as fh:
        rows = [dict(r, n=int(r["n"]), us_per_step=float(r["us_per_step"])) for r in csv.DictReader(fh)]
    assert {r["method"] for r in rows} >= {"full SPH", "frozen (n_freeze = 10)"}
    assert np.isfinite(growth(rows, "full SPH"))
    assert (out / "multimode_time_error.png").stat().st_size > 5000
    (out / "multimode_time_error.png").unlink()
    assert main(["bench", "--replot", "--out", str(out)]) == 0               # from bench.csv, no timing
    assert (out / "multimode_time_error.png").stat().st_size > 5000
    assert main(["bench", "--replot", "--out", str(tmp_path / "none")]) == 2


def test_stress_smoke_and_physics(tmp_path):
    from sphrom.bench.lib import stress as st
    scene = small_scene("multimode", T=2.0, n=32, every=25)
    ctx = st.context(scene, k=6)
    # far below the limit everything that should hold holds; the exact model holds at 2x
    assert st.run_one(ctx, "sph-rk4", 0.1 * ctx.dt_limit)["outcome"] == "stable"
    assert st.run_one(ctx, "exact", 2.0 * ctx.dt_limit)["outcome"] == "stable"
    # above the RK4 limit the full SPH blows up, and says when
    r = st.run_one(ctx, "sph-rk4", 2.0 * ctx.dt_limit, T=200.0)
    assert r["outcome"] == "blow-up" and 0 < r["blowup_time"] <= 200.0
    # a compression beyond J = 0 is flagged, not passed on
    r = st.run_one(ctx, "exact", scene.sph.dt, amplitude=2000.0)
    assert r["outcome"] == "unphysical" and r["blowup_time"] < scene.T
    assert main(["stress", "--quick", "--no-fmu", "--out", str(tmp_path), "--modes", "4,6", "--horizons", "2",
                 str(_scene_file(tmp_path, scene))]) == 0
    assert "Largest Δt" in (tmp_path / "stress.md").read_text()
    # as `sphrom bench --report` calls it: into a folder that does not exist yet
    from sphrom.bench.lib.stress_maps import stress_report
    text, _ = stress_report([scene], [1], [2.0], [4], (0.5,), tmp_path / "new" / "stress", no_fmu=True)
    assert "Largest Δt" in text and (tmp_path / "new" / "stress" / f"{scene.name}_stress.png").is_file()


def test_skipped_terms_give_identical_results_in_every_solver():
    """multimode has d = 0 and f = 0: every solver (full SPH, linearized and frozen POD-MOR, the FMU's C core)
    gives bitwise the same state with the terms skipped and with them evaluated (asserted inside)."""
    from sphrom.bench.lib.skip import skip_savings
    rows = skip_savings(small_scene("multimode", T=0.5, n=32, every=25), steps=500, k=4, repeats=1)
    assert [r["solver"].split(" (")[0].split(",")[0] for r in rows] == \
        ["full SPH", "linearized POD-MOR", "frozen POD-MOR", "FMU core"]
    for r in rows:
        assert r["specialised_us"] > 0 and r["general_us"] > 0 and r["saving"] < 1


def test_stress_fmu_columns_report_errors_never_nan():
    """The FMU in the stress maps: the same outcome as the Python model it packages, an error status naming the
    time where the state runs away or the density leaves (0, ∞), and never a silent NaN."""
    from sphrom.bench.lib import stress as st
    from sphrom.bench.lib.stress_fmu import FMUStress, stress_runners
    scene = small_scene("multimode", T=1.0, n=32, every=25)
    ctx = st.context(scene, k=6)
    # the Python models the FMUs package: the registry's, the frozen one with b about the rest density
    packaged = dataclasses.replace(ctx, operators={**ctx.operators, "frozen": st.fmu_operators(ctx, "frozen")})
    assert packaged.operators["frozen"].b_form == "rest" and ctx.operators["frozen"].b_form == "paper"
    with FMUStress() as fs:
        runners = stress_runners(fs)
        assert sorted(runners) == ["FMU exact", "FMU frozen"]          # the FMUs on the scene's POD basis
        for name, model in (("FMU frozen", "frozen"), ("FMU exact", "exact")):
            r = runners[name](ctx, 0.5 * ctx.dt_limit, 1.0)
            py = st.run_one(packaged, model, 0.5 * ctx.dt_limit)
            assert r["outcome"] == py["outcome"] and r["silent_nan"] == 0 and not r["fmu_error"]
            assert r["energy_end"] == pytest.approx(py["energy_end"], rel=1e-9)
            bad = runners[name](ctx, scene.sph.dt, 1000.0)            # compressed beyond ρ -> 0, or runaway
            assert bad["outcome"] == "blow-up" and bad["silent_nan"] == 0
            assert "t = " in bad["fmu_error"] and 0 < bad["blowup_time"] <= scene.T


def _scene_file(tmp_path, scene):
    path = tmp_path / "scene.toml"
    path.write_text(scene.text)
    return path
