"""A user's scene with only its physics: [domain], [fields], [force] and [sph] n_particles, dt (the minimal scene
of docs/user/scenes.md).  It builds an FMU and co-simulates at the first try, and the FMU follows the full SPH;
pod, rom and validate run on it; the automatic choices follow their stated rules.
"""

import subprocess
import sys

import h5py
import numpy as np
import pytest

from sphrom.errors import UserError
from sphrom.pod.automatic import (ENERGY_LEFT_OUT, MAX_AUTO_MODES, MAX_AUTO_SNAPSHOTS, MIN_AUTO_SNAPSHOTS,
                                   automatic_count, automatic_modes)
from sphrom.pod.pipeline import basis_for_scene, scene_modes
from sphrom.scene import automatic_lines, load_scene, parse_scene, run_steps
from sphrom.scene_page import MINIMAL_SCENE

# The FMU against the full SPH of the scene, at its probes (eq. 3.4, square-root form, over probes and time): at
# most the automatic mode rule's own target, a projection error of sqrt(ENERGY_LEFT_OUT) = 3.2 %
# (measured: v 8.5e-3, rho - rho0 1.8e-4).
TOLERANCE = float(np.sqrt(ENERGY_LEFT_OUT))
FORCE = "1e-3*cos(2*pi*t)"              # the minimal scene's f


def _harness(*args, cwd):
    r = subprocess.run([sys.executable, "-m", "sphrom", *map(str, args)], capture_output=True, text=True, cwd=cwd,
                       timeout=900)
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stdout + r.stderr
    return r.stdout


@pytest.fixture(scope="module")
def minimal(tmp_path_factory):
    folder = tmp_path_factory.mktemp("user")
    path = folder / "my_bar.toml"
    path.write_text(MINIMAL_SCENE)
    assert [line for line in MINIMAL_SCENE.splitlines() if line.startswith("[")] == \
        ["[domain]", "[fields]", "[force]", "[sph]"]
    assert "n_particles" in MINIMAL_SCENE and "dt" in MINIMAL_SCENE and "every" not in MINIMAL_SCENE
    return path


def _csv(path):
    data = np.genfromtxt(path, delimiter=",", names=True)
    probes = sorted(n for n in data.dtype.names if n.startswith("v_probe_") and not n.endswith("_error_bound"))
    v = np.column_stack([data[n] for n in probes])
    rho = np.column_stack([data[n.replace("v_", "rho_")] for n in probes])
    return data["time"], v, rho


def test_the_minimal_scene_builds_an_fmu_and_cosimulates_at_the_first_try(minimal):
    from sphrom.fmu.check.verify import case_errors, probe_values
    from sphrom.sph.solver import build_problem, run_sph

    folder = minimal.parent
    out = _harness("fmu", minimal.name, "--out", "X.fmu", "--quiet", cwd=folder)
    scene = load_scene(minimal)
    basis, _ = basis_for_scene(scene, progress=False)
    k, why = automatic_modes(basis)
    assert "scene my_bar: name from the file name (my_bar.toml)" in out
    for line in automatic_lines(scene)[1:] + [f"scene my_bar: rom.modes: {why}"]:
        assert line in out, (line, out)
    # the default model is the cheaper accurate one (frozen: "k POD modes", exact: "k energy-weighted POD modes")
    assert f"modes: k = {k} POD modes" in out or f"modes: k = {k} energy-weighted POD modes" in out, out

    # as the docs write it: from the FMU's start (at rest) without force, it stays at rest
    _harness("cosim", "X.fmu", "--out", "X.csv", cwd=folder)
    t, v, rho = _csv(folder / "X.csv")
    assert t[-1] == pytest.approx(scene.T) and np.all(v == 0) and np.abs(rho - 1.0).max() < 1e-6

    # from the scene's initial state with the scene's force: the full SPH of the scene
    _harness("cosim", "X.fmu", "--out", "Y.csv", "--initial-state-scale", "1", "--force", FORCE, cwd=folder)
    t, v, rho = _csv(folder / "Y.csv")
    problem = build_problem(scene)
    steps = np.rint(t / scene.sph.dt).astype(np.int64)
    np.testing.assert_allclose(steps * scene.sph.dt, t, rtol=0, atol=1e-12)
    run = run_sph(scene, sample_steps=steps, progress=False, problem=problem)
    v_sph, rho_sph, rho0 = probe_values(problem, scene.L, (0.25, 0.5, 0.66), (run.v, run.rho, problem.rho0))
    err_v, err_rho, _ = case_errors(v, rho, v_sph, rho_sph, rho0, t)
    print(f"\nminimal scene, FMU (k = {k}) against the full SPH at the probes: v {err_v:.3e}, rho - rho0 "
          f"{err_rho:.3e} (tolerance {TOLERANCE:.3g})")
    assert err_v < TOLERANCE and err_rho < TOLERANCE
    assert np.abs(v_sph).max() > 1e-4            # the comparison is of a moving bar


def test_pod_rom_and_validate_on_the_minimal_scene(minimal):
    folder = minimal.parent
    scene = load_scene(minimal)
    out = _harness("pod", minimal.name, "--out", "b.h5", cwd=folder)
    basis, _ = basis_for_scene(scene, progress=False)
    k, why = automatic_modes(basis)
    assert f"scene my_bar: rom.modes: {why}" in out and f"k_v = {k} " in out and f"k_rho = {k} " in out
    assert f"{scene.snapshots['count']} velocity and {scene.snapshots['count']} density snapshots" in out
    with h5py.File(folder / "b.h5") as h5:
        assert h5.attrs["default_modes_v"] == h5.attrs["default_modes_rho"] == k

    out = _harness("rom", minimal.name, "--basis", "b.h5", "--model", "frozen", "--out", "r.h5", cwd=folder)
    assert automatic_lines(scene)[1] in out
    with h5py.File(folder / "r.h5") as h5:
        assert h5.attrs["solver.k_v"] == k and 0 < h5.attrs["error.sph.v"] < TOLERANCE

    # validate without [paper]: the SPH against the exact solution, the POD and the reduced models with the
    # automatic k, no paper column, no snapshot studies
    out = _harness("validate", minimal.name, "--out", "report", "--repeats", "1", "--quiet", cwd=folder)
    assert f"scene my_bar: rom.modes: {why}" in out
    page = (folder / "report" / "my_bar.md").read_text()
    assert "Not a scene of the paper." in page and "it reports no figure for it" in page
    assert "### The paper's snapshot studies" not in page
    assert "### Time against error of the accelerated models" in page and f"at k = {k}" in page
    assert "| exact |" in page


# ---------------------------------------------------------------------------------------------------------------
# the automatic choices and their rules
# ---------------------------------------------------------------------------------------------------------------

def test_the_automatic_snapshot_count_follows_its_rule():
    T_ = np.sqrt(10.0)                                      # the paper's T' for c = 0.1, rho0 = 1, L = 1
    assert automatic_count(1.6, T_, 8000, 100) == 102       # ceil(200 * 1.6 / 3.162): the paper's 100 over T'/2
    assert automatic_count(10.0, T_, 50000, 100) == 633
    assert automatic_count(0.01, T_, 100, 100) == MIN_AUTO_SNAPSHOTS
    assert automatic_count(1000.0, T_, 10**9, 100) == MAX_AUTO_SNAPSHOTS
    assert automatic_count(10.0, T_, 7, 100) == 7                               # at most the run's steps
    assert automatic_count(10.0, T_, 50000, 10_000_000) == 26                   # 26 x 1e7 x 16 bytes <= 4 GiB


def test_the_steps_of_a_run_as_the_solver_counts_them():
    from sphrom.sph.solver import step_count
    rng = np.random.default_rng(0)
    cases = [(10.0, 2e-4), (0.5, 1e-3), (1.6, 0.016), (0.1, 0.03), (1.0, 1 / 3), (1e-15, 1e-24), (1e15, 1e6)]
    cases += [(float(T), float(T / n * (1 + e))) for T, n, e in zip(10 ** rng.uniform(-15, 15, 2000),
                                                                      rng.integers(1, 10**9, 2000),
                                                                      rng.choice([0, 1e-12, -1e-12, 1e-6, -1e-6],
                                                                                 2000))]
    assert all(run_steps(T, dt) == step_count(T, dt) for T, dt in cases)


def test_the_automatic_settings_follow_T_dt_and_N():
    scene = parse_scene(MINIMAL_SCENE, "my_bar.toml", name="my_bar")
    assert scene.period() == pytest.approx(np.sqrt(10.0), rel=1e-12)
    assert scene.snapshots == {"count": 32, "window": [0.0, 0.5]}                # ceil(200 * 0.5 / 3.162)
    assert scene.sph.every == 15                                                # floor(0.5 / (32 * 1e-3))
    longer = scene.with_T(2.0)
    assert longer.snapshots == {"count": 127, "window": [0.0, 2.0]} and longer.sph.every == 15
    finer = scene.with_sph(dt=2.5e-4)
    assert finer.snapshots == scene.snapshots and finer.sph.every == 62
    given = scene.with_sph(every=3)
    assert given.sph.every == 3 and "sph.every" not in given.automatic and given.with_T(1.0).sph.every == 3
    heterogeneous = parse_scene(MINIMAL_SCENE.replace('c = "0.1"', 'c = "where(x/L <= 0.5, 0.1, 0.2)"'), "h.toml",
                                name="h")
    assert heterogeneous.period() == pytest.approx(0.5 * np.sqrt(10) + 0.5 * np.sqrt(5), rel=1e-12)


def test_the_automatic_mode_count_on_three_sine_modes():
    """Three standing sine waves (the paper's multimode v0): 3 velocity modes and 3 strain modes carry the energy,
    + 1 for the rest density: k = 4 (the paper's minimum data, section 3.1.2: 3 velocity and 4 density snapshots)."""
    three = 'v0 = "1e-3*sum(l*sin(2*pi*l*x/L) for l in range(1, 4))"'
    text = (MINIMAL_SCENE.replace('v0 = "1e-3*sin(2*pi*x/L)"', three)
            .replace('d = "0.5"', 'd = "0"').replace('f = "1e-3*cos(2*pi*t)"', 'f = "0"')
            .replace("T = 0.5", "T = 1.6").replace("n_particles = 32", "n_particles = 64"))
    scene = parse_scene(text, "three.toml", name="three")
    basis, _ = basis_for_scene(scene, progress=False)
    k, why = automatic_modes(basis)
    assert k == 4 and "k_v = 3, k_e = 3" in why and scene_modes(scene, basis) == 4
    given = parse_scene(text + "\n[rom]\nmodes = 6\n", "three.toml", name="three")
    assert scene_modes(given, basis) == 6 and "rom.modes" not in given.automatic
    assert MAX_AUTO_MODES == 20


def test_a_scene_without_motion_has_no_automatic_modes(tmp_path, capsys):
    from sphrom.cli import main
    text = MINIMAL_SCENE.replace('v0 = "1e-3*sin(2*pi*x/L)"', 'v0 = "0"').replace('f = "1e-3*cos(2*pi*t)"', 'f = "0"')
    path = tmp_path / "still.toml"
    path.write_text(text)
    with pytest.raises(UserError, match=r"rom.modes: the snapshots carry no motion"):
        scene_modes(load_scene(path), progress=False)
    out = tmp_path / "b.h5"
    assert main(["pod", str(path), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "rom.modes: the snapshots carry no motion" in err[0] and "allowed" in err[0]
    assert not out.exists()
