"""Scale-free numerics (issue 32, item 2): a steel-like bar in SI units and the same bar in unit scaling get the same
automatic choices relative to their own scales, the same relative accuracy, bounds and warnings, and both FMUs stay at
rest to round-off.

The twins: x' = x / L, t' = t / T' (T' = L sqrt(rho0 / c), the wave's time once around the bar), mass / rho0.  The
steel twin (rho0 = 7850 kg m^-3, c = 7.85e11 Pa: steel's density and a modulus of steel's order, chosen so that T' is
1e-4 s, a power of ten, as the unit twin's 1 s) has periods of a tenth of a millisecond; every dimensional number of
its scene is the unit twin's times its scale (v: L/T', f: L/T'^2, d: 1/T').
"""

import numpy as np
import pytest

from sphrom.scene import parse_scene

TIME = 1e-4                      # T' of the steel twin [s]; the unit twin's is 1 s
RHO = 7850.0                     # its density [kg m^-3]
TWIN = """\
[domain]
L = 1.0
T = {T!r}

[fields]
rho0 = "{rho!r}*(1 + 0.3*cos(2*pi*x/L))"
c = "{c!r}*(1 + 0.5*sin(2*pi*x/L))"
d = "{d!r}*x/L"
v0 = "{v!r}*(sin(2*pi*x/L) + 0.3*sin(6*pi*x/L))"

[force]
f = "{f!r}*sin(2*pi*{nu!r}*t)"
profile = "exp(-((x - 0.3*L)/(0.08*L))**2)"

[sph]
n_particles = 32
"""


def twin(time, rho):
    """The scene whose T' is ``time`` [s] and whose density is ``rho`` [kg m^-3] (module docstring)."""
    speed = 1.0 / time                                     # L / T', L = 1 m
    return parse_scene(TWIN.format(T=2.0 * time, rho=rho, c=rho * speed ** 2, d=0.4 / time, v=1e-3 * speed,
                                   f=2e-3 * speed / time, nu=1.7 / time), "twin.toml", name="twin")


@pytest.fixture(scope="module")
def twins():
    return twin(TIME, RHO), twin(1.0, 1.0)


@pytest.fixture(scope="module")
def packaged(twins, tmp_path_factory):
    """{model: (steel's FMUSummary, the unit twin's)}, packaged and measured as sphrom fmu does it, once."""
    from sphrom.fmu.make.package import package_fmu
    folder = tmp_path_factory.mktemp("twins")
    return {model: tuple(package_fmu(s, folder / f"{model}-{i}.fmu", model=model, verify=True, accept=False,
                                     progress=False, bounds=False, n_freeze=None) for i, s in enumerate(twins))
            for model in ("exact", "frozen")}


def test_the_automatic_choices_are_the_same_relative_to_the_bars_scales(twins):
    from sphrom.fmu.check.verify import communication_step, force_top, lowest_frequency
    from sphrom.fmu.make.options import default_modes
    from sphrom.sph.solver import build_problem
    steel, unit = twins
    assert steel.period() == pytest.approx(TIME * unit.period(), rel=1e-12)
    assert steel.spectrum[0] * TIME == pytest.approx(unit.spectrum[0], rel=1e-12)
    assert steel.sph.dt == pytest.approx(TIME * unit.sph.dt, rel=1e-12) and steel.sph.integrator == "symplectic"
    assert steel.sph.every == unit.sph.every and steel.snapshots["count"] == unit.snapshots["count"]
    assert default_modes(steel) == default_modes(unit)
    assert lowest_frequency(build_problem(steel)) * TIME == pytest.approx(lowest_frequency(build_problem(unit)),
                                                                           rel=1e-9)
    assert force_top(steel) * TIME == pytest.approx(force_top(unit), rel=1e-9)
    assert communication_step(steel, 3.7 / TIME) == pytest.approx(TIME * communication_step(unit, 3.7), rel=1e-12)


@pytest.mark.parametrize("model", ["exact", "frozen"])
def test_the_same_relative_outputs_errors_bounds_and_warnings(packaged, model):
    """Packaged and measured as sphrom fmu does it: the outputs in units of L/T', the errors of every case, the
    bounds relative to the signal and the warnings equal; error_tolerance scales with the velocity."""
    made = packaged[model]
    vs, vu = (s.verification for s in made)
    assert made[0].k_v == made[1].k_v and made[0].shadow_order == made[1].shadow_order
    assert vs.step == pytest.approx(TIME * vu.step, rel=1e-12)
    assert vs.error_tolerance == pytest.approx(vu.error_tolerance / TIME, rel=1e-9)
    speed = 1.0 / TIME
    for cs, cu in zip(vs.cases, vu.cases):
        assert cs.name == cu.name and cs.t.size == cu.t.size
        scale = np.abs(cu.sph_v).max()
        np.testing.assert_allclose(cs.sph_v / speed, cu.sph_v, rtol=0, atol=1e-9 * scale)       # the truth
        np.testing.assert_allclose(cs.fmu_v / speed, cu.fmu_v, rtol=0, atol=1e-8 * scale)       # the FMU
        assert cs.err_v == pytest.approx(cu.err_v, rel=1e-6, abs=1e-12)
        if cs.fmu_v_bound is not None:
            # the bounds' own tables and bisections (sphrom.rom.bounds) agree to a few parts in a million
            np.testing.assert_allclose(cs.fmu_v_bound / speed, cu.fmu_v_bound, rtol=1e-4, atol=1e-9 * scale)
            assert cs.bound_holds and cu.bound_holds
        assert len(cs.warnings) == len(cu.warnings)


@pytest.mark.parametrize("model", ["exact", "frozen"])
def test_at_rest_both_twins_stay_at_rest(twins, packaged, model):
    """initial_state_scale 0 and f = 0 over 50 T': the probe velocities stay below 1e-12 of the training run's, in
    both units (docs/fmu/contract.md: rest holds to round-off)."""
    from sphrom.fmu.check.verify import fmu_run
    for s, out in zip(twins, packaged[model]):
        scale = float(np.max(out.envelope.probe_v_max))
        h = s.period() / 100
        t = np.arange(5001) * h
        v, rho, _ = fmu_run(out.path, np.zeros_like(t), t, scale=0.0)
        assert np.abs(v).max() <= 1e-12 * scale, (s.name, np.abs(v).max(), scale)
