"""The exact linear reduced model (in the specific volume) inside the FMU: `sphrom fmu --model exact`.

The C core advances the model in its real eigen-coordinates y = V⁻¹ z (the default block form: 1 x 1 and
2 x 2 blocks, each with its own matrix exponential, cached per step length) and, without damping, evaluates
the free response (rotations) at the time itself.  These tests
hold it against the Python model of :mod:`sphrom.rom.exact_linear` (scipy's
expm, an independent implementation), against itself at other communication
steps, and check the energy over T = 1000, states and bad input.
"""

import math
import zipfile

import fmpy
import numpy as np
import pytest
from fmpy.fmi1 import FMICallException

from conftest import assert_units_through_declared_types, fmu_scene
from sphrom.fmu.make.build import ensure_binaries
from sphrom.fmu.run.driver import FMU
from sphrom.fmu.make.models import exact_model
from sphrom.fmu.make.package import package_fmu
from sphrom.fmu.resources import unpack
from sphrom.rom.exact_linear import run_exact
from sphrom.rom.modal import real_blocks

K = 6
PROBES = (0.25, 0.5, 0.66)
RTOL = 1e-11
# The packaged A and z0 are the Python model's in its real eigen-coordinates (A = V L V⁻¹): V L V⁻¹ and V y0 give
# them back to round-off of the transform, κ(V) ε ‖A‖ (κ(V) = 1 for the undamped model, V orthogonal; a few for the
# damped one): 1e-12 of the norm leaves κ(V) up to ~10³ (LAPACK's eigenvectors differ in round-off between CPUs).
TRANSFORM_RTOL = 1e-12


scene_for = fmu_scene


@pytest.fixture(scope="module")
def exact_fmus(tmp_path_factory):
    """make(case, fmi) -> (path, ExactData), packaged once each."""
    folder = tmp_path_factory.mktemp("exact-fmus")
    binaries = ensure_binaries()
    made = {}

    def make(case="forced", fmi=2):
        if (case, fmi) not in made:
            path = folder / f"{case}-fmi{fmi}.fmu"
            package_fmu(scene_for(case), path, k=K, fmi=fmi, probes=PROBES, progress=False, binaries=binaries,
                        model="exact")
            made[case, fmi] = (path, unpack(zipfile.ZipFile(path).read("resources/model.bin")))
        return made[case, fmi]

    return make


def probe_outputs(data, z):
    """[v_probe..., rho_probe...] from reduced states z (M, k), as rom_v_probe / rom_rho_probe."""
    z = np.atleast_2d(z)
    a, b = z[:, :data.k_v], z[:, data.k_v:]
    v = a @ data.Pv.T
    e = np.einsum("psk,mk->mps", data.Pe, b)                 # e = J - 1 at the two particles of each probe
    rho = np.sum(data.pw * data.prho0 / (1.0 + e), axis=2)
    return np.hstack([v, rho])


def relative_residual(out, ref):
    """max |out - ref| relative to the largest |ref| of the same kind (v probes, ρ probes): a probe at a node
    of every mode (x = L/2 in multimode) has v ≈ 1e-17 and no meaningful relative error of its own."""
    half = ref.shape[1] // 2
    scale = np.repeat([np.abs(ref[:, :half]).max(), np.abs(ref[:, half:]).max()], half)
    return float((np.abs(out - ref) / np.maximum(scale, 1e-300)).max())


@pytest.mark.parametrize("fmi", [2, 3])
def test_exact_fmu_validates_and_declares_the_model(exact_fmus, fmi):
    path, data = exact_fmus("forced", fmi)
    assert fmpy.validation.validate_fmu(str(path)) == []
    assert_units_through_declared_types(path)
    assert data.integrator == "exponential" and data.B is not None and data.damping
    md = fmpy.read_model_description(str(path))
    # no internal step: the exact model steps by the matrix exponential over any communication step
    assert b"fixedInternalStepSize" not in zipfile.ZipFile(path).read("modelDescription.xml")
    assert fmi == 2 or md.coSimulation.fixedInternalStepSize is None
    assert [v.name for v in md.modelVariables if v.causality == "output"] == \
        [f"{name}_{j}{bound}" for bound in ("", "_error_bound") for name in ("v_probe", "rho_probe") for j in (1, 2, 3)]
    _, unforced = exact_fmus("unforced", fmi)
    assert data.blocks and unforced.blocks                         # the block form, checked well conditioned
    assert unforced.Q is None and not unforced.damping             # d = 0: rotations, evaluated at the time itself


@pytest.mark.parametrize("case", ["forced", "unforced"])
def test_exact_fmu_equals_the_python_exact_model(exact_fmus, case, record_property):
    """FMU (C expm) = run_exact (scipy expm) with the input held over each step, FMI 2 and 3 bitwise alike."""
    path, data = exact_fmus(case, 2)
    scene = scene_for(case)
    dense, lin, _, _ = exact_model(scene, K, PROBES, progress=False)
    V = real_blocks(lin.A, skew=not data.damping).V
    assert data.blocks
    assert np.linalg.norm(V @ data.A @ np.linalg.inv(V) - lin.A) <= TRANSFORM_RTOL * np.linalg.norm(lin.A)
    assert np.linalg.norm(V @ data.z0 - lin.z0) <= TRANSFORM_RTOL * np.linalg.norm(lin.z0)
    H, M = 0.01, 50
    t = np.arange(M + 1) * H
    inputs = scene.force(t[:-1]) if case == "forced" else np.zeros(M)
    ref = run_exact(lin, t, step=H, force=scene.force if case == "forced" else None, hold="held")
    expected = probe_outputs(dense, ref.z)                          # the dense model's rows on its own z
    outs = []
    for fmi in (2, 3):
        with FMU(exact_fmus(case, fmi)[0]) as s:
            s.initialize(initial_state_scale=1)
            outs.append(s.run([H] * M, inputs))
    assert np.array_equal(outs[0], outs[1])
    residual = relative_residual(outs[0], expected)
    record_property("relative_residual", residual)
    assert residual <= RTOL
    assert np.ptp(outs[0][:, 0]) > 0                              # the probe velocity moves


def test_exact_fmu_does_not_depend_on_the_communication_step(exact_fmus):
    """Unforced: the state at t = 0.4 s from 40, 8, 1 and 14 (shortened last) steps agrees to round-off."""
    path, data = exact_fmus("unforced", 2)
    finals = {}
    for steps in ([0.01] * 40, [0.05] * 8, [0.4], [0.03] * 13 + [0.4 - 13 * 0.03]):
        with FMU(path) as s:
            s.initialize(initial_state_scale=1)
            out = s.run(steps, [0.0] * len(steps))
            assert s.time() == pytest.approx(0.4, abs=1e-15)
            finals[len(steps)] = out[-1]
    ref = finals[1]
    for n, value in finals.items():
        assert relative_residual(value[None, :], ref[None, :]) <= 1e-12, n


def test_an_importers_jittered_step_is_one_exponential(exact_fmus):
    """An importer's steps t[n+1] - t[n] of t = n H jitter by a few ulps of t (12 distinct values over 1000 steps
    of 10 ms); each new length would cost a matrix exponential (80 ms at order 282).  The core takes a step within
    8 ulps of its times as the cached one (rom_same_step): one exponential for the whole run, and the outputs equal
    the run at exactly H to 1e-12 of their range."""
    from sphrom.fmu.run.core import Core
    path, data = exact_fmus("forced", 2)
    blob = zipfile.ZipFile(path).read("resources/model.bin")
    core = Core(ensure_binaries().core)
    H, M = 0.01, 1000
    t = np.arange(M + 1) * H
    assert len(set(np.diff(t))) > 2                                 # the grid does jitter
    outs, counts = [], []
    for steps in (np.diff(t), np.full(M, H)):
        model = core.load(blob)
        try:
            model.set_input(0.02)
            rows, now = [], 0.0
            for h in steps:
                model.do_step(now, float(h))
                now = now + float(h)
                rows.append(np.concatenate(model.outputs(len(PROBES))))
            outs.append(np.array(rows))
            counts.append(model.expm_count)
        finally:
            model.close()
    assert counts == [1, 1], counts
    scale = np.ptp(outs[1], axis=0) + 1e-300
    assert np.max(np.abs(outs[0] - outs[1]) / scale) <= 1e-12


def test_exact_fmu_conserves_energy_over_t_1000(exact_fmus):
    """d = f = 0: the reduced energy ½|z|² (energy inner products) stays at its initial value to 1e-12 over
    T = 1000 s, and the state equals the Schur-form free response at the sum of its steps (math.fsum: the block
    form steps its rotations by ω h, so its state is at Σ h, which a float sum of 1000 steps misses by ~1e-11 s):
    to 4 ε ω_max T (the angles ω h and ω T rounded, and the block form's ω, its real Schur form's made exactly
    skew, against the Python model's own Schur form), at least 1e-12."""
    path, data = exact_fmus("unforced", 2)
    e0 = float(data.z0 @ data.z0)
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        assert np.array_equal(s.reduced_state(data.k), data.z0)
        t, drift = 0.0, 0.0
        for h in [0.7] * 500 + [1.3] * 500:                       # two step lengths, 1000 s in all
            s.do_step(t, h)
            t += h
        z = s.reduced_state(data.k)
        drift = abs(float(z @ z) - e0) / e0
    assert t == pytest.approx(1000.0, rel=1e-12)
    assert drift <= 1e-12, drift
    _, lin, _, _ = exact_model(scene_for("unforced"), K, PROBES, progress=False)
    t_steps = math.fsum([0.7] * 500 + [1.3] * 500)
    free = run_exact(lin, np.array([0.0, t_steps]), step=t_steps).z[-1]
    z = real_blocks(lin.A, skew=True).V @ z if data.blocks else z     # back from its eigen-coordinates (orthogonal)
    phase = 4 * np.finfo(float).eps * np.abs(np.linalg.eigvals(lin.A)).max() * t_steps
    assert np.max(np.abs(z - free)) <= max(1e-12, phase) * np.max(np.abs(free))


@pytest.mark.parametrize("fmi", [2, 3])
def test_exact_fmu_state_round_trip_is_bitwise(exact_fmus, fmi):
    path, data = exact_fmus("forced", fmi)
    rng = np.random.default_rng(4)
    steps, inputs = list(rng.uniform(0.002, 0.03, 20)), rng.normal(0, 0.05, 20)
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        s.run(steps[:8], inputs[:8])
        t1 = s.time()
        state = s.get_state()
        blob = s.serialize(state)
        a = s.run(steps[8:], inputs[8:], t0=t1)
        s.set_state(state)
        b = s.run(steps[8:], inputs[8:], t0=t1)
        restored = s.deserialize(blob)
        s.set_state(restored)
        c = s.run(steps[8:], inputs[8:], t0=t1)
        s.free_state(state)
        s.free_state(restored)
    assert np.array_equal(a, b) and np.array_equal(a, c)


@pytest.mark.parametrize("fmi", [2, 3])
def test_exact_fmu_bad_input_and_runaway_are_errors(exact_fmus, fmi):
    path, _ = exact_fmus("forced", fmi)
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        with pytest.raises(FMICallException):
            s.set_input(math.nan)
        assert any("not finite" in e for e in s.errors())
    with FMU(path) as s:
        s.initialize(f=1e300, initial_state_scale=1)
        with pytest.raises(FMICallException):
            s.do_step(0.0, 0.01)
        assert any(("ran away" in e or "non-finite" in e) and "t = " in e for e in s.errors()), s.errors()


# ---------------------------------------------------------------------------
# the exact FMU keeps its input direction: a force it was never trained on
# ---------------------------------------------------------------------------

@pytest.fixture(scope="module")
def unforced_exact_fmu(tmp_path_factory):
    """tenmode shrunk (d = f = 0: a free vibration, trained without any force), exact model, FMI 2."""
    from conftest import small_scene
    scene = small_scene("tenmode", T=1.0, n=64)
    path = tmp_path_factory.mktemp("unseen") / "tenmode-exact.fmu"
    package_fmu(scene, path, k=K, fmi=2, probes=PROBES, progress=False, binaries=ensure_binaries(), model="exact")
    return scene, path, unpack(zipfile.ZipFile(path).read("resources/model.bin"))


def _forced_response(path, steps, inputs):
    """Forced minus free run at the communication points (the model is linear): (v, rho) at the probes."""
    runs = []
    for f in (inputs, np.zeros_like(inputs)):
        with FMU(path) as s:
            s.initialize(initial_state_scale=1)
            runs.append(s.run(steps, f))
    d = runs[0] - runs[1]
    n = len(PROBES)
    return d[:, :n], d[:, n:]


def test_exact_fmu_reproduces_a_force_it_was_never_trained_on(unforced_exact_fmu):
    """A uniform force on uniform rho0 and c moves the bar rigidly: the full SPH's forced response is
    v(t) = the integral of the (held) input at every particle and no density change, because the SPH
    gradient of a constant vanishes (G 1 = 0).  The exact FMU, whose velocity basis always contains the
    force profile, gives that response to round-off although its POD modes come from a free vibration."""
    from sphrom.sph.solver import build_problem
    scene, path, data = unforced_exact_fmu
    G = build_problem(scene).neighbours.matrix()
    assert np.abs(G @ np.ones(G.shape[1])).max() < 1e-12 * np.abs(G).max()    # the full SPH's rigid response
    assert data.k_v == K + 1 and data.B is not None       # the profile's residual is a velocity mode
    h, n = 0.01, 150                                      # 1.5 s: beyond the training horizon
    t = np.arange(n) * h
    f = 2e-3 * np.sin(2 * np.pi * 3.7 * t) + 1e-3         # unseen frequency and a mean: a drift
    v, rho = _forced_response(path, [h] * n, f)
    expected = np.concatenate([[0.0], np.cumsum(f * h)])   # the integral of the held input
    assert np.abs(v - expected[:, None]).max() <= 1e-6 * np.abs(expected).max()
    assert np.abs(rho).max() <= 1e-9


def test_exact_fmu_ramps_under_a_constant_force_for_1000_s(unforced_exact_fmu):
    _, path, _ = unforced_exact_fmu
    h, n, f0 = 0.25, 4000, 1e-3
    v, rho = _forced_response(path, [h] * n, np.full(n, f0))
    ramp = f0 * h * np.arange(n + 1)
    assert np.abs(v - ramp[:, None]).max() <= 1e-6 * ramp[-1]
    assert np.abs(rho).max() <= 1e-9
