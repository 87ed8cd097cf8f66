"""The FMU in importers nobody here wrote: libcosim (through libcosimpy, FMI 2), fmu-manipulation-toolbox's
container (FMI 3) and Ecos (through ecospy, FMI 2 and 3; it needs the system library libtbb12).

libcosim loads the FMU with the FMI Library, runs its own instantiate/initialise/step sequence and reads the
outputs; the container's own runtime loads, instantiates and steps the FMI 3 FMU (fmpy only drives the
container), and sets the start values listed in the container's description (parameters before initialization,
inputs it exposes).  The outputs must equal fmpy's (through :class:`sphrom.fmu.run.driver.FMU`) to round-off: the
plain frozen, exact and balanced FMUs, a port FMU (constant port forces), a parametric FMU (c and d set before
initialization), and each FMU left at its start values (initial_state_scale = 0: at rest).  Skips, with a message,
where an importer is not installed.  libcosim imports FMI 2.0 only; fmi-sim (``cargo install fmi-sim``, a Rust
importer with its own FMI 2 and FMI 3 bindings; its build needs libclang) runs both, the FMI 3 FMU from a copy
without the ``nominal`` attributes its version 0.7 does not read.
"""

import json
import shutil
import subprocess

import numpy as np
import pytest

from conftest import fmu_scene, fmu_models
from sphrom.fmu.make.build import ensure_binaries
from sphrom.fmu.run.driver import FMU
from sphrom.fmu.make.package import package_fmu
from sphrom.rom.parametric import parse_vary

H, N_STEPS = 0.01, 50
# libcosim against fmpy: measured differences up to 2.2e-16 on the O(1) outputs of the exact and balanced FMUs and
# 2e-11 on the port FMU's outputs (up to 235 m/s), each within RTOL |fmpy| + ATOL; 0 (bitwise) for the frozen and
# parametric FMUs and at rest.  The container against fmpy: 0 (bitwise) in every case, asserted as such.
RTOL, ATOL = 1e-12, 1e-15

# name -> (package_fmu options, start values of the feature: inputs held, parameters set before initialization)
PLAIN = {model: (dict(model=model), {}) for model in fmu_models()}
FEATURES = {"ports": (dict(model="exact", ports=[0.3, 0.7]), {"F_port_1": 0.5, "F_port_2": -0.2}),
            # (0.5 N compresses the balanced model's probe J below 0 within 0.43 s: an error status, by design)
            "ports_balanced": (dict(model="balanced", ports=[0.3, 0.7]), {"F_port_1": 0.05, "F_port_2": -0.02}),
            "ports_frozen": (dict(model="frozen", ports=[0.3, 0.7]), {"F_port_1": 0.05, "F_port_2": -0.02}),
            "parametric": (dict(model="frozen", vary=[parse_vary("c=0.05:0.2"), parse_vary("d=5:15")]),
                           {"c": 0.15, "d": 12.5})}       # inside the trained ranges, off the scene's c = 0.1, d = 10
CASES = {**PLAIN, **FEATURES}
LINEAR = {"exact", "balanced", "ports", "ports_balanced"}   # models whose rest state is exactly v = 0


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    """fmus(name, fmi) -> path of the case's FMU (fmu_scene("forced"), k = 6), packaged once per module."""
    folder = tmp_path_factory.mktemp("importer-fmus")
    made = {}

    def make(name, fmi):
        if (name, fmi) not in made:
            path = folder / f"{name}-fmi{fmi}.fmu"
            package_fmu(fmu_scene("forced"), path, k=6, fmi=fmi, progress=False, binaries=ensure_binaries(),
                        **CASES[name][0])
            made[name, fmi] = path
        return made[name, fmi]

    return make


def fmpy_outputs(path, start=None, initial_state_scale=1.0):
    """fmpy's outputs (names, rows at 0, H, ..., N_STEPS H) with the start values ``start`` set before
    initialization and f = 0 held; ``initial_state_scale`` None leaves the FMU's start value (0: at rest)."""
    start = start or {}
    with FMU(path) as s:
        s.set_real([s.vr[n] for n in start], list(start.values()))
        s.initialize(initial_state_scale=initial_state_scale)
        # every output, the certified error bounds too (harness/rom/bounds.py): the importers must agree on them
        # (steps of exactly H, the points accumulated from them, as the importers step: FMU.run's sequence)
        steps = np.full(N_STEPS, H)
        times = np.concatenate([[0.0], np.cumsum(steps)])
        return list(s.outputs), s.simulate(times, {"f": np.zeros(N_STEPS + 1)}, steps=steps)


def libcosim_outputs(path, names, start=None, initial_state_scale=1.0):
    """libcosim's outputs ``names`` over N_STEPS steps of H (rows at H, ..., N_STEPS H), from the start values
    ``start`` (name -> value: inputs held, parameters fixed before initialization); ``initial_state_scale`` 1 is
    the scene's initial state, None leaves the FMU's start value (0: at rest)."""
    libcosim = pytest.importorskip("libcosimpy.CosimExecution",
                                   reason="libcosimpy is not installed (pip install libcosimpy)")
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave
    ex = libcosim.CosimExecution.from_step_size(step_size=int(round(H * 1e9)))
    idx = ex.add_local_slave(local_slave=CosimLocalSlave(fmu_path=str(path), instance_name="sphrom"))
    obs = CosimObserver.create_last_value()
    ex.add_observer(observer=obs)
    refs = {v.name.decode(): v.reference for v in ex.slave_variables(idx)}
    values = dict(start or {})
    if initial_state_scale is not None:
        values["initial_state_scale"] = float(initial_state_scale)
    for var, value in values.items():
        assert ex.real_initial_value(slave_index=idx, variable_reference=refs[var], value=value), var
    rows = []
    for _ in range(N_STEPS):
        assert ex.step()
        rows.append(obs.last_real_values(slave_index=idx, variable_references=[refs[n] for n in names]))
    return np.array(rows)


def container_outputs(folder, path, names, start=None, initial_state_scale=1.0):
    """fmu-manipulation-toolbox's container around the FMI 3 FMU ``path``, built in ``folder`` with ``start``
    (and ``initial_state_scale`` unless None) as the container's start values of the embedded FMU, simulated by
    fmpy with nothing set on the container: outputs ``names`` at 0, H, ..., N_STEPS H."""
    import fmpy
    tool = shutil.which("fmucontainer")
    if tool is None:
        pytest.skip("fmu-manipulation-toolbox is not installed (pip install fmu-manipulation-toolbox)")
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copy(path, folder / path.name)
    values = dict(start or {})
    if initial_state_scale is not None:
        values["initial_state_scale"] = float(initial_state_scale)
    (folder / "container.json").write_text(json.dumps({
        "name": "container.fmu", "step_size": H, "fmu": [path.name],
        "start": [[path.name, var, repr(float(value))] for var, value in values.items()]}))
    done = subprocess.run([tool, "-container", "container.json", "-fmi", "3"], cwd=folder, capture_output=True,
                          text=True, timeout=300)
    assert (folder / "container.fmu").is_file(), done.stdout + done.stderr
    result = fmpy.simulate_fmu(str(folder / "container.fmu"), stop_time=N_STEPS * H, output_interval=H)
    return np.column_stack([result[n] for n in names])


def assert_outputs_close(theirs, ours, names, name):
    """The model's outputs within RTOL |fmpy| + ATOL; an error bound (|output - shadow| + a certified remainder,
    harness/rom/bounds.py) carries its output's difference: within RTOL x the largest |output| besides."""
    bound = np.array([n.endswith("_error_bound") for n in names])
    np.testing.assert_allclose(theirs[:, ~bound], ours[:, ~bound], rtol=RTOL, atol=ATOL, err_msg=name)
    np.testing.assert_allclose(theirs[:, bound], ours[:, bound], rtol=RTOL,
                               atol=ATOL + RTOL * np.abs(ours[:, ~bound]).max(), err_msg=name)


def print_difference(importer, name, theirs, ours):
    """Print the largest |importer - fmpy| over the run, absolute and relative to the largest output (the figures
    docs/fmu/importers.md quotes: ``python3 -m pytest -n 0 -s tests/test_importers.py -k libcosim``)."""
    diff, scale = float(np.max(np.abs(theirs - ours))), float(np.max(np.abs(ours)))
    print(f"\n{importer} vs fmpy, {name}: max |difference| {diff:.2e} (largest output {scale:.3g}, "
          f"relative {diff / scale:.2e})")


@pytest.mark.parametrize("model", fmu_models())
def test_libcosim_runs_the_fmi2_fmu_as_fmpy_does(fmus, model):
    path = fmus(model, 2)
    names, ours = fmpy_outputs(path)
    ours = ours[1:]
    theirs = libcosim_outputs(path, names)
    assert theirs.shape == ours.shape and np.ptp(ours[:, 0]) > 0         # a trajectory that moves
    assert np.all(np.isfinite(theirs))
    print_difference("libcosim", model, theirs, ours)
    assert_outputs_close(theirs, ours, names, model)


def ecos_outputs(path, names, initial_state_scale=1.0, values=None):
    """Ecos's outputs ``names`` over N_STEPS steps of H (rows at H, ..., N_STEPS H): its own FMI 2 / 3 loader,
    instantiate/initialise/step sequence, with ``initial_state_scale`` and ``values`` (port forces, c, d) set by
    a parameter set at initialization."""
    try:
        from ecospy import EcosSimulation, EcosSimulationStructure
    except (ImportError, OSError) as e:      # OSError: the package's library without libtbb12
        pytest.skip(f"Ecos is not usable here (pip install ecospy; apt-get install libtbb12): {e}")
    structure = EcosSimulationStructure()
    structure.add_model("sphrom", str(path))
    structure.add_parameter_set("start", {"sphrom::initial_state_scale": float(initial_state_scale),
                                          **{f"sphrom::{k}": float(v) for k, v in (values or {}).items()}})
    rows = []
    with EcosSimulation(structure=structure, step_size=H) as sim:
        sim.init(parameter_set="start")
        for _ in range(N_STEPS):
            sim.step()
            rows.append([sim.get_real(f"sphrom::{n}") for n in names])
    return np.array(rows)


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("model", fmu_models())
def test_ecos_runs_the_fmi2_and_fmi3_fmus_as_fmpy_does(fmus, model, fmi):
    """Ecos (ecospy) loads, instantiates and steps the FMU with its own code, FMI 2 and FMI 3 alike."""
    path = fmus(model, fmi)
    names, ours = fmpy_outputs(path)
    theirs = ecos_outputs(path, names)
    assert theirs.shape == ours[1:].shape and np.ptp(ours[:, 0]) > 0     # a trajectory that moves
    np.testing.assert_array_equal(theirs, ours[1:])                      # measured: bitwise


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("name", sorted(FEATURES))
def test_ecos_runs_port_and_parametric_fmus_as_fmpy_does(fmus, name, fmi):
    """The component features in Ecos, FMI 2 and FMI 3: port FMUs (exact, balanced, frozen in the energy inner
    products; constant port forces set by a parameter set at initialization) and a parametric FMU (c and d
    inside their trained ranges) give fmpy's outputs, port velocities included."""
    path = fmus(name, fmi)
    names, ours = feature_run(path, name)
    theirs = ecos_outputs(path, names, values=FEATURES[name][1])
    assert theirs.shape == ours[1:].shape, name
    print_difference(f"Ecos FMI {fmi}", name, theirs, ours[1:])
    assert_outputs_close(theirs, ours[1:], names, name)


@pytest.mark.parametrize("model", fmu_models())
def test_fmu_manipulation_toolbox_container_runs_the_fmi3_fmu_as_fmpy_does(fmus, tmp_path, model):
    """fmu-manipulation-toolbox's container wraps the FMI 3 FMU: its own runtime (not ours, not fmpy's)
    loads, instantiates and steps it; fmpy only drives the container."""
    path = fmus(model, 3)
    names, ours = fmpy_outputs(path)
    theirs = container_outputs(tmp_path, path, names)
    assert theirs.shape == ours.shape and np.ptp(ours[:, 0]) > 0         # a trajectory that moves
    np.testing.assert_array_equal(theirs, ours)                          # measured: bitwise


def feature_run(path, name):
    """fmpy's outputs of the feature FMU ``name`` with its start values, after checking that they change the
    outputs (a port FMU: every port velocity too): without them the FMU runs otherwise, so an importer that
    dropped them would fail the comparison."""
    values = FEATURES[name][1]
    names, ours = fmpy_outputs(path, values)
    _, plain = fmpy_outputs(path)
    change = np.max(np.abs(plain - ours), axis=0)
    assert np.max(change) > 1e-6 * np.max(np.abs(ours)), name
    if name.startswith("ports"):
        assert {"v_port_1", "v_port_2"} <= set(names)
        assert all(change[names.index(n)] > 0 for n in ("v_port_1", "v_port_2"))
    assert np.ptp(ours[:, 0]) > 0, name                                   # a trajectory that moves
    return names, ours


@pytest.mark.parametrize("name", sorted(FEATURES))
def test_libcosim_runs_port_and_parametric_fmus_as_fmpy_does(fmus, name):
    """The component features in an independent importer: port FMUs (exact, balanced, frozen; two ports, constant port forces
    set as libcosim start values of the inputs) and a parametric FMU (frozen, c and d chosen inside their trained
    ranges before initialization) give fmpy's outputs (port velocities included) to round-off."""
    pytest.importorskip("libcosimpy.CosimExecution", reason="libcosimpy is not installed (pip install libcosimpy)")
    path = fmus(name, 2)
    names, ours = feature_run(path, name)
    theirs = libcosim_outputs(path, names, FEATURES[name][1])
    assert theirs.shape == ours[1:].shape, name
    print_difference("libcosim", name, theirs, ours[1:])
    assert_outputs_close(theirs, ours[1:], names, name)


@pytest.mark.parametrize("name", sorted(FEATURES))
def test_fmu_manipulation_toolbox_container_runs_port_and_parametric_fmi3_fmus_as_fmpy_does(fmus, tmp_path, name):
    """The same in the container (FMI 3): the port forces and c, d are the container's start values of the
    embedded FMU (the port forces become container inputs with that start, which fmpy leaves alone); the
    container's runtime sets them, and its outputs (port velocities included) are fmpy's to round-off."""
    if shutil.which("fmucontainer") is None:
        pytest.skip("fmu-manipulation-toolbox is not installed (pip install fmu-manipulation-toolbox)")
    path = fmus(name, 3)
    names, ours = feature_run(path, name)
    theirs = container_outputs(tmp_path, path, names, FEATURES[name][1])
    assert theirs.shape == ours.shape, name
    np.testing.assert_array_equal(theirs, ours, err_msg=name)            # measured: bitwise


def rest_run(path):
    """fmpy's outputs of the FMU left at its start values (initial_state_scale = 0, f = 0, port forces 0, the
    scene's c and d), after checking that the scene's initial state (scale 1) gives other outputs."""
    names, rest = fmpy_outputs(path, initial_state_scale=None)
    _, moving = fmpy_outputs(path)
    assert np.max(np.abs(moving - rest)) > 1e-6 * np.max(np.abs(moving))
    return names, rest, moving


def assert_rest(name, names, theirs, rest, moving, bitwise=False):
    """The importer's outputs are fmpy's at rest (``bitwise``, else to RTOL, ATOL); a linear model's velocities
    are exactly 0, the frozen model's to round-off of the scene's velocities ``moving`` (its b is taken about the
    projected rest density, so b - K a_rho_rest is the round-off of k products), and the densities stay at
    their first value."""
    if bitwise:
        np.testing.assert_array_equal(theirs, rest, err_msg=name)
    else:
        np.testing.assert_allclose(theirs, rest[-len(theirs):], rtol=RTOL, atol=ATOL, err_msg=name)
    v = [i for i, n in enumerate(names) if n.startswith("v_")]
    rho = [i for i, n in enumerate(names) if n.startswith("rho_")]
    assert len(v) >= 3 and rho, name
    if name in LINEAR:
        assert np.all(theirs[:, v] == 0) and np.all(rest[:, v] == 0), name
    else:
        assert np.max(np.abs(theirs[:, v])) <= 1e-13 * np.max(np.abs(moving[:, v])), name
    assert np.all(np.ptp(theirs[:, rho], axis=0) == 0), name


@pytest.mark.parametrize("name", sorted(CASES))
def test_libcosim_leaves_the_fmu_at_rest_as_fmpy_does(fmus, name):
    """Start at rest in an independent importer: libcosim sets nothing (initial_state_scale keeps its start
    value 0, f its start 0) and the FMU stays where fmpy has it: the linear models exactly at rest."""
    pytest.importorskip("libcosimpy.CosimExecution", reason="libcosimpy is not installed (pip install libcosimpy)")
    path = fmus(name, 2)
    names, rest, moving = rest_run(path)
    assert_rest(name, names, libcosim_outputs(path, names, initial_state_scale=None), rest, moving)


@pytest.mark.parametrize("name", sorted(CASES))
def test_fmu_manipulation_toolbox_container_leaves_the_fmi3_fmu_at_rest_as_fmpy_does(fmus, tmp_path, name):
    """The same in the container (FMI 3), built with no start values."""
    if shutil.which("fmucontainer") is None:
        pytest.skip("fmu-manipulation-toolbox is not installed (pip install fmu-manipulation-toolbox)")
    path = fmus(name, 3)
    names, rest, moving = rest_run(path)
    theirs = container_outputs(tmp_path, path, names, initial_state_scale=None)
    assert theirs.shape == rest.shape, name
    assert_rest(name, names, theirs, rest, moving, bitwise=True)                 # measured: bitwise


def fmi_sim_executable():
    """fmi-sim (the Rust FMI importer, ``cargo install fmi-sim``, which ``.ci/run`` builds where cargo is), on PATH
    or in cargo's bin folder ($CARGO_HOME/bin, by default ~/.cargo/bin); None if absent."""
    import os
    from pathlib import Path
    found = shutil.which("fmi-sim")
    cargo = Path(os.environ.get("CARGO_HOME", Path.home() / ".cargo")) / "bin" / "fmi-sim"
    return found or (str(cargo) if cargo.exists() else None)


def fmi_sim_outputs(tmp_path, path, fmi, start):
    """fmi-sim's co-simulation of the FMU over N_STEPS steps of H with ``start`` set before initialization:
    (names, rows at 0, H, ..., N_STEPS H).  fmi-sim 0.7 refuses FMI 3's ``nominal`` attribute of a Float64
    variable (valid in the standard's schema): for FMI 3 it runs a copy whose modelDescription has none (the
    binary and every other byte unchanged)."""
    import csv
    import re
    import zipfile
    exe = fmi_sim_executable()
    run = path
    if fmi == 3:
        run = tmp_path / "no-nominal.fmu"
        with zipfile.ZipFile(path) as zin, zipfile.ZipFile(run, "w") as zout:
            for item in zin.infolist():
                data = zin.read(item.filename)
                if item.filename == "modelDescription.xml":
                    data = re.sub(rb' nominal="[^"]*"', b"", data)
                zout.writestr(item, data)
    out = tmp_path / "fmi-sim.csv"
    args = [exe, "--model", str(run), "-o", str(out), "co-simulation", "--step", str(H), "-f", str(N_STEPS * H),
            "--output-interval", str(H)]      # fmi-sim 0.7: "-n 0" still gives its 500 default output points
    for name, value in start.items():
        args += ["--init-values", f"{name}={value!r}"]
    done = subprocess.run(args, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, (done.stdout + done.stderr)[-2000:]
    rows = list(csv.reader(out.open()))
    names = [h.strip().strip('"') for h in rows[0]]
    return names[1:], np.array([[float(x) for x in r] for r in rows[1:]])[:, 1:]


@pytest.mark.parametrize("name", ["frozen", "exact", "balanced", "ports", "ports_frozen"])
@pytest.mark.parametrize("fmi", [2, 3])
def test_fmi_sim_runs_the_fmus_as_fmpy_does(fmus, tmp_path, name, fmi):
    """fmi-sim (Rust, its own FMI 2 and FMI 3 bindings) steps the plain and the port FMUs from the scene's initial
    state (port forces held at their start values): every output, the error bounds too, as fmpy gives it (the
    differences: ``python3 -m pytest -n 0 -s tests/test_importers.py -k fmi_sim``)."""
    if fmi_sim_executable() is None:
        pytest.skip("fmi-sim is not installed (cargo install fmi-sim; its build needs libclang: "
                    "LIBCLANG_PATH and BINDGEN_EXTRA_CLANG_ARGS=-I<gcc include>)")
    path = fmus(name, fmi)
    start = {"initial_state_scale": 1.0, **CASES[name][1]}
    names, ours = fmpy_outputs(path, CASES[name][1])
    their_names, theirs = fmi_sim_outputs(tmp_path, path, fmi, start)
    assert set(their_names) == set(names), (their_names, names)
    theirs = theirs[:, [their_names.index(n) for n in names]]
    assert theirs.shape == ours.shape, name
    print_difference(f"fmi-sim FMI {fmi}", name, theirs, ours)
    assert_outputs_close(theirs, ours, names, name)
