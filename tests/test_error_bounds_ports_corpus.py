"""`sphrom bench error_bounds_ports --corpus N`: the generated user scenes of `sphrom bench error_bounds --corpus N`,
their port cases sized from each scene's own properties (harness/bench/error_bounds_ports.py `sizes`), so that a
steel-like bar gets a mass-spring and forces of its own magnitudes, not the unit bar's; the built-in scenes keep the
published cases."""

import numpy as np
import pytest

from sphrom.bench import error_bounds, error_bounds_ports as ebp
from sphrom.bench.lib.error_corpus import user_scenes
from sphrom.rom.inputs import band
from sphrom.scene import derive_scene, load_scene
from sphrom.sph.solver import build_problem

from conftest import small_scene


def _unit_bar():
    return small_scene("damped_forced", T=2.0, n=48)


def _steel_bar():
    """The unit bar made of steel (ρ0 = 7850 kg m^-3, c = 2.1e11 Pa): 10^7 x the impedance, ~10^4 x ω1."""
    return derive_scene(_unit_bar(), {"name": "steel_bar", "domain": {"T": 1e-3},
                                      "fields": {"rho0": "7850", "c": "2.1e11", "d": "2000",
                                                 "v0": "5e-3*sin(2*pi*x/L)"},
                                      "sph": {"dt": 2e-8, "every": 500},
                                      "snapshots": {"count": 20, "window": [0.0, 1e-3]}})


def test_the_corpus_is_error_bounds_corpus():
    ours, theirs = user_scenes(3), error_bounds.user_scenes(3)
    assert [s.name for s in ours] == [s.name for s in theirs] == ["user_1", "user_2", "user_3"]
    assert [s.fields for s in ours] == [s.fields for s in theirs]


def test_options_and_scene_selection(capsys):
    assert ebp.scene_names([], 0) == list(ebp.DEFAULT_SCENES)
    assert ebp.scene_names([], 4) == []                    # --corpus alone: the user scenes alone
    assert ebp.scene_names(["tenmode"], 4) == ["tenmode"]
    for bad in ("-1", "two"):
        with pytest.raises(SystemExit) as exc:
            ebp.main(["--corpus", bad])
        assert exc.value.code == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1                                 # one line, naming the option and its range
        assert "--corpus" in err[0] and "allowed: an integer >= 0" in err[0]


def test_the_si_corpus_scenes_are_the_scenes_benchs_above_the_unit_corpus():
    """--si-corpus N: the first N scenes of `sphrom bench scenes`'s corpus (seed --si-seed) with at least
    SI_MIN_PARTICLES particles, in its order and under its names (the unit corpus's N of 64-128 port FMUs keep every
    plane); --si-corpus alone measures them alone, and a bad count is refused in one line."""
    from sphrom.bench.lib.corpus import user_scene
    from sphrom.bench.lib.error_corpus import SI_MIN_PARTICLES, si_scenes
    got = si_scenes(3, seed=0)
    drawn = [user_scene(0, i) for i in range(40)]
    want = [name for name, _, facts in drawn if facts["n"] >= SI_MIN_PARTICLES][:3]
    assert [s.name for s in got] == want
    for s in got:
        assert build_problem(s).n >= SI_MIN_PARTICLES
    assert ebp.scene_names([], 2) == []                    # (main passes --corpus or --si-corpus)
    with pytest.raises(SystemExit) as exc:
        ebp.main(["--si-corpus", "-1"])
    assert exc.value.code == 2


def test_builtin_scenes_keep_the_published_cases():
    t = np.arange(0, 3.0, 0.01)
    got = ebp.cases(t, 3.0)
    assert list(got) == ["slow port forces", "constant 1e-3 N at port 1", "port 1 coupled to a mass-spring",
                         "port 1 coupled to a mass-spring-damper", "f = 2e-3 and slow port forces"]
    slow = got["slow port forces"][1]
    np.testing.assert_allclose(slow[:, 0], 2e-3 * np.sin(1.3 * t), rtol=0, atol=1e-18)
    np.testing.assert_allclose(slow[:, 1], 1e-3 * np.cos(3.1 * t) + 5e-4 * (t > 1.5), rtol=0, atol=1e-18)
    coupled = got["port 1 coupled to a mass-spring-damper"][1]
    assert coupled == ebp.Coupled(ebp.DAMPER, 0.05, 5.0, 1e-3)


@pytest.mark.parametrize("make", [_unit_bar, _steel_bar])
def test_cases_are_sized_from_the_scene(make):
    problem = build_problem(make())
    w1, w_top = band(problem)
    size = ebp.sizes(problem)
    w_spring = np.sqrt(size.stiffness / size.mass)
    assert w1 < w_spring < w_top                             # the lumped mass-spring rings inside the scene's band
    assert w1 < 1.55 * size.rate < w_top and size.rate == pytest.approx(w1, rel=1e-12)
    bar_mass = float(np.sum(problem.rho0)) * problem.neighbours.dx
    assert size.mass == pytest.approx(0.05 * bar_mass, rel=1e-12)
    V = float(np.max(np.abs(problem.v0)))
    Z = bar_mass * w1 / (2 * np.pi)
    assert size.force == pytest.approx(Z * V, rel=1e-12)
    # the spring's force at t = 0 and the dashpot are the same fractions of the bar's on any bar: pi Z V, a tenth of
    # critical
    assert size.stiffness * size.stretch == pytest.approx(np.pi * size.force, rel=1e-12)
    assert size.damper == pytest.approx(0.2 * np.sqrt(size.stiffness * size.mass), rel=1e-12)
    assert size.step * w1 == pytest.approx(min(ebp.STEP * w1, ebp.STEP_OMEGA), rel=1e-12)


def test_steel_and_unit_bars_get_cases_of_their_own_magnitudes():
    unit, steel = (ebp.sizes(build_problem(make())) for make in (_unit_bar, _steel_bar))
    ratio_w = steel.rate / unit.rate                             # √(c/ρ0) ratio: ~1.6e4
    assert ratio_w == pytest.approx(np.sqrt(2.1e11 / 7850 / 0.1), rel=0.05)
    assert steel.mass / unit.mass == pytest.approx(7850, rel=1e-9)
    assert np.sqrt(steel.stiffness / steel.mass) / np.sqrt(unit.stiffness / unit.mass) == pytest.approx(ratio_w)
    # communication steps of the same ω1 h as the unit bar's 10 ms (the sampled loops' stability depends on it)
    assert steel.step * steel.rate == pytest.approx(unit.step * unit.rate, rel=0.01)
    assert steel.step < 1e-3 * _steel_bar().T


def test_a_run_the_fmu_stops_is_recorded_with_its_reason(monkeypatch):
    """error_bounds: an FMU's error status stops that run alone (recorded with the FMU's reason), not the bench."""
    from sphrom import defaults
    from sphrom.bench.lib.stopped import RunStopped

    def stop(*args, **kwargs):
        raise RunStopped("negative density at probe 1")
    monkeypatch.setattr(error_bounds, "run_fmu", stop)
    problem = build_problem(small_scene("multimode", T=0.5, n=32))
    t = np.arange(3) * 0.01
    cases = {"constant, held, rest": ("rest", 0.0, "constant", np.zeros(3), False)}
    rows, kept = error_bounds.measure_fmu("unused.fmu", problem, defaults.PROBES, t, cases, {})
    assert kept == {} and len(rows) == 1 and rows[0]["stopped"] == "negative density at probe 1"
    note = {"scene": "multimode", "model": "exact", **rows[0], "note": error_bounds._stopped(rows[0])}
    line = error_bounds._note_row(note, before=6, after=7)
    assert "constant, held, rest stopped: negative density at probe 1" in line and "not built" not in line
    assert line.count("|") == 17                                   # the table's 16 columns
