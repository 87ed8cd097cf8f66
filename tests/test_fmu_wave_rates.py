"""Input derivatives of the wave form's incident waves: fmi2SetRealInputDerivatives (order 1) on a_port_j.

A port FMU declares canInterpolateInputs, so a master may give every continuous real input a rate.  In the wave
form (port_impedance Z > 0) the incident wave then goes linearly over the step, a(t) = a + ȧ (t - t_k); the port
force is held at the mean of 2 a(t) - Z v(t) over the step, so a enters exactly through its mean a + ȧ h / 2
(fmu_src/rom_port.c, sphrom.rom.port_channel.mean_waves), and a continues along its line after the step.  Checked
here against the Python mirror (FrozenCosim with the channel: scipy's exponentials against the core's Taylor
series), and against an independent path: the same FMU at a 10x finer step with each incident wave held at the
line's value at the fine step's midpoint, which the rate run meets at second order in the step (a held incident
wave: first).
"""

import xml.etree.ElementTree as ET
import zipfile
from ctypes import c_double, c_int, c_uint32

import numpy as np
import pytest
from conftest import mixed_steps
from fmpy.fmi1 import FMICallException

from sphrom.fmu.run.driver import FMU
from sphrom.fmu.variables import vr

AREA = 2.0
IMPEDANCE = 0.05          # Z = k h of tests/test_master_loop.py's springs at 10 ms [N s m^-1]
VR_A = [vr("a_port_j", j) for j in (1, 2)]
VR_B = [vr("b_port_j", j) for j in (1, 2)]


@pytest.fixture
def wave_fmu(channel_port_fmu):
    """(path, data): a frozen FMI 2 FMU of the shrunk damped_forced scene (k = 6) with the port channel."""
    return channel_port_fmu


def waves(t):
    """Two smooth incident waves [N], (len(t), 2)."""
    t = np.atleast_1d(np.asarray(t, float))
    return np.stack([1e-3 * np.sin(2 * np.pi * 4 * t + 0.3), 2e-3 * np.cos(2 * np.pi * 2.5 * t)], axis=-1)


def set_derivatives(s, refs, rates):
    n = len(refs)
    s.fmu.fmi2SetRealInputDerivatives(s.fmu.component, (c_uint32 * n)(*refs), n, (c_int * n)(*([1] * n)),
                                      (c_double * n)(*[float(r) for r in rates]))


def run_fmu(path, steps, a, rates=None):
    """(outputs (M+1, v_probe, rho_probe, v_port, b_port), a_port read back after each step) of the wave-form FMU
    from rest with f = 0 over ``steps``, the incident waves a (M, 2) set before each step, their rates when given."""
    out, back = [], []
    with FMU(path) as s:
        s.set_real([vr("area")], [AREA])
        s.initialize(initial_state_scale=0, port_impedance=IMPEDANCE)
        names = [n for n in s.model_outputs if n.startswith(("v_probe_", "rho_probe_", "v_port_"))]
        out.append(np.concatenate([s.output_values(names), s.get_real(VR_B)]))
        tc = 0.0
        for n, h in enumerate(steps):
            s.set_real(VR_A, list(a[n]))
            if rates is not None:
                set_derivatives(s, VR_A, rates[n])
            s.do_step(tc, h)
            tc = tc + h
            out.append(np.concatenate([s.output_values(names), s.get_real(VR_B)]))
            back.append(s.get_real(VR_A))
    return np.array(out), np.array(back)


def run_mirror(data, steps, a, rates):
    """The same run through the Python mirror (FrozenCosim with the port channel)."""
    from sphrom.fmu.check.python_cosim import FrozenCosim
    ref = FrozenCosim(data, initial_state_scale=0.0)
    ref.area, ref.impedance = AREA, IMPEDANCE

    def outputs():
        v, rho = ref.outputs()
        return np.concatenate([v, rho, ref.port_velocities(), ref.channel.reflected])

    out = [outputs()]
    for n, h in enumerate(steps):
        ref.waves, ref.wave_rates = np.array(a[n], float), np.array(rates[n], float)
        ref.do_step(h, 0.0)
        out.append(outputs())
    return np.array(out)


def test_every_continuous_real_input_takes_an_input_derivative(wave_fmu):
    """The contract canInterpolateInputs declares: fmi2SetRealInputDerivatives of order 1 is accepted on every
    continuous real input the modelDescription declares (read from it, not listed here), in both port forms."""
    path, _ = wave_fmu
    root = ET.fromstring(zipfile.ZipFile(path).read("modelDescription.xml"))
    assert root.find("CoSimulation").get("canInterpolateInputs") == "true"
    inputs = [(v.get("name"), int(v.get("valueReference"))) for v in root.iter("ScalarVariable")
              if v.get("causality") == "input" and v.get("variability", "continuous") == "continuous"
              and v.find("Real") is not None]
    assert {"f", "F_port_1", "a_port_2"} <= {n for n, _ in inputs}
    for impedance in (0.0, IMPEDANCE):
        with FMU(path) as s:
            s.initialize(port_impedance=impedance)
            for name, ref in inputs:
                set_derivatives(s, [ref], [1e-3])           # raises FMICallException when refused
            set_derivatives(s, [ref for _, ref in inputs], [0.0] * len(inputs))
            s.do_step(0.0, 0.01)
            with pytest.raises(FMICallException):
                set_derivatives(s, [VR_A[0]], [float("nan")])


def test_linear_incident_waves_equal_the_python_channel(wave_fmu):
    """Incident waves with rates over whole, shortened and sub-dt steps: the FMU equals its Python mirror (the
    channel's exact solution over each step, scipy's exponentials) to 1e-12; after a step a_port_j reads
    a_j + ȧ_j h; zero rates give the held run bit for bit; the rates change v_port and b_port."""
    path, data = wave_fmu
    steps, t = mixed_steps(data.dt)
    a, rates = waves(t[:-1]), np.diff(waves(t), axis=0) / np.diff(t)[:, None]
    out, back = run_fmu(path, steps, a, rates)
    mirror = run_mirror(data, steps, a, rates)
    assert np.abs(out - mirror).max() <= 1e-12 * np.abs(mirror).max()
    assert np.allclose(back, a + rates * np.array(steps)[:, None], rtol=4e-16, atol=0.0)
    held, _ = run_fmu(path, steps, a)
    zero, _ = run_fmu(path, steps, a, np.zeros_like(rates))
    assert np.array_equal(zero, held)
    assert np.abs(out[:, -4:] - held[:, -4:]).max() > 1e-2 * np.abs(held[:, -4:]).max()


def test_linear_incident_waves_converge_at_second_order(wave_fmu):
    """Against the same FMU at a 10x finer step with each incident wave held at the line's midpoint value (an
    independent path to the continuous wave relation), the v_port of the rate run at the coarse step H converges
    at second order in H, the held run's at first; a set a_port_j without a new derivative holds it again."""
    path, _ = wave_fmu
    T = 0.4
    errors = {}
    for H in (0.02, 0.01):
        M = int(round(T / H))
        t = H * np.arange(M + 1)
        a, rates = waves(t[:-1]), np.diff(waves(t), axis=0) / H
        lin, _ = run_fmu(path, [H] * M, a, rates)
        held, _ = run_fmu(path, [H] * M, a)
        h = H / 10
        fine_t = h * np.arange(10 * M)
        fine_a = a[np.arange(10 * M) // 10] + rates[np.arange(10 * M) // 10] * (fine_t + 0.5 * h
                                                                                 - t[np.arange(10 * M) // 10])[:, None]
        fine, _ = run_fmu(path, [h] * (10 * M), fine_a)
        ref = fine[::10, -4:-2]
        scale = np.linalg.norm(ref)
        errors[H] = {"rate": np.linalg.norm(lin[:, -4:-2] - ref) / scale,
                     "held": np.linalg.norm(held[:, -4:-2] - ref) / scale}
    print("wave rates, v_port relative L2 against the 10x finer midpoint run:", errors)
    assert errors[0.01]["rate"] < 0.1 * errors[0.01]["held"], errors
    assert 3.0 < errors[0.02]["rate"] / errors[0.01]["rate"] < 5.0, errors
    assert 1.5 < errors[0.02]["held"] / errors[0.01]["held"] < 3.0, errors


def test_wave_rate_survives_a_saved_state_and_setting_the_wave_holds_it_again(wave_fmu):
    """ȧ is part of the FMU state: restored, a step equals the step taken before saving; setting a_port_j without
    a new derivative holds it (the rate goes back to 0)."""
    path, _ = wave_fmu
    with FMU(path) as s:
        s.set_real([vr("area")], [AREA])
        s.initialize(initial_state_scale=0, port_impedance=IMPEDANCE)
        s.set_real(VR_A, [1e-3, -2e-3])
        set_derivatives(s, VR_A, [0.05, 0.02])
        s.do_step(0.0, 0.01)
        state = s.fmu.getFMUstate()
        s.do_step(0.01, 0.01)
        first = np.concatenate([s.output_values(), s.get_real(VR_B + VR_A)])
        s.fmu.setFMUstate(state)
        s.do_step(0.01, 0.01)
        assert np.array_equal(np.concatenate([s.output_values(), s.get_real(VR_B + VR_A)]), first)
        s.fmu.freeFMUstate(state)
        s.set_real(VR_A, list(s.get_real(VR_A)))
        before = s.get_real(VR_A)
        s.do_step(0.02, 0.01)
        assert np.array_equal(s.get_real(VR_A), before)
