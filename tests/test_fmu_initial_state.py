"""The FMU parameter ``initial_state_scale``: the initial state is that multiple of the scene's deviation from rest.

Start value 0 (a component starts at rest); 1 reproduces the FMUs from before the parameter bit for bit
(tests/data/initial_state_reference.npz, made by tests/data/make_initial_state_reference.py on the code before
it); 0 with f = 0 stays at rest over T = 100 s; any finite real scales the initial state, as the Python models'
``initial_state_scale`` does; non-finite values and a set after initialization are refused, naming the variable.
"""

import dataclasses
import math
import re
import zipfile
from pathlib import Path

import fmpy
import numpy as np
import pytest
from fmpy.fmi1 import FMICallException

from old_formats import from_format_3
from conftest import fmu_maker, fmu_scene
from sphrom.fmu.make.build import ensure_binaries
from sphrom.fmu.make.describe import model_description
from sphrom.fmu.run.driver import FMU
from sphrom.fmu.make.models import exact_model, reduced_model
from sphrom.fmu.make.archive import write_fmu
from sphrom.fmu.check.python_cosim import cosim_reference
from sphrom.fmu.resources import probe_pairs, unpack
from sphrom.fmu.variables import vr
from sphrom.rom.exact_linear import run_exact
from sphrom.sph.solver import build_problem

DATA = Path(__file__).parent / "data"
K = 6
PROBES = (0.25, 0.5, 0.66)
MODELS = ("frozen", "exact")


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    """make(model, fmi, case) -> (path, data), packaged once each."""
    return fmu_maker(tmp_path_factory.mktemp("iss-fmus"), "frozen", k=K, probes=PROBES)


def _run(path, steps, inputs, scale=None):
    with FMU(path) as s:
        s.initialize(initial_state_scale=scale)
        return s.run(steps, inputs)


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("model", MODELS)
def test_scale_one_reproduces_the_fmus_before_the_parameter_bitwise(tmp_path, model, fmi):
    """The stored resources (rewritten in today's model.bin format, tests/old_formats.py), packaged with today's
    binaries: at initial_state_scale = 1 the outputs equal the outputs of the FMU before the parameter existed bit
    for bit; left at its start value they do not."""
    ref = np.load(DATA / "initial_state_reference.npz")
    blob = from_format_3(ref[f"{model}/model_bin"].tobytes())       # stored as format 3: the same numbers today
    data = unpack(blob)
    description = model_description(fmi, token=data.token, scene=fmu_scene("forced"), data=data, k_requested=K,
                                     step_size=0.01, stop_time=0.5, input_error=float("nan"), model=model)
    binaries = ensure_binaries()
    path = tmp_path / f"{model}-{fmi}.fmu"
    write_fmu(path, fmi=fmi, blob=blob, description=description,
              binary=binaries.fmi2 if fmi == 2 else binaries.fmi3)
    steps, inputs = ref["steps"], ref["inputs"]
    out = _run(path, steps, inputs, scale=1.0)
    assert np.array_equal(out, ref[f"{model}/fmi{fmi}"])
    assert np.ptp(out[:, 0]) > 0
    at_start = _run(path, steps, inputs)                      # the start value: at rest, only the force moves it
    assert not np.array_equal(at_start, out)
    assert np.all(at_start[0, :len(PROBES)] == 0.0)


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("case", ["forced", "unforced"])
def test_scale_zero_without_force_stays_at_rest_for_100_s(fmus, model, fmi, case, record_property):
    """initial_state_scale = 0 (the start value), f = 0, T = 100 s: v = 0 and rho = rho0 at the probes.

    The exact model: to round-off (z = 0 is its rest state: v = 0 and e = 0 exactly).  The frozen model: to
    round-off too, because its b is taken about the projected rest density (the frozen model's build option
    b="rest": b = K a_rho_rest).  With eq. 2.22's b (b="paper") the FMU drifts at the level of ρ0's projection
    error (test_the_frozen_models_b_option_gives_the_rest_benchs_eq_2_22_fmu; every scene: python -m
    sphrom.bench.rest).
    Its density outputs stay constant at ρ0 as the density modes represent it (off ρ0 by ρ0's projection error
    at the probes, asserted below 1e-6 of ρ0)."""
    path, data = fmus(model, fmi, case)
    n = 1000
    out = _run(path, [0.1] * n, np.zeros(n))                  # not set: the start value 0
    moving = _run(path, [0.1] * 50, np.zeros(50), scale=1.0)
    P = len(PROBES)
    v, rho = out[:, :P], out[:, P:]
    v_scale = np.abs(moving[:, :P]).max()
    scene = fmu_scene(case)
    problem = build_problem(scene)
    i0, i1, w = probe_pairs(problem.x, scene.L, np.asarray(PROBES))
    rho0 = problem.rho0[i0] * (1 - w) + problem.rho0[i1] * w          # the probes interpolate between particles
    record_property("max_v_over_scene_v", float(np.abs(v).max() / v_scale))
    record_property("max_rho_error", float(np.abs(rho - rho0).max()))
    assert v_scale > 1e-4
    if model == "exact":
        assert np.abs(v).max() <= 1e-14 * v_scale
        assert np.abs(rho - rho0).max() <= 1e-14 * rho0.max()
    else:
        assert np.all(v[0] == 0.0)
        assert np.abs(v).max() <= 1e-14 * v_scale
        assert np.all(rho == rho[0])                           # no density rate at all: a^v stays 0 exactly
        assert np.abs(rho - rho0).max() <= 1e-6 * rho0.max()    # ρ0 as the density modes hold it


def test_any_finite_scale_scales_the_initial_state(fmus):
    """Exact model: the outputs are affine in the initial state (v(s) - v(0) = s (v(1) - v(0))); frozen: the
    FMU equals the Python mirror of doStep started from s a_v0, and the Python models' initial_state_scale."""
    rng = np.random.default_rng(3)
    steps, inputs = [0.01] * 30, rng.normal(0, 0.02, 30)
    path, data = fmus("exact", 2)
    outs = {s: _run(path, steps, inputs, scale=s) for s in (0.0, 1.0, -2.5)}
    P = len(PROBES)
    v = {s: o[:, :P] for s, o in outs.items()}
    np.testing.assert_allclose(v[-2.5] - v[0.0], -2.5 * (v[1.0] - v[0.0]), rtol=0, atol=1e-12 * np.abs(v[1.0]).max())
    dense, lin, _, _ = exact_model(fmu_scene("forced"), K, PROBES, progress=False)   # its rows over the dense z
    t = np.arange(31) * 0.01
    held = {round(ti, 9): f for ti, f in zip(t, inputs)}

    def force(s):
        return np.array([held.get(round(float(x), 9), inputs[-1]) for x in np.atleast_1d(s)])
    for s in (0.0, -2.5):
        z = run_exact(lin, t, step=0.01, force=force, hold="held", initial_state_scale=s).z
        np.testing.assert_allclose(outs[s][:, :P], z[:, :lin.k_v] @ dense.Pv.T, rtol=0,
                                   atol=1e-11 * np.abs(v[1.0]).max())
    path, data = fmus("frozen", 2)
    for s in (0.0, 0.5, -3.0):
        out = _run(path, steps, inputs, scale=s)
        _, rv, rr = cosim_reference(data, steps, inputs, initial_state_scale=s)
        assert np.array_equal(out, np.hstack([rv, rr]))
    _, rv1, rr1 = cosim_reference(data, steps, inputs)
    _, rv2, rr2 = cosim_reference(data, steps, inputs, initial_state_scale=1.0)
    assert np.array_equal(rv1, rv2) and np.array_equal(rr1, rr2)


def test_python_models_scale_one_is_bitwise_and_rest_stays_at_rest():
    from sphrom.rom.registry import get_model
    scene = fmu_scene("unforced")
    _, lin, problem, _ = exact_model(scene, K, PROBES, progress=False)
    _, ops, _, _ = reduced_model(scene, K, 10, PROBES, "euler", progress=False)
    n = 200
    for name, operators in (("exact", lin), ("frozen", ops)):
        run = get_model(name).run
        a = run(operators, problem, dt=scene.sph.dt, n_steps=n)
        b = run(operators, problem, dt=scene.sph.dt, n_steps=n, initial_state_scale=1.0)
        assert np.array_equal(a.a_v, b.a_v) and np.array_equal(a.a_rho, b.a_rho), name
        c = run(operators, problem, dt=scene.sph.dt, n_steps=n, initial_state_scale=0.0)
        assert np.all(c.a_v[0] == 0.0) and np.array_equal(c.a_rho[0], operators.a_rho0), name
        if name == "exact":
            assert np.all(c.a_v == 0.0) and np.all(c.a_rho == 0.0)
        else:       # the FMU's frozen model (b = K a_rho_rest) stays at rest; with eq. 2.22's b it drifts
            moving = np.abs(a.a_v).max()
            assert np.abs(c.a_v).max() <= 1e-13 * moving
            b_paper = operators.U_v.T @ (operators.inv_rho0 * (problem.neighbours.matrix() @ problem.c))  # eq. 2.22
            paper = dataclasses.replace(operators, b=b_paper, b_form="paper")
            drift = run(paper, problem, dt=scene.sph.dt, n_steps=n, initial_state_scale=0.0).a_v
            assert np.abs(drift).max() > 1e-9 * moving
            np.testing.assert_allclose(operators.b, operators.K @ operators.a_rho0, rtol=0, atol=0)
        with pytest.raises(ValueError, match="initial_state_scale"):
            run(operators, problem, dt=scene.sph.dt, n_steps=n, initial_state_scale=float("nan"))
    assert np.all(lin.z0[lin.k_v:] == 0.0)             # z0 has no e-part: z0 is the deviation from rest


@pytest.mark.parametrize("fmi", [2, 3])
def test_declared_as_a_fixed_parameter_starting_at_rest(fmus, fmi):
    for model in MODELS:
        path, _ = fmus(model, fmi)
        assert fmpy.validation.validate_fmu(str(path)) == []
        md = fmpy.read_model_description(str(path))
        var = next(v for v in md.modelVariables if v.name == "initial_state_scale")
        assert (var.valueReference, var.causality, var.variability, var.type) == (
            vr("initial_state_scale"), "parameter", "fixed", "Real" if fmi == 2 else "Float64")
        assert float(var.start) == 0.0 and var.initial in (None, "exact")
        text = zipfile.ZipFile(path).read("modelDescription.xml").decode()
        assert re.search(r'name="initial_state_scale"[^>]*causality="parameter"', text)


@pytest.mark.parametrize("fmi", [2, 3])
def test_settable_before_initialization_refused_after_or_non_finite(fmus, fmi):
    path, _ = fmus("frozen", fmi)
    with FMU(path) as s:                                 # settable in Instantiated and in InitializationMode
        s.set_real([vr("initial_state_scale")], [0.25])
        if fmi == 2:
            s.fmu.setupExperiment(startTime=0.0)
            s.fmu.enterInitializationMode()
        else:
            s.fmu.enterInitializationMode(startTime=0.0)
        s.set_real([vr("initial_state_scale")], [0.5])
        s.fmu.exitInitializationMode()
        assert s.get_real([vr("initial_state_scale")])[0] == 0.5
        with pytest.raises(FMICallException):
            s.set_real([vr("initial_state_scale")], [1.0])
        assert any("initial_state_scale is a fixed parameter" in e for e in s.errors())
    for bad in (math.nan, math.inf, -math.inf):
        with FMU(path) as s:
            with pytest.raises(FMICallException):
                s.set_real([vr("initial_state_scale")], [bad])
            assert any("initial_state_scale" in e and "out of range (allowed: [-1000, 1000]" in e for e in s.errors()), s.errors()


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("model", MODELS)
def test_states_carry_the_scale_and_reset_restores_the_start_value(fmus, fmi, model):
    path, _ = fmus(model, fmi)
    steps, inputs = [0.01] * 10, np.full(10, 0.01)
    with FMU(path) as s:
        s.initialize(initial_state_scale=0.75)
        state = s.get_state()
        blob = s.serialize(state)
        first = s.run(steps, inputs)
        s.reset()
        s.initialize()
        assert s.get_real([vr("initial_state_scale")])[0] == 0.0      # fmi2Reset / fmi3Reset: the start value again
        restored = s.deserialize(blob)
        s.set_state(restored)
        assert s.get_real([vr("initial_state_scale")])[0] == 0.75
        assert np.array_equal(s.run(steps, inputs), first)
        s.free_state(state)
        s.free_state(restored)


def test_the_frozen_models_b_option_gives_the_rest_benchs_eq_2_22_fmu(fmus, tmp_path):
    """The frozen model's build option b (sphrom.bench.rest compares its two values): the FMU packaged with
    b="paper" holds eq. 2.22's b = U^vᵀ ρ0⁻¹ G c and otherwise the numbers of the registry's (b="rest") FMU; it
    equals the Python mirror of its resources bit for bit, and left at rest it drifts where the packaged one
    does not."""
    from sphrom.bench.rest import rest_run
    from sphrom.fmu.make.package import package_fmu
    scene = fmu_scene("unforced")
    path, data = fmus("frozen", 2, "unforced")
    _, ops, problem, _ = reduced_model(scene, K, 10, PROBES, "euler", progress=False)
    old = tmp_path / "eq222.fmu"
    package_fmu(scene, old, k=K, fmi=2, probes=PROBES, progress=False, binaries=ensure_binaries(), model="frozen",
                build_options={"b": "paper"})
    old_data = unpack(zipfile.ZipFile(old).read("resources/model.bin"))
    eq_2_22 = ops.U_v.T @ (ops.inv_rho0 * np.asarray(problem.neighbours.matrix() @ problem.c))     # eq. 2.22
    np.testing.assert_allclose(old_data.b, eq_2_22, rtol=0, atol=1e-14 * np.max(np.abs(eq_2_22)))
    assert not np.array_equal(old_data.b, data.b)
    np.testing.assert_array_equal(data.b, ops.K @ ops.a_rho0)                       # b = K a^ρ_rest
    for name in ("K", "T", "a_v0", "a_rho0", "Pv", "Prho"):
        assert np.array_equal(getattr(old_data, name), getattr(data, name)), name
    assert fmpy.validation.validate_fmu(str(old)) == []
    t, v_old, rho_old = rest_run(old, 0.1, T=20.0)
    _, v_new, _ = rest_run(path, 0.1, T=20.0)
    _, rv, rr = cosim_reference(old_data, [0.1] * (t.size - 1), np.zeros(t.size - 1), initial_state_scale=0.0)
    assert np.array_equal(np.hstack([v_old, rho_old]), np.hstack([rv, rr]))
    moving = np.abs(_run(path, [0.1] * 50, np.zeros(50), scale=1.0)[:, :len(PROBES)]).max()
    assert np.abs(v_old).max() > 1e-6 * moving > 1e6 * np.abs(v_new).max()
