"""A system simulator's master loop around a bar with ports (sphrom.fmu.run.master): a mass on a
spring at each of two ports, Jacobi and Gauss-Seidel against the monolithic coupled system integrated exactly, the
port FMUs against the full SPH in the same loop, and the wave form passive at any communication step."""

import zipfile

import numpy as np
import pytest

from conftest import small_scene
from sphrom.fmu.make.package import package_fmu
from sphrom.fmu.run.master import CoreBar, FMUBar, LinearBar, MassSpring, SPHBar, monolithic, run_loop
from sphrom.sph.solver import build_problem

PORTS = (0.3, 0.7)
MASS, STIFFNESS, S0 = 0.05, 5.0, 1e-3


def springs():
    return [MassSpring(MASS, STIFFNESS, S0), MassSpring(MASS, STIFFNESS, -S0)]


def rel(a, b):
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


@pytest.fixture(scope="module")
def undamped():
    scene = small_scene("multimode", T=1.0, n=32)
    return scene, build_problem(scene)


@pytest.fixture(scope="module")
def port_fmus(tmp_path_factory):
    """fmus(base) -> {model: path} of the frozen and the exact port FMU (the port channel) of a small bar, packaged
    once each."""
    folder = tmp_path_factory.mktemp("loop-fmus")
    made = {}

    def fmus(base):
        if base not in made:
            scene = small_scene(base, T=1.0, n=32)
            made[base] = {}
            for model in ("frozen", "exact"):
                path = folder / f"{base}-{model}.fmu"
                package_fmu(scene, path, model=model, k=6, ports=PORTS, progress=False, verify=False,
                            error_bounds=False)
                made[base][model] = path
        return made[base]
    return fmus


def test_monolithic_conserves_energy_and_the_loops_converge_to_it(undamped):
    """The monolithic system (the full linear SPH and the masses on their springs, exact in time) keeps the coupled
    energy of an undamped bar to round-off; the Jacobi and Gauss-Seidel loops around the same linear SPH (exact in
    time between exchanges) converge to it at first order in the communication step (error ratio near 2 when h
    halves)."""
    scene, problem = undamped
    T = 0.5
    mono = monolithic(problem, PORTS, springs(), 1e-3, 500, initial_state_scale=1.0)
    assert np.abs(mono.energy / mono.energy[0] - 1.0).max() < 1e-10
    for master in ("jacobi", "gauss_seidel"):
        errors = []
        for h in (2e-3, 1e-3):
            n = int(round(T / h))
            ref = monolithic(problem, PORTS, springs(), h, n, initial_state_scale=1.0)
            run = run_loop(LinearBar(problem, PORTS, initial_state_scale=1.0), springs(), h, n, master)
            errors.append(rel(run.v_port, ref.v_port))
        assert errors[1] < 5e-2, (master, errors)
        assert 1.6 < errors[0] / errors[1] < 2.5, (master, errors)


@pytest.mark.parametrize("master", ["jacobi", "gauss_seidel"])
def test_port_fmus_follow_the_full_sph_in_the_same_loop(undamped, port_fmus, master):
    """The frozen and the exact port FMU (FMI 2 through fmpy) in a 1 ms loop with a mass on a spring at each of two
    ports of an undamped bar, from the scene's initial state: v_port within 5e-2 (relative L2 over 1 s) of the full
    SPH in the same loop."""
    scene, problem = undamped
    h, n = 1e-3, 1000
    sph = run_loop(SPHBar(scene, PORTS, initial_state_scale=1.0, problem=problem), springs(), h, n, master)
    for model, path in port_fmus("multimode").items():
        bar = FMUBar(path, initial_state_scale=1.0)
        try:
            run = run_loop(bar, springs(), h, n, master)
        finally:
            bar.close()
        assert np.all(np.isfinite(run.v_port))
        assert rel(run.v_port, sph.v_port) < 5e-2, (model, master, rel(run.v_port, sph.v_port))


@pytest.mark.parametrize("base", ["multimode", "damped_forced"])
def test_wave_loop_never_grows_the_coupled_energy(base, port_fmus):
    """The wave form through the FMU's C core (port_impedance Z = k h, inputs a_port_j, outputs b_port_j), the masses
    on the lines' other ends, from rest with f = 0: the coupled energy (the port channel's, the masses', the waves'
    in the lines) never grows over a step, at steps of 1, 10 and 50 ms, undamped and damped, frozen and exact; the
    explicit Jacobi loop around the undamped bar does grow it at 50 ms (what the wave form is for)."""
    for model, path in port_fmus(base).items():
        blob = zipfile.ZipFile(path).read("resources/model.bin")
        for h in (1e-3, 1e-2, 5e-2):
            bar = CoreBar(blob, initial_state_scale=0.0, impedance=STIFFNESS * h)
            try:
                run = run_loop(bar, springs(), h, int(round(2.0 / h)), "wave", energy=bar.energy)
            finally:
                bar.close()
            e = run.energy
            assert np.all(np.isfinite(e)) and e[0] > 0
            assert np.all(np.diff(e) <= 1e-12 * e[0]), (model, h, np.diff(e).max() / e[0])
        if base == "multimode" and model == "exact":
            bar = CoreBar(blob, initial_state_scale=0.0)
            try:
                run = run_loop(bar, springs(), 5e-2, 40, "jacobi", energy=bar.energy)
            finally:
                bar.close()
            assert run.energy.max() > 1.01 * run.energy[0]
