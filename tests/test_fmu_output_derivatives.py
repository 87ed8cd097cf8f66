"""Output derivatives of the linear (exact) FMU: fmi2GetRealOutputDerivatives / fmi3GetOutputDerivatives.

dv_j/dt = Pv[j] . (A z + B f)_a and dρ_j/dt by the chain rule through J = 1 + e are exact at the FMU's time
(f the input now, including what an input rate made of it); held against a centered finite difference of the
FMU's own outputs over a tiny step, and against the Python model's rate.  The frozen FMU declares order 0
and refuses the call; order 2 is refused naming the maximum order.
"""


import fmpy
import numpy as np
import pytest
from fmpy.fmi1 import FMICallException

from conftest import fmu_maker
from sphrom.fmu.run.driver import FMU
from sphrom.fmu.check.python_cosim import linear_output_rates
from sphrom.fmu.variables import vr

K = 6
PROBES = (0.25, 0.5, 0.66)
DELTA = 1e-4            # the finite difference's half step [s]


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    """make(model, fmi, case) -> (path, data), packaged once each."""
    return fmu_maker(tmp_path_factory.mktemp("deriv-out-fmus"), "exact", k=K, probes=PROBES)


@pytest.mark.parametrize("fmi", [2, 3])
def test_declared_per_model(fmus, fmi):
    for model, order in (("exact", 1), ("frozen", 0)):
        path, _ = fmus(model, fmi)
        assert fmpy.validation.validate_fmu(str(path)) == []
        assert int(fmpy.read_model_description(str(path)).coSimulation.maxOutputDerivativeOrder) == order


@pytest.mark.parametrize("case", ["forced", "unforced"])
@pytest.mark.parametrize("fmi", [2, 3])
def test_derivative_equals_centered_difference_and_python(fmus, fmi, case, record_property):
    """At t = 0.2 s + δ after a forced run: the FMU's dy/dt against (y(t + δ) - y(t - δ)) / 2δ with f held over
    the window (1e-6 relative, the difference's own error is O(δ²) and round-off/δ), and against
    linear_output_rates on the FMU's reduced state (1e-12)."""
    path, data = fmus("exact", fmi, case)
    rng = np.random.default_rng(11)
    inputs = rng.normal(0, 0.05, 20)
    f_hold = 0.03
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        s.run([0.01] * 20, inputs)
        t = 0.2
        s.set_input(f_hold)
        s.do_step(t, DELTA)
        before = s.output_values()
        s.do_step(t + DELTA, DELTA)
        derivative = s.output_derivatives()
        z = s.reduced_state(data.k_v + data.k_rho)
        s.do_step(t + 2 * DELTA, DELTA)
        after = s.output_values()
    centered = (after - before) / (2 * DELTA)
    scale = np.maximum(np.abs(derivative).reshape(2, -1).max(axis=1, keepdims=True), 1e-300)
    rel = float(np.max(np.abs(derivative - centered).reshape(2, -1) / scale))
    record_property("relative_difference_to_centered_fd", rel)
    assert rel <= 1e-6
    dv, drho = linear_output_rates(data, z, f_hold)
    P = len(PROBES)
    np.testing.assert_allclose(derivative[:P], dv, rtol=0, atol=1e-12 * np.abs(dv).max())
    np.testing.assert_allclose(derivative[P:], drho, rtol=0, atol=1e-12 * max(np.abs(drho).max(), 1e-300))
    assert np.abs(dv).max() > 1e-4                 # the outputs do move


def test_derivative_uses_the_input_now_with_its_rate(fmus):
    """FMI 2 with fmi2SetRealInputDerivatives: after a step the input is f + (df/dt) h, and the derivative is
    taken with that input; the centered difference runs with the rate still set (f linear over the window)."""
    path, data = fmus("exact", 2)
    f0, rate, h = 0.02, 0.5, 0.01
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        s.set_input(f0)
        s.set_input_derivative(rate)
        s.do_step(0.0, h - DELTA)
        before = s.output_values()
        s.do_step(h - DELTA, DELTA)
        derivative = s.output_derivatives()
        f_now = s.get_real([vr("f")])[0]
        z = s.reduced_state(data.k_v + data.k_rho)
        s.do_step(h, DELTA)
        after = s.output_values()
    assert f_now == pytest.approx(f0 + rate * h, rel=1e-12)
    centered = (after - before) / (2 * DELTA)
    P = len(PROBES)
    assert np.max(np.abs(derivative[:P] - centered[:P])) <= 1e-6 * np.abs(derivative[:P]).max()
    dv, drho = linear_output_rates(data, z, f_now)
    np.testing.assert_allclose(derivative[:P], dv, rtol=0, atol=1e-12 * np.abs(dv).max())
    held_dv, _ = linear_output_rates(data, z, f0)
    assert np.max(np.abs(held_dv - dv)) > 1e-6 * np.abs(dv).max()      # the rate matters


@pytest.mark.parametrize("fmi", [2, 3])
def test_bad_orders_variables_and_the_frozen_model_are_refused(fmus, fmi):
    path, _ = fmus("exact", fmi)
    for order, text in ((2, "order 2 of the derivative of v_probe_1 is not supported (maxOutputDerivativeOrder = 1"),
                        (0, "order 0 of the derivative")):
        with FMU(path) as s:
            s.initialize(initial_state_scale=1)
            with pytest.raises(FMICallException):
                s.output_derivatives(order=order, names=["v_probe_1"])
            assert any(text in e for e in s.errors()), s.errors()
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        with pytest.raises(FMICallException):
            s.output_derivatives(names=["f"])
        assert any("f is not an output" in e for e in s.errors()), s.errors()
    path, _ = fmus("frozen", fmi)
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        with pytest.raises(FMICallException):
            s.output_derivatives(names=["v_probe_1"])
        assert any("frozen model provides no output derivatives" in e and "discrete map" in e
                   for e in s.errors()), s.errors()


def test_balanced_fmu_derivative_equals_centered_difference(fmus):
    """The balanced FMU runs the exact model's C path with probe rows over its whole state: its dy/dt is the
    same formula, held against a centered difference of its own outputs (1e-6 relative)."""
    path, _ = fmus("balanced", 2)
    rng = np.random.default_rng(5)
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        s.run([0.01] * 20, rng.normal(0, 0.05, 20))
        s.set_input(0.03)
        s.do_step(0.2, DELTA)
        before = s.output_values()
        s.do_step(0.2 + DELTA, DELTA)
        derivative = s.output_derivatives()
        s.do_step(0.2 + 2 * DELTA, DELTA)
        after = s.output_values()
    centered = (after - before) / (2 * DELTA)
    scale = np.maximum(np.abs(derivative).reshape(2, -1).max(axis=1, keepdims=True), 1e-300)
    assert float(np.max(np.abs(derivative - centered).reshape(2, -1) / scale)) <= 1e-6
