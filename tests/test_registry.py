"""The reduced models behind one interface: the registry, the one result type, truncation, and the
code-structure contracts (no model-name comparisons outside the registry, no import cycles)."""

import ast
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import sphrom.rom as rom
from conftest import small_scene
from sphrom.cli import main
from sphrom.errors import UserError
from sphrom.norms import relative_l2
from sphrom.pod import basis_for_scene, read_basis
from sphrom.rom import MODEL_NAMES, MODELS, ReducedResult, get_model, model_names, probe_rows
from sphrom.rom.exact_linear import run_exact
from sphrom.rom.model import ReducedModel
from sphrom.rom.registry import fmu_model_names
from sphrom.sph.solver import build_problem, step_count

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(__file__).resolve().parent / "data"
sys.path.insert(0, str(DATA))
import make_registry_reference as reference  # noqa: E402


@pytest.fixture(scope="module")
def forced():
    """damped_forced shrunk (d = 10, three-tone force): problem, basis, the full SPH run."""
    scene = small_scene("damped_forced", T=0.3, n=24, every=10)
    problem = build_problem(scene)
    basis, run = basis_for_scene(scene, {"count": 12, "window": [0, 0.3]}, progress=False, problem=problem)
    return scene, problem, basis, run


# ---------------------------------------------------------------------------
# one interface, one result type
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("name", MODEL_NAMES)
def test_every_model_runs_through_the_one_interface(forced, name):
    """build -> run -> ReducedResult holding the whole state z; the operators' protocol (order, named slices of z,
    z0, fields, projection, outputs) gives the documented shapes, units and reconstruction, near the full SPH."""
    scene, problem, basis, run = forced
    model = get_model(name)
    assert MODELS[name] is model and model.name == name and model.description
    assert model.basis_kind in ("density", "energy", None) and model.integrators
    # a model without a POD basis ignores it and takes its order from k_v: as many coordinates as 5 + 4 modes
    ops = model.build(problem, basis, 5, 4) if model.needs_basis else model.build(problem, None, 9, None)
    n = step_count(scene.T, scene.sph.dt)
    steps = np.arange(0, n + 1, 10)
    res = model.run(ops, problem, dt=scene.sph.dt, n_steps=n, sample_steps=steps)
    assert isinstance(res, ReducedResult) and res.model == name and res.settings["model"] == name
    M, N = steps.size, problem.n
    np.testing.assert_array_equal(res.steps, steps)
    np.testing.assert_array_equal(res.t, steps * scene.sph.dt)
    # the slices name consecutive blocks covering z; the run starts from z0
    slices = list(ops.slices.values())
    assert ops.order == 9 and res.z.shape == (M, 9) and ops.z0.shape == (9,)
    assert slices[0].start == 0 and slices[-1].stop == 9
    assert all(a.stop == b.start for a, b in zip(slices, slices[1:]))
    np.testing.assert_allclose(res.z[0], ops.z0, rtol=0, atol=1e-14 * np.max(np.abs(ops.z0)))
    assert res.v.shape == (M, N) and res.rho.shape == (M, N)
    v, rho = ops.fields(res.z)
    np.testing.assert_array_equal(res.v, v)
    np.testing.assert_array_equal(res.rho, rho)
    # the projection of the reconstructed fields gives the state back (orthonormal or biorthogonal bases)
    np.testing.assert_allclose(ops.project(res.v, res.rho, problem), res.z, rtol=0,
                               atol=1e-10 * np.max(np.abs(res.z)))
    assert res.wall_time > 0 and res.offline["operators"] > 0
    # every model's probe values come from its fields; a model with its own outputs (y) gives the same values
    probes = [0.25, 0.5, 0.66] if res.probes is None else res.probes
    at_probes = res.probe_outputs(problem.x, scene.L, probes, problem.rho0)
    assert at_probes.shape == (M, 2 * len(probes)) and np.all(np.isfinite(at_probes))
    np.testing.assert_array_equal(ops.outputs(res.z, problem, [0.3, 0.7]),
                                  res.probe_outputs(problem.x, scene.L, [0.3, 0.7], problem.rho0))
    if res.y is not None:
        np.testing.assert_allclose(at_probes, res.y, rtol=0, atol=1e-12 * np.max(np.abs(res.y)))
    if not model.needs_basis:
        # one block, the whole state x_r; the fields are the reconstruction x = V x_r in energy coordinates
        assert list(ops.slices) == ["state"]
        with pytest.raises(AttributeError, match="does not split"):
            res.a_v
        lti, V = ops.lti, ops.reduced.V
        np.testing.assert_array_equal(res.v, (res.z @ V.T)[:, :N] / lti.w_v)
        np.testing.assert_array_equal(res.rho, problem.rho0 / (1.0 + (res.z @ V.T)[:, N:] / lti.w_e))
        np.testing.assert_array_equal(res.z[0], ops.reduced.x0)            # Wᵀ x0, x0 = [√ρ0 v0; 0]
    else:
        # velocity coordinates, then density (density modes) or specific-volume coordinates (energy modes)
        second = "density" if model.basis_kind == "density" else "specific_volume"
        assert list(ops.slices) == ["velocity", second]
        assert res.a_v.shape == (M, ops.k_v) and res.a_rho.shape == (M, ops.k_rho) and ops.k_v + ops.k_rho == 9
        np.testing.assert_array_equal(res.z, np.hstack([res.a_v, res.a_rho]))
        # the fields are the reconstruction from the coordinates: U_rho a (density modes), rho0 / (1 + U_e b)
        np.testing.assert_array_equal(res.v, res.a_v @ ops.U_v.T)
        if model.basis_kind == "density":
            np.testing.assert_array_equal(res.rho, res.a_rho @ ops.U_rho.T)
            a_v0 = ops.U_v.T @ problem.v0                     # Euclidean projection of v0
        else:
            np.testing.assert_array_equal(res.rho, problem.rho0 / (1.0 + res.a_rho @ ops.U_e.T))
            a_v0 = ops.U_v.T @ (problem.rho0 * problem.v0)    # ρ0-weighted projection of v0
        np.testing.assert_allclose(res.a_v[0], a_v0, rtol=0, atol=1e-14 * np.max(np.abs(a_v0)))
    if not model.linear:
        assert ops.error_bounds(problem, probes) is None      # the certified bounds are the linear models'
    # five modes hold this short run: every model is near the full SPH [m/s], [kg/m^3]
    v_sph, rho_sph = run.v[np.searchsorted(run.steps, steps)], run.rho[np.searchsorted(run.steps, steps)]
    assert relative_l2(res.v, v_sph, res.t) < 0.05
    assert relative_l2(res.rho - problem.rho0, rho_sph - problem.rho0, res.t) < 0.05


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_the_protocol_gives_what_code_outside_rom_asks(forced, name):
    """The members that code outside sphrom.rom reads instead of the operators' own fields: block sizes by name,
    z0 with its velocity scaled (a run from it is the run with that initial_state_scale, bit for bit), the force
    input, the velocity from the velocity coordinates (at the particles, the probes and the ports), and the
    certified shadow of the model's outputs (its probes and its ports)."""
    scene, problem, basis, _ = forced
    model = get_model(name)
    ports = {"ports": (0.3,)} if model.ports else {}
    ops = (model.build(problem, basis, 5, 4, **ports) if model.needs_basis
           else model.build(problem, None, 9, None, **ports))
    assert list(ops.sizes) == list(ops.slices) and sum(ops.sizes.values()) == ops.order
    assert all(ops.sizes[k] == len(range(ops.order)[s]) for k, s in ops.slices.items())
    assert ops.has_force_input                                  # the scene has a force profile
    n = step_count(scene.T, scene.sph.dt)
    steps = np.arange(0, n + 1, 10)
    res = model.run(ops, problem, dt=scene.sph.dt, n_steps=n, sample_steps=steps)
    coords = res.z if "velocity" not in ops.slices else res.block("velocity")
    np.testing.assert_array_equal(ops.velocity(coords), res.v)
    probes = [0.25, 0.5, 0.66]
    rows = ops.velocity_probe_rows(problem, probes)
    at = ops.outputs(res.z, problem, probes)[:, :len(probes)]
    np.testing.assert_allclose(coords @ rows.T, at, rtol=0, atol=1e-12 * np.max(np.abs(at)))
    if model.ports:
        assert ops.port_velocity(coords).shape == (steps.size, 1)
    else:
        with pytest.raises(ValueError, match="no ports"):
            ops.port_velocity(coords)
    shadow = ops.bound_shadow(problem, probes)
    assert (shadow.n_probes, shadow.n_ports) == (len(probes), len(ops.ports))
    if "velocity" not in ops.slices:
        with pytest.raises(ValueError, match="velocity_scale: .*no velocity block"):
            ops.initial_state(0.5)
        return
    v = ops.slices["velocity"]
    np.testing.assert_array_equal(ops.initial_state(), ops.z0)
    still = ops.initial_state(0.0)
    assert not np.any(still[v]) and np.array_equal(np.delete(still, np.arange(ops.order)[v]),
                                                   np.delete(ops.z0, np.arange(ops.order)[v]))
    for s in (0.0, 2.5):
        a = model.run(ops, problem, dt=scene.sph.dt, n_steps=n, sample_steps=steps, state=ops.initial_state(s))
        b = model.run(ops, problem, dt=scene.sph.dt, n_steps=n, sample_steps=steps, initial_state_scale=s)
        np.testing.assert_array_equal(a.z, b.z)


def test_properties_are_what_the_models_do(forced):
    """uses_n_freeze: n_freeze changes the run exactly for those models, and is refused by the others; linear: the
    free response does not depend on the communication step; integrators: the ones accepted, others refused."""
    scene, problem, basis, _ = forced
    n = step_count(scene.T, scene.sph.dt)
    steps = np.arange(0, n + 1, 50)
    for name, model in MODELS.items():
        ops = model.build(problem, basis, 5, 4) if model.needs_basis else model.build(problem, None, 9, None)

        def go(force=None, **kw):
            return model.run(ops, problem, dt=scene.sph.dt, n_steps=n, sample_steps=steps, force=force,
                             options=model.options(**kw)).z

        if model.uses_n_freeze:
            assert not np.array_equal(go(n_freeze=1), go(n_freeze=7)), name
        else:
            with pytest.raises(ValueError, match=f"n_freeze: not an option of the {name} model"):
                model.options(n_freeze=7)
        if model.linear:
            free = dict(force=lambda t: np.zeros_like(t))       # exact in time: the free response at any step
            a, b = go(step=scene.sph.dt * 50, **free), go(step=scene.sph.dt * 3, **free)
            assert np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(a)), name
            assert model.integrators == ("exponential",) and "integrator" not in model.option_names
            with pytest.raises(ValueError, match="integrator: not an option"):
                model.options(integrator="euler")
            continue
        for integrator in ("euler", "symplectic", "rk4", "exponential"):
            if integrator in model.integrators:
                assert np.all(np.isfinite(go(integrator=integrator)))
            else:
                with pytest.raises(ValueError):
                    go(integrator=integrator)
    assert model_names(linear=False) == ("original", "linearized", "frozen")
    assert set(model_names(fmu_kind=None)) == {"original", "linearized"}
    assert fmu_model_names() == ("frozen", "exact", "balanced")      # the linear ones share resource kind 2
    assert get_model("balanced").fmu_kind == get_model("exact").fmu_kind == 2
    assert model_names(needs_basis=False) == ("balanced",) == model_names(sized_by_tolerance=True)
    with pytest.raises(ValueError, match="not one of original, linearized, frozen, exact"):
        get_model("balanced-typo")


def test_an_option_of_another_model_is_an_error_naming_it(forced):
    """run takes the shared arguments and the model's own options object; an option, a build option, an options
    object or port forces that do not belong to the model are refused, naming them (nothing silently ignored)."""
    scene, problem, basis, _ = forced
    exact, frozen, original = get_model("exact"), get_model("frozen"), get_model("original")
    lin = exact.build(problem, basis, 4, 4)
    common = dict(dt=scene.sph.dt, n_steps=20)
    with pytest.raises(ValueError, match="n_freeze: not an option of the exact model .its options: step, hold"):
        exact.run(lin, problem, options=exact.options(n_freeze=5), **common)
    with pytest.raises(ValueError, match="options: a FrozenOptions is not the exact model's"):
        exact.run(lin, problem, options=frozen.options(), **common)
    with pytest.raises(ValueError, match="tensor: not a build option of the exact model"):
        exact.build(problem, basis, 4, 4, tensor="always")
    with pytest.raises(ValueError, match="b: not a build option of the original model"):
        original.build(problem, basis, 4, 4, b="rest")
    with pytest.raises(ValueError, match="port_forces: the original model takes no port forces"):
        original.run(original.build(problem, basis, 4, 4), problem, port_forces=lambda t: np.zeros((len(t), 1)),
                     **common)
    with pytest.raises(ValueError, match="hold: 'zero' is out of range"):
        exact.options(hold="zero")
    with pytest.raises(ValueError, match="n_freeze: 0 is out of range"):
        frozen.options(n_freeze=0)
    # the options of a study running several models with common settings: those each model has
    assert exact.select_options(n_freeze=3, step=0.1) == exact.options(step=0.1)
    assert frozen.select_options(n_freeze=3, step=0.1) == frozen.options(n_freeze=3)


def test_the_registrys_frozen_model_is_the_fmus(forced):
    """The frozen model's build option b: the registry's default (and the FMU's) is b = K a^ρ_rest, so the
    projected rest state is an equilibrium; b="paper" (its paper_build) is eq. 2.22's, the operators the paper's
    original and linearised models share; truncation keeps the choice."""
    scene, problem, basis, _ = forced
    frozen, original = get_model("frozen"), get_model("original")
    rest = frozen.build(problem, basis, 5, 4)
    paper = frozen.build(problem, basis, 5, 4, **frozen.paper_build)
    assert rest.b_form == "rest" and paper.b_form == "paper" == original.build(problem, basis, 5, 4).b_form
    np.testing.assert_array_equal(rest.b, rest.K @ rest.a_rho0)
    np.testing.assert_array_equal(paper.b, original.build(problem, basis, 5, 4).b)
    for name in ("K", "D", "p", "T", "a_v0", "a_rho0", "U_v", "U_rho"):
        np.testing.assert_array_equal(getattr(rest, name), getattr(paper, name), err_msg=name)
    assert not np.array_equal(rest.b, paper.b)
    cut = frozen.truncate(problem, frozen.build(problem, basis, 9, 8), 5, 4)
    assert cut.b_form == "rest"
    np.testing.assert_array_equal(cut.b, cut.K @ cut.a_rho0)                 # K a^ρ_rest of the kept modes
    np.testing.assert_allclose(cut.b, rest.b, rtol=0, atol=1e-14 * np.max(np.abs(rest.K)) * np.max(rest.a_rho0))
    # at rest (a^v = 0, a^ρ = a^ρ_rest) the velocity rate b - K a^ρ is zero with the rest b, not with eq. 2.22's
    n = 200
    at_rest = np.concatenate([np.zeros(rest.k_v), rest.a_rho0])
    still = frozen.run(rest, problem, dt=scene.sph.dt, n_steps=n, state=at_rest, force=lambda t: 0 * t).z
    drift = frozen.run(paper, problem, dt=scene.sph.dt, n_steps=n, state=at_rest, force=lambda t: 0 * t).z
    moving = np.max(np.abs(frozen.run(rest, problem, dt=scene.sph.dt, n_steps=n).a_v))
    assert np.max(np.abs(still[:, :rest.k_v])) <= 1e-12 * moving < np.max(np.abs(drift[:, :rest.k_v]))


# Allowed differences to the stored reference, in ulps of each array's largest magnitude.  The reference was
# written on one CPU; OpenBLAS and numpy pick CPU-specific kernels (AVX-512 on an EPYC sums in another order),
# so the same code differs in the last bits elsewhere.  Measured on an AVX-512 EPYC: operators and runs
# within 38 ulps; the operators on the appended input direction ("aug") within 4.4e5 ulps, because that
# direction is the residual of a profile nearly in the modes' span (a cancellation that magnifies the
# last-bit differences of the projection).  Bitwise on the CPU of the capture (.ci/run's second pass).
ULPS_RUN = 256
ULPS_APPENDED = 2 ** 22


def assert_within_ulps(actual, desired, ulps, err_msg=""):
    """|actual - desired| <= ulps * eps * max|desired| elementwise."""
    actual, desired = np.asarray(actual), np.asarray(desired)
    assert actual.shape == desired.shape, err_msg
    scale = np.max(np.abs(desired)) if desired.size else 0.0
    worst = np.max(np.abs(actual - desired)) if desired.size else 0.0
    assert worst <= ulps * np.finfo(float).eps * scale, f"{err_msg}: {worst / (np.finfo(float).eps * scale):.3g} ulps"


@pytest.mark.cpu_sensitive
def test_registry_runs_equal_the_code_before_the_registry():
    """The registry's build and run on the stored bases give the operators and the reduced coordinates the
    per-model entry points gave before the refactoring (tests/data/make_registry_reference.py), to the ulps
    stated above (bitwise on the CPU of the capture)."""
    from types import SimpleNamespace
    ref = np.load(DATA / "registry_reference.npz")
    for tag, scene in reference.scenes():
        problem = build_problem(scene)
        basis = SimpleNamespace(**{k: ref[f"{tag}/{k}"] for k in ("U_v", "U_rho", "U_ve", "U_e")})
        n, steps = step_count(scene.T, scene.sph.dt), ref[f"{tag}/steps"]
        paper = get_model("frozen").paper_build              # the reference is of the paper's eq. 2.22 b
        built = {"ops": get_model("frozen").build(problem, basis, 5, 4, **paper),
                 "aug": get_model("frozen").build(problem, basis, 5, 4, input_direction="augment",
                                                  input_moments=False, **paper),
                 "lin": get_model("exact").build(problem, basis, 5, 4)}
        for key in ref.files:
            parts = key.split("/")
            if parts[0] == tag and parts[1] in built:
                ulps = ULPS_APPENDED if parts[1] == "aug" else ULPS_RUN
                assert_within_ulps(getattr(built[parts[1]], parts[2]), ref[key], ulps, err_msg=key)
        for label, name, opts in reference.RUNS:
            opts = dict(opts)
            # the old run without an input: a zero force; the others the scene's (force None)
            force = (lambda t: np.zeros_like(t)) if opts.pop("force", 0) is None else None
            ops = built["aug" if label == "frozen-augmented" else "lin" if name == "exact" else "ops"]
            model = get_model(name)
            res = model.run(ops, problem, dt=scene.sph.dt, n_steps=n, sample_steps=steps, force=force,
                            options=model.options(**opts))
            for field in ("a_v", "a_rho"):
                assert_within_ulps(getattr(res, field), ref[f"{tag}/{label}/{field}"], ULPS_RUN,
                                   err_msg=f"{tag} {label} {field}")
            for field in ("v", "rho"):
                assert_within_ulps(getattr(res, field)[::10], ref[f"{tag}/{label}/{field}"], ULPS_RUN,
                                   err_msg=f"{tag} {label} {field}")


def test_run_exact_at_the_grid_times_is_the_exact_models_run():
    """run_exact, the exact model at any sample times, gives at the step grid's times what the one entry
    ``get_model("exact").run`` gives (one result type); the earlier by-name entries are gone."""
    assert not any(hasattr(rom, name) for name in ("run_reduced", "run_model", "build_model", "truncate_model"))
    assert not hasattr(ReducedModel, "run_keywords")
    scene = small_scene("multimode", T=0.2, n=24)
    problem = build_problem(scene)
    basis, _ = basis_for_scene(scene, {"count": 8, "window": [0, 0.2]}, progress=False, problem=problem)
    n = step_count(scene.T, scene.sph.dt)
    lin = get_model("exact").build(problem, basis, 4, 4)
    steps = np.arange(0, n + 1, 20)
    a = run_exact(lin, steps * scene.sph.dt)
    b = get_model("exact").run(lin, problem, n_steps=n, dt=scene.sph.dt, sample_steps=steps)   # scene: f = 0
    assert type(a) is ReducedResult and a.steps is None and np.array_equal(a.z, b.z)


# ---------------------------------------------------------------------------
# truncation
# ---------------------------------------------------------------------------

TRUNCATION_SCENES = {
    "damped": lambda: small_scene("damped_forced", T=0.3, n=24, every=10),
    "hetero": lambda: small_scene("heterogeneous", T=0.3, n=24, every=10, rho0="1 + 0.2*cos(2*pi*x/L)",
                                  f="1e-2*sin(10*t)", profile="1 + 0.5*cos(2*pi*x/L)"),
}
# the hetero profile is missed by 1.7 % by 5 POD modes: "needed" at 1e-3 appends it at k = 5, not at k = 9
INPUTS = [{}, {"input_direction": "augment"}, {"input_direction": "needed", "input_tolerance": 1e-3},
          {"input_direction": "never"}]
FIELDS = {"density": ("U_v", "U_rho", "K", "b", "D", "p", "GU_v", "inv_rho0", "T", "a_v0", "a_rho0"),
          "energy": ("U_v", "U_e", "A", "B", "z0", "rho0")}
EXACT_SLICES = {"U_v", "U_rho", "U_e", "GU_v", "inv_rho0", "rho0", "a_rho0"}   # the same arithmetic: bitwise


@pytest.mark.parametrize("tag", sorted(TRUNCATION_SCENES))
@pytest.mark.parametrize("name", ["frozen", "exact"])
def test_truncated_operators_equal_a_direct_build(tag, name):
    """truncate(build(k = 9, 8), 5, 4) = build(5, 4): every operator to round-off (bitwise where it is the same
    arithmetic), the input decision and error exactly, and a run on them alike to round-off."""
    scene = TRUNCATION_SCENES[tag]()
    problem = build_problem(scene)
    basis, _ = basis_for_scene(scene, {"count": 12, "window": [0, 0.3]}, progress=False, problem=problem)
    model = get_model(name)
    n = step_count(scene.T, scene.sph.dt)
    flips = 0
    for opts in INPUTS:
        big = model.build(problem, basis, 9, 8, **opts)
        direct = model.build(problem, basis, 5, 4, **opts)
        cut = model.truncate(problem, big, 5, 4)
        flips += big.augmented != direct.augmented
        assert (cut.k_v, cut.k_rho, cut.augmented) == (direct.k_v, direct.k_rho, direct.augmented)
        assert cut.input_error == direct.input_error or (np.isnan(cut.input_error) and np.isnan(direct.input_error))
        for field in FIELDS[model.basis_kind]:
            a, b = getattr(cut, field), getattr(direct, field)
            assert (a is None) == (b is None), field
            if a is None:
                continue
            assert a.shape == b.shape, field
            if field in EXACT_SLICES:
                np.testing.assert_array_equal(a, b, err_msg=field)
            else:
                # the frozen model's b = K a^ρ_rest nearly cancels (zero for uniform c): to the round-off of its terms
                scale = np.max(np.abs(b)) if field != "b" else np.max(np.abs(direct.K)) * np.max(direct.a_rho0)
                np.testing.assert_allclose(a, b, rtol=0, atol=1e-14 * scale, err_msg=field)
        if model.linear and cut.skew:                    # the Schur form is rebuilt: it reproduces A
            np.testing.assert_allclose(cut.schur_Q @ cut.schur_T @ cut.schur_Q.T, cut.A, rtol=0, atol=1e-13)
        ra = model.run(cut, problem, dt=scene.sph.dt, n_steps=n, every=50)
        rb = model.run(direct, problem, dt=scene.sph.dt, n_steps=n, every=50)
        for x, y in ((ra.a_v, rb.a_v), (ra.a_rho, rb.a_rho)):
            np.testing.assert_allclose(x, y, rtol=0, atol=1e-11 * np.max(np.abs(y)))
    assert tag != "hetero" or flips == 1                 # the "needed" decision was taken again at k = 5
    with pytest.raises(ValueError, match="out of range"):
        model.truncate(problem, direct, 6, 4)


def test_truncated_probe_rows_are_slices():
    """Probe rows of the first k modes are the first k columns of the rows of all modes (bitwise)."""
    rng = np.random.default_rng(0)
    x = (np.arange(40) + 0.5) * 2.0 / 40
    U = rng.normal(size=(40, 9))
    np.testing.assert_array_equal(probe_rows(U[:, :5], x, 2.0, [0.1, 0.5, 0.66]),
                                  probe_rows(U, x, 2.0, [0.1, 0.5, 0.66])[:, :5])


# ---------------------------------------------------------------------------
# compiled loops: one named structure of operators, cached
# ---------------------------------------------------------------------------

def test_compiled_loops_load_from_the_cache():
    """The loops take a namedtuple of operators; numba's cache still holds them (a second process loads them)."""
    code = textwrap.dedent("""
        import numpy as np
        from sphrom.rom.frozen import frozen_advance, loop_operators
        from sphrom.rom.galerkin import galerkin_advance
        from sphrom.rom.loops import GalerkinOperators
        K = np.eye(2) * 0.1
        ops = loop_operators(K, np.zeros(2), None, None, 3, T=np.zeros((3, 2, 2)))
        av, ar = np.ones(2), np.ones(2)
        out = np.zeros((0, 2))
        none = np.zeros(0, dtype=np.int64)
        frozen_advance(0, av, ar, np.zeros((2, 2)), np.zeros(2), 0, 5, 1e-3, np.zeros(5), ops, none, 0, out, out, 1e9)
        z1, z2 = np.zeros((1, 1)), np.zeros(1)
        g = GalerkinOperators(False, K, np.zeros(2), z1, False, np.zeros(2), False, np.zeros((4, 2)), np.ones(4),
                              np.zeros((4, 2)), np.zeros((4, 2)), np.zeros((4, 2), dtype=np.int64), np.zeros((4, 2)),
                              z2, z2, z2, z2, 0)
        galerkin_advance(0, av, ar, 0, 5, 1e-3, np.zeros((5, 3)), g, none, 0, out, out, 1e9)
        print(sum(frozen_advance.stats.cache_hits.values()), sum(galerkin_advance.stats.cache_hits.values()))
    """)
    runs = [subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
            for _ in range(2)]
    hits = [int(h) for h in runs[1].stdout.split()]
    assert hits[0] >= 1 and hits[1] >= 1, (runs[0].stdout, runs[1].stdout, runs[1].stderr)


# ---------------------------------------------------------------------------
# basis files: one I/O module, errors naming the file
# ---------------------------------------------------------------------------

def test_basis_io_is_one_module_and_names_the_file(tmp_path, capsys):
    pod_dir = ROOT / "harness" / "pod"
    for path in pod_dir.glob("*.py"):
        imported = {a.name for node in ast.walk(ast.parse(path.read_text())) if isinstance(node, ast.Import)
                    for a in node.names}
        imported |= {node.module for node in ast.walk(ast.parse(path.read_text()))
                     if isinstance(node, ast.ImportFrom) and node.module}
        if path.name != "io.py":
            assert "h5py" not in imported and "runio" not in imported, path.name
    missing = tmp_path / "none.h5"
    with pytest.raises(UserError) as err:
        read_basis(missing)
    assert str(missing) in str(err.value) and "--" not in str(err.value)
    not_basis = tmp_path / "x.h5"
    not_basis.write_bytes(b"not hdf5")
    with pytest.raises(UserError, match="cannot be read as HDF5"):
        read_basis(not_basis)
    assert main(["rom", "multimode", "--basis", str(missing), "--model", "exact", "--out", str(tmp_path / "r.h5")]) == 2
    assert f"--basis: '{missing}': not found" in capsys.readouterr().err


# ---------------------------------------------------------------------------
# code structure
# ---------------------------------------------------------------------------

REGISTRY = ["harness/rom/registry.py"]
# "exact" is also a continuum reference solver (sphrom reference --solver exact): not a model name there.
REFERENCE_SOLVER_FILES = ["harness/commands/reference.py", "harness/report/accuracy.py",
                          "harness/report/pages.py", "harness/compare.py", "harness/references/*.py"]


def _model_name_comparisons(path, names):
    """(line, text) of comparisons of a string in ``names`` (==, !=, in, not in a literal container) and of
    lookups in a literal dict keyed by one."""
    tree = ast.parse(path.read_text(), str(path))
    found = []

    def literals(node):
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            return {node.value}
        if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
            return set().union(*(literals(e) for e in node.elts)) if node.elts else set()
        return set()

    for node in ast.walk(tree):
        hit = set()
        if isinstance(node, ast.Compare):
            for operand in [node.left, *node.comparators]:
                hit |= literals(operand)
        elif isinstance(node, ast.Subscript) and isinstance(node.value, ast.Dict):
            hit |= {k.value for k in node.value.keys if isinstance(k, ast.Constant) and isinstance(k.value, str)}
        if hit & names:
            found.append((node.lineno, ast.get_source_segment(path.read_text(), node)))
    return found


def test_no_model_name_comparisons_outside_the_registry():
    names = set(MODEL_NAMES)
    registry = {ROOT / p for p in REGISTRY}
    solver_files = {p for pattern in REFERENCE_SOLVER_FILES for p in ROOT.glob(pattern)}
    offenders = []
    for path in sorted((ROOT / "harness").rglob("*.py")):
        if path in registry:
            continue
        hits = _model_name_comparisons(path, names - ({"exact"} if path in solver_files else set()))
        offenders.extend(f"{path.relative_to(ROOT)}:{line}: {text}" for line, text in hits)
    assert not offenders, "model names compared outside the registry (ask get_model(name) instead):\n" + \
        "\n".join(offenders)


def test_operators_are_read_through_the_protocol_only():
    """No getattr duck typing on operators or on a basis outside the protocol (harness/rom/model.py): every
    operators type answers the protocol of sphrom.rom.protocol, every model its properties."""
    suspects = {"ops", "lin", "operators", "basis"}
    offenders = []
    for path in sorted((ROOT / "harness").rglob("*.py")):
        if path in (ROOT / "harness/rom/model.py", ROOT / "harness/pod/io.py"):   # the protocol; the basis file's
            continue                                                                # writer, field by field
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in ("getattr",
                                                                                                 "hasattr"):
                target = node.args[0]
                name = target.attr if isinstance(target, ast.Attribute) else getattr(target, "id", None)
                if name in suspects:
                    offenders.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert not offenders, "duck typing on operators or a basis (ask the protocol instead):\n" + "\n".join(offenders)


# the protocol (sphrom.rom.protocol) and what every operators type has; the rest of their fields are internals
PROTOCOL = {"order", "slices", "sizes", "z0", "initial_state", "as_state", "block", "fields", "velocity",
            "port_velocity", "velocity_probe_rows", "project", "outputs", "output_probes", "error_bounds",
            "bound_shadow", "has_force_input", "ports", "port_errors", "Bp", "Cp", "input_error", "augmented",
            "timings", "method"}
# one type's own methods, called by code that built that type: the density operators' basis file group (sphrom
# pod) and their every-term twin (the skip measurement), the balanced model's Hankel singular values (sphrom rom)
TYPE_METHODS = {"basis_file_group", "with_every_term", "hsv"}
# a model's packaging reads its own numbers (the FMU's model.bin of its kind: sphrom.fmu); the operators' own
# module reads them
OWN_NUMBERS = ("harness/rom/", "harness/fmu/")


def test_no_operator_internals_outside_rom():
    """Code outside sphrom.rom reads operators through the protocol: no field of an operators type that is not a
    protocol member is read on operators (ops, lin, operators ...) outside sphrom.rom and the packaging."""
    from dataclasses import fields
    from sphrom.rom import LinearOperators, ReducedOperators
    from sphrom.rom.balanced_model import BalancedOperators
    types = (ReducedOperators, LinearOperators, BalancedOperators)
    internals = ({f.name for t in types for f in fields(t)} | {n for t in types for n in vars(t) if n[0] != "_"}
                 ) - PROTOCOL - TYPE_METHODS
    assert {"k_v", "k_rho", "k_e", "U_v", "a_v0", "a_rho0", "lti", "reduced"} <= internals
    receivers = {"ops", "lin", "operators", "ops_p", "ops_1", "unit"}
    offenders = []
    for path in sorted((ROOT / "harness").rglob("*.py")):
        if str(path.relative_to(ROOT)).startswith(OWN_NUMBERS):
            continue
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in receivers
                    and node.attr in internals):
                offenders.append(f"{path.relative_to(ROOT)}:{node.lineno}: {node.value.id}.{node.attr}")
    assert not offenders, "operator internals read outside sphrom.rom (ask the protocol):\n" + "\n".join(offenders)


def test_a_basis_is_data_the_models_take():
    """One arrow between the POD and the reduced models: sphrom.rom imports sphrom.pod, sphrom.pod nothing of
    sphrom.rom (at module level or in a function)."""
    edges = _import_graph()
    back = sorted(f"{m} -> {t}" for m, ts in edges.items() if m.startswith("sphrom.pod") for t in ts
                  if t.startswith("sphrom.rom"))
    assert not back, back
    assert any(t.startswith("sphrom.pod") for m, ts in edges.items() if m.startswith("sphrom.rom") for t in ts)


def _import_graph():
    """{module: modules it imports} over harness/**/*.py: absolute, relative and function-level imports."""
    files = {}
    for path in (ROOT / "harness").rglob("*.py"):
        parts = ["sphrom", *path.relative_to(ROOT / "harness").with_suffix("").parts]
        files[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    edges = {m: set() for m in files}
    for mod, path in files.items():
        package = mod if path.name == "__init__.py" else mod.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package.split(".")[:len(package.split(".")) - (node.level - 1)]
                    base = ".".join(base + ([node.module] if node.module else []))
                else:
                    base = node.module
                subs = [f"{base}.{a.name}" for a in node.names]
                # "from package import submodule" needs the submodule; any other name comes from base
                targets = subs + ([base] if any(s not in files for s in subs) else [])
            else:
                continue
            edges[mod] |= {t for t in targets if t in files and t != mod}
    return edges


def _cycles(edges):
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on_stack, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(edges[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return out


# core.py <-> sph_c.py: another change removes this cycle; then this list is emptied.
ALLOWED_CYCLES = [["sphrom.fmu.run.core", "sphrom.fmu.run.sph_c"]]


def test_no_import_cycles_inside_harness():
    edges = _import_graph()
    assert "sphrom.rom.loops" in edges and not any(e.startswith("sphrom.rom") for e in edges["sphrom.rom.loops"])
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]     # the finder finds one
    cycles = [c for c in _cycles(edges) if c not in ALLOWED_CYCLES]
    assert not cycles, f"import cycles: {cycles}"
