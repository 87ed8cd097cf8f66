"""The FMU: packaging, fmpy validation and simulation, equality with
the Python frozen model, exact communication points, FMU states, bad input,
many instances, the sphrom fmu / cosim commands.

The binaries are built once per session (private cache); FMUs of two shrunk
scenes are packaged once per combination of options.
"""

import concurrent.futures
import math
import os
import shutil
import zipfile

import fmpy
import numpy as np
import pytest
from fmpy.fmi1 import FMICallException

from conftest import assert_units_through_declared_types, fmu_scene
from sphrom.cli import main
from sphrom.fmu.make.build import ensure_binaries
from sphrom.fmu.run.driver import FMU
from sphrom.fmu.make.package import package_fmu
from sphrom.fmu.check.python_cosim import cosim_reference, probe_values, split_step
from sphrom.fmu.resources import unpack
from sphrom.fmu.variables import vr
from sphrom.pod.pipeline import basis_for_scene
from sphrom.rom.operators import probe_rows
from sphrom.rom.registry import get_model
from sphrom.sph.solver import build_problem

K = 6
PROBES = (0.25, 0.5, 0.66)
RTOL = 1e-12


scene_for = fmu_scene


@pytest.fixture(scope="session")
def binaries():
    return ensure_binaries()


@pytest.fixture(scope="session")
def fmus(binaries, tmp_path_factory):
    """make(case, fmi, integrator, n_freeze, k) -> (path, ModelData), packaged once each."""
    folder = tmp_path_factory.mktemp("fmus")
    made = {}

    def make(case="forced", fmi=2, integrator="euler", n_freeze=10, k=K):
        key = (case, fmi, integrator, n_freeze, k)
        if key not in made:
            path = folder / f"{case}-fmi{fmi}-{integrator}-nf{n_freeze}-k{k}.fmu"
            package_fmu(scene_for(case), path, k=k, fmi=fmi, integrator=integrator, n_freeze=n_freeze,
                        probes=PROBES, progress=False, binaries=binaries)
            made[key] = (path, unpack(zipfile.ZipFile(path).read("resources/model.bin")))
        return made[key]

    return make


def relative_residual(out, ref):
    """max over outputs of |out - ref| / max |ref| of that output."""
    scale = np.maximum(np.abs(ref).max(axis=0), 1e-300)
    return float((np.abs(out - ref) / scale).max())


# ---------------------------------------------------------------------------
# validation and simulation through fmpy
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("fmi", [2, 3])
def test_fmpy_validates_and_simulates(fmus, fmi):
    path, data = fmus("forced", fmi)
    assert fmpy.validation.validate_fmu(str(path)) == []
    assert_units_through_declared_types(path)
    md = fmpy.read_model_description(str(path))
    names = [v.name for v in md.modelVariables]
    assert names[:4 - (fmi == 2)] == (["f", "n_freeze", "dt"] if fmi == 2 else ["time", "f", "n_freeze", "dt"])
    assert [n for n in names if "probe" in n] == [f"{name}_{j}{bound}" for bound in ("", "_error_bound")
                                                  for name in ("v_probe", "rho_probe") for j in (1, 2, 3)]
    assert md.coSimulation.modelIdentifier == "sphrom"
    assert md.coSimulation.canHandleVariableCommunicationStepSize
    assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate
    if fmi == 3:
        assert float(md.coSimulation.fixedInternalStepSize) == data.dt
        names_in_zip = zipfile.ZipFile(path).namelist()
        assert "sources/buildDescription.xml" in names_in_zip
    assert {"sources/rom.c", "sources/rom.h", f"sources/fmi{fmi}_cs.c", "sources/README.txt",
            "resources/model.bin"} <= set(zipfile.ZipFile(path).namelist())
    assert [c.name for c in md.logCategories] == ["logEvents", "logStatusWarning", "logStatusError"]
    assert float(md.defaultExperiment.stopTime) == 0.5 and float(md.defaultExperiment.startTime) == 0
    result = fmpy.simulate_fmu(str(path), stop_time=0.5, output_interval=0.01)
    assert result.shape[0] == 51
    for name in result.dtype.names:
        assert np.all(np.isfinite(result[name]))
    assert np.all(result["rho_probe_1"] > 0)


def test_fmi2_and_fmi3_agree_bitwise(fmus):
    rng = np.random.default_rng(1)
    inputs = rng.normal(0, 0.02, 40)
    steps = [0.01] * 40
    outs = []
    for fmi in (2, 3):
        with FMU(fmus("forced", fmi)[0]) as s:
            s.initialize(initial_state_scale=1)
            outs.append(s.run(steps, inputs))
    assert np.array_equal(outs[0], outs[1])


# ---------------------------------------------------------------------------
# equality with the Python frozen model
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("case", ["forced", "unforced"])
@pytest.mark.parametrize("integrator", ["euler", "symplectic"])
def test_equals_python_frozen_model(fmus, case, integrator, record_property):
    """FMU outputs = the registry's frozen model (b about the rest density, the FMU's) on the same basis, k,
    n_freeze, force held per step."""
    path, data = fmus(case, 2, integrator)
    scene = scene_for(case)
    problem = build_problem(scene)
    basis, _ = basis_for_scene(scene, progress=False, problem=problem)
    ops = get_model("frozen").build(problem, basis, K, K, input_direction="needed", tensor="always")
    dt, H, M = scene.sph.dt, 0.01, 50
    m = int(round(H / dt))
    inputs = scene.force(np.arange(M) * H) if case == "forced" else np.zeros(M)

    def held(tn):
        return inputs[np.minimum(np.rint(np.asarray(tn) / dt).astype(int) // m, M - 1)]

    frozen = get_model("frozen")
    res = frozen.run(ops, problem, n_steps=M * m, dt=dt, force=held, sample_steps=np.arange(0, M * m + 1, m),
                     options=frozen.options(integrator=integrator, n_freeze=10))
    Pv = probe_rows(ops.U_v, problem.x, scene.L, PROBES)
    Pr = probe_rows(ops.U_rho, problem.x, scene.L, PROBES)
    ref = np.hstack([np.array([probe_values(Pv, a) for a in res.a_v]),
                     np.array([probe_values(Pr, a) for a in res.a_rho])])
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        out = s.run([H] * M, inputs)
    residual = relative_residual(out, ref)
    record_property("relative_residual", residual)
    record_property("bitwise", bool(np.array_equal(out, ref)))
    assert residual <= RTOL
    # the velocity output must actually move: not a trivially equal constant
    assert np.ptp(out[:, 0]) > 0
    # and the same through fmpy.simulate_fmu (FMI 3, input signal sampled at the points)
    path3, _ = fmus(case, 3, integrator)
    signal = np.zeros(M + 1, dtype=[("time", float), ("f", float)])
    signal["time"] = np.arange(M + 1) * H
    signal["f"][:M] = inputs
    signal["f"][M] = inputs[-1]
    sim = fmpy.simulate_fmu(str(path3), stop_time=M * H, output_interval=H, input=signal,
                            start_values={"initial_state_scale": 1.0})
    names = ["v_probe_1", "v_probe_2", "v_probe_3", "rho_probe_1", "rho_probe_2", "rho_probe_3"]
    out3 = np.column_stack([sim[n] for n in names])
    assert relative_residual(out3, ref) <= RTOL


def test_n_freeze_parameter(fmus):
    """n_freeze set at initialization equals the Python model with that n_freeze (and differs from 10)."""
    path, data = fmus("forced", 2)
    rng = np.random.default_rng(3)
    steps, inputs = [0.004] * 30, rng.normal(0, 0.05, 30)
    with FMU(path) as s:
        s.initialize(n_freeze=3, initial_state_scale=1)
        assert s.fmu.getInteger([vr("n_freeze")]) == [3]
        out = s.run(steps, inputs)
    _, v, r = cosim_reference(data, steps, inputs, n_freeze=3)
    assert relative_residual(out, np.hstack([v, r])) <= RTOL
    _, v10, r10 = cosim_reference(data, steps, inputs, n_freeze=10)
    assert not np.array_equal(np.hstack([v10, r10]), out)


# ---------------------------------------------------------------------------
# communication points reached exactly
# ---------------------------------------------------------------------------

def test_split_step_rule():
    dt = 2e-4
    assert split_step(50 * dt, dt) == (50, 0.0)
    assert split_step(0.01 * (1 + 1e-13), dt) == (50, 0.0)
    n, rest = split_step(2.5 * dt, dt)
    assert n == 2 and rest == pytest.approx(0.5 * dt, rel=1e-12)
    assert split_step(0.3 * dt, dt) == (0, 0.3 * dt)
    # dt above h: one step of length h however small h/dt is (it used to round to no step at all)
    assert split_step(1e-13 * dt, dt) == (0, 1e-13 * dt)
    assert split_step(dt * (1 - 1e-12), dt) == (1, 0.0)


@pytest.mark.parametrize("fmi", [2, 3])
def test_non_multiple_steps_reach_points_exactly(fmus, fmi):
    path, data = fmus("forced", fmi)
    dt = data.dt
    rng = np.random.default_rng(7)
    steps = [0.37 * dt, 2.5 * dt, 7.3 * dt, dt, 13.03 * dt, 0.0123, 1e-3, 0.5 * dt, 3 * dt] + \
        list(rng.uniform(0.1, 20, 20) * dt)
    inputs = rng.normal(0, 0.05, len(steps))
    times, out = [], []
    with FMU(path) as s:
        s.initialize(n_freeze=4, initial_state_scale=1)
        t = 0.0
        out.append(s.output_values())
        for h, f in zip(steps, inputs):
            s.set_input(f)
            s.do_step(t, h)
            t = t + h
            times.append(s.time())
            assert s.time() == t                 # exactly t_comm + h, never accumulated internally
            out.append(s.output_values())
    tr, v, r = cosim_reference(data, steps, inputs, n_freeze=4)
    assert np.array_equal(np.array(times), tr[1:])
    assert relative_residual(np.array(out), np.hstack([v, r])) <= RTOL


def test_start_time_and_long_step(fmus):
    """A start time other than 0 and one communication step over the whole horizon."""
    path, data = fmus("forced", 3)
    with FMU(path) as a, FMU(path) as b:
        a.initialize(start=1.25, f=0.01, initial_state_scale=1)
        b.initialize(start=0.0, f=0.01, initial_state_scale=1)
        a.do_step(1.25, 0.3)
        b.do_step(0.0, 0.3)
        assert a.time() == 1.25 + 0.3
        # the state does not depend on the start time, only on the steps
        assert np.array_equal(a.output_values(), b.output_values())


# ---------------------------------------------------------------------------
# FMU state
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("fmi", [2, 3])
def test_state_get_set_serialize_bitwise(fmus, fmi):
    path, data = fmus("forced", fmi)
    rng = np.random.default_rng(11)
    steps = list(rng.uniform(0.5, 30, 30) * data.dt)
    inputs = rng.normal(0, 0.05, 30)
    with FMU(path) as s:
        s.initialize(n_freeze=7, initial_state_scale=1)
        s.run(steps[:12], inputs[:12])
        t1 = s.time()
        state = s.get_state()
        blob = s.serialize(state)
        a = s.run(steps[12:], inputs[12:], t0=t1)
        s.set_state(state)
        b = s.run(steps[12:], inputs[12:], t0=t1)
        restored = s.deserialize(blob)
        s.set_state(restored)
        c = s.run(steps[12:], inputs[12:], t0=t1)
        s.free_state(state)
        s.free_state(restored)
    assert np.array_equal(a, b) and np.array_equal(a, c)
    # a serialized state restores in another instance of the same FMU
    with FMU(path) as other:
        other.set_state(other.deserialize(blob))
        d = other.run(steps[12:], inputs[12:], t0=t1)
    assert np.array_equal(a, d)


@pytest.mark.parametrize("fmi", [2, 3])
def test_state_from_another_fmu_is_refused(fmus, fmi):
    path, data = fmus("forced", fmi)
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        s.do_step(0.0, 0.01)
        blob = s.serialize(s.get_state())
    # same sizes, other token (other default n_freeze), and other sizes (k = 5)
    for other_path in (fmus("forced", fmi, n_freeze=7)[0], fmus("forced", fmi, k=5)[0]):
        with FMU(other_path) as o:
            o.initialize(initial_state_scale=1)
            with pytest.raises(FMICallException):
                o.deserialize(blob)
            assert any("another FMU" in e for e in o.errors()), o.errors()
    # truncated and corrupted blobs
    for bad in (blob[:-9], blob[:50], blob[:100] + bytes([blob[100] ^ 1]) + blob[101:]):
        with FMU(path) as o:
            with pytest.raises(FMICallException):
                o.deserialize(bad)
            assert o.errors()


# ---------------------------------------------------------------------------
# bad input: errors with a message, never a crash or a silent NaN
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("fmi", [2, 3])
def test_bad_input_values(fmus, fmi):
    path, _ = fmus("forced", fmi)
    for value in (math.nan, math.inf, -math.inf):
        with FMU(path) as s:
            s.initialize(initial_state_scale=1)
            with pytest.raises(FMICallException):
                s.set_input(value)
            assert any("not finite" in e for e in s.errors())
            # after an error only reset/free (or restoring a state) are allowed
            with pytest.raises(FMICallException):
                s.do_step(0.0, 0.01)
            assert any("Error state" in e for e in s.errors())
            s.reset()
            s.initialize(f=0.01, initial_state_scale=1)
            s.do_step(0.0, 0.01)
            assert np.all(np.isfinite(s.output_values()))
    with FMU(path) as s:
        with pytest.raises(FMICallException):
            s.initialize(n_freeze=0, initial_state_scale=1)
        assert any("n_freeze" in e and ">= 1" in e for e in s.errors())
    with FMU(path) as s:
        with pytest.raises(FMICallException):
            s.initialize(dt=-1.0, initial_state_scale=1)
        assert any("dt" in e for e in s.errors())


@pytest.mark.parametrize("fmi", [2, 3])
def test_runaway_is_an_error_naming_the_time(fmus, fmi):
    path, _ = fmus("forced", fmi)
    with FMU(path) as s:
        s.initialize(f=1e300, initial_state_scale=1)
        with pytest.raises(FMICallException):
            s.do_step(0.0, 0.01)
        assert any("ran away" in e or "non-finite" in e for e in s.errors())
        assert any("t = " in e for e in s.errors())
    with FMU(path) as s:
        s.initialize(dt=1e3, initial_state_scale=1)
        with pytest.raises(FMICallException):
            s.do_step(0.0, 1e6)
        assert any("t = " in e for e in s.errors())


@pytest.mark.parametrize("fmi", [2, 3])
def test_illegal_call_sequences(fmus, fmi):
    path, _ = fmus("forced", fmi)
    with FMU(path) as s:                    # doStep before exitInitializationMode
        with pytest.raises(FMICallException):
            s.do_step(0.0, 0.01)
        assert any("illegal call sequence" in e for e in s.errors())
    with FMU(path) as s:                    # a fixed parameter in step mode
        s.initialize(initial_state_scale=1)
        with pytest.raises(FMICallException):
            s.set_real([vr("dt")], [1e-4])
        assert any("fixed parameter" in e for e in s.errors())
    with FMU(path) as s:                    # the wrong communication point
        s.initialize(initial_state_scale=1)
        with pytest.raises(FMICallException):
            s.do_step(0.5, 0.01)
        assert any("does not match" in e for e in s.errors())
    for h in (0.0, -0.01, math.nan):
        with FMU(path) as s:
            s.initialize(initial_state_scale=1)
            with pytest.raises(FMICallException):
                s.do_step(0.0, h)
            assert s.errors()
    with FMU(path) as s:                    # an unknown value reference
        s.initialize(initial_state_scale=1)
        with pytest.raises(FMICallException):
            s.get_real([999])
        assert any("unknown value reference" in e for e in s.errors())


@pytest.mark.parametrize("fmi", [2, 3])
def test_bad_resources_and_token(fmus, fmi, tmp_path):
    path, _ = fmus("forced", fmi)
    blob = zipfile.ZipFile(path).read("resources/model.bin")
    cases = {
        "flipped": blob[:300] + bytes([blob[300] ^ 0x10]) + blob[301:],
        "truncated": blob[: len(blob) // 2],
        "empty": b"",
        "header": blob[:80],
        "version": blob[:8] + (5).to_bytes(4, "little") + blob[12:],
    }
    expect = {"flipped": "checksum", "truncated": "bytes", "empty": "truncated", "header": "bytes",
              "version": "version 5"}
    for name, content in list(cases.items()) + [("missing", None)]:
        folder = tmp_path / f"{name}-{fmi}"
        fmpy.extract(str(path), unzipdir=str(folder))
        target = folder / "resources" / "model.bin"
        if content is None:
            target.unlink()
        else:
            target.write_bytes(content)
        messages = []
        with pytest.raises(Exception, match="instantiate"):
            FMU(folder, messages=messages)
        texts = " ".join(m[2] for m in messages)
        assert messages and messages[-1][0] >= 3, name
        assert expect.get(name, "not found") in texts, (name, texts)
        shutil.rmtree(folder)
    messages = []
    with pytest.raises(Exception, match="instantiate"):
        FMU(path, token="{00000000-0000-0000-0000-000000000000}", messages=messages)
    assert "does not match" in messages[-1][2]


@pytest.mark.parametrize("fmi", [2, 3])
def test_debug_logging_categories_are_honoured(fmus, fmi):
    path, _ = fmus("forced", fmi)
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        s.do_step(0.0, 0.01)
        assert not any(cat == "logEvents" for _, cat, _ in s.messages)       # off by default
        s.fmu.setDebugLogging(True, ["logEvents"])
        s.do_step(0.01, 0.01)
        assert any(cat == "logEvents" and "t = 0.02" in text for _, cat, text in s.messages)
        s.fmu.setDebugLogging(False, [])                                      # everything off
        count = len(s.messages)
        with pytest.raises(FMICallException):
            s.do_step(0.0, 0.01)
        assert len(s.messages) == count                                       # the error is silent now
    with FMU(path) as s:
        s.fmu.setDebugLogging(True, ["logNoSuchCategory"])      # a warning (fmpy raises only on an error)
        assert not s.errors()
        assert any(status == 1 and "unknown log category 'logNoSuchCategory'" in text and "logEvents" in text
                   for status, _, text in s.messages), s.messages
        s.initialize(initial_state_scale=1)
        s.do_step(0.0, 0.01)                                     # the instance stays usable


# ---------------------------------------------------------------------------
# many instances per process, threads
# ---------------------------------------------------------------------------

def test_many_instances_interleaved_and_threads(fmus):
    path, data = fmus("forced", 2)
    other, _ = fmus("unforced", 3)
    rng = np.random.default_rng(5)
    steps, inputs = [0.01] * 30, rng.normal(0, 0.05, 30)
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        alone = s.run(steps, inputs)
    instances = [FMU(path, name=f"i{i}") for i in range(3)] + [FMU(other, name="other")]
    try:
        for s in instances:
            s.initialize(initial_state_scale=1)
        outs = [[s.output_values()] for s in instances]
        t = 0.0
        for h, f in zip(steps, inputs):       # interleave the instances step by step
            for s, out in zip(instances, outs):
                s.set_input(f)
                s.do_step(t, h)
                out.append(s.output_values())
            t += h
        for out in outs[:3]:
            assert np.array_equal(np.array(out), alone)
    finally:
        for s in instances:
            s.close()

    def job(i):
        with FMU(path, name=f"thread{i}") as s:
            s.initialize(initial_state_scale=1)
            return s.run(steps, inputs)

    cwd = os.getcwd()
    with concurrent.futures.ThreadPoolExecutor(4) as pool:
        results = list(pool.map(job, range(8)))
    for r in results:
        assert np.array_equal(r, alone)
    # fmpy chdir()s while loading a library: concurrent loads must not leave the
    # process in another instance's (deleted) folder
    assert os.getcwd() == cwd


# ---------------------------------------------------------------------------
# the commands
# ---------------------------------------------------------------------------

@pytest.fixture
def scene_file(tmp_path):
    path = tmp_path / "small_forced.toml"
    path.write_text(scene_for("forced").text)
    return path


@pytest.mark.parametrize("args, option", [
    (["--modes", "0"], "--modes"),
    (["--modes", "x"], "--modes"),
    (["--modes", "99"], "--modes"),
    (["--freeze", "0"], "--freeze"),
    (["--probes", "0.2,1.5"], "--probes"),
    (["--probes", "a,b"], "--probes"),
    (["--fmi", "4"], "--fmi"),
    (["--integrator", "rk4"], "--integrator"),
])
def test_fmu_command_rejects_bad_options(scene_file, tmp_path, capsys, args, option):
    out = tmp_path / "bad.fmu"
    assert main(["fmu", str(scene_file), *args, "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and option in err[0] and "allowed" in err[0]
    assert not out.exists()
    assert not list(tmp_path.glob(".bad.fmu*"))


def test_fmu_and_cosim_commands(scene_file, tmp_path, capsys):
    out = tmp_path / "small.fmu"
    assert main(["fmu", str(scene_file), "--modes", "6", "--fmi", "3", "--probes", "0.1,0.66", "--freeze", "5",
                 "--out", str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    for piece in ("k_v = 6", "k_rho = 6", "input projection error", "f projected on the modes", "x/L = 0.1, 0.66",
                  "no problems", "KiB"):
        assert piece in text, piece
    assert fmpy.validation.validate_fmu(str(out)) == []
    data = unpack(zipfile.ZipFile(out).read("resources/model.bin"))
    assert data.n_freeze == 5 and list(data.probe_x) == [0.1, 0.66]
    # cosim with an expression: equals the reference with f sampled at the points
    csv_out = tmp_path / "result.csv"
    assert main(["cosim", str(out), "--force", "0.02*sin(2*pi*t/T)", "--t-end", "0.2", "--step", "0.01",
                 "--initial-state-scale", "1", "--out", str(csv_out)]) == 0
    assert "wall time" in capsys.readouterr().out
    table = np.genfromtxt(csv_out, delimiter=",", names=True)
    model_names = ("v_probe_1", "v_probe_2", "rho_probe_1", "rho_probe_2")
    assert table.dtype.names == ("time", *model_names, *(n + "_error_bound" for n in model_names))
    assert all(np.all(table[n + "_error_bound"] >= 0) for n in model_names)
    assert table.shape[0] == 21 and table["time"][-1] == pytest.approx(0.2)
    t = np.arange(20) * 0.01
    tr, v, r = cosim_reference(data, [0.01] * 20, 0.02 * np.sin(2 * np.pi * t / 0.2))
    got = np.column_stack([table[n] for n in model_names])
    assert relative_residual(got, np.hstack([v, r])) <= RTOL
    # cosim with a CSV force and --n-freeze
    force_csv = tmp_path / "force.csv"
    force_csv.write_text("time,f\n0,0.01\n0.1,-0.01\n0.2,0.0\n")
    assert main(["cosim", str(out), "--force", str(force_csv), "--t-end", "0.2", "--step", "0.05",
                 "--n-freeze", "2", "--out", str(csv_out)]) == 0
    assert np.genfromtxt(csv_out, delimiter=",", names=True).shape[0] == 5


def test_cosim_command_errors(fmus, tmp_path, capsys):
    path, _ = fmus("forced", 2)
    out = tmp_path / "r.csv"
    bad = [
        (["--force", "nosuch(t)"], "--force"),
        (["--force", "log(t - 1)"], "--force"),
        (["--step", "0"], "--step"),
        (["--t-end", "-1"], "--t-end"),
        (["--n-freeze", "0"], "--n-freeze"),
        (["--initial-state-scale", "nan"], "--initial-state-scale"),
        (["--initial-state-scale", "inf"], "--initial-state-scale"),
        (["--force", str(tmp_path / "missing.csv")], "--force"),
        (["--t-end", "0.1", "--step", "0.2"], "--step: 0.2 is out of range (allowed: 0 < step <= t_end = 0.1)"),
    ]
    for args, option in bad:
        assert main(["cosim", str(path), *args, "--out", str(out)]) == 2, args
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and option in err[0], err
    assert main(["cosim", str(tmp_path / "nothing.fmu"), "--out", str(out)]) == 2
    capsys.readouterr()
    assert not out.exists()
    # a failure inside the FMU: exit 3 with its message naming the time, no CSV
    assert main(["cosim", str(path), "--force", "1e300", "--t-end", "0.05", "--out", str(out)]) == 3
    err = capsys.readouterr().err
    assert "t = " in err and not out.exists()


def test_cosim_force_longer_than_a_file_name_is_an_expression(fmus, tmp_path, capsys):
    """A --force of 300 characters is no possible file name: it is evaluated, never an OSError."""
    path, _ = fmus("forced", 2)
    long = " + ".join(["1e-3*sin(2*pi*t/T)"] * 15) + " + 0*t" * 5
    assert len(long) > 255
    runs = {}
    for name, force in (("long", long), ("short", "15e-3*sin(2*pi*t/T)")):
        out = tmp_path / f"{name}.csv"
        assert main(["cosim", str(path), "--force", force, "--t-end", "0.1", "--step", "0.01",
                     "--out", str(out)]) == 0
        runs[name] = np.genfromtxt(out, delimiter=",", names=True)
    capsys.readouterr()
    for col in runs["short"].dtype.names:
        np.testing.assert_allclose(runs["long"][col], runs["short"][col], rtol=1e-12, atol=1e-15)
    out = tmp_path / "r.csv"
    assert main(["cosim", str(path), "--force", "maximum(t, 0.9, t)" + " " * 300, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--force: maximum() takes 2 arguments" in err[0] and not out.exists(), err


@pytest.mark.parametrize("fmi", [2, 3])
def test_resources_in_a_folder_that_needs_escaping(fmus, tmp_path, fmi):
    """FMI 2 passes a percent-encoded file URI, FMI 3 a plain path: both find model.bin."""
    path, _ = fmus("forced", fmi)
    folder = tmp_path / "a folder with space, 100% #1"
    fmpy.extract(str(path), unzipdir=str(folder))
    with FMU(folder) as s:
        s.initialize(initial_state_scale=1)
        s.do_step(0.0, 0.01)
        assert np.all(np.isfinite(s.output_values()))


def test_bench_fmu_command_smoke(scene_file, tmp_path, capsys):
    out = tmp_path / "bench"
    assert main(["bench-fmu", str(scene_file), "--sizes", "48", "--steps", "0.05", "--out", str(out),
                 "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "ns/step" in text and "faster than the full SPH" in text and "where the time goes" in text
    assert (out / "bench_fmu_core.csv").is_file() and (out / "bench_fmu_e2e.csv").is_file()
    assert "| comm. step |" in (out / "bench_fmu.md").read_text()
    # both FMUs, each with its probe-velocity error against the full SPH, and the SPH's against exact
    assert "FMU frozen" in text and "FMU exact" in text and "probe v error against the full SPH" in text
    import csv
    with open(out / "bench_fmu_e2e.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert {r["model"] for r in rows} == {"frozen", "exact"}
    for r in rows:
        assert 0 < float(r["probe_error_v_vs_sph"]) < 1


@pytest.mark.parametrize("fmi", [2, 3])
def test_no_template_or_repository_text_ships_in_the_fmu(fmus, fmi):
    """The modelDescription (and FMI 3's buildDescription) inside an FMU are filled templates: no placeholder left,
    and none of the template's own comment (it explains this repository's placeholders and names its files)."""
    path, _ = fmus(fmi=fmi)
    with zipfile.ZipFile(path) as z:
        names = ["modelDescription.xml"] + (["sources/buildDescription.xml"] if fmi == 3 else [])
        for name in names:
            text = z.read(name).decode("utf-8")
            assert "{{" not in text and "}}" not in text, name
            assert "harness/" not in text and "double braces" not in text, name
