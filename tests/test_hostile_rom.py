"""Hostile input for the reduced models: an explicit integrator's amplification said before a run, a blow-up
stopped during it (exit status 3 through ``sphrom rom``, SimulationError from the library), and no false alarm
on the training scenes."""

import re

import numpy as np
import pytest

from conftest import small_scene
from sphrom.cli import main
from sphrom.errors import SimulationError
from sphrom.pod.io import read_basis
from sphrom.pod.pipeline import basis_for_scene
from sphrom.rom.registry import get_model
from sphrom.rom.stepping import (linearized_jacobian, reduced_amplification, reduced_energy,
                                  reduced_stability_warnings, reduced_step_matrix)
from sphrom.scene import dump_toml, load_scene, scene_dict
from sphrom.sph.solver import BLOWUP_FACTOR, GROWTH_WARN, build_problem, energy_bound_factors, step_count


def _stiff_scene(tmp_path, T=0.5, name="stiff_rom"):
    """Undamped, unforced, c = 100 at N = 50 (omega_max ~ 500 rad/s), dt = 1 ms: symplectic Euler is stable
    (omega_max dt ~ 0.5 < 2), explicit Euler amplifies every undamped mode by |1 + i omega dt| per step."""
    data = scene_dict(load_scene("multimode"))
    data["name"] = name
    data["domain"]["T"] = T
    data["fields"].update(c="100", v0="1e-3*sin(2*pi*x) + 1e-4*sin(8*pi*x)")
    data["sph"].update(n_particles=50, dt=1e-3, every=10, integrator="symplectic")
    data["snapshots"] = {"count": 20, "window": [0.0, T]}
    data["rom"] = {"modes": 8}
    path = tmp_path / f"{name}.toml"
    path.write_text(dump_toml(data))
    return path


@pytest.fixture(scope="module")
def stiff(tmp_path_factory):
    path = _stiff_scene(tmp_path_factory.mktemp("stiff"))
    scene = load_scene(path)
    problem = build_problem(scene)
    basis, _ = basis_for_scene(scene, progress=False, problem=problem)
    return path, scene, problem, basis


def test_amplification_is_the_step_matrix_spectrum(stiff):
    """Euler's factor over the run is max |1 + lambda dt|^n over the eigenvalues of the linearised reduced
    operator; for an undamped mode lambda = i omega that is (1 + omega^2 dt^2)^(n/2)."""
    _, scene, problem, basis = stiff
    ops = get_model("frozen").build(problem, basis, 8, 8)
    J = linearized_jacobian(ops)
    lam = np.linalg.eigvals(J)
    dt, n = scene.sph.dt, step_count(scene.T, scene.sph.dt)
    growth, omega = reduced_amplification(ops, dt, "euler", scene.T)
    assert growth == pytest.approx(np.max(np.abs(1 + lam * dt)) ** n, rel=1e-9)
    fastest = lam[np.argmax(np.abs(1 + lam * dt))]
    assert omega == pytest.approx(np.angle(1 + fastest * dt) / dt, rel=1e-9)
    w = abs(fastest.imag)
    assert abs(fastest.real) < 1e-6 * w             # undamped: the mode is on the imaginary axis
    assert growth == pytest.approx((1 + (w * dt) ** 2) ** (n / 2), rel=1e-3)
    # RK4's step matrix is the degree-4 Taylor polynomial of e^{dt J}; symplectic Euler is a rotation here
    S = reduced_step_matrix(J, ops.k_v, dt, "rk4")
    mu = np.sort_complex(np.linalg.eigvals(S))
    z = lam * dt
    assert np.allclose(mu, np.sort_complex(1 + z + z ** 2 / 2 + z ** 3 / 6 + z ** 4 / 24), rtol=0, atol=1e-9)
    assert reduced_amplification(ops, dt, "symplectic", scene.T)[0] <= 1 + 1e-9


def test_unstable_reduced_run_warns_then_exits_3(stiff, tmp_path, capsys):
    path, scene, problem, basis = stiff
    b = tmp_path / "basis.h5"
    assert main(["pod", str(path), "--out", str(b), "--quiet"]) == 0
    capsys.readouterr()
    out = tmp_path / "rom.h5"
    code = main(["rom", str(path), "--basis", str(b), "--model", "frozen", "--integrator", "euler",
                 "--out", str(out), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 3, err
    assert len(err) == 2 and "Traceback" not in "\n".join(err), err
    warning, failure = err
    assert warning.startswith("sphrom rom: warning: 'euler' amplifies") and "by a factor" in warning
    written = read_basis(b)
    ops = get_model("frozen").build(problem, written, *[int(written.attrs[f"default_modes_{s}"]) for s in ("v", "rho")])
    growth = reduced_amplification(ops, scene.sph.dt, "euler", scene.T)[0]
    assert growth > 1e6 * GROWTH_WARN
    assert float(re.search(r"by a factor ([0-9.e+]+)", warning).group(1)) == pytest.approx(growth, rel=1e-2)
    assert failure.startswith("sphrom rom: failed: frozen reduced run blew up by step") and "t = " in failure
    assert f"{BLOWUP_FACTOR:g} x the bound" in failure
    step = int(re.search(r"by step (\d+)", failure).group(1))
    assert 0 < step < step_count(scene.T, scene.sph.dt)          # stopped before the end, the state still finite
    assert not out.exists()
    # the same basis and scene with symplectic Euler: no warning, no failure
    assert main(["rom", str(path), "--basis", str(b), "--model", "frozen", "--integrator", "symplectic",
                 "--out", str(out), "--quiet"]) == 0
    assert capsys.readouterr().err == "" and out.exists()


@pytest.mark.parametrize("name", ["frozen", "linearized", "original"])
def test_library_raises_simulation_error_while_finite(stiff, name):
    _, scene, problem, basis = stiff
    model = get_model(name)
    ops = model.build(problem, basis, 8, 8, **model.paper_build)
    n = step_count(scene.T, scene.sph.dt)
    with pytest.raises(SimulationError, match="blew up by step") as info:
        model.run(ops, problem, dt=scene.sph.dt, n_steps=n, options=model.options(integrator="euler"))
    assert 0 < info.value.step < n and info.value.time == pytest.approx(info.value.step * scene.sph.dt)
    assert reduced_stability_warnings(model, ops, scene.sph.dt, "euler", scene.T)
    # stable settings: no warning, and the run completes with its energy within the bound
    res = model.run(ops, problem, dt=scene.sph.dt, n_steps=n, options=model.options(integrator="symplectic"),
                    every=10)
    assert reduced_stability_warnings(model, ops, scene.sph.dt, "symplectic", scene.T) == []
    e = [reduced_energy(ops, problem, av, ar) for av, ar in zip(res.a_v, res.a_rho)]
    assert max(e) < 1.1 * e[0]                  # undamped, unforced: the energy stays near its initial value


@pytest.mark.parametrize("base", ["multimode", "damped_forced", "tenmode", "heterogeneous"])
def test_no_false_alarm_on_training_scenes(base):
    """The training scenes, shrunk, at the paper's integrator (explicit Euler) and step: no warning, no blow-up,
    and the reconstructed energy stays within a few percent of the exact dynamics' bound (far below 1e4 x)."""
    scene = small_scene(base, T=1.0, n=40)
    problem = build_problem(scene)
    basis, _ = basis_for_scene(scene, progress=False, problem=problem)
    n = step_count(scene.T, scene.sph.dt)
    sigma, lam = energy_bound_factors(problem)
    k = min(8, *basis.max_modes)
    for name in ("frozen", "linearized"):
        model = get_model(name)
        ops = model.build(problem, basis, k, k, **model.paper_build)
        assert reduced_stability_warnings(model, ops, scene.sph.dt, "euler", scene.T) == []
        res = model.run(ops, problem, dt=scene.sph.dt, n_steps=n, options=model.options(integrator="euler"),
                        every=scene.sph.every)
        e = np.array([reduced_energy(ops, problem, av, ar) for av, ar in zip(res.a_v, res.a_rho)])
        f = np.abs(scene.force(np.arange(n + 1) * scene.sph.dt)) if problem.terms["force_profile"] else np.zeros(n + 1)
        f_int = np.concatenate([[0.0], np.cumsum(f[:-1]) * scene.sph.dt])[res.steps]
        bound = (np.exp(lam * res.t) * (np.sqrt(e[0]) + sigma * f_int)) ** 2
        assert np.max(e / bound) < 1.2, (base, name, np.max(e / bound))


@pytest.mark.parametrize("name", ["exact", "frozen", "balanced"])
def test_forced_run_from_rest_is_not_a_runaway(name):
    """A scene starting at rest under a force: the linear models' runaway bound was 1e6 |z0| = 0 and stopped
    the run at its first sample; now it counts the forcing (|z| <= |z0| + |B| int |f| for the exact model)."""
    from sphrom.rom.exact_linear import linear_runaway_bound
    scene = small_scene("damped_forced", T=0.5, n=32, v0="0")
    problem = build_problem(scene)
    model = get_model(name)
    basis = basis_for_scene(scene, progress=False, problem=problem)[0] if model.needs_basis else None
    ops = model.build(problem, basis, 4, 4)
    res = model.run(ops, problem, dt=scene.sph.dt, n_steps=step_count(scene.T, scene.sph.dt), every=50,
                    force=scene.force)
    assert np.all(np.isfinite(res.z)) and np.max(np.abs(res.z)) > 0
    if name == "exact":
        h = res.settings["step"]
        f_int = h * float(np.sum(np.abs(scene.force(np.arange(res.t.size + 1) * h))))
        assert np.max(np.linalg.norm(res.z, axis=1)) <= linear_runaway_bound(ops, f_int) / 1e6 * 1.01


def test_exact_fmu_forced_from_rest_is_not_a_runaway(tmp_path):
    """The exact FMU of a scene at rest, driven by a force: its packaged bound was 1e6 |z0| = 0 (a runaway at the
    first forced step); it is now 1e6 (|z0| + |B| int |f| dt) over the scene's force, so the forced run goes on
    and equals the Python exact model (held input)."""
    import zipfile

    from sphrom.fmu.make.build import ensure_binaries
    from sphrom.fmu.run.driver import FMU
    from sphrom.fmu.make.models import exact_model
    from sphrom.fmu.make.package import package_fmu
    from sphrom.rom.exact_linear import run_exact
    from test_fmu_exact import probe_outputs, relative_residual
    from sphrom.fmu.resources import unpack
    scene = small_scene("damped_forced", T=0.5, n=32, v0="0")
    path = tmp_path / "rest.fmu"
    package_fmu(scene, path, k=4, fmi=2, progress=False, binaries=ensure_binaries(), model="exact")
    data = unpack(zipfile.ZipFile(path).read("resources/model.bin"))
    assert data.bound > 0 and not np.any(data.z0)                # at rest, and still a bound to scale by
    h, m = 0.01, 30
    t = np.arange(m + 1) * h
    f = 1e-2 * np.sin(2 * np.pi * 3 * t[:-1])
    with FMU(path) as s:
        s.initialize()
        out = s.run([h] * m, f)
    assert np.all(np.isfinite(out)) and np.max(np.abs(out[:, 0])) > 0
    dense, lin, _, _ = exact_model(scene, 4, (0.25, 0.5, 0.66), progress=False)   # rows over the dense z
    force = lambda s_: 1e-2 * np.sin(2 * np.pi * 3 * np.floor(np.asarray(s_, float) / h + 1e-9) * h)  # noqa: E731
    ref = probe_outputs(dense, run_exact(lin, t, step=h, force=force, hold="held").z)
    assert relative_residual(out, ref) <= 1e-10
