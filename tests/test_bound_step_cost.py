"""The lean per-step work of the certified error bounds (the doStep cost with bounds; fmu_src/rom_bound.c, rom.c):

- the kind's v_probe is kept per state (RomState.v_kept) so that doStep's error check and the importer's read share
  one sum: every read equals what a fresh read of that state gives, after a step, a state restore, a reset and a set
  input alike;
- the error check warns at exactly the step where a velocity bound first exceeds error_tolerance, whether or not the
  importer reads the bounds (group 0's rows are summed in the step where the check read them, else when read);
- the lanes of the shadow's step and rows' sums (GCC vector extensions: two SSE2 lanes, the planes' step in four
  AVX2 lanes on a CPU that has AVX2) and the plain-array path (-DROM_NO_LANES) give the same bits;
- within the free response table the error check reads the probes' velocity rows four side by side (rom_bound.c
  table_rows_exceed): whatever the build, it warns at exactly the step where a velocity bound output (the rows one at
  a time, rom_v_probe_error_bound) first exceeds error_tolerance, a tolerance equal to a bound included (no warning
  there: the same bits).
"""
import re
import shutil
import sys
import zipfile

import numpy as np
import pytest

from conftest import fmu_scene
from sphrom.fmu.run.driver import FMU
from sphrom.fmu.variables import members

PROBES = (0.25, 0.5, 0.66)
H = 0.01
STEPS = 100


@pytest.fixture(scope="module")
def make(tmp_path_factory):
    """make(model, ports) -> path: the FMU of fmu_scene("forced") (k = 6, with its shadow), packaged once."""
    from sphrom.fmu.make.build import ensure_binaries
    from sphrom.fmu.make.package import package_fmu
    folder, made = tmp_path_factory.mktemp("bound-cost-fmus"), {}

    def build(model="exact", ports=None, probes=PROBES):
        key = (model, ports, probes)
        if key not in made:
            path = folder / f"{model}-{bool(ports)}-{len(probes)}.fmu"
            package_fmu(fmu_scene("forced"), path, k=6, fmi=2, probes=probes, progress=False,
                        binaries=ensure_binaries(), model=model, ports=ports, bounds=False)
            made[key] = path
        return made[key]

    return build


def force(j):
    """A force the basis never saw [m s^-2] at step j: a step up, then a fast tone."""
    t = j * H
    return 4e-3 * (t > 0.2) + 3e-3 * np.sin(2 * np.pi * 4.0 * t)


def test_kept_outputs_are_the_states_own(make):
    """v_probe read after a step, after a restore, after a reset and after setting the input is the same number a
    read of that state gives the first time (a stale kept value would repeat the last state's): the restore's
    reads equal the first pass's bit for bit, the reset's equal a fresh instance's, and a set input leaves them."""
    path = make()
    with FMU(path) as fresh:
        fresh.initialize(parameters={"initial_state_scale": 1.0})
        start = fresh.output_values()
    with FMU(path) as fmu:
        v = members(fmu.outputs, "v_probe_j")
        fmu.initialize(parameters={"initial_state_scale": 1.0})
        np.testing.assert_array_equal(fmu.output_values(), start)
        for j in range(40):
            fmu.set_input(force(j))
            fmu.do_step(j * H, H)
        state = fmu.get_state()
        saved = fmu.output_values()
        first = []
        for j in range(40, 70):
            before = fmu.output_values()
            fmu.set_input(force(j))
            np.testing.assert_array_equal(fmu.output_values(), before)    # the input moves no output
            fmu.do_step(j * H, H)
            first.append(fmu.output_values())
        assert np.all(first[-1][v] != saved[v])                          # (the outputs moved)
        fmu.set_state(state)
        np.testing.assert_array_equal(fmu.output_values(), saved)        # at once, before a step
        second = []
        for j in range(40, 70):
            fmu.set_input(force(j))
            fmu.do_step(j * H, H)
            second.append(fmu.output_values())
        np.testing.assert_array_equal(np.array(second), np.array(first))
        fmu.free_state(state)
        fmu.fmu.reset()
        fmu.initialize(parameters={"initial_state_scale": 1.0})
        np.testing.assert_array_equal(fmu.output_values(), start)


def warned_at(warnings):
    """The time [s] named by the error check's one warning."""
    assert len(warnings) == 1 and "error_tolerance" in warnings[0], warnings
    return float(re.search(r"at t = ([-+0-9.eE]+) s", warnings[0]).group(1))


@pytest.mark.parametrize("ports", [None, (0.3,)])
def test_warning_at_the_step_where_a_bound_first_exceeds(make, ports):
    """error_tolerance between the run's smallest and largest velocity bound: the one warning names the time of the
    first step whose v_probe (or v_port) bound exceeds it, whether the importer reads the bounds at every step (the
    rows then summed in the step) or never (summed by the check itself); a port force makes the shadow's inputs two
    (the general path)."""
    path = make(ports=ports)
    names = None
    with FMU(path) as fmu:                                  # the bounds at every step
        fmu.initialize(parameters={"initial_state_scale": 1.0, "error_tolerance": 0.0})
        names = [n for n in fmu.outputs if re.fullmatch(r"v_(probe|port)_\d+_error_bound", n)]
        bounds = []
        for j in range(STEPS):
            fmu.set_input(force(j))
            if ports:
                fmu.set_real([fmu.vr["F_port_1"]], [2e-3 * np.cos(7.0 * j * H)])
            fmu.do_step(j * H, H)
            bounds.append(fmu.output_values(names).max())
    bounds = np.array(bounds)
    tol = float(np.sqrt(bounds.min() * bounds.max()))
    first = int(np.argmax(bounds > tol))
    assert bounds[0] <= tol < bounds.max() and first > 0
    for read in (True, False):
        with FMU(path) as fmu:
            fmu.initialize(parameters={"initial_state_scale": 1.0, "error_tolerance": tol})
            for j in range(STEPS):
                fmu.set_input(force(j))
                if ports:
                    fmu.set_real([fmu.vr["F_port_1"]], [2e-3 * np.cos(7.0 * j * H)])
                fmu.do_step(j * H, H)
                if read:
                    fmu.output_values(names)
            assert warned_at(fmu.warnings()) == pytest.approx((first + 1) * H, rel=1e-6)   # (%.9g)


@pytest.fixture(scope="module")
def parametric(tmp_path_factory):
    """The parametric exact FMU of fmu_scene("unforced") over c in [0.05, 0.2], d in [0, 5] (k = 6): its shadow keeps
    14 of the 32 planes, assembled in the core at the c and d it is given."""
    from conftest import fmu_maker
    from sphrom.rom import parametric as par
    make = fmu_maker(tmp_path_factory.mktemp("bound-cost-parametric"), probes=PROBES, default_case="unforced",
                     vary=[par.Range("c", 0.05, 0.2), par.Range("d", 0.0, 5.0)])
    return make("exact")[0]


@pytest.fixture(scope="module")
def builds(tmp_path_factory):
    """{flag: folder}: the FMU binary built with -DROM_NO_CLONES (rom_bound.c's two SSE2 lanes alone, what a CPU
    without AVX2 runs) and with -DROM_NO_LANES (the plain-array path, what a compiler without GCC's vector extensions
    builds)."""
    from sphrom.fmu.make.build import configure_and_build
    from sphrom.paths import data_dir
    out = {}
    for flag in ("ROM_NO_CLONES", "ROM_NO_LANES"):
        out[flag] = tmp_path_factory.mktemp(flag)
        configure_and_build(data_dir("fmu_src"), out[flag], tests=False, options=(f"-DCMAKE_C_FLAGS=-D{flag}",),
                            targets=("sphrom_fmi2",))
    return out


def with_binary(path, build, folder):
    """The FMU at ``path`` unzipped into ``folder``, its binary the one of ``build`` (None: its own)."""
    with zipfile.ZipFile(path) as z:
        z.extractall(folder)
    if build:
        shutil.copy(build / "fmi2" / "sphrom.so", folder / "binaries" / "linux64" / "sphrom.so")
    return folder


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="builds the Linux FMU binary")
def test_check_warns_where_the_bound_outputs_first_exceed(make, parametric, undamped, builds, tmp_path):
    """The error check against the bound outputs (rom_v_probe_error_bound: the rows one at a time, the scalar path):
    on the forced FMU with 3 probes (one quad of rows) and with 5 (a second quad, three of its lanes past the probes),
    on a parametric one (no table: the scalar path), on the undamped one across its table's end (continued modes: the
    scalar path) and on the forced balanced one across its table's end (no continued mode: the lanes' tails), with the default
    build, -DROM_NO_CLONES and -DROM_NO_LANES, at tolerances between the run's bounds, equal to a bound output (not
    above it: no warning at its step) and just below one (the number before it: a warning there at the latest), the one
    warning names the first step whose velocity bound output exceeds the tolerance, and no warning comes where none
    does: the check's bounds are the outputs' to the bit."""
    past = int(round(20 * undamped(2)[1].T / H)) + 40               # 40 steps past the table's end
    # the forced balanced FMU past its table, where no mode is continued (the lanes sum the rows' tails' decays): its
    # first step jumps there (its bounds fall over the run: every check of the run past the table)
    jump = np.concatenate([[20 * fmu_scene("forced").T + 0.5], np.full(60, H)])
    with zipfile.ZipFile(make("balanced")) as z:
        assert b"SHCONT" not in z.read("resources/model.bin") and b"SHTAB" in z.read("resources/model.bin")
    cases = ((make(), {}, STEPS), (make(probes=(0.1, 0.3, 0.45, 0.6, 0.85)), {}, STEPS),
             (parametric, {"c": 0.13, "d": 2.5}, STEPS), (undamped(2)[0], {}, past),
             (make("balanced"), {}, jump))

    def plan(steps):
        """the step lengths [s] of a case (its number of steps of H, or the lengths)"""
        return np.full(steps, H) if np.isscalar(steps) else np.asarray(steps, float)

    def run(folder, parameters, steps, tol, read):
        with FMU(folder) as fmu:
            fmu.initialize(parameters={"initial_state_scale": 1.0, "error_tolerance": tol, **parameters})
            names = [n for n in fmu.outputs if re.fullmatch(r"v_probe_\d+_error_bound", n)]
            bounds = []
            t = 0.0
            for j, h in enumerate(plan(steps)):
                fmu.set_input(force(j))
                fmu.do_step(t, h)
                t += h
                if read:
                    bounds.append(fmu.output_values(names).max())
            return np.array(bounds), fmu.warnings()

    for i, (path, parameters, steps) in enumerate(cases):
        bounds, warned = run(with_binary(path, None, tmp_path / f"read-{i}"), parameters, steps, 0.0, True)
        assert warned == [] and np.all(np.isfinite(bounds))
        order = np.sort(bounds)
        # a bound itself (no warning at its step) and the number just below it (a warning there at the latest), the
        # largest bound (no warning), a tolerance between bounds
        tolerances = [float(x) for b in (order[len(order) // 2], order[-2], order[-1])
                      for x in (b, np.nextafter(b, 0.0))] + [float(order[len(order) // 4] * 1.000001)]
        for build in (None, *builds.values()):
            folder = with_binary(path, build, tmp_path / f"fmu-{i}-{build.name if build else 'default'}")
            for tol in tolerances:
                first = np.flatnonzero(bounds > tol)
                _, warned = run(folder, parameters, steps, tol, False)
                if first.size == 0:
                    assert warned == [], (path.name, build, tol)
                else:
                    at = np.cumsum(plan(steps))[first[0]]
                    assert warned_at(warned) == pytest.approx(at, rel=1e-6), (path.name, build, tol)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="builds the Linux FMU binary")
def test_lanes_clones_and_plain_arrays_give_the_same_bits(make, parametric, undamped, builds, tmp_path):
    """The FMU binary built with -DROM_NO_CLONES (rom_bound.c's two SSE2 lanes alone, what a CPU without AVX2 runs,
    where the default build steps a one-input shadow's planes in four AVX2 lanes on a CPU that has AVX2) and with
    -DROM_NO_LANES (the plain-array path, what a compiler without GCC's vector extensions builds) give every output
    and every bound of the default build to 0 ulps over a run with a restore, a held input and one with input derivatives (the slope's
    columns), on the forced FMU, on a parametric one at c, d away from its scene's, and on the undamped exact FMU
    past its free response table (the continued modes' product and sums in lanes) (the same IEEE operations in the
    same order, no fused multiply-add)."""
    past = int(round(20 * undamped(2)[1].T / H)) + 40               # 40 steps past the table's end
    for path, parameters, steps in ((make(), {}, STEPS), (parametric, {"c": 0.13, "d": 2.5}, STEPS),
                                    (undamped(2)[0], {}, past + 40)):
        runs = []
        for build in (None, *builds.values()):
            folder = with_binary(path, build, tmp_path / f"fmu-{path.stem}-{build.name if build else 'default'}")
            with FMU(folder) as fmu:
                fmu.initialize(parameters={"initial_state_scale": 1.0, **parameters})
                assert fmu.can_interpolate_inputs
                rows = []
                for j in range(steps):
                    if j == steps - 40:
                        state = fmu.get_state()
                    fmu.set_input(force(j))
                    fmu.set_input_derivative(3e-2 * np.cos(3.0 * j * H) if j % 50 < 25 else 0.0)
                    fmu.do_step(j * H, H)
                    rows.append(fmu.output_values(fmu.outputs))
                fmu.set_state(state)
                rows.append(fmu.output_values(fmu.outputs))
                fmu.free_state(state)
            runs.append(np.array(rows))
        assert np.all(np.isfinite(runs[0]))
        for other in runs[1:]:
            np.testing.assert_array_equal(other, runs[0])


@pytest.fixture(scope="module")
def undamped(tmp_path_factory):
    """undamped(fmi) -> (path, scene): the exact FMU of multimode shrunk (N = 32, T = 0.25 s: the free response table
    spans 20 T = 5 s, 500 steps of H; undamped, so its modes that matter are continued past it), packaged once."""
    from conftest import small_scene
    from sphrom.fmu.make.package import package_fmu
    scene, folder, made = small_scene("multimode", T=0.25, n=32), tmp_path_factory.mktemp("bound-undamped"), {}

    def build(fmi=2):
        if fmi not in made:
            made[fmi] = folder / f"mm-exact-{fmi}.fmu"
            package_fmu(scene, made[fmi], k=6, fmi=fmi, probes=PROBES, progress=False, model="exact", bounds=False)
        return made[fmi], scene

    return build


def step_plan(seed, span, lengths=(H, 1.3 * H, 0.7 * H)):
    """Step lengths [s] over ``span`` [s]: runs of 1 to 150 steps of one length, drawn from ``lengths`` (the FMU
    carries the continued modes' exponentials within a run and anchors them where the length changes)."""
    rng = np.random.default_rng(seed)
    plan, t = [], 0.0
    while t < span:
        h = float(lengths[rng.integers(len(lengths))])
        for _ in range(int(rng.integers(1, 151))):
            plan.append(h)
            t += h
    return plan


def drive(fmu, plan, t=0.0):
    """Step ``fmu`` over the steps ``plan`` from time ``t`` (a held tone f = 3e-3 sin(1.7 t)); the outputs after each
    step (every bound too) and the time at the end."""
    rows = []
    for h in plan:
        fmu.set_input(3e-3 * np.sin(1.7 * t))
        fmu.do_step(t, h)
        t += h
        rows.append(fmu.output_values(fmu.outputs))
    return np.array(rows), t


@pytest.mark.parametrize("fmi", [2, 3])
def test_continuation_restored_past_the_table_continues_bit_for_bit(undamped, fmi):
    """Past the free response table the continued modes' exponentials are carried in the FMU's state over the steps
    (e^{mu h} per step, anchored exactly every CONT_ANCHOR steps and where the step length changes): a state saved
    past the table's end, restored in the same instance and (serialized) in a fresh one, continues with the same
    bits as the uninterrupted run, over steps of changing lengths that cross an anchor; and a reset instance repeats
    the run from the start bit for bit (the continuation forgotten)."""
    from sphrom.rom.bounds import CONT_ANCHOR
    path, scene = undamped(fmi)
    t_end = 20 * scene.T
    before = [H] * (int(round(t_end / H)) + 30)               # 30 steps past the table's end: carried, not anchored
    after = [H] * (CONT_ANCHOR + 20) + [1.3 * H] * 25 + [H] * 15 + [0.7 * H] * 10
    with FMU(path) as fmu:
        fmu.initialize(parameters={"initial_state_scale": 1.0})
        first, t = drive(fmu, before)
        assert t > t_end
        state = fmu.get_state()
        blob = fmu.serialize(state)
        straight, _ = drive(fmu, after, t)
        fmu.set_state(state)
        again, _ = drive(fmu, after, t)
        np.testing.assert_array_equal(again, straight)
        fmu.free_state(state)
        fmu.reset()
        fmu.initialize(parameters={"initial_state_scale": 1.0})
        np.testing.assert_array_equal(drive(fmu, before)[0], first)
    with FMU(path) as other:
        other.initialize(parameters={"initial_state_scale": 1.0})
        drive(other, [0.9 * H] * 20)                         # (another history: the restore replaces it)
        state = other.deserialize(blob)
        other.set_state(state)
        restored, _ = drive(other, after, t)
        other.free_state(state)
    np.testing.assert_array_equal(restored, straight)
    assert np.all(np.isfinite(straight))


def test_continued_bounds_hold_over_long_runs_of_varying_steps(undamped):
    """The bounds against the truth (the full linear SPH, each step's exact map) over 3 x the table's span with steps
    of three lengths in runs of 1 to 150 (the continued modes' exponentials carried over each run, anchored where the
    length changes and every CONT_ANCHOR steps, with the recurrence's round-off allowance): every velocity and
    density bound >= the true error at every point, and past the table the velocity bound stays within 2 x its
    largest over the table's last 2 T."""
    from sphrom.rom.lti import full_linear_system, probe_matrix
    from sphrom.rom.truth import step_map
    from sphrom.sph.solver import build_problem
    path, scene = undamped(2)
    t_end = 20 * scene.T
    plan = step_plan(7, 3 * t_end)
    problem = build_problem(scene)
    lti = full_linear_system(problem, PROBES)
    n = problem.rho0.size
    maps = {h: step_map(lti.A, lti.B[:, 0], h) for h in set(plan)}   # the exact map of a held input over h
    z, t, X, times = np.zeros(2 * n + 2), 0.0, [], []
    z[:2 * n] = lti.x0
    for h in plan:
        apply, scale = maps[h]
        z[2 * n], z[2 * n + 1] = scale * 3e-3 * np.sin(1.7 * t), 0.0
        z = apply(z)
        t += h
        X.append(z[:2 * n].copy())
        times.append(t)
    X, times = np.array(X), np.array(times)
    interp = probe_matrix(problem.x, problem.scene.L, PROBES, np.ones(n))
    v_true = (X[:, :n] / np.sqrt(problem.rho0)) @ interp.T
    rho_true = (problem.rho0 / (1.0 + X[:, n:] / np.sqrt(problem.c))) @ interp.T
    with FMU(path) as fmu:
        fmu.initialize(parameters={"initial_state_scale": 1.0})
        out, _ = drive(fmu, plan)
        names = fmu.outputs
    ev = np.abs(out[:, members(names, "v_probe_j")] - v_true)
    er = np.abs(out[:, members(names, "rho_probe_j")] - rho_true)
    vb, rb = out[:, members(names, "v_probe_j_error_bound")], out[:, members(names, "rho_probe_j_error_bound")]
    assert np.all(vb >= ev), np.max(ev - vb)
    assert np.all(rb >= er), np.max(er - rb)
    late = times > t_end
    assert late.sum() > len(plan) // 2
    before = (times > t_end - 2 * scene.T) & ~late
    assert vb[late].max() <= 2.0 * vb[before].max(), (vb[late].max(), vb[before].max())


def test_warning_past_the_table_says_what_the_bound_is(undamped, tmp_path):
    """On an undamped bar the complement's free response from the initial state is tabulated over the table's span
    and its modes that matter are continued exactly past it (section SHCONT): an accurate model run from the initial
    state four times as long as the table does not warn at the default tolerance (it warned just past the table's
    end while its size alone bounded it).  Without SHCONT (every mode bounded by its size past the table, as before)
    the warning there names that share of the bound, the table's end and the modes continued (0), so that a warning
    on an accurate model reads as what it is."""
    from sphrom.fmu.resources import pack, unpack
    path, scene = undamped(2)

    def run(fmu_path, steps):
        with FMU(fmu_path) as fmu:
            fmu.initialize(parameters={"initial_state_scale": 1.0})
            j = 0
            while not fmu.warnings() and j < steps:    # the table spans 20 T = 5 s: 500 steps
                fmu.do_step(j * H, H)
                j += 1
            return fmu.warnings()

    assert run(path, 2000) == []
    # the same FMU without its continued modes, their sizes |Q_rM| in the rows' tails at the slowest rate (as before:
    # every mode bounded by its size past the table; model.bin repacked, the token in modelDescription.xml with it)
    with zipfile.ZipFile(path) as z:
        files = {name: z.read(name) for name in z.namelist()}
    data = unpack(files["resources/model.bin"])
    old = data.token
    cont = data.sections.pop("SHCONT")
    rates = data.sections["SHRATE"][0]
    row = data.sections["SHROW"].copy()
    row[:, row.shape[1] - rates.size + int(np.argmin(rates))] += np.hypot(cont[1:, 0::2], cont[1:, 1::2]).sum(axis=1)
    data.sections["SHROW"] = row
    files["resources/model.bin"] = pack(data)
    files["modelDescription.xml"] = files["modelDescription.xml"].replace(old.encode(), data.token.encode())
    bare = tmp_path / "mm-exact-bare.fmu"
    with zipfile.ZipFile(bare, "w", zipfile.ZIP_DEFLATED) as z:
        for name, blob in files.items():
            z.writestr(name, blob)
    (text,) = run(bare, 2000)
    end = float(re.search(r"past the end of its table \(t > ([-+0-9.eE]+) s\): 0 modes continued", text).group(1))
    assert end == pytest.approx(20 * scene.T, rel=1e-6)
    assert warned_at([text]) > end
    share, bound = (float(re.search(p, text).group(1)) for p in (r", ([-+0-9.eE]+) m s\^-1 of it",
                                                                  r"error bound ([-+0-9.eE]+) m s\^-1"))
    assert 0.5 * bound <= share <= bound


def test_round_off_complement_is_not_continued_past_the_table(monkeypatch):
    """Past the free response table each continued mode costs the FMU a complex product and its rows' sums per step
    (cont_step): a complement whose free response from the initial state is round-off (an undamped bar's lowest sine
    for v0, its shadow of 12 planes: what the planes left out carry of x0 is the decomposition's round-off) is bounded
    by its size there instead, within CONT_SHARE of the round-off allowance ROUNDOFF |c_r| |x0| the bound carries at
    every time (bounds.continued_modes).  Against the shadow that continues every mode the table's own error asks
    for: fewer modes continued, the same bound within the table, past it a bound larger by at most that share; and
    the velocity rows' bound holds against the truth (the full linear SPH exact in time, sphrom.rom.truth) over 1.5 x
    the table's span from the initial state."""
    import sphrom.rom.bounds as bounds
    from conftest import small_scene
    from sphrom.rom.truth import exact_probe_outputs
    from sphrom.sph.solver import build_problem
    problem = build_problem(small_scene("high_frequency", T=0.5, n=64, v0="1e-3*sin(2*pi*x/L)"))
    lean = bounds.build_shadow(problem, PROBES, order=12)
    rule = bounds.continued_modes
    monkeypatch.setattr(bounds, "continued_modes", lambda modes, decayed, budget, values, fixed, floor=None:
                        rule(modes, decayed, budget, values, fixed))      # the room of the table's own error alone
    full = bounds.build_shadow(problem, PROBES, order=12)
    assert 0 < full.comp.t_end == lean.comp.t_end
    assert lean.comp.cont_mu.size < full.comp.cont_mu.size
    steps = int(round(1.5 * lean.comp.t_end / H))
    t = np.arange(steps + 1) * H
    zero = np.zeros((steps, 1))
    y, cert = bounds.run_shadow(lean, np.full(steps, H), zero, zero, scale=1.0)
    y_full, cert_full = bounds.run_shadow(full, np.full(steps, H), zero, zero, scale=1.0)
    late = t > lean.comp.t_end
    assert late.sum() > 0.3 * steps
    np.testing.assert_allclose(cert[~late], cert_full[~late], rtol=1e-14, atol=0)
    share = bounds.CONT_SHARE * bounds.ROUNDOFF * lean.row_norm * lean.x0_norm * (1 + 1e-9)
    assert np.all(cert[late] - cert_full[late] <= share[None, :]), np.max(cert[late] - cert_full[late] - share)
    v_true, _ = exact_probe_outputs(problem, PROBES, t, np.zeros((t.size, 1)), [1.0])
    P = len(PROBES)
    err = np.abs(y[:, :P] - v_true[:, :, 0])
    assert np.all(err <= cert[:, :P]), np.max(err - cert[:, :P])
