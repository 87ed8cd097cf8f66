"""Mechanical ports: point forces F_j [N] spread by the SPH kernel, port velocities Σ_i W(x_i - x_j, h) v_i Δx.

The full SPH with port forces (:mod:`sphrom.sph.ports`), the reduced models that take them as inputs (frozen,
exact), the FMU's F_port_j / v_port_j / area against those models, and a coupled example (the FMU and a lumped
mass-spring exchanging force and velocity each communication step) against one full SPH of the coupled system.
"""

import numpy as np
import pytest

from conftest import small_scene, model_per_kind
from sphrom.errors import FieldError
from sphrom.fmu.variables import vr
from sphrom.sph.ports import momentum_weights, parse_ports, port_accelerations, port_velocity_rows, run_sph_ports
from sphrom.sph.solver import build_problem

F_PORT = [vr("F_port_j", j) for j in (1, 2)]
V_PORT = [vr("v_port_j", j) for j in (1, 2)]


def port_forces(t):
    """Two port forces [N] that no model was trained on."""
    t = np.atleast_1d(np.asarray(t, float))
    return 1e-3 * np.stack([np.sin(5 * t + 0.3), np.cos(2 * t) ** 2], axis=-1)


def test_port_force_changes_total_momentum_by_its_impulse():
    """d/dt Σ m_i v_i = Σ_j F_j S_j (m_i = ρ0 A Δx, S_j = Σ_i W_ij Δx): the SPH pressure conserves momentum, so
    with d = f = 0 the momentum gained over the run is the port impulse, to round-off (explicit Euler sums the
    forces at t_n exactly so), for any area A (the mass per length ρ0 A scales out); S_j is 1 to 1e-5."""
    scene = small_scene("multimode", T=0.5, n=32)
    problem = build_problem(scene)
    assert not problem.terms["damping"]
    ports = [0.1, 0.6]
    S = momentum_weights(problem, ports)
    assert np.all(np.abs(S - 1.0) < 1e-5)
    dt = scene.sph.dt
    n = int(round(scene.T / dt))
    impulse = dt * float(np.sum(port_forces(np.arange(n) * dt) @ S))
    for area in (1.0, 2.5):
        run = run_sph_ports(scene, ports, forces=lambda t: port_forces(t)[0], area=area, problem=problem, every=100)
        gained = run.momentum[-1] - run.momentum[0]
        assert abs(gained - impulse) <= 1e-12 * abs(impulse) + 1e-18
        assert abs(impulse) > 1e-5
    free = run_sph_ports(scene, ports, problem=problem, every=100)
    assert abs(free.momentum[-1] - free.momentum[0]) < 1e-18


def test_port_power_is_force_times_port_velocity():
    """Σ_i (ρ0 A Δx) v_i a_i = Σ_j F_j v_port_j: v_port is the velocity power-conjugate to F."""
    problem = build_problem(small_scene("multimode", T=0.5, n=32))
    ports = [0.2, 0.55]
    rng = np.random.default_rng(1)
    v, F, area = rng.normal(size=problem.n), rng.normal(size=2), 0.7
    a = F @ port_accelerations(problem, ports, area)
    power = float(np.sum(problem.rho0 * area * problem.neighbours.dx * v * a))
    assert power == pytest.approx(float(F @ (port_velocity_rows(problem, ports) @ v)), rel=1e-13)


@pytest.mark.parametrize("text", ["", "0.5,x", "1.0", "-0.1", "nan", "0.3,0.3", "0.1,0.2,0.3,0.4,0.5"])
def test_bad_ports_are_one_line_errors(text):
    with pytest.raises(FieldError, match="^ports: "):
        parse_ports(text)


# ---- the FMU with ports ------------------------------------------------------------------------------------------

FMU_PORTS = (0.3, 0.7)
H, M, AREA = 0.01, 50, 2.0


@pytest.fixture(scope="module")
def port_fmus(tmp_path_factory):
    """make(model, fmi) -> (path, data), a port FMU of the shrunk damped_forced scene (k = 6), packaged once."""
    import zipfile

    from conftest import fmu_scene
    from sphrom.fmu.make.build import ensure_binaries
    from sphrom.fmu.make.package import package_fmu
    from sphrom.fmu.resources import unpack
    folder = tmp_path_factory.mktemp("port-fmus")
    binaries = ensure_binaries()
    made = {}

    def make(model="frozen", fmi=2):
        if (model, fmi) not in made:
            path = folder / f"{model}-{fmi}.fmu"
            summary = package_fmu(fmu_scene("forced"), path, k=6, fmi=fmi, probes=(0.25, 0.5), progress=False,
                                  binaries=binaries, model=model, ports=FMU_PORTS)
            make.summaries[model, fmi] = summary
            made[model, fmi] = (path, unpack(zipfile.ZipFile(path).read("resources/model.bin")))
        return made[model, fmi]

    make.summaries = {}
    return make


def run_port_fmu(path, scene, steps=M, area=AREA, state_at=None):
    """v_port at the communication points of the FMU with port_forces held over steps of H and area set;
    ``state_at``: the step after which a state is taken and restored (the run goes on from the restored one)."""
    from sphrom.fmu.run.driver import FMU
    t = np.arange(steps + 1) * H
    with FMU(path) as s:
        s.set_real([vr("area")], [area])
        s.initialize(initial_state_scale=1)
        out = [s.get_real(V_PORT)]
        for n in range(steps):
            s.set_input(float(scene.force(t[n])))
            s.set_real(F_PORT, list(port_forces(t[n])[0]))
            s.do_step(t[n], H)
            out.append(s.get_real(V_PORT))
            if state_at == n:
                snap = s.fmu.getFMUState() if s.fmi == 2 else s.fmu.getFMUState()
                s.set_real(F_PORT, [5.0, -5.0])              # changed, then restored with the state
                s.fmu.setFMUState(snap)
        assert s.get_real([vr("area")])[0] == area
    return np.array(out)


@pytest.mark.parametrize("fmi", [2, 3])
def test_port_fmu_equals_the_python_reduced_models(port_fmus, fmi):
    """F_port_j in, v_port_j out, area dividing the inputs: every model is its portless model plus the port channel
    (sphrom.rom.port_channel), which takes the port forces; the frozen FMU equals the Python frozen model stepped
    like the FMU with the channel (its part from the C core's Taylor exponentials, the Python one's from scipy's:
    to 1e-12), the exact FMU run_exact (scipy's expm) plus the channel to 1e-12; FMI 2 and 3 alike."""
    from conftest import assert_units_through_declared_types, fmu_scene
    from sphrom.fmu.check.python_cosim import FrozenCosim
    scene = fmu_scene("forced")
    t = np.arange(M + 1) * H
    path, data = port_fmus("frozen", fmi)
    assert_units_through_declared_types(path)
    ref = FrozenCosim(data)
    ref.area = AREA
    expected = [ref.port_velocities()]
    for n in range(M):
        ref.port_forces = port_forces(t[n])[0]
        ref.do_step(H, float(scene.force(t[n])))
        expected.append(ref.port_velocities())
    out = run_port_fmu(path, scene)
    assert ref.channel is not None and "PORTB" not in data.sections
    assert np.abs(out - np.array(expected)).max() <= 1e-12 * np.abs(expected).max()
    assert np.ptp(out[:, 0]) > 0
    path, data = port_fmus("exact", fmi)
    out = run_port_fmu(path, scene)
    ref = exact_port_velocities(scene, t, "held")
    assert np.abs(out - ref).max() <= 1e-12 * np.abs(ref).max()


def exact_port_velocities(scene, t, hold):
    """v_port of the exact model with ports in Python: run_exact of its portless model (f, the initial state) plus
    the port channel's part under the port forces (:func:`sphrom.rom.port_channel.run_channel`)."""
    from sphrom.fmu.make.models import exact_model
    from sphrom.rom.exact_linear import run_exact
    from sphrom.rom.port_channel import probe_outputs, run_channel
    _, lin, _, _ = exact_model(scene, 6, (0.25, 0.5), progress=False, ports=FMU_PORTS)
    own = lin.port_velocity(run_exact(lin, t, step=H, force=scene.force, hold=hold).a_v)
    return own + probe_outputs(lin.channel, run_channel(lin.channel, t, port_forces, area=AREA, hold=hold))[2]


def test_port_fmu_state_round_trip_keeps_forces_and_area(port_fmus):
    """A state taken after a step restores the port forces and the area with it: the run from the restored
    state equals the uninterrupted run bit for bit."""
    from conftest import fmu_scene
    scene = fmu_scene("forced")
    path, _ = port_fmus("frozen", 2)
    plain = run_port_fmu(path, scene, steps=20)
    # restore after step 9: the forces set for step 10 are set again by the loop, the area comes from the state
    restored = run_port_fmu(path, scene, steps=20, state_at=9)
    assert np.array_equal(plain, restored)


@pytest.mark.parametrize("fmi", [2, 3])
def test_area_and_port_inputs_refuse_bad_values(port_fmus, fmi):
    """area <= 0 or non-finite and a non-finite port force are errors naming the variable; a port FMU declares
    area (start 1, fixed), F_port_j and v_port_j with their value references, and an FMU without ports has none."""
    import fmpy

    from sphrom.fmu.run.driver import FMU
    path, _ = port_fmus("frozen", fmi)
    md = {v.name: v for v in fmpy.read_model_description(str(path)).modelVariables}
    assert md["area"].valueReference == vr("area") and md["area"].start in ("1", 1, 1.0) and md["area"].variability == "fixed"
    assert [md[f"F_port_{j}"].valueReference for j in (1, 2)] == F_PORT
    assert [md[f"v_port_{j}"].valueReference for j in (1, 2)] == V_PORT
    assert md["F_port_1"].causality == "input" and md["v_port_2"].causality == "output"
    for bad in (0.0, -1.0, float("nan"), float("inf")):
        with FMU(path) as s:
            with pytest.raises(Exception):
                s.set_real([vr("area")], [bad])
            assert any("area" in m and "allowed: a finite number > 0" in m for m in s.errors()), s.errors()
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        with pytest.raises(Exception):
            s.set_real(F_PORT[1:], [float("nan")])
        assert any("F_port_2" in m and "not finite" in m for m in s.errors())
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        with pytest.raises(Exception):
            s.set_real([vr("area")], [2.0])                                  # fixed: not in step mode
        assert any("area is a fixed parameter" in m for m in s.errors())


def test_fmu_without_ports_has_no_port_variables(port_fmus, tmp_path):
    from conftest import fmu_scene
    from sphrom.fmu.make.build import ensure_binaries
    from sphrom.fmu.run.driver import FMU
    from sphrom.fmu.make.package import package_fmu
    path = tmp_path / "plain.fmu"
    package_fmu(fmu_scene("forced"), path, k=6, progress=False, binaries=ensure_binaries())
    with FMU(path) as s:
        assert "v_port_1" not in s.outputs
        for ref in (vr("area"), F_PORT[0], V_PORT[0]):
            with FMU(path) as t:
                t.initialize(initial_state_scale=1)
                with pytest.raises(Exception):
                    t.get_real([ref])
                assert any(f"unknown value reference {ref}" in m for m in t.errors())


@pytest.mark.parametrize("ports, detail", [("1.5", "out of range"), ("0.2,0.2", "same position"),
                                           ("a", "comma-separated"), ("0.1,0.2,0.3,0.4,0.5", "5 ports")])
def test_fmu_command_refuses_bad_ports(ports, detail, tmp_path, capsys):
    from sphrom.cli import main
    out = tmp_path / "x.fmu"
    assert main(["fmu", "damped_forced", "--ports", ports, "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("sphrom fmu: error: --ports: "), err
    assert detail in err[0] and not out.exists()


def test_coupled_example_against_one_full_sph_of_the_coupled_system():
    """damped_forced (N = 100, trained over its T = 10 s), two ports: the frozen FMU under untrained port forces,
    and coupled to a lumped mass-spring on port 1 through an fmpy loop (force and velocity exchanged every 1 ms),
    against the full SPH with the same forces and against ONE full SPH of the coupled system, over 1 s: every
    error below 2 % and within 4x the scene's POD error level (the same FMU without port forces against the
    full SPH, read through the same port rows: 0.28 %; measured 0.32 % open loop, 0.89 % coupled at port 1,
    0.92 % in the spring's elongation), while the coupling itself changes the port velocity by more than 100 %."""
    from sphrom.bench.port_coupling import measure
    row = measure(t_end=1.0, models=("frozen",))[0]
    level = row["pod_level"]
    assert 1e-3 < level < 1e-2
    assert row["coupling_effect"] > 1.0 and row["port_force_effect"] > 0.3
    for key in ("open_loop", "coupled_v_port_1", "coupled_v_port_2", "coupled_spring"):
        assert row[key] <= min(4 * level, 2e-2), (key, row)


def test_exact_port_fmu_takes_port_input_derivatives(port_fmus):
    """FMI 2, exact model: fmi2SetRealInputDerivatives (order 1) on f and the port forces makes each input go
    linearly between the communication points, equal to run_exact(hold="linear") to 1e-12; setting a force
    without a derivative holds it again; an unknown reference is named.  (The frozen FMU takes the derivatives
    too: tests/test_fmu_ports_rates.py.)"""
    from ctypes import c_double, c_int, c_uint32

    from conftest import fmu_scene
    from sphrom.fmu.run.driver import FMU
    scene = fmu_scene("forced")
    t = np.arange(M + 1) * H
    path, _ = port_fmus("exact", 2)

    def derivatives(s, refs, rates):
        n = len(refs)
        s.fmu.fmi2SetRealInputDerivatives(s.fmu.component, (c_uint32 * n)(*refs), n, (c_int * n)(*([1] * n)),
                                          (c_double * n)(*rates))

    with FMU(path) as s:
        s.set_real([vr("area")], [AREA])
        s.initialize(initial_state_scale=1)
        out = [s.get_real(V_PORT)]
        for n in range(M):
            F0, F1 = port_forces(t[n])[0], port_forces(t[n + 1])[0]
            f0, f1 = float(scene.force(t[n])), float(scene.force(t[n + 1]))
            s.set_input(f0)
            s.set_real(F_PORT, list(F0))
            derivatives(s, [vr("f"), *F_PORT], [(f1 - f0) / H, *((F1 - F0) / H)])
            s.do_step(t[n], H)
            out.append(s.get_real(V_PORT))
        out = np.array(out)
        with pytest.raises(Exception):
            derivatives(s, [F_PORT[-1] + 1], [1.0])          # one past the last port
        assert any(f"value reference {F_PORT[-1] + 1} is not a real input" in m and f"{F_PORT[0]} to {F_PORT[1]}" in m
                   for m in s.errors())
    ref, held = exact_port_velocities(scene, t, "linear"), exact_port_velocities(scene, t, "held")
    assert np.abs(out - ref).max() <= 1e-12 * np.abs(ref).max()
    assert np.abs(held - ref).max() > 1e-6 * np.abs(ref).max()            # the derivatives change the result
    with FMU(port_fmus("frozen", 2)[0]) as s:                            # the frozen FMU takes them as well
        s.initialize(initial_state_scale=1)
        derivatives(s, [3000], [1.0])
        s.do_step(0.0, H)
        assert s.get_real([3000])[0] == 1.0 * H and not s.errors()


@pytest.mark.parametrize("model", model_per_kind(needs_basis=True))
def test_packaging_checks_the_port_maps_passivity_and_says_it_on_the_page(port_fmus, model):
    """A port FMU's packaging runs the passivity check of its port map (sphrom.rom.passivity.port_passivity): on
    this uniform damped bar every model's port map is the port channel's (storage ½ α |z|², α = Δx: collocated,
    dissipative planes), passive by structure, and the FMU's page says so."""
    import zipfile
    path, _ = port_fmus(model)
    found = port_fmus.summaries[model, 2].port_passivity
    assert found.verdict == "structure", found
    alpha, beta, collocation, dissipation = found.storage
    assert alpha > 0 and beta > 0 and collocation < 1e-12 and dissipation < 1e-12, found
    page = zipfile.ZipFile(path).read("documentation/index.html").decode()
    assert "Passivity of the port map" in page and "passive by structure" in page
