"""Port-force rates on the frozen FMU: fmi2SetRealInputDerivatives (order 1) on F_port_j, taken as on f.

The frozen FMU evaluates F_j + (dF_j/dt) τ at each refresh of its force term (τ the internal step's time after
the communication point), ports in order, divided by the area after; the Python mirror
(:class:`sphrom.fmu.check.python_cosim.FrozenCosim` with ``port_rates``) computes the same bits.  With rates the
port force follows a smooth time history to second order in the communication step, where a held force is
first order: against the same FMU fed the exact force at every refresh, the rate run is much closer.

That is the frozen kind's own path, the ports in its basis (a damping that varies along the bar, or the build
option ``port_channel=False``: the fixture's).  With the port channel (sphrom.rom.port_channel) the channel takes the
port forces and integrates their rates exactly (the last test).
"""

import zipfile
from ctypes import c_double, c_int, c_uint32

import numpy as np
import pytest
from conftest import mixed_steps

from conftest import fmu_scene
from sphrom.fmu.make.build import ensure_binaries
from sphrom.fmu.run.driver import FMU
from sphrom.fmu.make.package import package_fmu
from sphrom.fmu.resources import unpack
from sphrom.fmu.variables import vr

PORTS = (0.3, 0.7)
PROBES = (0.25, 0.5)
AREA = 2.0
VR_F_PORT = [vr("F_port_j", j) for j in (1, 2)]
VR_V_PORT = [vr("v_port_j", j) for j in (1, 2)]


@pytest.fixture(scope="module")
def frozen_port_fmu(tmp_path_factory):
    """(path, data): a frozen FMI 2 port FMU of the shrunk damped_forced scene (k = 6), its ports in its basis."""
    path = tmp_path_factory.mktemp("port-rate-fmus") / "frozen-2.fmu"
    package_fmu(fmu_scene("forced"), path, k=6, fmi=2, probes=PROBES, progress=False, binaries=ensure_binaries(),
                model="frozen", ports=PORTS, integrator="symplectic", build_options={"port_channel": False})
    return path, unpack(zipfile.ZipFile(path).read("resources/model.bin"))


def forces(t):
    """Two smooth port forces [N] (a sine and a ramp), (len(t), 2): inside the level of
    sphrom.bench.port_coupling (1e-3 N)."""
    t = np.atleast_1d(np.asarray(t, float))
    return np.stack([1e-3 * np.sin(2 * np.pi * 4 * t + 0.3), 2e-3 * t], axis=-1)


def set_derivatives(s, refs, rates):
    n = len(refs)
    s.fmu.fmi2SetRealInputDerivatives(s.fmu.component, (c_uint32 * n)(*refs), n, (c_int * n)(*([1] * n)),
                                      (c_double * n)(*[float(r) for r in rates]))


def run_fmu(path, steps, F, rates=None, f=None, f_rates=None, n_freeze=None):
    """(outputs (M+1, v_probe, rho_probe, v_port), F_port read back after each step) of the port FMU over ``steps``
    with the port forces F (M, 2) set before each step, their rates when given (else held), and f with its rate."""
    out, back = [], []
    with FMU(path) as s:
        s.set_real([vr("area")], [AREA])
        s.initialize(n_freeze=n_freeze, initial_state_scale=1)
        names = [n for n in s.model_outputs if n.startswith(("v_probe_", "rho_probe_", "v_port_"))
                 and not n.endswith("_error_bound")]
        assert names[-2:] == ["v_port_1", "v_port_2"]
        out.append(s.output_values(names))
        tc = 0.0
        for n, h in enumerate(steps):
            if f is not None:
                s.set_input(f[n])
                if f_rates is not None:
                    s.set_input_derivative(f_rates[n])
            s.set_real(VR_F_PORT, list(F[n]))
            if rates is not None:
                set_derivatives(s, VR_F_PORT, rates[n])
            s.do_step(tc, h)
            tc = tc + h
            out.append(s.output_values(names))
            back.append(s.get_real(VR_F_PORT))
    return np.array(out), np.array(back)


def run_mirror(data, steps, F, rates=None, f=None, f_rates=None, n_freeze=None):
    """The same run through the Python mirror (FrozenCosim)."""
    from sphrom.fmu.check.python_cosim import FrozenCosim
    ref = FrozenCosim(data, n_freeze=n_freeze)
    ref.area = AREA

    def outputs():
        v, rho = ref.outputs()
        return np.concatenate([v, rho, ref.port_velocities()])

    out = [outputs()]
    for n, h in enumerate(steps):
        ref.port_forces = np.array(F[n], float)
        ref.port_rates = np.zeros(2) if rates is None else np.array(rates[n], float)
        ref.do_step(h, 0.0 if f is None else f[n], 0.0 if f_rates is None else f_rates[n])
        out.append(outputs())
    return np.array(out)


def test_frozen_port_fmu_with_port_rates_equals_python_bitwise(frozen_port_fmu):
    """Port-force rates (and f's rate beside them) over whole, shortened and sub-dt steps, n_freeze 1, 4, 10:
    the FMU equals the Python mirror bit for bit; after a step F_port_j reads F_j + rate_j h; zero rates give
    the held run bit for bit; the rates change the outputs."""
    path, data = frozen_port_fmu
    dt = data.dt
    scene = fmu_scene("forced")
    rng = np.random.default_rng(5)
    steps = [0.01] * 8 + [2.5 * dt, 0.3 * dt, 7.3 * dt, 13.03 * dt] + list(rng.uniform(0.5, 30, 8) * dt)
    t = np.concatenate([[0.0], np.cumsum(steps)])
    F = forces(t[:-1])
    rates = np.diff(forces(t), axis=0) / np.diff(t)[:, None]
    f = scene.force(t[:-1])
    f_rates = np.diff(scene.force(t)) / np.diff(t)
    for n_freeze in (1, 4, 10):
        out, back = run_fmu(path, steps, F, rates, f, f_rates, n_freeze=n_freeze)
        assert np.array_equal(out, run_mirror(data, steps, F, rates, f, f_rates, n_freeze=n_freeze)), n_freeze
        assert np.array_equal(back, F + rates * np.array(steps)[:, None])
        held, _ = run_fmu(path, steps, F, None, f, f_rates, n_freeze=n_freeze)
        zero, _ = run_fmu(path, steps, F, np.zeros_like(rates), f, f_rates, n_freeze=n_freeze)
        assert np.array_equal(zero, held)
        assert np.array_equal(held, run_mirror(data, steps, F, None, f, f_rates, n_freeze=n_freeze))
        v_port = slice(out.shape[1] - 2, None)
        assert np.abs(out[:, v_port] - held[:, v_port]).max() > 1e-3 * np.abs(held[:, v_port]).max()


def test_port_rate_survives_a_saved_state_and_setting_the_force_holds_it_again(frozen_port_fmu):
    """The port rates are part of the FMU state (as f's): restored, a step equals the step taken before saving;
    setting F_port_j without a new derivative holds it again (the rate is reset to 0)."""
    path, _ = frozen_port_fmu
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        s.set_real(VR_F_PORT, [1e-3, -2e-3])
        set_derivatives(s, VR_F_PORT, [0.05, 0.02])
        saved = s.get_state()
        s.do_step(0.0, 0.01)
        first = s.get_real(VR_V_PORT)
        s.set_real(VR_F_PORT, [4.0, 4.0])
        set_derivatives(s, VR_F_PORT, [-3.0, 1.0])                   # overwritten by the restored state
        s.set_state(saved)
        s.do_step(0.0, 0.01)
        assert np.array_equal(s.get_real(VR_V_PORT), first)
        assert np.array_equal(s.get_real(VR_F_PORT), [1e-3 + 0.05 * 0.01, -2e-3 + 0.02 * 0.01])
        blob = s.serialize(s.get_state())
    with FMU(path) as s:                                          # the serialized state carries the rates
        s.initialize(initial_state_scale=1)
        s.set_state(s.deserialize(blob))
        s.do_step(0.01, 0.01)
        after = s.get_real(VR_F_PORT)
        assert np.array_equal(after, [1e-3 + 0.05 * 0.01 + 0.05 * 0.01, -2e-3 + 0.02 * 0.01 + 0.02 * 0.01])
        s.set_real(VR_F_PORT, list(after))                          # set again: held from here on
        s.do_step(0.02, 0.01)
        assert np.array_equal(s.get_real(VR_F_PORT), after)


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -float("inf")])
def test_non_finite_port_rate_is_refused_naming_the_variable(frozen_port_fmu, bad):
    path, _ = frozen_port_fmu
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        with pytest.raises(Exception):
            set_derivatives(s, [3001], [bad])
        assert any("F_port_2" in m and "not finite" in m for m in s.errors()), s.errors()


def test_port_rates_make_the_frozen_port_fmu_second_order(frozen_port_fmu):
    """Against the same FMU fed the exact port forces at every refresh (communication step n_freeze dt, the
    frozen model's own sampling of its inputs), over 0.5 s at communication steps of 10 and 20 ms, v_port error
    relative to the port forces' effect on v_port: with rates it is at least 10x smaller than held (measured
    3.7e-3 against 6.6e-2 at 10 ms, 18x) and falls ~4x when the step is halved (second order: 4.1x), held
    ~2x (first order: 2.3x)."""
    path, data = frozen_port_fmu
    fine = data.n_freeze * data.dt
    t_end = 0.5
    n_fine = int(round(t_end / fine))
    t_fine = np.arange(n_fine) * fine
    ref, _ = run_fmu(path, [fine] * n_fine, forces(t_fine))
    errors = {}
    for h in (0.01, 0.02):
        n = int(round(t_end / h))
        stride = int(round(h / fine))
        t = np.arange(n + 1) * h
        F = forces(t[:-1])
        rates = np.diff(forces(t), axis=0) / h
        sub = ref[::stride, -2:]
        held, _ = run_fmu(path, [h] * n, F)
        lin, _ = run_fmu(path, [h] * n, F, rates)
        effect = np.linalg.norm(sub - run_fmu(path, [fine] * n_fine, np.zeros_like(forces(t_fine)))[0][::stride, -2:])
        errors[h] = {name: float(np.linalg.norm(v[:, -2:] - sub) / effect) for name, v in (("held", held),
                                                                                            ("rate", lin))}
    assert errors[0.01]["rate"] < 0.1 * errors[0.01]["held"], errors
    assert 3.0 < errors[0.02]["rate"] / errors[0.01]["rate"] < 5.0, errors
    assert 1.5 < errors[0.02]["held"] / errors[0.01]["held"] < 3.0, errors


def test_port_channel_takes_the_port_rates_exactly(channel_port_fmu):
    """With the port channel the port forces go linearly over each step by their rates and the channel integrates
    them exactly: the frozen FMU equals its Python mirror with the channel (FrozenCosim, scipy's exponentials
    against the C core's Taylor series) to 1e-12 over whole, shortened and sub-dt steps, and the rates change the
    port velocities."""
    path, data = channel_port_fmu           # conftest.py: the same ports (PORTS) and probes (PROBES)
    steps, t = mixed_steps(data.dt)
    F, rates = forces(t[:-1]), np.diff(forces(t), axis=0) / np.diff(t)[:, None]
    out, back = run_fmu(path, steps, F, rates)
    mirror = run_mirror(data, steps, F, rates)
    assert np.abs(out - mirror).max() <= 1e-12 * np.abs(mirror).max()
    assert np.array_equal(back, F + rates * np.array(steps)[:, None])
    held, _ = run_fmu(path, steps, F)
    assert np.abs(out[:, -2:] - held[:, -2:]).max() > 1e-3 * np.abs(held[:, -2:]).max()
