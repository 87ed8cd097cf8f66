"""A frozen port FMU in a damped sampled loop for longer than its scene: its own state conserves the energy it started
with (no port force ever reaches it: the port channel takes them), and its port velocity follows the full SPH in
the same loop.

The defect this guards against (docs/fmu/ports.md, "The integrator of a port FMU"): the frozen port FMU's own part
stepped with the scene's explicit Euler, which multiplies each undamped mode's energy by 1 + (ω dt)² a step; on
heterogeneous (N = 100, dt = 2e-4 s) its density went negative at probe 1 at t = 194.56 s of the ports bench's
damped loop, while the full SPH in the same loop stays within 2 % of ρ0 (``sphrom bench port_integrator --sph``)."""

import zipfile

import numpy as np
import pytest

from conftest import small_scene
from sphrom.bench.lib.ports import damped_loop, frozen_fields, lumped_energy
from sphrom.fmu.kinds.frozen import reduced_model
from sphrom.fmu.make.options import default_integrator
from sphrom.fmu.make.package import package_fmu
from sphrom.fmu.run.master import CoreBar, SPHBar
from sphrom.rom.stepping import reduced_amplification

PORTS = (0.3, 0.7)
PROBES = (0.25, 0.5, 0.66)          # the FMU's default probes
H, DAMPING, T_LOOP = 1e-2, 0.1, 20.0  # the ports bench's damped loop: 10 ms steps, a dashpot of 0.1 N s/m; 20 s


def loop(bar, n_steps, watch):
    """Port 1 of ``bar`` tied to the bench's mass-spring-damper (sphrom.bench.lib.ports.damped_loop): v_port_1 at
    every communication point, ``watch()`` there and the mass-spring's energy ½ m w² + ½ k s² [J]."""
    v, seen, stop = damped_loop(lambda: bar.port_velocities()[0], lambda F: bar.step(H, [F, 0.0]), n_steps,
                                lambda y: (watch(), lumped_energy(y)), H, DAMPING)
    assert stop is None, stop
    return v, np.array([s[0] for s in seen]), np.array([s[1] for s in seen])


@pytest.fixture(scope="module")
def het(tmp_path_factory):
    """A small heterogeneous bar (c jumping from 0.1 to 0.2 at L/2, undamped, f = 0, the scene's explicit Euler at a
    long step so that its growth shows within the loop), its frozen port FMU's model.bin at the default integrator
    (key None) and with explicit Euler, and the FMU's own model built in Python (its bases: the energy of the FMU's
    own state)."""
    scene = small_scene("heterogeneous", T=2.0, n=32, dt=5e-3)
    assert scene.sph.integrator == "euler" and default_integrator(scene, PORTS) != "euler"
    folder = tmp_path_factory.mktemp("loop-energy")
    blobs = {}
    for integrator in (None, "euler"):                 # the default, and the scene's own as before the fix
        path = folder / f"het-frozen-{integrator}.fmu"
        package_fmu(scene, path, model="frozen", k=6, ports=PORTS, progress=False, verify=False, error_bounds=False,
                    integrator=integrator)
        blobs[integrator] = zipfile.ZipFile(path).read("resources/model.bin")
    _, ops, problem, _ = reduced_model(scene, 6, 10, PROBES, default_integrator(scene, PORTS), progress=False,
                                       ports=PORTS)
    return scene, problem, ops, blobs


def own_run(blob, ops, problem, n):
    """The FMU of ``blob`` through its C core in the damped loop: (v_port_1, its own state's energy) per point."""
    bar = CoreBar(blob, initial_state_scale=1.0)
    try:
        np.testing.assert_allclose(bar.model.reduced_state(), np.r_[ops.a_v0, ops.a_rho0], rtol=1e-12, atol=1e-15)
        fields = frozen_fields(ops, problem)
        v, e_own, _ = loop(bar, n, lambda: fields(bar.model.reduced_state())[0])
    finally:
        bar.close()
    return v, e_own


def test_frozen_port_fmu_keeps_its_energy_in_a_damped_loop(het):
    """From the scene's initial state, 20 s (ten times the scene's T) in the damped loop.  Explicit Euler at this dt
    would amplify the model's fastest mode more than 100-fold over the run; the full SPH in the same loop
    (symplectic Euler) loses coupled energy (the bar's and the mass-spring's) to the dashpot.  The default FMU's own
    state, which no port force reaches, keeps its starting energy within 5 % at every point (undamped, unforced:
    conserved up to the frozen model's own linearisation), and its v_port_1 is within 5e-2 (relative L2) of the full
    SPH's; the same FMU with explicit Euler grows its own energy more than tenfold (what the default avoids)."""
    scene, problem, ops, blobs = het
    n = int(round(T_LOOP / H))
    euler_growth = reduced_amplification(ops, scene.sph.dt, "euler", T_LOOP)[0]
    assert euler_growth > 100.0, euler_growth            # the setting shows the growth an integrator adds
    sph = SPHBar(scene, PORTS, initial_state_scale=1.0, problem=problem)
    v_sph, e_sph, lumped = loop(sph, n, sph.energy)
    total = e_sph + lumped
    assert total[-1] < 0.5 * total[0], total[[0, -1]]      # the dashpot takes energy out of the coupled system
    v, e_own = own_run(blobs[None], ops, problem, n)
    drift = np.abs(e_own / e_own[0] - 1.0).max()
    error = float(np.linalg.norm(v - v_sph) / np.linalg.norm(v_sph))
    assert drift < 0.05, (drift, euler_growth)
    assert error < 5e-2, (error, euler_growth)
    _, e_euler = own_run(blobs["euler"], ops, problem, n)
    assert e_euler.max() > 10.0 * e_euler[0], e_euler.max() / e_euler[0]
