"""User scenes at the first try: a few small scenes of the corpus (sphrom.bench.lib.corpus; the larger set
is `sphrom bench scenes`) written to files and given to `sphrom fmu` as a user would: each loads, the default and the
exact FMU are written, within 0.1 and 0.05 of the full SPH linear in J integrated exactly in time on the training
force, a step and an unseen sine, and their certified bounds hold at every point."""

import numpy as np
import pytest

from sphrom.bench.lib.corpus import corpus, user_scene
from sphrom.scene import load_scene, parse_scene

# CPU- and version-sensitive (eigen and singular value decisions): .ci/run runs it on Python 3.11 and 3.12 with the
# oldest and the newest numpy and scipy that pyproject.toml allows, and on the baseline CPU paths
pytestmark = pytest.mark.cpu_sensitive

SEED, COUNT, N_MAX = 0, 3, 100           # small bars: the suite's time


def test_the_corpus_is_deterministic_and_varied():
    a, b = corpus(SEED, 12, 64, 2000), corpus(SEED, 12, 64, 2000)
    assert [t for _, t, _ in a] == [t for _, t, _ in b]
    assert user_scene(SEED, 3)[1] == a[3][1] and user_scene(SEED + 1, 3)[1] != a[3][1]
    facts = [f for _, _, f in corpus(SEED, 40, 64, 2000)]
    for key, values in (("kind", {"unit", "rubber", "steel"}), ("modulus", {"uniform", "two materials", "graded"}),
                        ("damping", {"none", "uniform", "graded", "local"}),
                        ("motion", {"initial velocity", "force", "both"}), ("dt_given", {True, False}),
                        ("integrator", {"(default)", "symplectic", "rk4", "euler"})):
        assert {f[key] for f in facts} == values, key
    assert all(64 <= f["n"] <= 2000 for f in facts)
    for name, text, _ in a[:6]:                                 # scenes load, as a user's file
        parse_scene(text, f"{name}.toml", name=name)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """[(scene, default FMUSummary, its note, exact FMUSummary)] of the small scenes, as sphrom fmu builds them."""
    from sphrom.fmu.check.verify import acceptance
    from sphrom.fmu.make.auto import choose_default, default_candidates
    from sphrom.fmu.make.package import package_fmu
    folder = tmp_path_factory.mktemp("user-scenes")
    out = []
    for name, text, _ in corpus(SEED, COUNT, 64, N_MAX):
        path = folder / f"{name}.toml"
        path.write_text(text)
        scene = load_scene(path)
        options = dict(progress=False, verify=True, tolerance=None, bounds=False)
        (folder / name).mkdir()
        tried = default_candidates(scene, folder / name, options)
        best, note = choose_default(tried, folder / f"{name}.fmu")
        exact = next((s for s, _ in tried if s is not None and s.model == "exact"), None)
        if exact is None:
            exact = package_fmu(scene, folder / name / "exact.fmu", model="exact", accept=False, **options)
        assert acceptance(exact.verification, None, "exact") is None, name
        out.append((scene, best, note, exact))
    return out


def test_the_default_and_the_exact_fmu_build_and_meet_the_accuracy(built):
    for scene, default, note, exact in built:
        assert default.model in ("frozen", "exact") and (note == "") == (default.model == "frozen"), note
        assert default.verification.worst.err_v <= 0.1, (scene.name, default.verification.as_rows())
        assert exact.verification.worst.err_v <= 0.05, (scene.name, exact.verification.as_rows())
        assert [c.name for c in exact.verification.cases] == ["training", "step", "unseen"]


def test_the_certified_bounds_hold_at_every_point(built):
    for scene, default, _, exact in built:
        for s in (default, exact):
            for c in s.verification.cases:
                assert c.fmu_v_bound is not None and c.bound_holds, (scene.name, s.model, c.name)
                assert np.all(np.isfinite(c.fmu_v_bound))


def test_the_cost_is_the_median_cpu_time_ratio_of_runs_timed_in_pairs(built):
    """The bench's cost figures (sphrom bench scenes): thread CPU times of the FMU's doStep calls and of the full SPH's
    loop, medians of runs timed in pairs, and the median of the pairs' ratios; the SPH's CPU time is within its wall
    time (one thread)."""
    from sphrom.fmu.check.verify import cost_medians, sph_cost
    from sphrom.sph.solver import build_problem, run_sph
    scene, _, _, exact = built[0]
    problem = build_problem(scene)
    fmu_s, sph_s, ratio = cost_medians(exact.path, scene, exact.verification, problem=problem, repeats=3)
    assert np.isfinite(fmu_s) and fmu_s > 0 and np.isfinite(sph_s) and sph_s > 0 and np.isfinite(ratio) and ratio > 0
    run = run_sph(scene, sample_steps=[1], progress=False, problem=problem)
    assert 0 < run.cpu_time <= run.wall_time + 0.02            # 0.02 s: the clocks' tick on any system
    assert sph_cost(scene, problem, run.wall_time, repeats=3) > 0
