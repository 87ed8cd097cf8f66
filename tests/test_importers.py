"""The FMU in importers nobody here wrote: libcosim (through libcosimpy, FMI 2) and fmu-manipulation-toolbox's
container (FMI 3).

libcosim loads the FMU with the FMI Library, runs its own instantiate/initialise/step sequence and reads the
outputs; the outputs must equal fmpy's (through :class:`harness.fmu.fmi.Slave`) to round-off.  Skips, with a
message, where an importer is not installed.  libcosim imports FMI 2.0 only; the FMI 3 FMU runs inside the
container's own runtime.
"""

import numpy as np
import pytest

from conftest import fmu_scene
from harness.fmu.build import ensure_binaries
from harness.fmu.fmi import Slave
from harness.fmu.package import package_fmu

H, N_STEPS = 0.01, 50


def libcosim_outputs(path, names, start=None):
    """libcosim's outputs ``names`` over N_STEPS steps of H, from the scene's initial state and the start
    values ``start`` (name -> value: inputs held, parameters fixed before initialization)."""
    libcosim = pytest.importorskip("libcosimpy.CosimExecution",
                                   reason="libcosimpy is not installed (pip install libcosimpy)")
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave
    ex = libcosim.CosimExecution.from_step_size(step_size=int(round(H * 1e9)))
    idx = ex.add_local_slave(local_slave=CosimLocalSlave(fmu_path=str(path), instance_name="sphrom"))
    obs = CosimObserver.create_last_value()
    ex.add_observer(observer=obs)
    refs = {v.name.decode(): v.reference for v in ex.slave_variables(idx)}
    # the scene's initial state (the FMU starts at rest): the comparison needs a trajectory that moves
    for var, value in {"initial_state_scale": 1.0, **(start or {})}.items():
        assert ex.real_initial_value(slave_index=idx, variable_reference=refs[var], value=value), var
    rows = []
    for _ in range(N_STEPS):
        assert ex.step()
        rows.append(obs.last_real_values(slave_index=idx, variable_references=[refs[n] for n in names]))
    return np.array(rows)


@pytest.mark.parametrize("model", ["frozen", "exact", "balanced"])
def test_libcosim_runs_the_fmi2_fmu_as_fmpy_does(tmp_path, model):
    path = tmp_path / f"{model}.fmu"
    package_fmu(fmu_scene("forced"), path, k=6, fmi=2, progress=False, binaries=ensure_binaries(), model=model)
    with Slave(path) as s:
        s.initialize(initial_state_scale=1)
        names = list(s.outputs)
        ours = s.run([H] * N_STEPS, np.zeros(N_STEPS))[1:]
    theirs = libcosim_outputs(path, names)
    assert theirs.shape == ours.shape and np.ptp(ours[:, 0]) > 0         # a trajectory that moves
    assert np.all(np.isfinite(theirs))
    np.testing.assert_allclose(theirs, ours, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("model", ["frozen", "exact", "balanced"])
def test_fmu_manipulation_toolbox_container_runs_the_fmi3_fmu_as_fmpy_does(tmp_path, model):
    """fmu-manipulation-toolbox's container wraps the FMI 3 FMU: its own runtime (not ours, not fmpy's)
    loads, instantiates and steps it; fmpy only drives the container."""
    import json
    import shutil
    import subprocess

    import fmpy
    tool = shutil.which("fmucontainer")
    if tool is None:
        pytest.skip("fmu-manipulation-toolbox is not installed (pip install fmu-manipulation-toolbox)")
    path = tmp_path / f"{model}.fmu"
    package_fmu(fmu_scene("forced"), path, k=6, fmi=3, progress=False, binaries=ensure_binaries(), model=model)
    (tmp_path / "container.json").write_text(json.dumps({"name": "container.fmu", "step_size": H,
                                                         "fmu": [path.name],
                                                         "start": [[path.name, "initial_state_scale", "1"]]}))
    done = subprocess.run([tool, "-container", "container.json", "-fmi", "3"], cwd=tmp_path, capture_output=True,
                          text=True, timeout=300)
    assert (tmp_path / "container.fmu").is_file(), done.stdout + done.stderr
    result = fmpy.simulate_fmu(str(tmp_path / "container.fmu"), stop_time=N_STEPS * H, output_interval=H)
    with Slave(path) as s:
        s.initialize(initial_state_scale=1)
        names = list(s.outputs)
        ours = s.run([H] * N_STEPS, np.zeros(N_STEPS))
    theirs = np.column_stack([result[n] for n in names])
    assert theirs.shape == ours.shape and np.ptp(ours[:, 0]) > 0         # a trajectory that moves
    np.testing.assert_allclose(theirs, ours, rtol=1e-12, atol=1e-15)


def test_libcosim_runs_port_and_parametric_fmus_as_fmpy_does(tmp_path):
    """The component features in an independent importer: a port FMU (exact, two ports, constant port forces
    set as libcosim start values of the inputs) and a parametric FMU (frozen, d chosen inside its trained range
    before initialization) give fmpy's outputs (port velocities included) to round-off."""
    pytest.importorskip("libcosimpy.CosimExecution", reason="libcosimpy is not installed (pip install libcosimpy)")
    from harness.rom.parametric import parse_vary
    cases = {"ports": (dict(model="exact", ports=[0.3, 0.7]), {"F_port_1": 0.5, "F_port_2": -0.2}),
             "parametric": (dict(model="frozen", vary=[parse_vary("d=5:15")]), {"d": 12.5})}
    for name, (options, values) in cases.items():
        path = tmp_path / f"{name}.fmu"
        package_fmu(fmu_scene("forced"), path, k=6, fmi=2, progress=False, binaries=ensure_binaries(), **options)
        with Slave(path) as s:
            s.set_real([s.vr[n] for n in values], list(values.values()))
            s.initialize(initial_state_scale=1)
            names = list(s.outputs)
            ours = s.run([H] * N_STEPS, np.zeros(N_STEPS))[1:]
        with Slave(path) as s:                      # the same without the values: they change the outputs
            s.initialize(initial_state_scale=1)
            plain = s.run([H] * N_STEPS, np.zeros(N_STEPS))[1:]
        assert np.max(np.abs(plain - ours)) > 1e-6 * np.max(np.abs(ours)), name
        theirs = libcosim_outputs(path, names, values)
        if name == "ports":
            assert {"v_port_1", "v_port_2"} <= set(names)
        assert theirs.shape == ours.shape and np.ptp(ours[:, 0]) > 0, name
        np.testing.assert_allclose(theirs, ours, rtol=1e-12, atol=1e-15, err_msg=name)
