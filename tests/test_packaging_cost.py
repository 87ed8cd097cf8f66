"""Packaging's cost per simulated second ("never slower than the SPH it replaces"): the figure is the median
of pairs of CPU-time runs in steady stepping (sphrom.fmu.check.verify.measure_cost), the default keeps the cheaper of
the candidates that meet the accuracy, a model exact in time steps at what its input and outputs need, and where the
FMU is slower packaging takes a cheaper configuration that still meets the accuracy, or says that it is slower."""

from types import SimpleNamespace

import numpy as np
import pytest

from sphrom.scene import parse_scene

# a small free bar (two materials, local damping, N = 48): seconds to package and measure
SCENE = """
[domain]
L = 1.0
T = 4.0
[fields]
rho0 = "where(x < 0.6*L, 1.0, 0.8)"
c = "where(x < 0.6*L, 0.4, 0.1)"
d = "0.05*exp(-((x - 0.5*L)/(0.1*L))**2)"
v0 = "1e-3*sin(2*pi*x/L)"
[force]
f = "2e-3*sin(2*pi*0.3*t)"
[sph]
n_particles = 48
integrator = "symplectic"
dt = 0.004
"""


def _summary(model, ratio):
    cost = SimpleNamespace(ratio=ratio)
    return SimpleNamespace(model=model, verification=SimpleNamespace(cost_ratio=ratio, cost=cost))


@pytest.mark.parametrize("frozen, exact", [(1.1, 0.03), (0.2, 0.6), (0.9, 0.5)])
def test_the_default_keeps_the_cheaper_of_two_accurate_candidates(tmp_path, frozen, exact):
    from sphrom.fmu.make.auto import DEFAULT_MODEL, choose_default
    tried = [(_summary("frozen", frozen), None), (_summary("exact", exact), None)]
    best, note = choose_default(tried, tmp_path / "x.fmu")
    assert best.verification.cost_ratio == min(frozen, exact)
    assert (note == "") == (best.model == DEFAULT_MODEL)
    if note:
        assert "cheaper" in note and f"{frozen:.3g}x" in note and f"{exact:.3g}x" in note


def test_an_inaccurate_candidate_is_not_kept_however_cheap(tmp_path):
    from sphrom.fmu.make.auto import choose_default
    tried = [(_summary("frozen", 0.01), "the frozen FMU's probe v error ... is above the accuracy 0.1; remedy: x"),
             (_summary("exact", 0.5), None)]
    best, note = choose_default(tried, tmp_path / "x.fmu")
    assert best.model == "exact" and "above the accuracy" in note


def test_the_cost_is_the_median_of_pairs_in_steady_stepping(monkeypatch):
    """measure_cost: the FMU's steady time (the first doStep left out, scaled to every step), the median of the pairs'
    ratios (one slow outlier does not move it), the first doStep's median as the setup; the verdict (Verification.
    slower) reads that median, not the single run of the training case."""
    from sphrom.fmu.check import verify
    t = np.linspace(0.0, 1.0, 11)                     # 10 steps
    fmu = iter([(2.0, 1.1), (2.0, 1.1), (50.0, 1.1), (2.0, 1.1), (2.0, 1.1)])    # (step_s, first_s) per run
    sph = iter([1.0, 1.0, 1.0, 1.0, 1.0])
    monkeypatch.setattr(verify, "fmu_facts", lambda path: (True, False, 0.1, float("nan")))
    monkeypatch.setattr(verify, "cached_sph", lambda *a, **k: SimpleNamespace(wall_time=0.1))
    monkeypatch.setattr(verify, "error_steps", lambda scene: [1])
    monkeypatch.setattr(verify, "build_problem", lambda scene: None)

    def case(path, f, times, scale=None, interpolate=False):
        step_s, first_s = next(fmu)
        return verify.FMURun(v=None, rho=None, v_bound=None, wall=0.0, step_s=step_s, warnings=[], first_s=first_s)
    monkeypatch.setattr(verify, "fmu_case", case)
    monkeypatch.setattr(verify, "sph_cost", lambda *a, **k: next(sph))
    scene = SimpleNamespace(L=1.0, T=1.0, sph=SimpleNamespace(dt=0.01))
    training = SimpleNamespace(name="training", t=t, cost_ratio=50.0)
    v = verify.Verification(step=0.1, T=1.0, input="held", probes=[0.5], cases=[training],
                            refs={"training": ("0", 1.0, "rest", None)})
    c = verify.measure_cost("x.fmu", scene, v, repeats=5)
    steady = (2.0 - 1.1) * 10 / 9
    assert c.fmu_s == pytest.approx(steady, rel=1e-12) and c.ratio == pytest.approx(steady, rel=1e-12)
    assert c.setup_s == pytest.approx(1.1) and c.steps == 10 and c.sph_steps == 100 and c.repeats == 5
    assert v.slower                                    # no cost measured: the training case's single run, 50x
    v.cost = c
    assert v.cost_ratio == c.ratio and v.slower == (c.ratio > 1)
    assert "us per step x 10 communication steps" in c.why()


def test_steady_time_leaves_out_the_first_step():
    from sphrom.fmu.check.verify import FMURun, steady_seconds
    run = FMURun(v=None, rho=None, v_bound=None, wall=0.0, step_s=10.0, warnings=[], first_s=6.0)
    assert steady_seconds(run, 5) == pytest.approx(5.0) and steady_seconds(run, 1) == 10.0


@pytest.fixture(scope="module")
def bar():
    from sphrom.sph.solver import build_problem
    scene = parse_scene(SCENE, "cost.toml", name="cost")
    return scene, build_problem(scene)


def test_a_model_exact_in_time_steps_at_what_its_input_and_outputs_need(bar):
    """The exact model's default step: at least POINTS_PER_PERIOD points per period of the force's band and
    OUTPUT_POINTS_PER_PERIOD of the response's, at most 10 % more steps than that; never finer than the time-stepped
    rule's (which samples the response at POINTS_PER_PERIOD)."""
    from sphrom.fmu.check.verify import (OUTPUT_POINTS_PER_PERIOD, POINTS_PER_PERIOD, communication_step, force_top,
                                         model_band, top_frequency)
    from sphrom.fmu.make.package import default_step
    from sphrom.fmu.kinds.linear import exact_model
    scene, problem = bar
    data, lin, _, _ = exact_model(scene, 6, [0.25, 0.5], progress=False, problem=problem)
    h = default_step(scene, data, lin, problem)
    need = max(10.0, POINTS_PER_PERIOD * force_top(scene) * scene.T,
               OUTPUT_POINTS_PER_PERIOD * model_band(scene, problem, lin) * scene.T)
    steps = scene.T / h
    assert abs(steps - round(steps)) < 1e-9 * steps                       # a whole number of steps over T
    assert need * (1 - 1e-12) <= steps <= 1.1 * need + 1
    assert h >= communication_step(scene, top_frequency(scene, problem, lin)) * (1 - 1e-12)


def _fmu_states(path):
    """The coordinates an FMU steps (k_v + k_rho of its model, the order of its bounds' shadow), read back from its
    resources/model.bin."""
    import zipfile
    from sphrom.fmu import layout
    from sphrom.fmu.kinds import unpack
    data = unpack(zipfile.ZipFile(path).read("resources/model.bin"))
    shadow = int(layout.value(data.sections, "SHSCAL", "order")) if "SHSCAL" in data.sections else 0
    return data.k_v + data.k_rho + shadow


def _cost_of(path, parity):
    """A deterministic Cost: the FMU's stepped coordinates over ``parity`` (so that the choice, not the machine's
    speed, is tested)."""
    from sphrom.fmu.check.verify import Cost
    r = _fmu_states(path) / parity
    return Cost(fmu_s=r, sph_s=1.0, ratio=r, setup_s=0.0, steps=10, sph_steps=10, repeats=5)


@pytest.fixture(scope="module")
def exact_first(bar, tmp_path_factory):
    from sphrom.fmu.make.package import package_fmu
    scene, problem = bar
    folder = tmp_path_factory.mktemp("cost")
    s = package_fmu(scene, folder / "first.fmu", model="exact", progress=False, verify=True, bounds=False,
                    problem=problem)
    return s, folder


@pytest.mark.parametrize("share", [0.9, 0.6, 0.01])
def test_a_slower_fmu_is_replaced_by_a_cheaper_configuration_that_meets_the_accuracy(bar, exact_first, monkeypatch,
                                                                                      share):
    """The cost made proportional to the stepped coordinates, parity at ``share`` of the first FMU's: packaging
    keeps the first of cheaper_settings whose FMU meets the accuracy and costs at most the full SPH, and says why
    (the note, the FMU's page); where none does (share 0.01), it keeps the first FMU, whose page says in bold that
    it is slower."""
    import zipfile
    from sphrom.fmu.check.verify import acceptance
    from sphrom.fmu.make import auto, package
    scene, _ = bar
    first, folder = exact_first
    options = dict(progress=False, verify=True, tolerance=None, bounds=False)
    parity = share * _fmu_states(first.path)
    monkeypatch.setattr(package, "measure_cost", lambda path, *a, **k: _cost_of(path, parity))
    first.verification.cost = _cost_of(first.path, parity)
    assert first.verification.slower
    (folder / str(share)).mkdir()
    best, note = auto.cheaper_if_slower(scene, folder / str(share), first, options)
    if first.k_v + first.k_rho <= parity:         # the same model without its bounds is cheap enough: one is taken
        assert best is not first
    if parity < 2:                                # no FMU steps fewer than 2 coordinates: none is cheap enough
        assert best is first
    if best is first:
        assert note == "" and first.verification.slower
        return
    assert not best.verification.slower and _fmu_states(best.path) <= parity
    assert acceptance(best.verification) is None
    assert best.k < first.k or best.shadow_order == 0
    assert note.startswith(f"the exact FMU at k = {first.k}") and "packaging chose" in note
    page = zipfile.ZipFile(best.path).read("documentation/index.html").decode()
    assert "Configuration chosen for its cost" in page and "slower than the full SPH it replaces" not in page
    assert any(note.endswith(f"packaging chose {words}: {best.verification.cost_ratio:.3g}x, the accuracy met")
               for words, _ in auto.cheaper_settings(first, options))


def test_a_slower_fmu_says_so_on_its_page(exact_first, monkeypatch):
    """Where no configuration is cheaper, the page of the FMU packaging keeps says in bold that it is slower, and
    why (each one's time per step and steps over T)."""
    import zipfile
    from sphrom.fmu.check.verify import Cost
    from sphrom.fmu.make import package
    first, folder = exact_first
    slow = Cost(fmu_s=3.0, sph_s=1.0, ratio=3.0, setup_s=1e-3, steps=10, sph_steps=20, repeats=5)
    monkeypatch.setattr(package, "measure_cost", lambda *a, **k: slow)
    s = package.package_fmu(parse_scene(SCENE, "cost.toml", name="cost"), folder / "slow.fmu", model="exact",
                            progress=False, verify=True, bounds=False, error_bounds=False)
    page = zipfile.ZipFile(s.path).read("documentation/index.html").decode()
    assert s.verification.slower and "<strong>This FMU is slower than the full SPH it replaces</strong>" in page
    assert "communication steps per T against the full SPH" in page
