"""The certified error-bound outputs of a parametric FMU (``--vary c --vary d``; harness/rom/bounds.py with
``parametric=True``, fmu_src/rom_bound.c assembling the shadow's planes at the FMU's c and d).

The truth is that of tests/test_fmu_error_bounds.py: the full SPH of eqs. 2.10-2.11, exactly linear in J,
integrated exactly in time with the inputs the FMU received, here of the scene with c and d replaced by the
FMU's held-out values (neither the scene's nor a training point), from the FMU's initial state
(initial_state_scale 1) under forces no basis saw.  The scene is multimode shrunk (N = 32, d = 0, unforced):
its shadow keeps 14 of the 32 planes, so the complement's terms (the all-time G, the energy bound of the
inputs, the residual pieces) are exercised, not only |model - shadow|.
"""


import numpy as np
import pytest

import test_fmu_error_bounds as base
from conftest import fmu_scene
from sphrom.rom import parametric as par

CASE = "unforced"
RANGES = [par.Range("c", 0.05, 0.2), par.Range("d", 0.0, 5.0)]


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    """make(model, fmi) -> (path, data): the parametric FMU of fmu_scene("unforced") over RANGES (k = 6), once."""
    from conftest import fmu_maker
    return fmu_maker(tmp_path_factory.mktemp("bound-parametric"), probes=base.PROBES, default_case=CASE, vary=RANGES)


def held_out():
    """The first held-out (c, d) of the trained box (Halton; neither the scene's (0.1, 0) nor a training point)."""
    from sphrom.sph.solver import build_problem
    space = par.parameter_space(build_problem(fmu_scene(CASE)), RANGES)
    c, d = par.held_out_points(space, 1)[0]
    assert (c, d) != (0.1, 0.0) and not any(np.allclose((c, d), p) for p in par.training_points(space))
    return float(c), float(d)


def times():
    return np.arange(int(round(base.T / base.H)) + 1) * base.H


@pytest.mark.parametrize("model", ["exact", "frozen"])
def test_parametric_bounds_hold_at_a_held_out_point(fmus, model):
    """At a held-out (c, d), under three forces no basis saw (held, and the chirp linear with input derivatives),
    initial_state_scale 1: every bound >= |output - truth| at every communication point, the truth the full
    linear SPH with that c and d; and the bound is not vacuous: within 2x of the true velocity error where that
    error is above 1e-3 of its largest (measured: at most 1.51 exact, 1.00002 frozen)."""
    path, data = fmus(model)
    assert "SHPIECE" in data.sections and "SHPARAM" in data.sections
    c, d = held_out()
    fields = (("c", c), ("d", d))
    t = times()
    effs = []
    for name in ("constant", "step", "chirp"):
        f = base.forces(t)[name]
        out, names, _ = base.run(path, 1.0, f, parameters={"c": c, "d": d})
        v, rho, _ = base.truth(CASE, 1.0, f, fields=fields)
        effs.append(base.check(out, names, v, rho))
    f = base.forces(t)["chirp"]
    out, names, _ = base.run(path, 1.0, f, linear=True, parameters={"c": c, "d": d})
    v, rho, _ = base.truth(CASE, 1.0, f, linear=True, fields=fields)
    effs.append(base.check(out, names, v, rho))
    eff = np.concatenate(effs)
    # the velocity error is far above round-off (|v| ~ 1e-2 m s^-1): the exact model's ~3e-8, the frozen's ~1e-3
    assert np.max(np.abs(base.columns(out, names, "v_probe_j") - v)) > 1e-9
    assert eff.size and np.max(eff) < 2.0, np.max(eff)


def test_parametric_bounds_are_the_python_shadow_fmi2_and_3(fmus):
    """Two paths: the C core's bounds at the held-out (c, d) (its planes, residual norm and e-row scale assembled
    at ExitInitializationMode) equal harness/rom/bounds.py's run_shadow + output_bounds at that (c, d) on the
    shadow rebuilt from the scene (its sections equal the FMU's), within rtol 1e-9 (plus 1e-13 of the outputs'
    largest: |model - shadow| differs by the C Taylor vs scipy Pade exponentials' round-off); FMI 3 gives the
    bounds of FMI 2 (held inputs, rtol 1e-12), certified."""
    from sphrom.rom.bounds import fmu_shadow, output_bounds, run_shadow, sections
    from sphrom.sph.solver import build_problem
    path, data = fmus("exact")
    shadow = fmu_shadow(build_problem(fmu_scene(CASE)), base.PROBES, parametric=True,
                        scale_v=float(np.max(data.sections["ENVPROBE"][1])))
    assert shadow.parametric and shadow.order < 2 * 32          # a complement left: its terms are exercised
    for tag, value in sections(shadow).items():
        np.testing.assert_allclose(data.sections[tag], value, rtol=1e-12, atol=1e-300, err_msg=tag)
    c, d = held_out()
    t = times()
    f = base.forces(t)["chirp"]
    out, names, _ = base.run(path, 1.0, f, linear=True, parameters={"c": c, "d": d})
    y, cert = run_shadow(shadow, np.full(t.size - 1, base.H), f[:-1, None], (np.diff(f) / base.H)[:, None],
                         scale=1.0, c=c, d=d)
    v, rho = base.columns(out, names, "v_probe_j"), base.columns(out, names, "rho_probe_j")
    vb, rb, _ = output_bounds(shadow, y, cert, v, rho)
    np.testing.assert_allclose(base.columns(out, names, "v_probe_j_error_bound"), vb, rtol=1e-9,
                               atol=1e-13 * np.abs(v).max())
    np.testing.assert_allclose(base.columns(out, names, "rho_probe_j_error_bound"), rb, rtol=1e-9,
                               atol=1e-13 * np.abs(rho).max())
    # and (c, d) matter: the Python shadow at the scene's own (c, d) gives other bounds
    y0, cert0 = run_shadow(shadow, np.full(t.size - 1, base.H), f[:-1, None], (np.diff(f) / base.H)[:, None],
                           scale=1.0, c=0.1, d=0.0)
    assert np.max(np.abs(output_bounds(shadow, y0, cert0, v, rho)[0] - vb)) > 1e3 * 1e-13 * np.abs(v).max()
    # FMI 3 (held inputs: it takes no input derivatives) gives FMI 2's bounds, certified
    results = []
    for fmi in (2, 3):
        out, names, _ = base.run(fmus("exact", fmi)[0], 1.0, f, parameters={"c": c, "d": d})
        base.check(out, names, *base.truth(CASE, 1.0, f, fields=(("c", c), ("d", d)))[:2])
        results.append(base.columns(out, names, "v_probe_j_error_bound"))
    np.testing.assert_allclose(results[1], results[0], rtol=1e-12, atol=0)


def test_ordinary_sections_unchanged():
    """A non-parametric FMU's shadow has the eight sections SH* of every shadow and the free response table (and
    SHCONT, its modes continued past it, where some are; no SHPIECE, SHPARAM, SHCPL); a parametric one has no table,
    no SHCONT and the three parametric sections."""
    from sphrom.rom.bounds import fmu_shadow, sections
    from sphrom.sph.solver import build_problem
    every = ["SHSCAL", "SHLAM", "SHB", "SHC", "SHW0", "SHROW", "SHRATE", "SHPROBE"]
    problem = build_problem(fmu_scene(CASE))
    ordinary = set(sections(fmu_shadow(problem, base.PROBES)))       # (SHCONT: with the table, where modes go on)
    assert ordinary - {"SHCONT"} == set(every + ["SHTAB", "SHTERR"])
    assert sorted(sections(fmu_shadow(problem, base.PROBES, parametric=True))) == sorted(
        every + ["SHPIECE", "SHPARAM", "SHCPL"])


def test_core_refuses_a_malformed_parametric_shadow(fmus):
    """The loader names the problem: SHPIECE without SHPARAM (and the reverse), the pieces without section PARAMS,
    a c_ref <= 0, a negative residual norm, SHPIECE of the wrong shape; the packaged file itself loads."""
    from conftest import load_changed
    from sphrom.fmu.run.core import CoreError
    _, data = fmus("exact")

    def load(change):
        return load_changed(data, change)

    assert load(lambda s: None) is not None
    cases = [(lambda s: s.pop("SHPARAM"), "SHPIECE and SHPARAM come together"),
             (lambda s: s.pop("SHPIECE"), "SHPIECE and SHPARAM come together"),
             (lambda s: [s.pop(t) for t in ("PARAMS", "A0", "AC", "AD")], "SHPIECE and SHPARAM come together"),
             (lambda s: s["SHPARAM"].__setitem__((0, 0), -1.0), "section 'SHPARAM' row 1, column 1 holds -1: the shadow's reference stiffness"),
             (lambda s: s["SHPARAM"].__setitem__((0, 3), -1.0), "section 'SHPARAM' row 1, column 4 holds -1: a residual piece's norm is >= 0"),
             (lambda s: s.__setitem__("SHPIECE", s["SHPIECE"][:, :4]), "section SHPIECE is")]
    for change, text in cases:
        with pytest.raises(CoreError, match=text):
            load(change)


@pytest.fixture(scope="module")
def strongly_damped(tmp_path_factory):
    """The parametric exact FMU of fmu_scene("unforced") over c in [0.05, 0.2], d in [0, 40] (k = 6): at d = 36 the
    lower planes of the complement are overdamped (two real modes each), the others underdamped."""
    from conftest import fmu_maker
    make = fmu_maker(tmp_path_factory.mktemp("bound-overdamped"), probes=base.PROBES, default_case=CASE,
                     vary=[par.Range("c", 0.05, 0.2), par.Range("d", 0.0, 40.0)])
    return make("exact")


def test_parametric_overdamped_complement(strongly_damped):
    """At (c, d) = (0.13, 36) the C core's complement terms (fmu_src/rom_bound.c assemble_complement: underdamped,
    overdamped and their two groups) give run_shadow's bounds (harness/rom/bounds.py parametric_complement) within
    rtol 1e-9, and they hold against the full linear SPH with that c and d from the initial state and under a
    force."""
    from sphrom.rom.bounds import fmu_shadow, output_bounds, run_shadow
    from sphrom.sph.solver import build_problem
    path, data = strongly_damped
    c, d = 0.13, 36.0
    shadow = fmu_shadow(build_problem(fmu_scene(CASE)), base.PROBES, parametric=True,
                        scale_v=float(np.max(data.sections["ENVPROBE"][1])))
    comp = shadow.at(c, d)
    assert comp.rates[1] < comp.rates[0] and np.max(comp.gain[:, :, 1]) > 0      # overdamped modes left out
    t = times()
    f = base.forces(t)["step"]
    out, names, _ = base.run(path, 1.0, f, parameters={"c": c, "d": d})
    v, rho, _ = base.truth(CASE, 1.0, f, fields=(("c", c), ("d", d)))
    base.check(out, names, v, rho)
    y, cert = run_shadow(shadow, np.full(t.size - 1, base.H), f[:-1, None], np.zeros((t.size - 1, 1)), scale=1.0,
                         c=c, d=d)
    vm, rm = base.columns(out, names, "v_probe_j"), base.columns(out, names, "rho_probe_j")
    vb, rb, _ = output_bounds(shadow, y, cert, vm, rm)
    np.testing.assert_allclose(base.columns(out, names, "v_probe_j_error_bound"), vb, rtol=1e-9,
                               atol=1e-13 * np.abs(vm).max())
    np.testing.assert_allclose(base.columns(out, names, "rho_probe_j_error_bound"), rb, rtol=1e-9,
                               atol=1e-13 * np.abs(rm).max())
