"""The one FMU driver (harness/fmu/run/driver.py) against an importer nobody here wrote, and sphrom cosim's rule.

* Held inputs: the driver's outputs equal ``fmpy.simulate_fmu``'s bit for bit, FMI 2 and FMI 3, frozen and exact
  (the same calls in the same order: fmpy sets f at each communication point, the FMU holds it).
* ``sphrom cosim`` held (``--hold-inputs``): the FMI 2 and FMI 3 builds of one model give the same outputs bit
  for bit.  With its defaults the FMI 2 FMU gets df/dt (f linear over each step) and the FMI 3 FMU holds f,
  because FMI 3.0 co-simulation has no input derivatives (docs/fmu/cosim.md): their outputs then differ by the
  input's interpolation, which the test bounds from below (it is there) and from above.
* The rule is the FMU's declaration: ``input_derivatives`` is True exactly for FMI 2 (canInterpolateInputs).
"""

import fmpy
import numpy as np
import pytest

from conftest import fmu_scene, fmu_models, model_per_kind
from sphrom.fmu.make.build import ensure_binaries
from sphrom.fmu.make.package import package_fmu
from sphrom.fmu.run.cosim import run_cosim
from sphrom.fmu.run.driver import FMU

K = 6
FORCE = "3e-2*sin(2*pi*3*t) + 1e-2"
T_END, STEP = 0.5, 0.01


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    folder = tmp_path_factory.mktemp("driver-fmus")
    binaries = ensure_binaries()
    made = {}

    def make(model, fmi):
        if (model, fmi) not in made:
            path = folder / f"{model}-fmi{fmi}.fmu"
            package_fmu(fmu_scene("forced"), path, k=K, fmi=fmi, progress=False, binaries=binaries, model=model,
                        bounds=False)
            made[model, fmi] = path
        return made[model, fmi]
    return make


def _signal(times):
    sig = np.zeros(times.size, dtype=[("time", np.float64), ("f", np.float64)])
    sig["time"], sig["f"] = times, 3e-2 * np.sin(2 * np.pi * 3 * times) + 1e-2
    return sig


@pytest.mark.parametrize("model", model_per_kind())
@pytest.mark.parametrize("fmi", [2, 3])
def test_driver_equals_fmpy_simulate_fmu_bitwise(fmus, model, fmi):
    path = fmus(model, fmi)
    n = int(round(T_END / STEP))
    times = np.arange(n + 1) * STEP
    signal = _signal(times)
    ref = fmpy.simulate_fmu(str(path), stop_time=T_END, output_interval=STEP, input=signal,
                            start_values={"initial_state_scale": 1.0})
    with FMU(path) as fmu:
        fmu.initialize(initial_state_scale=1.0, f=float(signal["f"][0]))
        y = fmu.simulate(times, {"f": signal["f"]})
        names = fmu.outputs
    assert np.array_equal(np.asarray(ref["time"]), times)
    for j, name in enumerate(names):
        assert np.array_equal(y[:, j], np.asarray(ref[name])), (model, fmi, name)


@pytest.mark.parametrize("model", fmu_models())
def test_cosim_fmi2_and_fmi3_agree(fmus, model, record_property):
    p2, p3 = fmus(model, 2), fmus(model, 3)
    held2, held3 = (run_cosim(p, force=FORCE, t_end=T_END, step=STEP, hold_inputs=True, initial_state_scale=1)
                    for p in (p2, p3))
    assert not held2.input_derivatives and not held3.input_derivatives
    assert held2.names == held3.names and np.array_equal(held2.values, held3.values)
    lin2, def3 = (run_cosim(p, force=FORCE, t_end=T_END, step=STEP, initial_state_scale=1) for p in (p2, p3))
    assert lin2.input_derivatives and not def3.input_derivatives          # the rule: the FMU's declaration
    assert np.array_equal(def3.values, held3.values)                        # FMI 3: held, as documented
    v = [i for i, n in enumerate(lin2.names) if n.startswith("v_probe_")]
    diff = np.max(np.abs(lin2.values[:, v] - def3.values[:, v])) / np.max(np.abs(lin2.values[:, v]))
    record_property("fmi2_linear_vs_fmi3_held", float(diff))
    # the input's interpolation: f moves by up to 0.03 * 2 pi * 3 * h = 5.7e-3 over a step
    assert 1e-9 < diff < 0.1, diff


def test_fmpy_logs_safely_after_a_driver_instance_is_gone(fmus):
    """fmpy's FMI 2 logger proxy keeps one logger per process: after our FMU is freed (and its Python objects
    collected), an FMU run by fmpy.simulate_fmu that logs (a frozen FMU far beyond its training warns) must
    reach a live logger, and our messages must still reach our instance while another FMU runs beside it."""
    import gc
    path = fmus("frozen", 2)
    with FMU(path) as ours:
        ours.initialize(initial_state_scale=1.0, f=0.0)
    del ours
    gc.collect()
    times = np.arange(51) * STEP
    big = np.zeros(times.size, dtype=[("time", np.float64), ("f", np.float64)])
    big["time"], big["f"] = times, 50.0              # far outside the training envelope: the FMU warns
    fmpy.simulate_fmu(str(path), stop_time=T_END, output_interval=STEP, input=big)   # fmpy's default logger
    with FMU(path) as a, FMU(path) as b:
        a.initialize(initial_state_scale=1.0, f=50.0)
        b.initialize(initial_state_scale=0.0, f=0.0)         # at rest: nothing to warn about
        a.simulate(times, {"f": big["f"]})
        b.simulate(times, {"f": np.zeros(times.size)})
        # the error signal: the certified bound above error_tolerance (the training envelope without bounds)
        assert any("exceeds error_tolerance" in w or "training envelope" in w for w in a.warnings()), a.messages
        assert not b.warnings(), b.messages                   # a's warning did not land in b
