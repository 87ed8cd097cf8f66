"""The certified error-bound outputs (harness/rom/bounds.py, fmu_src/rom_bound.c): every output with its certified error at every step.

The truth is computed here independently of every reduced model and of the shadow: the full SPH of eqs.
2.10-2.11 as the linear system of :mod:`sphrom.rom.lti` (exactly linear in J), advanced exactly in time over each
communication step (the matrix exponential of the system augmented with the input and its slope), from the FMU's
initial state, with the very inputs the FMU received (held, or linear with input derivatives; the port forces of
a closed loop as the FMU read them).  Every bound must be >= |output - truth| at every communication point, on
forces and initial-state scales the bases never saw, for the frozen, exact and balanced FMUs, FMI 2 and 3.
"""

import functools
import math

import numpy as np
import pytest
import scipy.linalg as sla

from conftest import fmu_scene
from sphrom.fmu.run.driver import FMU
from sphrom.fmu.variables import members, vr

PROBES = (0.25, 0.5, 0.66)
PORTS = (0.3,)
H = 0.01
T = 1.0


def forces(t):
    """Forces the bases never saw [m s^-2]: a constant, a slow sine, a step, a fast chirp."""
    return {"constant": 3e-3 * np.ones_like(t), "slow sine": 1e-2 * np.sin(2 * np.pi * 0.3 * t),
            "step": 4e-3 * (t > 0.37), "chirp": 5e-3 * np.sin(2 * np.pi * (1.0 + 3.0 * t) * t)}


@pytest.fixture(scope="module")
def make(tmp_path_factory):
    """make(model, fmi, case, ports) -> (path, data): the FMU of ``fmu_scene(case)`` (k = 6, without the a priori
    bounds), packaged once."""
    import zipfile

    from sphrom.fmu.make.build import ensure_binaries
    from sphrom.fmu.make.package import package_fmu
    from sphrom.fmu.resources import unpack
    folder, made = tmp_path_factory.mktemp("bound-fmus"), {}

    def build(model="exact", fmi=2, case="forced", ports=None):
        key = (model, fmi, case, ports)
        if key not in made:
            path = folder / f"{model}-{fmi}-{case}-{bool(ports)}.fmu"
            package_fmu(fmu_scene(case), path, k=6, fmi=fmi, probes=PROBES, progress=False,
                        binaries=ensure_binaries(), model=model, ports=ports, bounds=False)
            made[key] = (path, unpack(zipfile.ZipFile(path).read("resources/model.bin")))
        return made[key]

    return build


def scene_of(case, fields=()):
    """The shrunk scene ``case`` (or the scene file ``case``, a path ending in .toml) with the fields ``fields``
    ((name, value) pairs: c, d) replaced."""
    from sphrom.scene import derive_scene, load_scene
    scene = load_scene(case) if str(case).endswith(".toml") else fmu_scene(case)
    return derive_scene(scene, {"fields": {name: str(value) for name, value in fields}}) if fields else scene


@functools.lru_cache(maxsize=None)
def full_system(case, ports=(), area=1.0, fields=()):
    """(problem, lti, Phi, G0, G1, input columns' count) of the shrunk scene ``case`` (its ``fields`` replaced,
    :func:`scene_of`): the exact maps of one step H of the full linear SPH (eqs. 2.10-2.11 in J) with the inputs f
    and the port forces [N], held (G0) and their change (G1)."""
    from sphrom.rom.lti import full_linear_system
    from sphrom.sph.ports import port_accelerations
    from sphrom.sph.solver import build_problem
    problem = build_problem(scene_of(case, fields))
    lti = full_linear_system(problem, PROBES)
    n = problem.rho0.size
    cols = [lti.B[:, 0]]
    if ports:
        acc = port_accelerations(problem, ports, area)                  # per N
        cols += [np.concatenate([np.sqrt(problem.rho0) * a, np.zeros(n)]) for a in acc]
    Bm = np.column_stack(cols)
    m = Bm.shape[1]
    M = np.zeros((2 * n + 2 * m,) * 2)
    M[:2 * n, :2 * n] = lti.A.toarray() * H
    M[:2 * n, 2 * n:2 * n + m] = Bm * H
    M[2 * n:2 * n + m, 2 * n + m:] = np.eye(m)
    E = sla.expm(M)
    return problem, lti, E[:2 * n, :2 * n], E[:2 * n, 2 * n:2 * n + m], E[:2 * n, 2 * n + m:], m


def truth(case, scale, f, ports=(), port_forces=None, linear=False, fields=()):
    """(v (M+1, P), rho (M+1, P), v_port (M+1, ports)) of the full linear SPH at the communication points t = j H,
    from scale x the scene's initial state, f (and the port forces [N]) held over each step or linear; ``fields``
    replaced in the scene (:func:`scene_of`)."""
    from sphrom.rom.lti import probe_matrix
    from sphrom.sph.ports import port_velocity_rows
    problem, lti, Phi, G0, G1, m = full_system(case, tuple(ports), fields=tuple(fields))
    n = problem.rho0.size
    u = np.column_stack([f] + ([port_forces[:, j] for j in range(len(ports))] if ports else []))
    x = scale * lti.x0
    X = [x]
    for j in range(len(f) - 1):
        du = (u[j + 1] - u[j]) if linear else np.zeros(m)
        x = Phi @ x + G0 @ u[j] + G1 @ du
        X.append(x)
    X = np.array(X)
    v = X[:, :n] / np.sqrt(problem.rho0)
    rho = problem.rho0 / (1.0 + X[:, n:] / np.sqrt(problem.c))
    interp = probe_matrix(problem.x, problem.scene.L, PROBES, np.ones(n))
    v_port = v @ port_velocity_rows(problem, ports).T if ports else np.zeros((len(f), 0))
    return v @ interp.T, rho @ interp.T, v_port


def run(path, scale, f, linear=False, parameters=None, feedback=None):
    with FMU(path) as fmu:
        fmu.initialize(parameters={"initial_state_scale": scale, **(parameters or {})}, inputs={"f": float(f[0])})
        out = fmu.simulate(np.arange(len(f)) * H, {"f": f}, rates=linear, feedback=feedback)
        return out, fmu.outputs, fmu.warnings()


def columns(out, names, name):
    return out[:, members(names, name)]


def check(out, names, v, rho, v_port=None):
    """Every bound >= |output - truth| at every communication point; returns the velocity effectivities
    (bound / error where the error exceeds 1e-3 of its largest)."""
    ev = np.abs(columns(out, names, "v_probe_j") - v)
    er = np.abs(columns(out, names, "rho_probe_j") - rho)
    vb, rb = columns(out, names, "v_probe_j_error_bound"), columns(out, names, "rho_probe_j_error_bound")
    assert vb.shape == ev.shape and rb.shape == er.shape
    assert np.all(vb >= ev) and np.all(rb >= er), (np.max(ev - vb), np.max(er - rb))
    if v_port is not None:
        ep = np.abs(columns(out, names, "v_port_j") - v_port)
        assert np.all(columns(out, names, "v_port_j_error_bound") >= ep)
    mask = ev > 1e-3 * ev.max()
    return vb[mask] / ev[mask]


@pytest.mark.parametrize("model", ["exact", "balanced", "frozen"])
def test_bounds_hold_on_unseen_forces(make, model):
    """frozen, exact, balanced (FMI 2): five forces never trained (held, and one linear with input derivatives)
    at initial_state_scale 0, 1, 3: certified at every point; the exact model's effectivity near 1."""
    case = "forced"
    path, _ = make(model=model)
    t = np.arange(int(round(T / H)) + 1) * H
    effs = []
    for scale in (0.0, 1.0, 3.0):
        for name, f in forces(t).items():
            out, names, _ = run(path, scale, f)
            v, rho, _ = truth(case, scale, f)
            effs.append(check(out, names, v, rho))
    f = forces(t)["chirp"]
    out, names, _ = run(path, 1.0, f, linear=True)
    effs.append(check(out, names, *truth(case, 1.0, f, linear=True)[:2]))
    eff = np.concatenate(effs)
    assert np.median(eff) < 10, np.median(eff)


def test_bounds_undamped_and_fmi3(make):
    """The undamped scene (d = 0, the a priori force bound there is vacuous): certified on FMI 2 and 3, whose
    bound outputs agree (held inputs: the same arithmetic)."""
    case = "unforced"
    t = np.arange(int(round(T / H)) + 1) * H
    f = forces(t)["slow sine"]
    results = []
    for fmi in (2, 3):
        path, _ = make(model="exact", fmi=fmi, case="unforced")
        out, names, _ = run(path, 1.0, f)
        check(out, names, *truth(case, 1.0, f)[:2])
        results.append(columns(out, names, "v_probe_j_error_bound"))
    np.testing.assert_allclose(results[0], results[1], rtol=1e-12, atol=0)


def test_bounds_port_spring(make):
    """A port closed by a spring (F = -k_s x_port, x_port integrated from v_port: a coupled component): the port
    velocity's bound and the probes' hold against the full SPH driven by the forces the FMU received."""
    case = "forced"
    t = np.arange(int(round(T / H)) + 1) * H
    f = forces(t)["constant"]
    stiffness, position, applied = 5.0, [0.0], []

    def spring(j, tj, y):
        position[0] += H * y[names.index("v_port_1")] if j else 0.0
        applied.append(-stiffness * position[0])
        return {"F_port_1": applied[-1]}

    with FMU(make(ports=PORTS)[0]) as fmu:
        names = fmu.outputs
        fmu.initialize(parameters={"initial_state_scale": 1.0}, inputs={"f": float(f[0])})
        out = fmu.simulate(t, {"f": f}, feedback=spring)
    F = np.array(applied + applied[-1:])[:, None]          # the last point's value is never applied (held)
    assert np.abs(F).max() > 0
    v, rho, v_port = truth(case, 1.0, f, ports=PORTS, port_forces=F)
    check(out, names, v, rho, v_port)
    # not vacuous: the port channel is exact for the port forces (its own bound at round-off, every plane the port
    # excites kept), so the port bound is the model's error in its response to f and the initial state, whose
    # complement the shadow certifies (the shadow has the port rows, no port input columns): printed, and a small
    # fraction of the port velocity
    bound = columns(out, names, "v_port_j_error_bound")
    error = np.abs(columns(out, names, "v_port_j") - v_port)
    print(f"port bound {bound.max():.3g} m/s, port error {error.max():.3g} m/s, |v_port| {np.abs(v_port).max():.3g}")
    assert bound.max() < 1e-2 * np.abs(v_port).max(), (bound.max(), np.abs(v_port).max())


def test_the_fmu_bounds_are_the_python_shadow(make):
    """Two paths: the C core's bounds (fmu_src/rom_bound.c) equal harness/rom/bounds.py's run_shadow and
    output_bounds on the same shadow, rebuilt from the scene and the FMU's model (its sections equal the FMU's), to
    round-off."""
    from sphrom.fmu.training.steps import core_runs
    from sphrom.rom.bounds import fmu_shadow, output_bounds, run_shadow, sections
    from sphrom.sph.solver import build_problem
    path, data = make(model="exact")
    shadow = fmu_shadow(build_problem(fmu_scene("forced")), PROBES, scale_v=float(np.max(data.sections["ENVPROBE"][1])),
                        model_runs=core_runs(data))              # (sized against the model's error, as packaging)
    for tag, value in sections(shadow).items():
        np.testing.assert_allclose(data.sections[tag], value, rtol=1e-12, atol=1e-300, err_msg=tag)
    t = np.arange(int(round(T / H)) + 1) * H
    f = forces(t)["chirp"]
    out, names, _ = run(path, 2.0, f, linear=True)
    y, cert = run_shadow(shadow, np.full(t.size - 1, H), f[:-1, None], (np.diff(f) / H)[:, None], scale=2.0)
    vb, rb, _ = output_bounds(shadow, y, cert, columns(out, names, "v_probe_j"), columns(out, names, "rho_probe_j"))
    # the exponentials differ (C: Taylor, scipy: Pade) by round-off of the outputs (|model - shadow| is a
    # difference of outputs), which the smallest bounds (1e-10) show
    v, rho = columns(out, names, "v_probe_j"), columns(out, names, "rho_probe_j")
    np.testing.assert_allclose(columns(out, names, "v_probe_j_error_bound"), vb, rtol=1e-9,
                               atol=1e-13 * np.abs(v).max())
    np.testing.assert_allclose(columns(out, names, "rho_probe_j_error_bound"), rb, rtol=1e-9,
                               atol=1e-13 * np.abs(rho).max())


def test_error_tolerance_warns_once_when_a_bound_exceeds_it(make):
    """error_tolerance: a bound above it warns once (naming the output, the bound, the tolerance, the time); the
    bound is certified, so a true error above the tolerance always warns, and a tolerance above every bound never
    does; 0 disables; a negative one is refused naming the parameter."""
    case = "forced"
    path, _ = make(model="frozen")
    t = np.arange(int(round(T / H)) + 1) * H
    f = forces(t)["step"]
    v, _, _ = truth(case, 1.0, f)
    out, names, warnings = run(path, 1.0, f)
    err = np.abs(columns(out, names, "v_probe_j") - v).max()
    bound = columns(out, names, "v_probe_j_error_bound").max()
    _, _, warned = run(path, 1.0, f, parameters={"error_tolerance": 0.5 * err})
    assert len(warned) == 1 and "error_tolerance" in warned[0] and "v_probe_" in warned[0] and "t = " in warned[0]
    assert run(path, 1.0, f, parameters={"error_tolerance": 1.01 * bound})[2] == []
    assert run(path, 1.0, f, parameters={"error_tolerance": 0.0})[2] == []
    with FMU(path) as fmu:
        with pytest.raises(Exception):
            fmu.initialize(parameters={"error_tolerance": -1.0})
        assert any("error_tolerance" in e for e in fmu.errors())


def test_no_false_alarm_at_the_default_tolerance(make):
    """The quickstart's case (a small constant force from rest, errors far below the response): the default
    tolerance (5 % of the training run's largest |v_probe|, the description says so) stays silent, where the
    training envelope warned."""
    case = "forced"
    path, _ = make(model="frozen")
    t = np.arange(int(round(T / H)) + 1) * H
    f = 1e-3 * np.ones_like(t)
    out, names, warnings = run(path, 0.0, f)
    assert warnings == []
    check(out, names, *truth(case, 0.0, f)[:2])


def test_bounds_survive_a_state_round_trip(make):
    """getFMUState / setFMUState carry the shadow: the bounds after a restore equal those of the first pass, also
    read at once after the restore, before a step (the C core keeps the rows' sums of a state until it changes:
    a restore must drop them)."""
    path, _ = make(model="exact")
    t = np.arange(int(round(T / H)) + 1) * H
    f = forces(t)["chirp"]
    refs = [vr(name, j) for name in ("v_probe_j_error_bound", "rho_probe_j_error_bound") for j in (1, 2, 3)]

    def steps(fmu, points):
        bounds = []
        for j in points:
            fmu.set_input(f[j])
            fmu.do_step(t[j], H)
            bounds.append(fmu.get_real(refs))
        return np.array(bounds)

    with FMU(path) as fmu:
        fmu.initialize(parameters={"initial_state_scale": 1.0})
        steps(fmu, range(50))
        state = fmu.get_state()
        saved = np.array(fmu.get_real(refs))
        first = steps(fmu, range(50, 80))
        fmu.set_state(state)
        restored = np.array(fmu.get_real(refs))
        second = steps(fmu, range(50, 80))
        fmu.free_state(state)
    np.testing.assert_array_equal(saved, restored)
    np.testing.assert_array_equal(first, second)
    assert np.any(first[-1] != saved)                     # (the bounds moved: a stale pass would show)


def exact_rows(problem, f, scale=0.0, rows=None):
    """The full linear SPH's output rows (harness/rom/bounds.py output_rows) at t = j H under f held over each step,
    from scale x the initial state, exact in time (dense step map)."""
    from sphrom.rom.bounds import input_columns, output_rows
    from sphrom.rom.lti import full_linear_system
    n = problem.n
    lti = full_linear_system(problem, PROBES)
    C = output_rows(problem, PROBES)[0] if rows is None else rows
    M = np.zeros((2 * n + 1, 2 * n + 1))
    M[:2 * n, :2 * n] = lti.A.toarray() * H
    M[:2 * n, 2 * n] = input_columns(problem)[:, 0] * H
    E = sla.expm(M)
    x, out = scale * lti.x0, []
    for j in range(len(f)):
        out.append(C @ x)
        x = E[:2 * n, :2 * n] @ x + E[:2 * n, 2 * n] * f[j]
    out.append(C @ x)
    return np.array(out)


def test_complement_transient_saturates_under_a_persistent_input():
    """The planes a shadow leaves out answer a force whose profile reaches them (cos 8 pi x / L on the damped scene):
    their quasi-static part is added to the shadow's rows exactly and their transient is bounded by the force's
    variation weighted by their decay (d / 2): under a sine held over 20 s the certified bound of the shadow's rows
    holds at every point, saturates (its largest over the last quarter of the run is that of the second quarter,
    where the force's total variation, the former bound's measure, doubles), and stays within 5x the shadow's true
    error (measured: 1.8)."""
    from sphrom.rom.bounds import build_shadow, run_shadow
    from sphrom.scene import derive_scene
    from sphrom.sph.solver import build_problem
    problem = build_problem(derive_scene(fmu_scene("forced"), {"force": {"profile": "cos(8*pi*x/L)"}}))
    shadow = build_shadow(problem, PROBES, order=3)
    assert shadow.planes == 3 and np.max(shadow.comp.gain) > 0          # a complement the force reaches
    steps = 2000
    f = 1e-2 * np.sin(2.0 * np.arange(steps) * H)
    truth = exact_rows(problem, f)
    y, cert = run_shadow(shadow, np.full(steps, H), f[:, None], np.zeros((steps, 1)), scale=0.0)
    err = np.abs(truth - y)
    assert np.all(err <= cert)
    P = len(PROBES)
    second, last = cert[steps // 4:steps // 2, :P].max(), cert[3 * steps // 4:, :P].max()
    assert last <= 1.01 * second, (second, last)
    assert cert[:, :P].max() < 5 * err[:, :P].max(), (cert[:, :P].max(), err[:, :P].max())


def test_sparse_planes_match_the_dense_ones(monkeypatch):
    """Above DENSE_LIMIT particles the lowest planes come from the sparse shift-invert Lanczos solver on KᵀK (K is
    banded): on the shrunk damped scene (forced to that path) its singular values equal the dense SVD's to 1e-9 and
    its planes span the same subspace; the shadow built on them bounds the planes it never computed through norms
    (σ >= σ_cut) and is certified from the initial state and under a force; a second solve gives the same bits (the
    Lanczos start vector is fixed, not ARPACK's random one: packaging above DENSE_LIMIT writes the same model.bin)."""
    from sphrom.rom import planes as pl
    from sphrom.rom.bounds import build_shadow, run_shadow
    from sphrom.sph.solver import build_problem
    problem = build_problem(fmu_scene("forced"))
    dense = pl.singular_planes(problem)
    monkeypatch.setattr(pl, "DENSE_LIMIT", 10)
    sparse = pl.singular_planes(problem, count=12)
    assert not sparse.complete and 8 <= sparse.count <= 12
    again = pl.singular_planes(problem, count=12)              # (Lanczos from a fixed start: the same bits)
    np.testing.assert_array_equal(again.key, sparse.key)
    np.testing.assert_array_equal(again.Vv, sparse.Vv)
    np.testing.assert_array_equal(again.Ve, sparse.Ve)
    k = sparse.count
    np.testing.assert_allclose(sparse.key, dense.key[:k], rtol=1e-9, atol=1e-9 * dense.key[-1])
    Sd, Ss = dense.basis(np.arange(k)), sparse.basis(np.arange(k))
    assert np.linalg.norm(Sd @ Sd.T - Ss @ Ss.T, 2) < 1e-8
    shadow = build_shadow(problem, PROBES, order=4, count=12)
    assert not shadow.info["complete"] and np.max(shadow.comp.static) > 0
    steps = 200
    f = forces(np.arange(steps) * H)["chirp"]
    for scale in (1.0, 0.0):
        truth = exact_rows(problem, f, scale=scale)
        y, cert = run_shadow(shadow, np.full(steps, H), f[:, None], np.zeros((steps, 1)), scale=scale)
        assert np.all(np.abs(truth - y) <= cert)


def test_uncomputed_planes_chebyshev_response_in_the_shadow(monkeypatch):
    """The uncomputed planes' free response by the Chebyshev expansion (sphrom.rom.bounds.tail_free_chebyshev, the
    way at N = 1e5), in a whole shadow: on the shrunk damped scene forced to the sparse planes (DENSE_LIMIT = 10, 12
    planes) and to that way (TAIL_WORK = 0), the shadow is certified against the exact-in-time truth at every point,
    from the initial state and under a force, and its largest certificate over the run is at most the one of the
    same shadow with that response bounded through norms alone (tail_response=False), row by row."""
    import sphrom.rom.bounds as bounds
    from sphrom.rom import planes as pl
    from sphrom.rom.bounds import build_shadow, run_shadow
    from sphrom.sph.solver import build_problem
    problem = build_problem(fmu_scene("forced"))
    monkeypatch.setattr(pl, "DENSE_LIMIT", 10)
    monkeypatch.setattr(bounds, "TAIL_WORK", 0)
    shadow = build_shadow(problem, PROBES, order=4, count=12)
    norms = build_shadow(problem, PROBES, order=4, count=12, tail_response=False)
    assert shadow.info["tail_table"] is not None and norms.info["tail_table"] is None
    steps = 120
    f = forces(np.arange(steps) * H)["chirp"]
    truth_f = exact_rows(problem, f, scale=1.0)
    args = (np.full(steps, H), f[:, None], np.zeros((steps, 1)))
    y, cert = run_shadow(shadow, *args, scale=1.0)
    y0, cert0 = run_shadow(norms, *args, scale=1.0)
    assert np.all(np.abs(truth_f - y) <= cert) and np.all(np.abs(truth_f - y0) <= cert0)
    assert np.all(cert.max(axis=0) <= cert0.max(axis=0))


def test_the_bounds_truth_two_ways(monkeypatch):
    """sphrom.rom.reference.exact_probe_reference (the truth the bounds are of; one case of sphrom.rom.truth,
    which packaging's verification measures every FMU against) equals this file's truth (the dense step map of the
    augmented system), held and linear, and its sparse path (a Taylor series of the sparse operator, above
    truth.DENSE_MAX particles) equals its dense one to 1e-12 of the signal."""
    import sphrom.rom.truth as truth_module
    import sphrom.rom.reference as reference
    from sphrom.sph.solver import build_problem
    problem = build_problem(fmu_scene("forced"))
    t = np.arange(41) * H
    f = forces(t)["chirp"]
    for hold, linear in (("held", False), ("linear", True)):
        v, rho = reference.exact_probe_reference(problem, PROBES, t, f, 1.0, hold=hold)
        v_ref, rho_ref, _ = truth("forced", 1.0, f, linear=linear)
        np.testing.assert_allclose(v, v_ref, rtol=0, atol=1e-12 * np.abs(v_ref).max())
        np.testing.assert_allclose(rho, rho_ref, rtol=1e-13, atol=0)
    monkeypatch.setattr(truth_module, "DENSE_MAX", 8)
    v2, rho2 = reference.exact_probe_reference(problem, PROBES, t, f, 1.0, hold="linear")
    np.testing.assert_allclose(v2, v, rtol=0, atol=1e-12 * np.abs(v).max())
    np.testing.assert_allclose(rho2, rho, rtol=1e-13, atol=0)


def test_bounds_past_the_free_response_table(make):
    """A run from the initial state 1.5 x as long as the free response table (on the undamped scene it spans 20 T):
    past the table the complement's modes that matter are continued exactly (section SHCONT, bounds.continued_modes)
    instead of bounded by their size (a Hölder sum that does not decay: the bound jumped to about twice the
    complement's free response there, 1e5 x the exact model's error).  The bounds hold against the truth at every
    point; past the table the largest bound stays within 2 x its largest over the table's last 2 T (the one left
    out is sized to the table's own error allowance); a tolerance 10 x the largest true error does not warn; and the
    C core's bounds equal run_shadow's (the same shadow, rebuilt as packaging builds it) past the table too, within
    the continued sum's round-off allowance (bounds.cont_roundoff, the FMU's: its exponentials carried over up to
    CONT_ANCHOR steps, the state's time off the steps' sum by at most an ulp per step)."""
    from sphrom.fmu.training.steps import core_runs
    from sphrom.rom.bounds import CONT_ANCHOR, cont_roundoff, fmu_shadow, output_bounds, run_shadow
    from sphrom.sph.solver import build_problem
    path, data = make(model="exact", case="unforced")
    shadow = fmu_shadow(build_problem(fmu_scene("unforced")), PROBES,
                        scale_v=float(np.max(data.sections["ENVPROBE"][1])), model_runs=core_runs(data))
    comp = shadow.comp
    assert comp.values is not None
    steps = int(round(1.5 * comp.t_end / H))
    t = np.arange(steps + 1) * H
    f = 3e-3 * np.sin(1.7 * t)
    v_true, rho_true, _ = truth("unforced", 1.0, f)
    out, names, _ = run(path, 1.0, f)
    check(out, names, v_true, rho_true)
    tolerance = 10.0 * float(np.max(np.abs(columns(out, names, "v_probe_j") - v_true)))
    assert run(path, 1.0, f, parameters={"error_tolerance": tolerance})[2] == []
    vb_c = columns(out, names, "v_probe_j_error_bound")
    late = t > comp.t_end
    before = (t > comp.t_end - 2 * T) & ~late
    assert late.sum() > 0.3 * steps
    assert vb_c[late].max() <= 2.0 * vb_c[before].max(), (vb_c[late].max(), vb_c[before].max())
    y, cert = run_shadow(shadow, np.full(steps, H), f[:-1, None], np.zeros((steps, 1)), scale=1.0)
    v, rho = columns(out, names, "v_probe_j"), columns(out, names, "rho_probe_j")
    vb, rb, _ = output_bounds(shadow, y, cert, v, rho)
    allow = np.array([cont_roundoff(comp, tau, steps=CONT_ANCHOR, drift=CONT_ANCHOR * 2.0 ** -53 * tau)[:len(PROBES)]
                      for tau in t])
    # (the shadow's exponentials differ, C: Taylor, scipy: Padé, by round-off of the outputs that grows with the
    # steps: 1e-12 of the outputs after 1500 steps, as over the table's span)
    atol = 1e-12 * np.abs(v).max()
    np.testing.assert_allclose(vb_c[~late], vb[~late], rtol=1e-9, atol=atol)
    np.testing.assert_allclose(vb_c[late], vb[late], rtol=1e-9, atol=atol + 2 * allow[late].max())


def test_core_refuses_a_damaged_continuation(make, monkeypatch):
    """Section SHCONT (the modes continued past the free response table) damaged: the loader names the problem (a
    wrong shape, an odd column count, a growing mode, a non-finite number, the section without its table) rather
    than add a wrong or unbounded free response past the table."""
    import copy
    import struct
    import zlib

    import sphrom.rom.bounds as bounds
    from conftest import load_changed
    from sphrom.fmu import layout
    from sphrom.fmu.make.build import ensure_binaries
    from sphrom.fmu.resources import pack
    from sphrom.fmu.run.core import Core, CoreError
    from sphrom.fmu.training.steps import core_runs
    from sphrom.sph.solver import build_problem
    _, packaged = make(model="exact", case="unforced")
    # the premise, a model.bin with SHCONT: which modes are continued is a floating-point budget's choice
    # (bounds.continued_modes), so the shadow is rebuilt as packaging builds it with every candidate mode continued
    # (exact, of a finite size > 0 at the table's end): on the undamped scene the complement's free response from
    # the initial state is tabulated and does not decay, so its modes are candidates by construction
    monkeypatch.setattr(bounds, "continued_modes", lambda modes, decayed, *rest: (
        modes.exact & np.all(np.isfinite(decayed), axis=0) & np.any(decayed > 0, axis=0)))
    shadow = bounds.fmu_shadow(build_problem(fmu_scene("unforced")), PROBES,
                               scale_v=float(np.max(packaged.sections["ENVPROBE"][1])), model_runs=core_runs(packaged))
    data = copy.deepcopy(packaged)
    data.sections = {**{k: v for k, v in data.sections.items() if not k.startswith("SH")}, **bounds.sections(shadow)}
    assert "SHCONT" in data.sections

    def untabled(s):
        s.pop("SHTAB"), s.pop("SHTERR")
        s["SHSCAL"] = s["SHSCAL"].copy()
        s["SHSCAL"][0, 4] = 0.0                             # (nodes: no table)

    def entry(row, col, value):
        def change(s):
            s["SHCONT"] = s["SHCONT"].copy()
            s["SHCONT"][row, col] = value
        return change

    def written(row, col, value):
        """model.bin with SHCONT[row, col] = value written over its bytes (the checksum recomputed: the Python
        writer refuses a non-finite number, an editor of the file does not)"""
        blob = pack(data)
        at = blob.index(b"SHCONT\0\0")
        cols = struct.unpack_from("<II", blob, at + 8)[1]
        where = at + layout.SECTION.size + 8 * (row * cols + col)
        blob = blob[:where] + struct.pack("<d", value) + blob[where + 8:]
        return blob[:-4] + struct.pack("<I", zlib.crc32(blob[:-4]) & 0xFFFFFFFF)

    load_changed(data, lambda s: None).close()
    cases = [(lambda s: s.__setitem__("SHCONT", s["SHCONT"][:-1]), "section SHCONT is"),
             (lambda s: s.__setitem__("SHCONT", s["SHCONT"][:, :-1]), "section SHCONT is"),
             (entry(0, 0, 0.5), "SHCONT's mode 0 grows"),
             (untabled, "SHCONT .* without the table")]
    for change, text in cases:
        with pytest.raises(CoreError, match=text):
            load_changed(data, change)
    core = Core(ensure_binaries().core)
    for row, col, value in ((1, 1, np.nan), (0, 1, np.inf), (0, 0, np.nan)):
        with pytest.raises(CoreError, match="non-finite numbers in section 'SHCONT'"):
            core.load(written(row, col, value))


@pytest.mark.parametrize("n", [64, 20000])
def test_rigid_motion_is_in_the_planes_kernel_at_any_n(n):
    """The uniform velocity (rigid motion, no strain) is in ker Kᵀ at any N: null_rows finds it also where G 1's
    round-off (eps N of max|G|) is above a fixed 1e-12 (at N = 1e4 the kernel was missed and the sparse planes'
    null triplets got arbitrary left vectors: ‖Kᵀu − σw‖ = 729, bounds of 3 m/s on a bar moving at 4e-3 m/s)."""
    from sphrom.bench.error_bounds import large_scene
    from sphrom.rom.planes import null_rows
    from sphrom.sph.solver import build_problem
    problem = build_problem(large_scene(n))
    u_null, _ = null_rows(problem)
    rigid = np.sqrt(problem.rho0) / np.linalg.norm(np.sqrt(problem.rho0))
    assert np.linalg.norm(u_null.T @ rigid) == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("n", [64, 20000])
def test_every_kernel_test_uses_one_tolerance(n):
    """The input channels' rigid modes (sphrom.rom.inputs.rigid_modes, what candidate_directions and the force
    profile's rigidity test use) and the LTI's null modes take the same N-scaled kernel tolerance as the planes
    (inputs.kernel_tol): on the uniform lattice the constant and the alternating function (even N) are exact kernels
    of G at any N, and each is in the span returned (a fixed 1e-12 missed them from N = 1e4 on)."""
    from sphrom.bench.error_bounds import large_scene
    from sphrom.rom.inputs import rigid_modes
    from sphrom.rom.lti import null_modes
    from sphrom.sph.solver import build_problem
    problem = build_problem(large_scene(n))
    G = problem.neighbours.matrix().tocsr()
    R = rigid_modes(G)
    Q = np.linalg.qr(R)[0] if R.shape[1] else R
    w_e = np.sqrt(problem.c)
    Z = null_modes(G, w_e)
    for k in (np.ones(n), (-1.0) ** np.arange(n)):
        assert np.linalg.norm(k - Q @ (Q.T @ k)) <= 1e-12 * np.linalg.norm(k)
        e = np.concatenate([np.zeros(n), k / w_e])
        assert np.linalg.norm(e - Z @ (Z.T @ e)) <= 1e-12 * np.linalg.norm(e)


def shrunk_tail(k=24):
    """The shrunk damped_forced (N = 400, tenmode's v0 with its kink at the seam) with the lowest ``k`` planes of
    its dense SVD taken as the computed ones: (problem, dense planes, those k, k, rows, input columns, x0, Tail)."""
    from conftest import small_scene
    from sphrom.rom import planes as pl
    from sphrom.rom.bounds import input_columns, output_rows, tail_of
    from sphrom.sph.solver import build_problem
    problem = build_problem(small_scene("damped_forced", T=0.5, n=400))
    dense = pl.singular_planes(problem)
    sub = pl.Planes(blocks=dense.blocks[:, :k], Vv=dense.Vv[:, :k], Ve=dense.Ve[:, :k], Wv=dense.Wv[:, :k],
                    We=dense.We[:, :k], key=dense.key[:k], complete=False, orthonormal=True,
                    info={"sigma_cut": float(dense.key[k])})
    C = output_rows(problem, PROBES)[0]
    B = input_columns(problem)
    n = problem.rho0.size
    x0 = np.concatenate([np.sqrt(problem.rho0) * problem.v0, np.zeros(n)])
    return problem, dense, sub, k, C, B, x0, tail_of(sub, C, B, x0, float(problem.d[0]), K=pl.coupling(problem))


def test_uncomputed_planes_weighted_norms():
    """The planes never computed (above DENSE_LIMIT particles) are bounded through norms (sphrom.rom.bounds.Tail):
    the weighted ones (ω² = σ² + σ_cut², one sparse solve with K Kᵀ + s and a product with Kᵀ, no plane formed) equal
    the sums over the planes themselves (the dense SVD of the shrunk damped_forced at N = 400, the lowest 24 planes
    taken as the computed ones) to 1e-8; the free response's bound and the transient's gain are at least the
    Hölder sums over those planes (the bound holds); and on the probe rows (point rows, every plane alike) against
    tenmode's v0 (a kink at the seam) the free response's bound is within 5x the Hölder sum (measured 1.6-1.9; the
    plain Cauchy-Schwarz ‖c_tail‖ ‖x0_tail‖ it replaces: 4.3-4.9)."""
    problem, dense, sub, k, C, B, x0, tail = shrunk_tail()
    chat = np.linalg.norm(dense.right(C.T)[k:], axis=1)           # (planes, rows) ‖ĉ_i‖ of the tail planes
    eta = np.linalg.norm(dense.left(x0)[k:], axis=1)
    bhat = np.linalg.norm(dense.left(B)[k:], axis=1)
    sig = dense.key[k:]
    s = float(dense.key[k]) ** 2
    np.testing.assert_allclose(tail.c_weighted, np.sqrt((chat ** 2 / (sig ** 2 + s)[:, None]).sum(axis=0)),
                               rtol=1e-8)
    assert tail.x0_weighted == pytest.approx(math.sqrt(((sig ** 2 + s) * eta ** 2).sum()), rel=1e-8)
    holder = tail.kappa * (chat * eta[:, None]).sum(axis=0)
    assert np.all(holder <= tail.free())
    gains = tail.kappa * (chat[:, :, None] * bhat[:, None, :] / sig[:, None, None]).sum(axis=0)
    assert np.all(gains <= tail.gain())
    P = len(PROBES)
    assert np.all(tail.free()[:P] <= 5.0 * holder[:P])


def test_bench_summary_counts_every_scenes_runs():
    """sphrom bench error_bounds' per-model summary counts a run per scene, model and case: the case names repeat
    across scenes, and keyed by the name alone the summary had kept one scene's runs (its violations and points)."""
    from sphrom.bench.error_bounds import summarise
    rows = [{"scene": s, "model": "exact", "case": c, "output": o, "effectivity": 1.0, "max_err": 1e-6,
             "max_bound": 1e-6, "violations": v, "points": 11, "false_alarm": False}
            for s, v in (("a", 0), ("b", 2)) for c in ("step, held, rest", "chirp, held, rest")
            for o in ("v_probe_1", "rho_probe_1")]
    (total,) = summarise(rows, ("model",))
    assert total["runs"] == 4 and total["points"] == 44 and total["violations"] == 4 and total["outputs"] == 8


def test_bench_cost_summary_counts_every_fmu_once():
    """The benches' native doStep ratio is summarised over FMUs, not rows: an FMU's ratio repeats on each of its
    runs and outputs (and parametric points are FMUs of their own scene and model only once), and a row that was
    not built or not timed (NaN) is left out rather than counted as within the target."""
    from sphrom.bench.lib.native_cost import COST_TARGET, cost_summary
    rows = ([{"scene": "a", "model": "exact", "native_ratio": 1.1, "case": c} for c in range(7)]
            + [{"scene": "b", "model": "exact", "native_ratio": COST_TARGET + 0.5, "case": c} for c in range(3)]
            + [{"scene": "c", "model": "exact", "native_ratio": float("nan")},
               {"scene": "d", "model": "exact", "note": "not built"},
               {"scene": "a", "model": "balanced", "native_ratio": COST_TARGET - 0.1}])
    costs = cost_summary(rows)
    assert costs["exact"] == (pytest.approx(0.5 * (1.1 + COST_TARGET + 0.5)), COST_TARGET + 0.5, 1, 2)
    assert costs["balanced"][2:] == (0, 1)


def test_bench_cost_tables_carry_the_instruction_count_where_measured():
    """The cost tables show the native timing's ratio and, where callgrind measured it, the instruction count's:
    a row set without instruction counts (no valgrind) gives the timing's table alone, never a table of NaNs."""
    from sphrom.bench.lib.native_cost import cost_lines, cost_summary
    timed = [{"scene": "a", "model": "exact", "native_ratio": 1.2, "instr_ratio": float("nan")}]
    counted = [{**timed[0], "instr_ratio": 1.1}, {"scene": "b", "model": "exact", "native_ratio": 1.4,
                                                  "instr_ratio": 1.25}]
    assert cost_summary(counted, value="instr_ratio")["exact"] == (pytest.approx(1.175), 1.25, 0, 2)
    only_timing, both = "\n".join(cost_lines(timed)), "\n".join(cost_lines(counted))
    assert "native ratio median" in only_timing and "instruction ratio" not in only_timing
    assert "native ratio median" in both and "| exact | 2 | 1.18 | 1.25 | 0 |" in both
    assert "past-table" not in both                  # no FMU with a table counted past its end: no such table
    past = [{**counted[0], "instr_past_ratio": 1.2}, {**counted[1], "instr_past_ratio": float("nan")}]
    assert "| exact | 1 | 1.20 | 1.20 | 0 |" in "\n".join(cost_lines(past)).split("past-table")[1]


def test_bench_native_timing_rounds_within_the_budget():
    """The native timing's rounds (timing_rounds): the three variants back to back in each round, in turn forwards
    and backwards, as many rounds as NATIVE_ROUNDS where they fit in the budget, never fewer than the repeats asked
    for (an FMU of costly steps: the repeats alone, the bench no slower than before for it)."""
    from sphrom.bench.lib.native_cost import NATIVE_ROUNDS, timing_rounds
    now, order = [0.0], []

    def run(cost):
        def one(i):
            order.append(i)
            now[0] += cost
            return 100.0 + i
        return one
    quick = timing_rounds(run(0.001), 3, budget=4.0, clock=lambda: now[0])
    assert [len(x) for x in quick] == [NATIVE_ROUNDS] * 3 and quick[2] == [102.0] * NATIVE_ROUNDS
    assert order[:6] == [0, 1, 2, 2, 1, 0]
    now[0] = 0.0
    assert [len(x) for x in timing_rounds(run(2.0), 3, budget=4.0, clock=lambda: now[0])] == [3] * 3
    now[0] = 0.0
    assert [len(x) for x in timing_rounds(run(0.5), 1, budget=4.0, clock=lambda: now[0])] == [3] * 3

@pytest.mark.parametrize("path", ["taylor", "chebyshev"])
def test_uncomputed_planes_free_response_computed(monkeypatch, path):
    """Where it is affordable the uncomputed planes' free response from x0 is computed, not bounded
    (sphrom.rom.bounds.tail_table), by the full state's Taylor propagation or (where that is not affordable, forced
    here by TAIL_WORK = 0) by the Chebyshev expansion in K Kᵀ and Kᵀ K: on the shrunk damped_forced (N = 400, the
    lowest 24 planes of the dense SVD taken as the computed ones, tenmode's v0 with its kink at the seam) its nodes
    equal c_rᵀ e^{A t} x0_tail by the dense exponential to 1e-9 of the planes' norm bound, its Hermite interpolant
    between the nodes stays within the certified error of that exact response, and that error is at most 1e-3 of the
    norm bound it replaces at t = 0 and never above that bound plus the cubic's own size on any interval."""
    import scipy.linalg as sla

    import sphrom.rom.bounds as bounds
    from sphrom.rom.bounds import tail_table
    from sphrom.rom.lti import full_linear_system
    problem, dense, sub, k, C, B, x0, tail = shrunk_tail()
    if path == "chebyshev":
        monkeypatch.setattr(bounds, "TAIL_WORK", 0)
    table = tail_table(problem, C, x0, sub, tail, problem.scene.T)
    assert table is not None and table.values.shape[1] > 100
    tk = np.arange(table.error.shape[1]) * table.h
    v, s = np.abs(table.values), np.abs(table.slopes)
    cubic = np.maximum(v[:, :-1], v[:, 1:]) + 0.25 * table.h * np.maximum(s[:, :-1], s[:, 1:])
    assert np.all(table.error <= (np.outer(tail.free(), np.exp(-tail.alpha * tk)) + cubic) * (1 + 1e-9))
    A = full_linear_system(problem, [0.5]).A.toarray()
    S = sub.basis(np.arange(k))
    x_tail = x0 - S @ (S.T @ x0)
    scale = tail.free()
    nodes = table.values.shape[1]
    for j in (0, 7, nodes // 3, nodes - 1):
        exact = C @ (sla.expm(A * (j * table.h)) @ x_tail)
        np.testing.assert_allclose(table.values[:, j], exact, rtol=0, atol=1e-9 * scale.max())
        for s in (0.3, 0.5):                         # between nodes j and j + 1: the Hermite cubic
            if j + 1 >= nodes:
                break
            t = (j + s) * table.h
            h00, h10, h01, h11 = (1 + 2 * s) * (1 - s) ** 2, s * (1 - s) ** 2, s * s * (3 - 2 * s), s * s * (s - 1)
            cubic = (h00 * table.values[:, j] + h01 * table.values[:, j + 1] +
                     table.h * (h10 * table.slopes[:, j] + h11 * table.slopes[:, j + 1]))
            truth_t = C @ (sla.expm(A * t) @ x_tail)
            assert np.all(np.abs(cubic - truth_t) <= table.error[:, j]), (j, s)
    assert np.all(table.error[:, 0] <= 1e-3 * scale)


def test_no_subnormal_number_on_the_bounds_hot_path(make):
    """A subnormal operand costs the CPU about 100 cycles per operation (a damped scene's doStep with bounds cost
    1.29 x its doStep without, in time, past the free response table while its instructions said 1.13: tails of
    1e-289 times decays of 1e-20 each step).  The complement's positive gains and tails are at least SIZE_FLOOR in
    the FMU's sections, and the tails' decays after the table and the weighted variations, once positive, at least
    DECAY_FLOOR (raised: still upper bounds), so the products the step forms are normal numbers: checked in the
    serialized state at a time where the fastest group's decay e^{-α (τ - t_end)} would be subnormal (α (τ - t_end)
    = 720), reached by one long step; the bounds there equal run_shadow's, which floors the same way, and hold."""
    from sphrom.fmu.layout import STATE_HEADER
    from sphrom.fmu.training.steps import core_runs
    from sphrom.rom.bounds import DECAY_FLOOR, SIZE_FLOOR, fmu_shadow, floored_decay, output_bounds, run_shadow
    from sphrom.sph.solver import build_problem
    tiny = np.finfo(float).tiny
    x = np.concatenate([np.linspace(0.0, 800.0, 4001), [1e4, np.inf]])
    assert np.all(floored_decay(x) >= np.exp(-x)) and np.all(floored_decay(x) >= DECAY_FLOOR)
    assert SIZE_FLOOR * DECAY_FLOOR >= 2.0 ** 100 * tiny          # (a gain times a variation, a tail times a decay)
    path, data = make(model="exact", case="forced")
    row = data.sections["SHROW"]
    terms = row[:, 1 + 2 * 1:]                                      # (one input: norm, D, static, then H, tail)
    assert np.all((terms <= 0) | (terms >= SIZE_FLOOR)), terms[(terms > 0) & (terms < SIZE_FLOOR)]
    shadow = fmu_shadow(build_problem(fmu_scene("forced")), PROBES, scale_v=float(np.max(data.sections["ENVPROBE"][1])),
                        model_runs=core_runs(data))
    comp = shadow.comp
    assert comp.values is not None and comp.rates.max() > 0
    tau = comp.t_end + 720.0 / comp.rates.max()
    h = np.concatenate([np.full(10, H), [tau - 10 * H], np.full(10, H)])
    t = np.concatenate([[0.0], np.cumsum(h)])
    f = 3e-3 * np.sin(1.7 * t)
    with FMU(path) as fmu:
        fmu.initialize(parameters={"initial_state_scale": 1.0}, inputs={"f": float(f[0])})
        outs = [fmu.output_values(fmu.outputs)]
        for j in range(h.size):
            fmu.set_input(float(f[j]))
            fmu.do_step(t[j], h[j])
            outs.append(fmu.output_values(fmu.outputs))
            if j == 10:
                blob = fmu.serialize(fmu.get_state())
        names = fmu.outputs
    values = np.frombuffer(blob[STATE_HEADER.size:len(blob) - 4], dtype="<f8")
    odd = values[(values != 0) & (np.abs(values) < tiny)]
    assert odd.size == 0, odd
    out = np.array(outs)
    y, cert = run_shadow(shadow, h, f[:-1, None], np.zeros((h.size, 1)), scale=1.0)
    v, rho = columns(out, names, "v_probe_j"), columns(out, names, "rho_probe_j")
    vb, rb, _ = output_bounds(shadow, y, cert, v, rho)
    np.testing.assert_allclose(columns(out, names, "v_probe_j_error_bound")[11:], vb[11:], rtol=1e-9,
                               atol=1e-12 * np.abs(v).max())
