"""Defaults that work on any bar (issue 32, item 1): a scene that names no integrator gets one stable at its step,
a scene without dt gets one from the stability limit (printed), and a dt above the limit of the integrator is
refused in one line before any work."""

import numpy as np
import pytest

from sphrom.errors import SimulationError, UserError
from sphrom.scene import automatic_lines, parse_scene, run_steps
import sphrom.sph.timestep as st
from sphrom.sph.solver import build_problem, run_sph, spectral_radius

# CPU- and version-sensitive (eigen and singular value decisions): .ci/run runs it on Python 3.11 and 3.12 with the
# oldest and the newest numpy and scipy that pyproject.toml allows, and on the baseline CPU paths
pytestmark = pytest.mark.cpu_sensitive

# a user's bar: graded modulus (1 to 10), non-uniform density, graded damping, a local force; no integrator
USER_BAR = """\
[domain]
L = 1.0
T = 2.0

[fields]
rho0 = "1 + 0.5*sin(2*pi*x/L)"
v0 = "1e-3*sin(2*pi*x/L)"
c = "where(x < 0.5*L, 1, 10)"
d = "0.2*x/L"

[force]
f = "1e-3*cos(2*pi*t)"
profile = "exp(-((x - 0.3*L)/(0.05*L))**2)"

[sph]
n_particles = 64
"""


def _bar(sph_lines="", text=USER_BAR):
    return parse_scene(text + sph_lines, "bar.toml", name="bar")


def test_the_symbol_bound_is_the_operator_norm_on_a_uniform_bar():
    """omega_max = sqrt(c/rho0) max|D| is the largest eigenfrequency of the linearised SPH on uniform fields (to
    round-off), and an upper bound on graded ones."""
    from sphrom.rom.lti import full_linear_system
    uniform = _bar("dt = 1e-3\n", USER_BAR.replace("1 + 0.5*sin(2*pi*x/L)", "2").replace(
        "where(x < 0.5*L, 1, 10)", "3").replace("0.2*x/L", "0"))
    for scene in (uniform, _bar("dt = 1e-3\n")):
        lti = full_linear_system(build_problem(scene))
        top = float(np.max(np.abs(np.linalg.eigvals(lti.J.toarray()))))
        bound = spectral_radius(build_problem(scene))
        assert bound == pytest.approx(scene.spectrum[0], rel=1e-12)
        assert top <= bound * (1 + 1e-12)
        if scene is uniform:
            assert top == pytest.approx(bound, rel=1e-10)
    # the lattice's wavenumbers and the fine grid above SYMBOL_GRID particles agree within the grid's 1e-6
    assert st.lattice_symbol(st.SYMBOL_GRID + 2, 1.04) == pytest.approx(st.lattice_symbol(st.SYMBOL_GRID, 1.04),
                                                                     rel=2e-6)


@pytest.mark.parametrize("integrator", ["symplectic", "rk4", "euler"])
def test_the_limit_is_where_the_fastest_mode_starts_to_grow(integrator):
    """Just below the limit no mode grows per step (euler: none beyond its undamped (1 + w^2 dt^2)^(1/2)), just
    above it the fastest does, with the scene's largest damping."""
    for d in (0.0, 0.3, 50.0):
        w = 443.0
        lim = st.dt_limit(integrator, w, d, d)
        radius = [max(st._radius(integrator, om * lim * f, d * lim * f) for om in np.linspace(0, w, 513))
                  for f in (0.999, 1.01)]
        if integrator == "euler":
            assert lim == pytest.approx(min(2 / w, 2 / d if d else np.inf))
        else:
            assert radius[0] <= 1 + 1e-9 and radius[1] > 1 + 1e-6, (d, radius)
    assert st.dt_limit("symplectic", 10.0) == pytest.approx(0.2) and st.dt_limit("rk4", 10.0) == pytest.approx(
        0.2 * np.sqrt(2), rel=1e-6)


def test_a_scene_without_integrator_and_dt_runs_at_the_first_try():
    scene = _bar()
    assert scene.sph.integrator == "symplectic" and {"sph.integrator", "sph.dt"} <= set(scene.automatic)
    w, d_min, d_max = scene.spectrum
    limit = st.dt_limit("symplectic", w, d_max, d_min)
    n = run_steps(scene.T, scene.sph.dt)
    assert n * scene.sph.dt == pytest.approx(scene.T, rel=1e-12)          # T a whole number of steps
    assert st.DT_FRACTION * limit * (1 - 1 / n) <= scene.sph.dt <= st.DT_FRACTION * limit
    lines = automatic_lines(scene)
    assert any(f"sph.dt = {scene.sph.dt:.4g} s (automatic: 0.2" in line for line in lines), lines
    assert any("sph.integrator = symplectic" in line for line in lines), lines
    run = run_sph(scene, progress=False)
    assert np.all(np.isfinite(run.v)) and np.abs(run.v).max() < 10 * 1e-3
    # the case: a CFL-sized step, the integrator left to the default, runs (explicit Euler blew up)
    cfl = _bar(f"dt = {0.4 * limit!r}\n")
    assert cfl.sph.integrator == "symplectic" and np.all(np.isfinite(run_sph(cfl, progress=False).v))
    with pytest.raises(SimulationError, match="blew up|non-finite"):
        run_sph(cfl.with_sph(integrator="euler", stable=False), progress=False)


def test_the_automatic_dt_follows_N_T_and_the_integrator():
    scene = _bar()
    finer = scene.with_sph(n_particles=128)
    assert finer.sph.dt < 0.6 * scene.sph.dt and "sph.dt" in finer.automatic
    longer = scene.with_T(4.0)
    assert run_steps(4.0, longer.sph.dt) * longer.sph.dt == pytest.approx(4.0, rel=1e-12)
    euler = scene.with_sph(integrator="euler")
    w, d_min, _ = scene.spectrum
    assert euler.sph.dt < scene.sph.dt
    assert st.growth("euler", w, d_min, euler.sph.dt, euler.T)[0] <= st.EULER_AUTO_GROWTH
    given = scene.with_sph(dt=1e-3)
    assert given.sph.dt == 1e-3 and "sph.dt" not in given.automatic and given.with_T(1.0).sph.dt == 1e-3


def test_a_dt_above_the_limit_is_refused_at_load_in_one_line():
    scene = _bar()
    w, d_min, d_max = scene.spectrum
    limit = st.dt_limit("symplectic", w, d_max, d_min)
    with pytest.raises(UserError) as info:
        _bar(f"dt = {1.05 * limit!r}\n")
    text = str(info.value)
    assert text.startswith("bar.toml: sph.dt: ") and "above the stability limit" in text and "\n" not in text
    assert f"remedy: dt <= {limit:.3g} s" in text and "rk4 up to" in text
    _bar(f"dt = {0.99 * limit!r}\n")                                    # just below: accepted
    with pytest.raises(UserError, match=r"sph.dt: .* of the euler integrator"):
        _bar(f"dt = {1.05 * limit!r}\nintegrator = \"euler\"\n")


def test_an_impossible_scene_is_refused_by_fmu_before_any_work(tmp_path, capsys, monkeypatch):
    from sphrom.cli import main
    scene = _bar()
    w, d_min, d_max = scene.spectrum
    path = tmp_path / "bar.toml"
    path.write_text(USER_BAR + f"dt = {2 * st.dt_limit('symplectic', w, d_max, d_min)!r}\n")
    cache = tmp_path / "cache"
    monkeypatch.setenv("SPHROM_CACHE", str(cache))
    out = tmp_path / "bar.fmu"
    for argv in (["fmu", str(path), "--out", str(out)], ["pod", str(path), "--out", str(tmp_path / "b.h5")],
                 ["validate", str(path), "--out", str(tmp_path / "report")]):
        assert main(argv + ["--quiet"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "sph.dt:" in err[0] and "above the stability limit" in err[0], err
    assert not out.exists() and not (cache.exists() and any(cache.iterdir()))       # no SPH run was made


def test_every_command_warns_of_eulers_amplification_before_the_run(tmp_path, capsys):
    """Explicit Euler named, undamped, a long horizon: one warning line naming the remedy, from every command that
    runs the SPH (here pod), before its run."""
    from sphrom.cli import main
    text = USER_BAR.replace("0.2*x/L", "0").replace("T = 2.0", "T = 20.0")
    scene = parse_scene(text + "integrator = \"euler\"\ndt = 2e-3\n", "e.toml", name="e")
    growth = st.growth("euler", scene.spectrum[0], 0.0, 2e-3, 20.0)[0]
    assert growth > st.GROWTH_WARN
    path = tmp_path / "e.toml"
    path.write_text(text + "integrator = \"euler\"\ndt = 2e-3\n")
    main(["pod", str(path), "--out", str(tmp_path / "b.h5"), "--quiet"])
    err = [line for line in capsys.readouterr().err.splitlines() if "warning" in line]
    assert len(err) == 1 and err[0].startswith("sphrom pod: warning: 'euler' amplifies") and \
        "integrator symplectic/rk4" in err[0], err
