"""The certified error-bound outputs of an FMU whose damping d varies along the bar (harness/rom/planes.py
eigen_planes: the invariant planes of A itself, with their conditioning; fmu_src/rom_bound.c steps them as any
planes).

Without a uniform d the singular planes of the coupling are not invariant; the eigenvectors of A are: each complex
pair spans a real plane in normal form [[-α, ω], [-ω, -α]] (W = V^-ᵀ: the planes' conditioning enters every
coefficient), so the complement decays at its own rates and the bound of a run does not grow linearly in time (the
former dense Galerkin shadow's residual did).  The truth is that of tests/test_fmu_error_bounds.py: the full SPH of
eqs. 2.10-2.11, exactly linear in J, integrated exactly in time with the inputs the FMU received, from the FMU's
initial state, of the user scene tests/data/graded_damping.toml (d(x) = 4 + 3 sin(2πx/L), N = 64, T = 0.5 s).
"""

from pathlib import Path

import numpy as np
import pytest

import test_fmu_error_bounds as base

# CPU- and version-sensitive (eigen and singular value decisions): .ci/run runs it on Python 3.11 and 3.12 with the
# oldest and the newest numpy and scipy that pyproject.toml allows, and on the baseline CPU paths
pytestmark = pytest.mark.cpu_sensitive

SCENE = str(Path(__file__).resolve().parent / "data" / "graded_damping.toml")


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    """make(model, fmi) -> (path, data): the FMU of the scene (k = 6), packaged once."""
    from conftest import fmu_maker
    from sphrom.scene import load_scene
    return fmu_maker(tmp_path_factory.mktemp("bound-dense"), probes=base.PROBES, scene_of=lambda _: load_scene(SCENE),
                     bounds=False)


def times():
    return np.arange(int(round(base.T / base.H)) + 1) * base.H


@pytest.mark.parametrize("model", ["exact", "frozen"])
def test_bounds_hold_with_a_graded_damping(fmus, model):
    """d(x) not uniform: the FMU has the bound outputs (eigen-planes of A), and under three forces no basis saw
    (held, and the chirp linear with input derivatives), initial_state_scale 1 and 0, every bound >= |output -
    truth| at every communication point, and the largest bound of a held run within 3x the largest true velocity
    error."""
    path, data = fmus(model)
    assert "SHLAM" in data.sections and data.sections["SHLAM"].shape[1] == 4
    t = times()
    for scale in (1.0, 0.0):
        for name in ("constant", "step", "chirp"):
            f = base.forces(t)[name]
            out, names, _ = base.run(path, scale, f)
            v, rho, _ = base.truth(SCENE, scale, f)
            base.check(out, names, v, rho)
            error = np.abs(base.columns(out, names, "v_probe_j") - v).max()
            assert error > 1e-9 and base.columns(out, names, "v_probe_j_error_bound").max() < 3 * error
    f = base.forces(t)["chirp"]
    out, names, _ = base.run(path, 1.0, f, linear=True)
    base.check(out, names, *base.truth(SCENE, 1.0, f, linear=True)[:2])


def test_graded_bound_does_not_grow_in_time():
    """The shadow of the scene with few planes (so that the complement carries the force's response): under a
    constant force held for 40 T (the former dense shadow grew linearly there), its certified bound holds at every
    point and its largest value over the last half of the run is within 1 % of that over the first half's second
    half."""
    from sphrom.rom.bounds import build_shadow, run_shadow
    from sphrom.scene import load_scene
    from sphrom.sph.solver import build_problem
    problem = build_problem(load_scene(SCENE))
    shadow = build_shadow(problem, base.PROBES, order=6)
    assert not shadow.info["complete"] or shadow.planes < problem.n
    steps = 2000
    f = np.full(steps, 1e-2)
    truth = base.exact_rows(problem, f, scale=1.0)
    y, cert = run_shadow(shadow, np.full(steps, base.H), f[:, None], np.zeros((steps, 1)), scale=1.0)
    assert np.all(np.abs(truth - y) <= cert)
    P = len(base.PROBES)
    assert cert[steps // 2:, :P].max() <= 1.01 * cert[steps // 4:steps // 2, :P].max()


def test_graded_bounds_are_the_python_shadow_fmi2_and_3(fmus):
    """The C core's bounds (fmu_src/rom_bound.c) give harness/rom/bounds.py's run_shadow + output_bounds on the
    shadow rebuilt from the scene and the FMU's model (its sections equal the FMU's; sized against the model's
    error as packaging sizes it, the model run by the core) within rtol 1e-9 (plus 1e-13 of the outputs'
    largest); FMI 3 gives FMI 2's bounds (held inputs, rtol 1e-12)."""
    from sphrom.fmu.training.steps import core_runs
    from sphrom.rom.bounds import fmu_shadow, output_bounds, run_shadow, sections
    from sphrom.scene import load_scene
    from sphrom.sph.solver import build_problem
    path, data = fmus("exact")
    shadow = fmu_shadow(build_problem(load_scene(SCENE)), base.PROBES,
                        scale_v=float(np.max(data.sections["ENVPROBE"][1])), model_runs=core_runs(data))
    assert shadow.info["method"] == "dense eig(A)"
    for tag, value in sections(shadow).items():
        np.testing.assert_allclose(data.sections[tag], value, rtol=1e-12, atol=1e-300, err_msg=tag)
    t = times()
    f = base.forces(t)["chirp"]
    out, names, _ = base.run(path, 2.0, f, linear=True)
    y, cert = run_shadow(shadow, np.full(t.size - 1, base.H), f[:-1, None], (np.diff(f) / base.H)[:, None],
                         scale=2.0)
    v, rho = base.columns(out, names, "v_probe_j"), base.columns(out, names, "rho_probe_j")
    vb, rb, _ = output_bounds(shadow, y, cert, v, rho)
    np.testing.assert_allclose(base.columns(out, names, "v_probe_j_error_bound"), vb, rtol=1e-9,
                               atol=1e-13 * np.abs(v).max())
    np.testing.assert_allclose(base.columns(out, names, "rho_probe_j_error_bound"), rb, rtol=1e-9,
                               atol=1e-13 * np.abs(rho).max())
    results = []
    for fmi in (2, 3):
        out, names, _ = base.run(fmus("exact", fmi)[0], 1.0, f)
        results.append(base.columns(out, names, "v_probe_j_error_bound"))
    np.testing.assert_allclose(results[1], results[0], rtol=1e-12, atol=0)


def test_core_refuses_a_malformed_shadow(fmus):
    """The loader names the problem: SHTAB without SHTERR (and the reverse), a table of the wrong shape, a negative
    decay rate, SHROW of the wrong width, a missing SHRATE."""
    from conftest import load_changed
    from sphrom.fmu.run.core import CoreError
    _, data = fmus("exact")

    def load(change):
        return load_changed(data, change)

    assert load(lambda s: None) is not None
    cases = [(lambda s: s.pop("SHTERR"), "SHTAB and SHTERR come together"),
             (lambda s: s.pop("SHTAB"), "SHTAB and SHTERR come together"),
             (lambda s: s.__setitem__("SHTAB", s["SHTAB"][:, :-1]), "section SHTAB is"),
             (lambda s: s.__setitem__("SHRATE", -np.abs(s["SHRATE"]) - 1.0), "decay rate"),
             (lambda s: s.__setitem__("SHROW", s["SHROW"][:, :-1]), "section SHROW is"),
             (lambda s: s.pop("SHRATE"), "come together")]
    for change, text in cases:
        with pytest.raises(CoreError, match=text):
            load(change)


# a user's bar of the generated corpus (sphrom.bench.lib.corpus: seed 1's scene 15, which has 1841 particles, above
# the former limit of 1500): graded modulus, a damping that vanishes at x = 0 (so that no decay rate holds for the
# bar as a whole), an initial velocity and a local sine force; the same code path at any N <= EIGEN_LIMIT
USER_BAR = """
[domain]
L = 1.0
T = 3.0

[fields]
rho0 = "1.448"
c = "0.7348*(1 + 15.28*(0.5 + 0.5*sin(2*pi*x/L + 4.159)))/16.28"
d = "1.307*x/L"
v0 = "9.506e-05*(0.3605*sin(2*pi*1*x/L + 4.181) + 0.2704*sin(2*pi*3*x/L + 4.589) + 0.1821*sin(2*pi*4*x/L + 3.487))"

[force]
f = "0.0003756*sin(2*pi*0.6288*t)"
profile = "exp(-((x - 0.3217*L)/(0.08774*L))**2)"

[sph]
n_particles = {n}
"""


def user_bar(tmp_path, n):
    from sphrom.scene import load_scene
    from sphrom.sph.solver import build_problem
    path = tmp_path / f"user_bar_{n}.toml"
    path.write_text(USER_BAR.format(n=n))
    return build_problem(load_scene(str(path)))


def test_eigen_planes_are_invariant_and_dual(tmp_path):
    """The eigen-planes of the user bar (N = 160): every plane is invariant (‖A V_i - V_i Λ_i‖ within 1e-12 of
    ‖A‖), the left basis is dual to the right one (Wᵀ V = I within 1e-12 x the condition), each block is in
    normal form or diagonal, the planes come slowest first, and the residual and condition that ``info`` records
    (Lanczos estimates) are the dense 2-norms within 1e-6; a second call on the same bar returns the same planes
    (kept, read-only)."""
    import scipy.linalg as sla

    from sphrom.rom.lti import full_linear_system
    from sphrom.rom.planes import eigen_planes
    problem = user_bar(tmp_path, 160)
    n = problem.n
    pl = eigen_planes(problem)
    A = full_linear_system(problem, [0.5]).A.toarray()
    V = np.concatenate([pl.Vv, pl.Ve]).reshape(2 * n, -1)
    W = np.concatenate([pl.Wv, pl.We]).reshape(2 * n, -1)
    R = A @ V - V @ sla.block_diag(*pl.blocks[0])
    norm_a = np.linalg.norm(A, 2)
    assert np.max(np.linalg.norm(R.reshape(2 * n, -1, 2), axis=(0, 2))) <= 1e-12 * norm_a
    cond = np.linalg.norm(V, 2) * np.linalg.norm(W, 2)
    assert np.abs(W.T @ V - np.eye(2 * n)).max() <= 1e-12 * cond
    L = pl.blocks[0]
    pair = L[:, 0, 1] != 0.0
    np.testing.assert_array_equal(L[pair, 0, 0], L[pair, 1, 1])
    np.testing.assert_array_equal(L[pair, 0, 1], -L[pair, 1, 0])
    assert np.all(L[~pair, 1, 0] == 0.0) and np.all(pl.blocks[1:] == 0.0)
    assert np.all(np.diff(pl.key) >= 0.0)
    assert pl.info["condition"] == pytest.approx(cond, rel=1e-6)
    assert pl.info["residual"] == pytest.approx(np.linalg.norm(R, 2), rel=1e-6)
    again = eigen_planes(user_bar(tmp_path, 160))
    assert again.info["reused"] and not pl.info["reused"] and again.Vv is pl.Vv and not again.Vv.flags.writeable


def test_user_bar_bounds_hold_and_are_useful(tmp_path):
    """The FMU's shadow (fmu_shadow, as packaging builds it) of the user bar (N = 160) from its initial state under
    its own sine force and from rest under a step: at every communication point the certified bound holds against
    the full SPH linear in J integrated exactly in time, and it is useful (at most 1 % of the largest true |v|, the
    floor of a useful bound on a user's bar)."""
    from sphrom.rom.bounds import fmu_shadow, run_shadow
    problem = user_bar(tmp_path, 160)
    shadow = fmu_shadow(problem, base.PROBES)
    assert shadow is not None and shadow.info["method"] == "dense eig(A)"
    steps = 300
    t = np.arange(steps) * base.H
    P = len(base.PROBES)
    for scale, f in ((1.0, 0.0003756 * np.sin(2 * np.pi * 0.6288 * t)), (0.0, 2e-4 * (t > 0.37))):
        truth = base.exact_rows(problem, f, scale=scale)
        y, cert = run_shadow(shadow, np.full(steps, base.H), f[:, None], np.zeros((steps, 1)), scale=scale)
        assert np.all(np.abs(truth - y) <= cert)
        assert cert[:, :P].max() <= 1e-2 * np.abs(truth[:, :P]).max()


def test_graded_damping_above_the_limit_is_refused_in_one_line(tmp_path, monkeypatch):
    """Above EIGEN_LIMIT (lowered here to 100, the limit's own code path) a damping that varies gets no shadow
    (fmu_shadow: None, the FMU keeps its envelope warning) and eigen_planes refuses in one line naming the field and
    the allowed range; the limit covers the generated corpus (up to 2000 particles) and uniform d's dense planes."""
    from sphrom.bench.lib.corpus import corpus
    from sphrom.rom import bounds, planes
    import inspect
    assert planes.EIGEN_LIMIT >= planes.DENSE_LIMIT
    assert planes.EIGEN_LIMIT >= inspect.signature(corpus).parameters["n_max"].default
    problem = user_bar(tmp_path, 120)
    monkeypatch.setattr(planes, "EIGEN_LIMIT", 100)
    monkeypatch.setattr(bounds, "EIGEN_LIMIT", 100)
    assert bounds.fmu_shadow(problem, base.PROBES) is None
    with pytest.raises(ValueError, match=r"^n_particles: 120 is out of range .*\(allowed: up to 100;") as info:
        planes.eigen_planes(problem)
    assert "\n" not in str(info.value)
