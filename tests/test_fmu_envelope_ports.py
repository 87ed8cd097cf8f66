"""The training envelope of a frozen port FMU: port forces at the level its accuracy was measured at (open loop
and coupled, sphrom.bench.port_coupling) do not warn; a port force that drives the probe strain beyond the
failure strain (0.04) does.

The envelope is recorded from the scene's training run, which has no port force.  The coordinates appended
for the ports are exact input directions (each port's profile and its Krylov response,
sphrom.rom.operators.port_directions), not trained POD directions: they are never checked against that
run's ranges (section ENVPORT names them).  Once a port force has acted the state holds a response the
training run never saw, by design: from then on only |f| and the failure strain are checked (the frozen
model's port error is measured to hold there: docs/fmu/envelope.md); until then, and after a reset,
a port FMU is checked as one without ports.

These are the FMUs whose ports enter the basis: a scene whose damping varies along the bar, or the build option
``port_channel=False`` (the fixture's).  With the port channel (every uniform-d scene's port FMU,
sphrom.rom.port_channel) a port force never reaches the model's own state, and the envelope keeps guarding it
(the last test).
"""

import zipfile

import numpy as np
import pytest

from sphrom.bench.lib.ports import PORTS, open_loop_forces
from sphrom.fmu.training import envelope as E
from sphrom.fmu.make.build import ensure_binaries
from sphrom.fmu.run.core import Core
from sphrom.fmu.run.driver import FMU
from sphrom.fmu.make.package import package_fmu
from sphrom.fmu.resources import unpack
from sphrom.fmu.variables import vr
from sphrom.scene import load_scene

F_PORT = [vr("F_port_j", j) for j in (1, 2)]
V_PORT = [vr("v_port_j", j) for j in (1, 2)]

ENVELOPE_TEXT = "outside the training envelope"
H = 1e-3


@pytest.fixture(scope="module")
def port_fmu(tmp_path_factory):
    """(path, data, scene): damped_forced's frozen port FMU with its ports in the basis (build option
    port_channel=False, symplectic Euler: as sphrom.bench.port_coupling measured it before the port channel; k = 12,
    ports at x/L = 0.3 and 0.7, FMI 2)."""
    scene = load_scene("damped_forced")
    path = tmp_path_factory.mktemp("envelope-port-fmu") / "frozen-ports.fmu"
    package_fmu(scene, path, k=12, fmi=2, progress=False, binaries=ensure_binaries(), model="frozen", ports=PORTS,
                error_bounds=False,              # the envelope is the error signal of an FMU without bounds
                integrator="symplectic", build_options={"port_channel": False})
    return path, unpack(zipfile.ZipFile(path).read("resources/model.bin")), scene


def run(path, scene, t_end, forces):
    """(envelope warnings, largest probe strain, errors) of the FMU over [0, t_end] at steps of H with the scene's
    f and the port forces ``forces(t) -> (P,)`` [N] held over each step."""
    n = int(round(t_end / H))
    strain = 0.0
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        rho0 = E.Envelope.from_sections(unpack(zipfile.ZipFile(path).read("resources/model.bin")).sections,
                                        0).probe_rho0
        rho_vr = [s.vr[name] for name in s.outputs if name.startswith("rho_probe_")]
        for i in range(n):
            t = i * H
            s.set_input(float(scene.force(t)))
            s.set_real(F_PORT, list(forces(t)))
            s.do_step(t, H)
            strain = max(strain, float(np.max(np.abs(rho0 / s.get_real(rho_vr) - 1.0))))
        warnings = [text for status, _, text in s.messages if status == 1 and ENVELOPE_TEXT in text]
        return warnings, strain, s.errors()


def coupled_run(path, scene, t_end):
    """(envelope warnings, errors) of the coupled example of sphrom.bench.port_coupling: a lumped mass-spring
    on port 1 (its spring force, up to 5e-3 N, held as F_port_1), port 2 open loop."""
    from sphrom.bench.lib.ports import STIFFNESS, S0, mass_spring_step
    n = int(round(t_end / H))
    y = np.array([S0, 0.0])
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        for i in range(n):
            t = i * H
            v_port = s.get_real(V_PORT)
            F = open_loop_forces(t)[0]
            F[0] = STIFFNESS * y[0]
            s.set_input(float(scene.force(t)))
            s.set_real(F_PORT, list(F))
            s.do_step(t, H)
            y = mass_spring_step(y, v_port[0], H)
        return [text for status, _, text in s.messages if status == 1 and ENVELOPE_TEXT in text], s.errors()


def test_port_forces_at_the_measured_level_do_not_warn(port_fmu):
    """The open-loop port forces of sphrom.bench.port_coupling (1e-3 N, which move the port velocities by 47 %
    and at which the FMU's port error was measured, 5.2e-3), the coupled mass-spring (up to 5e-3 N on port 1,
    port error 1.0e-2) and 5x the open-loop forces (port error 0.47 % over 1 s, probe strain 3.7x the trained):
    no warning; the same FMU without port forces: none either.  (Before port forces were judged apart from
    the training run, each of these warned: a port coordinate, or a POD coordinate the port force moved.)"""
    path, _, scene = port_fmu
    for scale in (0.0, 1.0, 5.0):
        warnings, strain, errors = run(path, scene, 1.0, lambda t, a=scale: a * open_loop_forces(t)[0])
        assert warnings == [] and errors == [], (scale, warnings)
        assert strain < E.FAILURE_STRAIN
    warnings, errors = coupled_run(path, scene, 1.0)
    assert warnings == [] and errors == [], warnings


def test_a_port_force_beyond_the_failure_strain_warns_once(port_fmu):
    """20x the open-loop port forces strain the probes beyond 0.04 (where eq. 2.17's linearization is measured
    to fail): one warning, naming the probe strain."""
    path, _, scene = port_fmu
    warnings, strain, errors = run(path, scene, 0.5, lambda t: 20.0 * open_loop_forces(t)[0])
    assert strain > E.FAILURE_STRAIN and errors == []
    assert len(warnings) == 1, warnings
    assert "strain |rho0/rho - 1|" in warnings[0] and f"above {E.FAILURE_STRAIN:.3g}" in warnings[0], warnings


def test_the_training_envelope_still_guards_a_port_fmu_until_a_port_force_acts(port_fmu):
    """Without port forces a port FMU is checked as one without ports: 10x the initial state warns (a
    coordinate).  The port-driven mark is part of the FMU state: a state serialized after port-forced steps
    and restored in a fresh instance stays port-driven (10x the initial state is then judged by the failure
    strain alone); reset clears it."""
    path, _, scene = port_fmu

    def warnings_of(s):
        return [text for status, _, text in s.messages if status == 1 and ENVELOPE_TEXT in text]

    with FMU(path) as s:
        s.initialize(initial_state_scale=10)
        for i in range(20):
            s.do_step(i * H, H)
        assert len(warnings_of(s)) == 1 and "reduced coordinate" in warnings_of(s)[0], warnings_of(s)
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        s.set_real(F_PORT[:1], [1e-3])
        s.do_step(0.0, H)
        s.set_real(F_PORT[:1], [0.0])
        blob = s.serialize(s.get_state())
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        s.set_state(s.deserialize(blob))
        for i in range(1, 200):
            s.set_input(float(scene.force(i * H)))
            s.do_step(i * H, H)
        assert warnings_of(s) == [] and s.errors() == []
        s.reset()
        s.initialize(initial_state_scale=10)
        for i in range(20):
            s.do_step(i * H, H)
        assert any("reduced coordinate" in m for m in warnings_of(s)), warnings_of(s)


def test_port_directions_are_named_and_c_agrees_with_python(port_fmu):
    """ENVPORT holds the numbers of trailing port coordinates of a^v and a^rho (the columns
    sphrom.rom.operators appended for the ports), read back by the C core bitwise; the relative probe-strain
    check is off with ports; after a step from a start pushed along a port direction the C check and
    envelope.check find nothing, from one pushed along a POD direction both name that coordinate."""
    from sphrom.fmu.resources import pack
    path, data, _ = port_fmu
    env = E.Envelope.from_sections(data.sections, data.k_v)
    assert 0 < env.port_v < data.k_v and 0 < env.port_rho < data.k_rho
    assert env.checks & E.CHECK_STRAIN and env.checks & E.CHECK_COORDINATES and env.checks & E.CHECK_FAILURE
    core = Core(ensure_binaries().core)
    cm = core.load(zipfile.ZipFile(path).read("resources/model.bin"))
    assert np.array_equal(cm.section("ENVPORT"), data.sections["ENVPORT"])
    assert cm.envelope_check() is None
    widen = (env.margin - 1.0) * 0.5 * (env.hi - env.lo)[:data.k_v].max()
    for coordinate, expected in ((data.k_v - 1, None), (0, "a_v_1")):      # the last a^v column is a port's
        pushed = unpack(pack(data))
        pushed.a_v0 = data.a_v0.copy()
        pushed.a_v0[coordinate] = env.hi[coordinate] + 1.5 * widen
        cmp = core.load(pack(pushed))
        cmp.do_step(0.0, H)
        found = E.check(env, cmp.reduced_state(), 0.0, cmp.outputs(data.n_probes)[1], data.k_v)
        message = cmp.envelope_check()
        if expected is None:
            assert found is None and message is None, (found, message)
        else:
            assert found[0] == expected and f"{expected} = " in message, (found, message)
            z, rho = cmp.reduced_state(), cmp.outputs(data.n_probes)[1]
            assert E.check(env, z, 0.0, rho, data.k_v, port_driven=True) is None     # port-driven: not judged


@pytest.mark.parametrize("value, message", [
    (np.array([[1.0, 2.0, 3.0]]), "'ENVPORT' is 1 x 3, expected 1 x 2"),
    (np.array([[1.5, 0.0]]), "'ENVPORT': 1.5 port coordinates in block 1"),
    (np.array([[0.0, -1.0]]), "'ENVPORT': -1 port coordinates in block 2"),
    (np.array([[1e6, 0.0]]), "'ENVPORT': 1e+06 port coordinates in block 1")])
def test_a_bad_envport_section_is_refused_naming_it(port_fmu, value, message):
    from sphrom.fmu.run.core import CoreError
    from sphrom.fmu.resources import pack
    _, data, _ = port_fmu
    bad = unpack(pack(data))
    bad.sections["ENVPORT"] = value
    with pytest.raises(CoreError, match=message.replace("(", r"\(").replace("+", r"\+")):
        Core(ensure_binaries().core).load(pack(bad))


def test_with_the_port_channel_the_envelope_keeps_guarding_the_model(tmp_path):
    """The port channel takes every port force (no PORTB, no ENVPORT): 20x the open-loop port forces (probe strains
    beyond 0.04, exact in J in the channel: no linearisation there) do not warn, and after them 10x the initial
    state still warns by a reduced coordinate (the model's own state never saw a port force: not port-driven)."""
    scene = load_scene("damped_forced")
    path = tmp_path / "channel.fmu"
    package_fmu(scene, path, k=12, fmi=2, progress=False, binaries=ensure_binaries(), model="frozen", ports=PORTS,
                error_bounds=False)
    data = unpack(zipfile.ZipFile(path).read("resources/model.bin"))
    assert "PCSCAL" in data.sections and "PORTB" not in data.sections and "ENVPORT" not in data.sections
    warnings, strain, errors = run(path, scene, 0.5, lambda t: 20.0 * open_loop_forces(t)[0])
    assert strain > E.FAILURE_STRAIN and warnings == [] and errors == []
    with FMU(path) as s:
        s.initialize(initial_state_scale=10)
        for i in range(20):
            s.set_real(F_PORT, [1e-3, -1e-3])
            s.do_step(i * H, H)
        found = [text for status, _, text in s.messages if status == 1 and ENVELOPE_TEXT in text]
        assert len(found) == 1 and "reduced coordinate" in found[0], found
