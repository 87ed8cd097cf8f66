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
