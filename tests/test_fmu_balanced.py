"""The balanced reduced model inside the FMU (`sphrom fmu --model balanced`), and the certified error bounds of
the linear FMUs (balanced and exact).

The balanced FMU runs the exact model's C code (resource kind 2): only its matrices differ, and its probe rows
act on the whole state (flags bit3).  These tests hold it against the Python balanced model
(:mod:`sphrom.rom.balanced_model`, scipy's expm: an independent implementation of the same exact stepping),
check FMU states, the bounds the FMU declares (equal to :func:`sphrom.rom.balanced.error_bounds`) and the
measured error of the FMU against the full linear SPH (exact in time), which must stay below them.
"""

import zipfile

import fmpy
import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from scipy.integrate import simpson

from conftest import assert_units_through_declared_types, fmu_scene, small_scene
from sphrom.fmu.make.build import ensure_binaries
from sphrom.fmu.run.driver import FMU
from sphrom.fmu.make.models import balanced_model, exact_model
from sphrom.fmu.make.package import package_fmu
from sphrom.fmu.resources import FLAG_OUTPUT_ROWS, probe_pairs, unpack
from sphrom.fmu.variables import vr
from sphrom.rom.balanced import error_bounds, reduced_from_exact
from sphrom.rom.lti import full_linear_system, input_norm, sample_outputs
from sphrom.rom.modal import real_blocks
from sphrom.rom.registry import get_model

R = 12                      # balanced order
K = 6                       # exact model: POD modes
PROBES = (0.25, 0.5, 0.66)
RTOL = 1e-12
# The packaged A and z0 are the Python model's in its real eigen-coordinates (A = V L V⁻¹, the default block form):
# V L V⁻¹ and V y0 give them back to round-off of the transform, κ(V) ε ‖A‖; 1e-12 of the norm leaves κ(V) up to
# ~10³ (LAPACK's eigenvectors differ in round-off between CPUs).
TRANSFORM_RTOL = 1e-12

# a force profile that is not uniform: a uniform one drives only the mean velocity (v' = f - d v), which every
# model holding the constant mode reproduces to round-off, so the force channel would test nothing
SHAPED_PROFILE = "1 + sin(2*pi*x/L) + 0.5*cos(6*pi*x/L)"


def scene_for(case):
    """forced: damped_forced shrunk (N = 32, d = 10) with a shaped force profile; unforced: multimode shrunk
    (d = f = 0)."""
    if case == "forced":
        return small_scene("damped_forced", T=0.5, n=32, profile=SHAPED_PROFILE)
    return fmu_scene(case)


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    """make(model, case, fmi) -> (path, ExactData, FMUSummary), packaged once each."""
    folder = tmp_path_factory.mktemp("balanced-fmus")
    binaries = ensure_binaries()
    made = {}

    def make(model="balanced", case="forced", fmi=2):
        if (model, case, fmi) not in made:
            path = folder / f"{model}-{case}-fmi{fmi}.fmu"
            summary = package_fmu(scene_for(case), path, k=R if model == "balanced" else K, fmi=fmi, probes=PROBES,
                                  progress=False, binaries=binaries, model=model)
            made[model, case, fmi] = (path, unpack(zipfile.ZipFile(path).read("resources/model.bin")), summary)
        return made[model, case, fmi]

    return make


def bound_values(slave, n_probes):
    """(force max, initial max, force per probe, initial per probe) read from the FMU."""
    vrs = ([vr("force_error_bound"), vr("initial_state_error_bound")]
           + [vr("force_error_bound_j", j) for j in range(1, n_probes + 1)]
           + [vr("initial_state_error_bound_j", j) for j in range(1, n_probes + 1)])
    values = np.asarray(slave.get_real(vrs))
    return values[0], values[1], values[2:2 + n_probes], values[2 + n_probes:]


def relative_residual(out, ref):
    """max |out - ref| relative to the largest |ref| of the same kind (v probes, rho probes)."""
    half = ref.shape[1] // 2
    scale = np.repeat([np.abs(ref[:, :half]).max(), np.abs(ref[:, half:]).max()], half)
    return float((np.abs(out - ref) / np.maximum(scale, 1e-300)).max())


@pytest.mark.parametrize("fmi", [2, 3])
def test_balanced_fmu_validates_and_declares_its_model_and_bounds(fmus, fmi):
    path, data, summary = fmus("balanced", "forced", fmi)
    assert fmpy.validation.validate_fmu(str(path)) == []
    assert_units_through_declared_types(path)
    # one linear path: kind 2, the state does not split (k_v = r, k_e = 0), rows over the whole state
    assert data.k_v == R and data.k_rho == 0 and data.output_rows and data.Pv.shape == (3, R)
    assert data.Pe.shape == (3, 2, R) and data.damping and data.Q is None        # d = 10: BT, not skew
    assert data.sections["LINMODEL"].tolist() == [[2]] and summary.method == "bt"
    md = fmpy.read_model_description(str(path))
    calculated = [v for v in md.modelVariables if v.causality == "calculatedParameter"]
    assert [v.name for v in calculated] == (["force_error_bound", "initial_state_error_bound"]
                                            + [f"force_error_bound_{j}" for j in (1, 2, 3)]
                                            + [f"initial_state_error_bound_{j}" for j in (1, 2, 3)])
    assert [v.valueReference for v in calculated] == ([vr("force_error_bound"), vr("initial_state_error_bound")]
                                                      + [vr("force_error_bound_j", j) for j in (1, 2, 3)]
                                                      + [vr("initial_state_error_bound_j", j) for j in (1, 2, 3)])
    assert all(v.variability == "fixed" for v in calculated)
    assert b"fixedInternalStepSize" not in zipfile.ZipFile(path).read("modelDescription.xml")
    assert "certified" in md.description and "||f||_L2(0,T)" in md.description


def test_frozen_fmu_has_no_bounds_and_bounds_cannot_be_set(fmus, tmp_path):
    path = tmp_path / "frozen.fmu"
    package_fmu(fmu_scene("forced"), path, k=K, fmi=2, probes=PROBES, progress=False, binaries=ensure_binaries())
    md = fmpy.read_model_description(str(path))
    assert not [v for v in md.modelVariables if v.name.startswith(("force_error_bound", "initial_state_error_bound"))]
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        with pytest.raises(FMICallException):
            s.get_real([vr("force_error_bound")])
        assert any(f"unknown value reference {vr('force_error_bound')}" in e for e in s.errors())
    with FMU(fmus("balanced", "forced", 2)[0]) as s:
        s.initialize(initial_state_scale=1)
        with pytest.raises(FMICallException):
            s.set_real([vr("force_error_bound_j", 1)], [1.0])
        assert any("calculated parameter" in e for e in s.errors())


@pytest.mark.parametrize("case", ["forced", "unforced"])
def test_balanced_fmu_equals_the_python_balanced_model(fmus, case, record_property):
    """FMU (C Taylor expm) = the Python balanced model (scipy expm), input held over each step, to 1e-12
    relative, FMI 2 and 3 bitwise alike; the densities from the Python model's own reconstruction."""
    path, data, _ = fmus("balanced", case, 2)
    scene = scene_for(case)
    _, ops, problem = balanced_model(scene, R, PROBES)
    V = real_blocks(ops.A, skew=not data.damping).V
    assert data.blocks and data.Q is None
    assert np.linalg.norm(V @ data.A @ np.linalg.inv(V) - ops.A) <= TRANSFORM_RTOL * np.linalg.norm(ops.A)
    assert np.linalg.norm(V @ data.z0 - ops.z0) <= TRANSFORM_RTOL * max(np.linalg.norm(ops.z0), 1e-300)
    assert (case == "unforced") == (not data.damping)                 # d = 0: Galerkin, skew: rotations
    H, M = 0.01, 50
    t = np.arange(M + 1) * H
    force = scene.force if case == "forced" else (lambda tt: np.zeros_like(np.asarray(tt, float)))
    inputs = force(t[:-1])
    balanced = get_model("balanced")
    ref = balanced.run(ops, problem, dt=H, n_steps=M, options=balanced.options(step=H, hold="held"), force=force)
    i0, i1, w = probe_pairs(problem.x, scene.L, np.asarray(PROBES))
    rho = ref.rho
    expected = np.hstack([ref.y[:, :len(PROBES)], (1.0 - w) * rho[:, i0] + w * rho[:, i1]])
    outs = []
    for fmi in (2, 3) if case == "forced" else (2,):
        with FMU(fmus("balanced", case, fmi)[0]) as s:
            s.initialize(initial_state_scale=1)
            outs.append(s.run([H] * M, inputs))
    assert np.array_equal(outs[0], outs[-1])
    residual = relative_residual(outs[0], expected)
    record_property("relative_residual", residual)
    assert residual <= RTOL, residual
    assert np.ptp(outs[0][:, 0]) > 0


@pytest.mark.parametrize("fmi", [2, 3])
def test_balanced_fmu_state_round_trip_is_bitwise(fmus, fmi):
    path, data, _ = fmus("balanced", "forced", fmi)
    rng = np.random.default_rng(5)
    steps, inputs = list(rng.uniform(0.002, 0.03, 20)), rng.normal(0, 0.05, 20)
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        s.run(steps[:8], inputs[:8])
        t1 = s.time()
        state = s.get_state()
        blob = s.serialize(state)
        a = s.run(steps[8:], inputs[8:], t0=t1)
        z = s.reduced_state(data.k)
        s.set_state(state)
        b = s.run(steps[8:], inputs[8:], t0=t1)
        restored = s.deserialize(blob)
        s.set_state(restored)
        c = s.run(steps[8:], inputs[8:], t0=t1)
        assert np.array_equal(s.reduced_state(data.k), z)
        s.free_state(state)
        s.free_state(restored)
    assert np.array_equal(a, b) and np.array_equal(a, c)


def test_balanced_fmu_refuses_a_state_of_the_exact_fmu(fmus):
    with FMU(fmus("exact", "forced", 2)[0]) as s:
        s.initialize(initial_state_scale=1)
        blob = s.serialize(s.get_state())
    with FMU(fmus("balanced", "forced", 2)[0]) as s:
        s.initialize(initial_state_scale=1)
        with pytest.raises(FMICallException):
            s.deserialize(blob)
        assert any("another FMU" in e for e in s.errors()), s.errors()


def test_balanced_fmu_conserves_energy_over_t_1000(fmus):
    """d = f = 0: the Galerkin model's Ar is skew; the FMU's state keeps ½|z|² to 1e-12 over 1000 s."""
    path, data, _ = fmus("balanced", "unforced", 2)
    e0 = float(data.z0 @ data.z0)
    with FMU(path) as s:
        s.initialize(initial_state_scale=1)
        t = 0.0
        for h in [0.7] * 500 + [1.3] * 500:
            s.do_step(t, h)
            t += h
        z = s.reduced_state(data.k)
    assert abs(float(z @ z) - e0) / e0 <= 1e-12


@pytest.mark.parametrize("model", ["balanced", "exact"])
def test_the_fmu_bounds_are_the_python_bounds(fmus, model):
    """The calculated parameters equal :func:`error_bounds` recomputed from a freshly built model, FMI 2 and 3."""
    scene = scene_for("forced")
    if model == "balanced":
        _, ops, _ = balanced_model(scene, R, PROBES)
        lti, reduced = ops.lti, ops.reduced
    else:
        _, lin, problem, _ = exact_model(scene, K, PROBES, progress=False)
        lti = full_linear_system(problem, PROBES)
        reduced = reduced_from_exact(lti, lin)
    ref = error_bounds(lti, reduced, outputs="v")
    for fmi in (2, 3) if model == "balanced" else (2,):
        path, data, _ = fmus(model, "forced", fmi)
        with FMU(path) as s:
            s.initialize(initial_state_scale=1)
            fmax, imax, fb, ib = bound_values(s, len(PROBES))
        np.testing.assert_allclose(fb, ref["force_error_bound"], rtol=1e-12)
        np.testing.assert_allclose(ib, ref["initial_state_error_bound"], rtol=1e-12)
        assert fmax == fb.max() and imax == ib.max() and np.all(fb > 0) and np.all(ib > 0)


def _l2(err, h):
    """‖err‖_L2(0,T) per column: Simpson at h and 2h, extrapolated (samples at spacing h, count 4m + 1)."""
    e2 = err ** 2
    fine, coarse = simpson(e2, dx=h, axis=0), simpson(e2[::2], dx=2 * h, axis=0)
    return np.sqrt(np.maximum(fine + (fine - coarse) / 15.0, 0.0))


@pytest.mark.parametrize("model", ["balanced", "exact"])
def test_measured_fmu_error_stays_below_its_bounds(fmus, model, record_property):
    """The FMU's probe velocities against the full linear SPH of the same scene (N = 32, exact in time):
    the free response from the scene's initial state within initial_state_error_bound, and the response to
    a force it was not built for (from rest: forced minus free run, the model is linear) within
    force_error_bound ||f||; the input linear between communication points (fmi2SetRealInputDerivatives),
    as for the full model.  The ratios measured/bound are recorded."""
    path, data, _ = fmus(model, "forced", 2)
    scene = scene_for("forced")
    from sphrom.sph.solver import build_problem
    lti = full_linear_system(build_problem(scene), PROBES)
    P, T = len(PROBES), scene.T
    M = 2000                                              # samples: h = T/2000, Simpson + Richardson
    h = T / M
    t = np.arange(M + 1) * h
    rng = np.random.default_rng(16)
    f = sum(rng.normal(0, 1) * np.sin(2 * np.pi * rng.uniform(0.5, 40) * t + rng.uniform(0, 6)) for _ in range(5))

    def fmu_run(force):
        with FMU(path) as s:
            s.initialize(initial_state_scale=1)
            out = [s.output_values()[:P]]
            for m in range(M):
                s.set_input(force[m])
                s.set_input_derivative((force[m + 1] - force[m]) / h)
                s.do_step(m * h, h)
                out.append(s.output_values()[:P])
            fb_max, ib_max, fb, ib = bound_values(s, P)
        return np.array(out), fb, ib

    free, fb, ib = fmu_run(np.zeros(M + 1))
    forced, _, _ = fmu_run(f)
    A = lti.dense()
    full_free = sample_outputs(A, None, lti.C[:P], lti.x0, h, np.zeros(M + 1))
    full_forced = sample_outputs(A, lti.B[:, 0], lti.C[:P], np.zeros(lti.order), h, f)
    initial_error = _l2(free - full_free, h)
    force_gain = _l2(forced - free - full_forced, h) / input_norm(h, f)
    record_property("initial_state_ratio", (initial_error / ib).tolist())
    record_property("force_ratio", (force_gain / fb).tolist())
    assert np.all(initial_error <= ib), (initial_error, ib)
    assert np.all(force_gain <= fb), (force_gain, fb)
    assert np.all(initial_error > 0) and np.all(force_gain > 0)


def test_fmu_balanced_command_prints_its_order_and_bounds(tmp_path, capsys):
    """`sphrom fmu --model balanced --modes R`: the order, the bounds as stored and what they bound; an order
    or an order tolerance out of range names the option, and --tolerance keeps one meaning (the accepted error)."""
    from sphrom.cli import main
    from sphrom.scene import dump_toml, scene_dict
    from sphrom.sph.solver import build_problem
    scene_file = tmp_path / "small.toml"
    scene_file.write_text(dump_toml(scene_dict(scene_for("forced"))))
    out = tmp_path / "bal.fmu"
    assert main(["fmu", str(scene_file), "--model", "balanced", "--modes", str(R), "--out", str(out),
                 "--a-priori-bounds", "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "balanced model" in text and f"order r = {R} (bt" in text
    assert "force_error_bound_j [s]" in text and "||f||_L2(0,T)" in text and "no shift" in text
    data = unpack(zipfile.ZipFile(out).read("resources/model.bin"))
    lines = [line for line in text.splitlines() if line.strip().startswith(("0.25 |", "0.5 |", "0.66 |"))]
    printed = np.array([[float(x) for x in line.split("|")[1:]] for line in lines])
    np.testing.assert_allclose(printed.T, data.sections["BOUNDS"], rtol=1e-4)       # printed to 5 digits
    # the order from --order-tolerance: the registry's balanced build with that order_tolerance
    assert main(["fmu", str(scene_file), "--model", "balanced", "--order-tolerance", "1e-2", "--no-verify",
                 "--no-bounds", "--out", str(out), "--quiet"]) == 0
    r = get_model("balanced").build(build_problem(scene_for("forced")), None, None, None, order_tolerance=1e-2,
                                    probes=PROBES).order
    assert f"order r = {r} (" in capsys.readouterr().out and unpack(zipfile.ZipFile(out).read(
        "resources/model.bin")).k_v == r
    for argv, message in ((["--model", "balanced", "--order-tolerance", "1.5"],
                           "--order-tolerance: 1.5 is out of range (allowed: 0 < order_tolerance < 1)"),
                          (["--model", "balanced", "--modes", "64"], "--modes (k): 64 is out of range (allowed: an "
                                                                      "order r from 1 to 2N - 1 = 63)"),
                          # --tolerance is the measured error accepted; where it set the order before: refused
                          (["--model", "balanced", "--tolerance", "0.1"], "--tolerance: ambiguous with --model "
                                                                          "balanced and no --modes"),
                          (["--model", "balanced", "--modes", "6", "--order-tolerance", "0.01"],
                           "--order-tolerance: give the order k or order_tolerance, not both"),
                          (["--model", "frozen", "--order-tolerance", "0.01"],
                           "--order-tolerance: does not apply to the frozen model"),
                          (["--model", "auto", "--tolerance", "0.1", "--order-tolerance", "0.01"],
                           "--order-tolerance: not with --model auto")):
        assert main(["fmu", str(scene_file), "--out", str(tmp_path / "x.fmu"), "--quiet", *argv]) == 2
        assert message in capsys.readouterr().err
    assert not (tmp_path / "x.fmu").exists()


def test_loader_checks_the_output_rows_and_the_bounds_section(fmus):
    """The C loader: output rows need flag bit3 to allow k_e = 0; BOUNDS must be 2 x n_probes and >= 0;
    LINMODEL one known value; each refusal names the field."""
    import dataclasses

    from sphrom.fmu import layout
    from sphrom.fmu.run.core import Core, CoreError
    from sphrom.fmu.resources import pack_exact
    _, data, _ = fmus("balanced", "forced", 2)
    core = Core(ensure_binaries().core)

    def load(**changes):
        return core.load(pack_exact(dataclasses.replace(data, **changes)))

    assert load() is not None                                # the packaged numbers load
    bounds = data.sections["BOUNDS"]
    for sections, message in (({"BOUNDS": bounds[:, :2]}, "'BOUNDS' is 2 x 2, expected 2 x 3"),
                              ({"BOUNDS": -bounds}, "bounds are >= 0"),
                              ({"LINMODEL": [[3.0]]}, "'LINMODEL' must be one value")):
        with pytest.raises(CoreError, match=message):
            load(sections=sections)
    # without bit3 the rows are over a and b: k_e = 0 is refused by the pack and, forced through, by the loader
    # (the block form, the default, always has output rows: its flag bit4 is cleared with bit3)
    with pytest.raises(ValueError, match="mode counts"):
        load(output_rows=False, blocks=False)
    blob = bytearray(pack_exact(data))
    flags_at = layout.HEADER.offset("flags")                 # the shared header's flags (harness/fmu/layout.py)
    blob[flags_at] &= ~(8 | 16) & 0xFF
    with pytest.raises(CoreError, match=r"k_e = 0 out of range \[1"):
        core.load(bytes(blob))


def test_fmu_no_bounds_leaves_the_bound_variables_out(tmp_path, capsys):
    """``sphrom fmu --model exact --no-bounds``: an exact FMU without the BOUNDS section and without the
    calculated parameters (the option for large N, where the bounds cost minutes)."""
    import fmpy

    from sphrom.cli import main
    scene_file = tmp_path / "small.toml"
    scene_file.write_text(scene_for("forced").text)
    out = tmp_path / "exact.fmu"
    assert main(["fmu", str(scene_file), "--model", "exact", "--modes", "6", "--no-bounds", "--no-verify",
                 "--out", str(out), "--quiet"]) == 0
    data = unpack(zipfile.ZipFile(out).read("resources/model.bin"))
    assert "BOUNDS" not in data.sections
    names = {v.name for v in fmpy.read_model_description(str(out)).modelVariables}
    assert not any(n.startswith(("force_error_bound", "initial_state_error_bound")) for n in names)
    assert "v_probe_1" in names and "v_probe_1_error_bound" in names      # the per-step bounds stay
    assert "error bounds" not in capsys.readouterr().out


def test_every_model_takes_the_same_default_error_tolerance(fmus):
    """error_tolerance's default is 5 % of the training run's largest |v_probe| for every model (the modelDescription
    says so): the balanced model, which has no training envelope, reads it from the scene's training run as the
    others read it from theirs (it took the initial state's instead, 4.5e-5 against 1.53e-4 on a forced scene)."""
    from sphrom.fmu.training.steps import training_probe_speed
    from sphrom.rom.bounds import TOLERANCE_FRACTION
    from sphrom.sph.solver import build_problem
    tolerances = {model: fmus(model)[2].error_tolerance for model in ("balanced", "exact", "frozen")}
    speed = training_probe_speed(build_problem(scene_for("forced")), PROBES)
    for model, tol in tolerances.items():
        assert tol == pytest.approx(TOLERANCE_FRACTION * speed, rel=1e-12), (model, tolerances)
