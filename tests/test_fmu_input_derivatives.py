"""Input derivatives (fmi2SetRealInputDerivatives): the exact FMU integrates f + (df/dt) tau over a step.

With fmpy's ``set_input_derivatives`` and a force sampled at the communication
points, the exact FMU must equal the Python exact model with the input going
linearly between the samples (``run_exact(..., hold="linear")``) to round-off,
differ from the held-input run, and without derivatives give exactly today's
held outputs.  Order 2 and another value reference are refused with fmi2Error
and a message naming what is allowed.  The frozen FMU takes the derivative
too: f + (df/dt) tau evaluated at each refresh of its force term, equal bit for
bit to the Python mirror (sphrom.fmu.check.python_cosim with ``rates``).
"""

import zipfile

import fmpy
import numpy as np
import pytest
from fmpy.fmi1 import FMICallException

from conftest import fmu_scene
from sphrom.fmu.make.build import ensure_binaries
from sphrom.fmu.run.cosim import run_cosim
from sphrom.fmu.run.driver import FMU
from sphrom.fmu.make.models import exact_model
from sphrom.fmu.make.package import package_fmu
from sphrom.fmu.resources import unpack
from sphrom.fmu.variables import vr
from sphrom.rom.exact_linear import run_exact
from test_fmu_exact import probe_outputs, relative_residual

K = 6
PROBES = (0.25, 0.5, 0.66)
H, M = 0.01, 50


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    folder = tmp_path_factory.mktemp("deriv-fmus")
    binaries = ensure_binaries()
    made = {}

    def make(model="exact", fmi=2):
        if (model, fmi) not in made:
            path = folder / f"{model}-fmi{fmi}.fmu"
            package_fmu(fmu_scene("forced"), path, k=K, fmi=fmi, probes=PROBES, progress=False, binaries=binaries,
                        model=model)
            made[model, fmi] = path
        return made[model, fmi]

    return make


def _force(t):
    return 3e-2 * np.sin(2 * np.pi * 3 * t) + 1e-2


def test_declared_per_model(fmus):
    """canInterpolateInputs in FMI 2 for both models (FMI 3 has no such attribute); fmpy validates both."""
    for model in ("exact", "frozen"):
        path = fmus(model, 2)
        assert fmpy.validation.validate_fmu(str(path)) == []
        assert fmpy.read_model_description(str(path)).coSimulation.canInterpolateInputs is True


def test_exact_fmu_with_derivatives_equals_linear_input_model(fmus, tmp_path, record_property):
    """fmpy with set_input_derivatives = run_exact(hold="linear") to 1e-11; held inputs differ by far more."""
    path = fmus("exact", 2)
    scene = fmu_scene("forced")
    dense, lin, _, _ = exact_model(scene, K, PROBES, progress=False)   # its rows over the dense z (run_exact's)
    assert unpack(zipfile.ZipFile(path).read("resources/model.bin")).blocks   # the FMU steps its block form
    t = np.arange(M + 1) * H
    csv = tmp_path / "f.csv"
    np.savetxt(csv, np.column_stack([t, _force(t)]), delimiter=",", header="time,f", comments="", fmt="%.17g")
    lin_run = run_cosim(path, force=str(csv), t_end=M * H, step=H, initial_state_scale=1)
    held_run = run_cosim(path, force=str(csv), t_end=M * H, step=H, hold_inputs=True, initial_state_scale=1)
    assert lin_run.input_derivatives and not held_run.input_derivatives
    assert np.allclose(lin_run.values[:, 0], t, rtol=0, atol=1e-12)
    scene_force = lambda s: _force(np.asarray(s, float))                 # noqa: E731
    ref_lin = probe_outputs(dense, run_exact(lin, t, step=H, force=scene_force, hold="linear").z)
    ref_held = probe_outputs(dense, run_exact(lin, t, step=H, force=scene_force, hold="held").z)
    from sphrom.fmu.variables import members
    model = members(lin_run.names, "v_probe_j") + members(lin_run.names, "rho_probe_j")   # not the error bounds
    residual = relative_residual(lin_run.values[:, model], ref_lin)
    record_property("relative_residual", residual)
    assert residual <= 1e-11
    assert relative_residual(held_run.values[:, model], ref_held) <= 1e-11
    assert relative_residual(lin_run.values[:, model], held_run.values[:, model]) > 1e-4


def test_without_derivatives_outputs_are_bitwise_held(fmus):
    """Setting f resets the rate: a derivative set once and then f set again gives the held run bit for bit."""
    path = fmus("exact", 2)
    inputs = _force(np.arange(M) * H)
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        held = s.run([H] * M, inputs)
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        s.set_input_derivative(5.0)
        s.set_input(inputs[0])                      # a new value without a derivative: held again
        out = [s.output_values()]
        for j, f in enumerate(inputs):
            if j:
                s.set_input(f)
            s.do_step(j * H, H)
            out.append(s.output_values())
    assert np.array_equal(np.array(out), held)


def test_rate_continues_until_f_is_set(fmus):
    """f + rate tau over two steps without a new f equals one step of 2H with the same rate (the input continues
    linearly), and f reads back as f + rate 2H."""
    path = fmus("exact", 2)
    finals = []
    for steps in ([2 * H], [H, H]):
        with FMU(path) as s:
            s.initialize(initial_state_scale=1)
            s.set_input(1e-2)
            s.set_input_derivative(0.5)
            t = 0.0
            for h in steps:
                s.do_step(t, h)
                t += h
            finals.append(s.output_values())
            assert s.get_real([vr("f")])[0] == pytest.approx(1e-2 + 0.5 * 2 * H, rel=1e-14)
    assert relative_residual(np.atleast_2d(finals[1]), np.atleast_2d(finals[0])) <= 1e-11


@pytest.mark.parametrize("case,allowed", [(("f", 2, 0.1), "order 2 is not supported (allowed: 1)"),
                                          (("v_probe_j", 1, 0.1), "is not a real input (allowed: 1 (f))"),
                                          (("f", 1, float("nan")), "is not finite")])
def test_refused_with_a_message(fmus, case, allowed):
    name, order, value = case
    ref = vr(name, 1 if name.endswith("_j") else None)
    with FMU(fmus("exact", 2)) as s:
        s.initialize(initial_state_scale=1)
        with pytest.raises(FMICallException) as exc:
            from ctypes import c_double, c_int, c_uint32
            s.fmu.fmi2SetRealInputDerivatives(s.fmu.component, (c_uint32 * 1)(ref), 1, (c_int * 1)(order),
                                              (c_double * 1)(value))
        assert exc.value.status == 3                                       # fmi2Error
        assert any(allowed in text and "fmi2SetRealInputDerivatives" in text for text in s.errors()), s.errors()


def test_frozen_fmu_with_derivatives_equals_python_bitwise(fmus):
    """The frozen FMU with f and df/dt at every point, over whole, shortened and sub-dt steps, equals the
    Python mirror (cosim_reference with rates) bit for bit; a zero rate gives the held run bit for bit; the
    rate changes the outputs; and f reads back as f + rate h after a step."""
    from sphrom.fmu.check.python_cosim import cosim_reference
    path = fmus("frozen", 2)
    data = unpack(zipfile.ZipFile(path).read("resources/model.bin"))
    dt = data.dt
    rng = np.random.default_rng(11)
    steps = [H] * 10 + [2.5 * dt, 0.3 * dt, 7.3 * dt, 13.03 * dt] + list(rng.uniform(0.5, 30, 10) * dt)
    t = np.concatenate([[0.0], np.cumsum(steps)])
    inputs = _force(t[:-1])
    rates = np.diff(_force(t)) / np.diff(t)
    for n_freeze in (1, 4, 10):
        with FMU(path) as s:
            s.initialize(n_freeze=n_freeze, initial_state_scale=1)
            out = [s.output_values()]
            tc = 0.0
            for h, f, rate in zip(steps, inputs, rates):
                s.set_input(f)
                s.set_input_derivative(rate)
                s.do_step(tc, h)
                tc = tc + h
                out.append(s.output_values())
                assert s.get_real([vr("f")])[0] == f + rate * h
        _, v, r = cosim_reference(data, steps, inputs, n_freeze=n_freeze, rates=rates)
        assert np.array_equal(np.array(out), np.hstack([v, r])), n_freeze
        _, vh, rh = cosim_reference(data, steps, inputs, n_freeze=n_freeze)
        assert relative_residual(np.array(out), np.hstack([vh, rh])) > 1e-6
        _, v0, r0 = cosim_reference(data, steps, inputs, n_freeze=n_freeze, rates=np.zeros(len(steps)))
        assert np.array_equal(np.hstack([v0, r0]), np.hstack([vh, rh]))
        with FMU(path) as s:
            s.initialize(n_freeze=n_freeze, initial_state_scale=1)
            assert np.array_equal(s.run(steps, inputs), np.hstack([vh, rh]))


def test_frozen_fmu_derivative_survives_a_saved_state(fmus):
    """The rate is part of the FMU state: restored, a step with it equals the step taken before saving."""
    with FMU(fmus("frozen", 2)) as s:
        s.initialize(initial_state_scale=1)
        s.set_input(1e-2)
        s.set_input_derivative(0.7)
        saved = s.get_state()
        s.do_step(0.0, H)
        first = s.output_values()
        s.set_input(5.0)
        s.set_input_derivative(-3.0)            # both overwritten by the restored state
        s.set_state(saved)
        s.do_step(0.0, H)
        assert np.array_equal(s.output_values(), first)


def test_not_allowed_before_initialization(fmus):
    """Like setting inputs in step mode: allowed in InitializationMode and StepComplete, not in Instantiated."""
    with FMU(fmus("exact", 2)) as s:
        with pytest.raises(FMICallException):
            s.set_input_derivative(0.1)
        assert any("fmi2SetRealInputDerivatives" in text for text in s.errors())


def test_linear_input_converges_at_second_order_held_at_first(fmus):
    """Against the same FMU at 1 ms with df/dt: halving the step divides the held-input error by ~2 and the
    linear-input error by ~4 (sphrom.bench.input_derivatives measures tenmode the same way)."""
    from sphrom.bench.input_derivatives import relative_l2, velocity_columns
    path = fmus("exact", 2)
    force = "3e-2*sin(2*pi*3*t) + 1e-2"
    ref = velocity_columns(run_cosim(path, force=force, t_end=0.5, step=1e-3, initial_state_scale=1))
    errors = {}
    for h, stride in ((0.01, 10), (0.02, 20)):
        for hold in (True, False):
            v = velocity_columns(run_cosim(path, force=force, t_end=0.5, step=h, hold_inputs=hold,
                                           initial_state_scale=1))
            errors[h, hold] = relative_l2(v, ref[::stride][:v.shape[0]])
    assert 1.6 < errors[0.02, True] / errors[0.01, True] < 2.5
    assert 3.0 < errors[0.02, False] / errors[0.01, False] < 5.0
    assert errors[0.01, False] < 0.1 * errors[0.01, True]
