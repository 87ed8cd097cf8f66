"""Hostile input: numerical blow-ups said before and stopped during a run, unusual scenes."""

import re

import numpy as np
import pytest

from harness.cli import main
from harness.scene import dump_toml, load_scene, parse_scene, scene_dict
from harness.sph.solver import (BLOWUP_FACTOR, GROWTH_WARN, build_problem, energy, run_sph, stability,
                                step_count)


def _stiff_scene(tmp_path, v0, T, name="stiff"):
    """An undamped, unforced scene with c = 100 at N = 50: omega_max ~ 500 rad/s."""
    data = scene_dict(load_scene("multimode"))
    data["name"] = name
    data["domain"]["T"] = T
    data["fields"].update(c="100", v0=v0)
    data["sph"].update(n_particles=50, dt=1e-4, every=500, integrator="euler")
    path = tmp_path / f"{name}.toml"
    path.write_text(dump_toml(data))
    return path


def test_euler_far_below_the_limit_warns_with_its_amplification(tmp_path, capsys):
    path = _stiff_scene(tmp_path, "1e-3*sin(2*pi*x)", T=0.6)
    scene = load_scene(path)
    stab = stability(build_problem(scene), scene.sph.dt, "euler", scene.T)
    assert scene.sph.dt < stab["dt_limit"] / 20                  # far below 2/omega_max
    # explicit Euler, undamped: (1 + omega_max^2 dt^2)^(n/2), the fastest mode is the worst
    n = step_count(scene.T, scene.sph.dt)
    expect = (1 + stab["omega_dt"] ** 2) ** (n / 2)
    assert stab["growth"] == pytest.approx(expect, rel=1e-6) and stab["growth"] > GROWTH_WARN
    out = tmp_path / "run.h5"
    assert main(["sph", str(path), "--out", str(out), "--quiet"]) == 0     # smooth data: no blow-up
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "warning" in err[0] and "amplifies" in err[0], err
    figure = float(re.search(r"by a factor ([0-9.e+]+)", err[0]).group(1))
    assert figure == pytest.approx(stab["growth"], rel=1e-2)
    # symplectic Euler below its limit amplifies nothing: no warning
    assert main(["sph", str(path), "--integrator", "symplectic", "--out", str(out), "--quiet"]) == 0
    assert capsys.readouterr().err == ""


def test_damping_and_rk4_amplification():
    scene = load_scene("damped")
    problem = build_problem(scene)
    # d = 10 damps every mode faster than explicit Euler amplifies it at the paper's step
    assert stability(problem, scene.sph.dt, "euler", scene.T)["growth"] < 1.0
    tenmode = load_scene("tenmode")
    p = build_problem(tenmode)
    st = stability(p, tenmode.sph.dt, "rk4", tenmode.T)
    assert st["growth"] <= 1.0 + 1e-9                  # RK4 damps slightly inside its region
    assert stability(p, 3.0 / st["omega_max"], "rk4", tenmode.T)["growth"] > 1e10   # outside 2 sqrt 2


def test_energy_bound_holds_for_the_papers_runs():
    """The discrete energy stays near the exact dynamics' bound on an accurate run."""
    scene = load_scene("damped_forced").with_T(1.0).with_sph(n_particles=100, dt=2e-4, every=50)
    res = run_sph(scene, progress=False)
    e = np.array([energy(res.problem, v, r) for v, r in zip(res.v, res.rho)])
    assert np.all(np.isfinite(e)) and e.max() < 10 * e[0] + 1.0


def test_growth_past_the_bound_exits_3_with_step_and_time(tmp_path, capsys):
    # a rough initial velocity puts energy in the fastest modes, which Euler amplifies by ~1e8 over T
    path = _stiff_scene(tmp_path, "1e-6*sin(1234.5*x**2)", T=1.5, name="rough")
    scene = load_scene(path)
    assert stability(build_problem(scene), scene.sph.dt, "euler", scene.T)["growth"] > 1e6
    out = tmp_path / "run.h5"
    code = main(["sph", str(path), "--out", str(out), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 3
    assert len([line for line in err if "failed" in line]) == 1
    fail = [line for line in err if "failed" in line][0]
    assert "blew up by step" in fail and "t = " in fail and f"{BLOWUP_FACTOR:g}" in fail, fail
    step = int(re.search(r"by step (\d+)", fail).group(1))
    assert 0 < step < step_count(scene.T, scene.sph.dt)      # stopped before the end, state still finite
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["rough.toml"]
