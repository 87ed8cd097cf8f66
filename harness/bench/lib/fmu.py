"""Benchmarks of the FMU (``sphrom bench fmu``, the FMU rows and section of ``sphrom bench``).

1. The C core alone (``libsphrom_core`` through ctypes, no FMI, no Python in
   the loop): ns per internal step at k = 12, n_freeze = 10 for several
   particle counts N.  The step costs O(k^2) plus the refresh's
   O(k^3 (k+1)/2) every n_freeze steps; N appears nowhere, which the rows show.
2. End to end through the FMU driver (:class:`sphrom.fmu.run.driver.FMU`, fmpy's FMI bindings): one
   co-simulation of the scene's FMU over its horizon with 10 ms and 1 ms communication steps (extraction,
   loading, instantiation, the loop reading every output, freeing), beside the full SPH of the same scene timed
   in the same run (:func:`sphrom.sph.solver.run_sph`), as ratios.
3. Where the time goes, every per-step figure a slope between two step counts measured in pairs (so the
   fixed cost cancels; nothing timed apart is subtracted): per doStep through the driver (runs over T/2 and T),
   the fixed cost (the intercept of those two runs: extraction, loading, instantiation, freeing), the core's
   own time for the same internal steps (its slope), and a doStep call alone (doSteps of one internal step
   with no input and no output: 10^4 against 2 10^4 calls, the step's own work included).

4. The lean path (the FMU rows of ``sphrom bench``): the driver's loop on a pre-extracted FMU instantiated
   once (timed separately), fmi2Reset and initialization per run, then per communication step the input (when
   the scene has a force), fmi2DoStep and reading every output, through fmpy's ctypes bindings with
   preallocated arrays.  Not included: extraction, loading the shared library, instantiation (reported
   beside).  Against the full SPH (numba, the same run_sph call the rest of the tool uses, compiled before
   the clock starts).
5. The same-language ratio: the C frozen step (k = 12, n_freeze = 10) against
   the C full SPH step of fmu_src/sph.c at N = 400.

``bench_rows`` gives the FMU rows of ``sphrom bench``, :func:`fmu_measurements`
its FMU section (the Markdown is :mod:`.fmu_sections`).
Every figure is the median of ``repeats`` runs.
"""

from __future__ import annotations

import atexit
import hashlib
import math
import shutil
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from ... import defaults
from ...compare import error_table
from ...fmu.kinds import pack
from ...fmu.make.build import ensure_binaries
from ...fmu.make.models import RESOURCES, reduced_model
from ...fmu.make.package import package_fmu
from ...fmu.resources import probe_pairs
from ...fmu.run.core import Core
from ...fmu.run.driver import FMU
from ...norms import relative_l2
from ...progress import progress_bar
from ...references.exact import exact_solution, is_available
from ...rom.registry import fmu_model_names, get_model
from ...scene import derive_scene, load_scene
from ...sph.solver import build_problem, force_values, run_sph, step_count
from .methods import bench_row
from .tables import write_csv

BENCH_K = 12
BENCH_FREEZE = defaults.N_FREEZE


def _median(values):
    return float(statistics.median(values))


def bench_scene(base, n):
    """A scene like ``base`` with N = n particles for the core benchmark.

    The horizon is cut to the snapshot window's end (the POD needs no more) and
    the full SPH uses symplectic Euler, which stays stable at every N (explicit
    Euler amplifies the fastest SPH mode without bound at large N); neither
    changes the cost of a reduced step, which depends on k only.
    """
    scene = load_scene(base)
    window = scene.snapshots.get("window")
    T = float(window[1]) if window else scene.T
    every = max(1, min(scene.sph.every, int(round(T / scene.sph.dt / 10))))
    return derive_scene(scene, {"domain": {"T": T}, "sph": {"n_particles": int(n), "integrator": "symplectic",
                                                               "every": every}})


def core_rows(base, sizes, k=BENCH_K, n_freeze=BENCH_FREEZE, n_steps=200_000, repeats=5, core=None, progress=False,
              bar=None):
    """ns per internal step of the C core for each N in ``sizes`` (list of dicts).

    Each repeat times n_steps and 2 n_steps internal steps from the same start; the cost per step is the slope
    (t(2M) - t(M)) / M, so that the call's fixed cost cancels: ``ns_per_step`` the median of the repeats' wall
    slopes (min and max beside), ``ns_per_step_cpu`` the median of the same runs' thread CPU-time slopes (the
    time the core itself ran, whatever else the machine ran meanwhile)."""
    core = core or Core(ensure_binaries().core)
    rows = []
    for n in sizes:
        scene = bench_scene(base, n)
        data, ops, problem, basis = reduced_model(scene, k, n_freeze, [0.5], "euler", progress=progress)
        model = core.load(pack(data))
        model.set_n_freeze(n_freeze)
        model.advance(1000)                      # warm up
        wall, cpu = step_slopes(model, n_steps, repeats, n_freeze)
        refresh = model.refresh
        model.close()
        rows.append({"n": int(n), "k": k, "k_v": data.k_v, "k_rho": data.k_rho, "n_freeze": n_freeze,
                     "steps": n_steps, "ns_per_step": _median(wall), "ns_min": min(wall), "ns_max": max(wall),
                     "ns_per_step_cpu": _median(cpu), "refresh": refresh["path"]})
        if bar is not None:
            bar.update(1)
    return rows


def step_slopes(model, n_steps, repeats, n_freeze):
    """ns per internal step of a loaded core model (:class:`sphrom.fmu.run.core.CoreModel`) from ``repeats``
    pairs of runs of n_steps and 2 n_steps from a reset: (wall slopes, thread CPU-time slopes), lists."""
    wall, cpu = [], []
    for _ in range(repeats):
        pair = []
        for count in (n_steps, 2 * n_steps):
            model.reset()
            model.set_n_freeze(n_freeze)
            w0, c0 = time.perf_counter(), time.thread_time()
            model.advance(count)
            pair.append((time.perf_counter() - w0, time.thread_time() - c0))
        wall.append((pair[1][0] - pair[0][0]) / n_steps * 1e9)
        cpu.append((pair[1][1] - pair[0][1]) / n_steps * 1e9)
    return wall, cpu


def _simulate(path, stop_time, step, keep=None):
    """Wall time [s] of one co-simulation through the FMU driver, end to end: extract, load, instantiate,
    initialize from the scene's initial state (initial_state_scale = 1, the training run's; the FMU's own start
    is rest), the loop to ``stop_time`` reading every output at each step, free.  (times, outputs, names) go into
    ``keep`` (a list) when given."""
    n = int(math.ceil(stop_time / step - 1e-9))
    times = np.minimum(np.arange(n + 1) * step, stop_time)
    t0 = time.perf_counter()
    with FMU(path, name="bench") as fmu:
        fmu.initialize(initial_state_scale=1.0)
        values = fmu.simulate(times)
        names = fmu.outputs
    wall = time.perf_counter() - t0
    if keep is not None:
        keep.append((times, values, names))
    return wall


def _bare_calls(unzipdir, md, n_calls, h):
    """Wall time [s] of n_calls doSteps of length h on an extracted FMU through the driver's loop with no input
    and no output: the cost of a doStep call through fmpy's ctypes binding, of the loop itself and of the
    step's own work; :func:`end_to_end` takes the slope between n_calls and 2 n_calls."""
    with FMU(unzipdir, name="bench") as fmu:
        fmu.initialize(initial_state_scale=1.0)        # the scene's initial state, as every bench run
        times = np.arange(n_calls + 1) * h
        t0 = time.perf_counter()
        fmu.simulate(times, outputs=[])
        return time.perf_counter() - t0


def sph_at_probes(scene, problem, probes, step):
    """The full SPH sampled every ``step`` [s] and interpolated linearly at the probes (as the FMU interpolates
    its reduced field): (t, v (M, P)), and the relative L² error of that v against the exact solution at the
    probes when the scene has one (else None)."""
    n = step_count(scene.T, scene.sph.dt)
    m = int(round(step / scene.sph.dt))
    sph = run_sph(scene, sample_steps=np.arange(0, n + 1, m), progress=False, problem=problem)
    i0, i1, w = probe_pairs(problem.x, scene.L, probes)
    v = sph.v[:, i0] * (1.0 - w) + sph.v[:, i1] * w
    error = None
    if is_available(scene):
        v_ex, _ = exact_solution(scene, np.asarray(probes, float) * scene.L, sph.t)
        error = relative_l2(v, v_ex, sph.t)
    return sph.t, v, error


def probe_error(result, t, v_sph, scene):
    """Relative L² error over the run of an FMU's probe velocities (``result``: (times, outputs, names) of
    :func:`_simulate`) against the full SPH at the probes (:func:`sph_at_probes`) at the same communication
    points."""
    times, values, names = result
    v_fmu = values[:, [names.index(f"v_probe_{j + 1}") for j in range(v_sph.shape[1])]]
    rows = np.searchsorted(times, t - 1e-12 * max(1.0, scene.T))
    if np.any(np.abs(times[np.minimum(rows, times.size - 1)] - t) > 1e-9 * max(1.0, scene.T)):
        raise ValueError("the FMU's communication points are not the SPH samples")
    return relative_l2(v_fmu[rows], v_sph, t)


def end_to_end(scene_name="tenmode", steps=(0.01, 0.001), repeats=5, k=None, progress=False, bar=None, workdir=None,
               models=None):
    """End-to-end FMU time (the FMU driver, :func:`_simulate`) beside the full SPH of the same scene.

    For each model (default every model that can be packaged as an FMU: the frozen FMU, the product's
    default, and the exact linear one) and each communication step: the median wall time of
    co-simulation over the scene's horizon, the ratio to the full SPH (numba,
    :func:`sphrom.sph.solver.run_sph`) timed in the same run, and, at the first step, the
    probe-velocity error against the full SPH (:func:`probe_error`).  For a time-stepped model (the
    frozen one) also where the time goes (fixed cost, the core's internal steps, per doStep); a linear
    model has no internal steps.

    Returns a dict with ``rows`` (one per model and communication step), ``sph`` (full SPH medians,
    its probe error against the exact solution) and ``scene`` facts.
    """
    import fmpy
    from fmpy import extract, read_model_description


    scene = load_scene(scene_name)
    problem = build_problem(scene)
    n_internal = step_count(scene.T, scene.sph.dt)
    binaries = ensure_binaries()
    rows, summaries, sph_probes = [], {}, None
    models = benched_fmu_models() if models is None else models
    with tempfile.TemporaryDirectory(dir=workdir) as tmp:
        for model in models:
            spec = get_model(model)
            path = Path(tmp) / f"{scene.name}-{model}.fmu"
            summary = package_fmu(scene, path, k=k, fmi=2, progress=progress, binaries=binaries, problem=problem,
                                  model=model, bounds=False)
            summaries[model] = summary
            core_time = bare_us = float("nan")
            if not spec.linear:
                md = read_model_description(str(path))
                unzipdir = extract(str(path), unzipdir=str(Path(tmp) / f"unzipped-{model}"))
                # the core alone, same model (the FMU's resources): the slope between half and all of the
                # scene's internal steps, times the internal steps
                *_, blob = RESOURCES[spec.fmu_kind](scene, model, summary.k, summary.n_freeze, summary.probes,
                                                    summary.integrator, False, problem, bounds=False)
                core_model = Core(binaries.core).load(blob)
                half = n_internal // 2
                wall, _ = step_slopes(core_model, half, repeats, summary.n_freeze)
                core_model.close()
                core_time = _median(wall) * 1e-9 * n_internal
                # the bare call: doSteps of one internal step each, no input, no output; slope per doStep
                n_calls = 10_000
                pairs = [(_bare_calls(unzipdir, md, n_calls, scene.sph.dt),
                          _bare_calls(unzipdir, md, 2 * n_calls, scene.sph.dt)) for _ in range(repeats)]
                bare_us = _median([(b - a) / n_calls * 1e6 for a, b in pairs])
            for j, h in enumerate(steps):
                kept = []
                _simulate(path, scene.T, h, keep=kept)                # warm (page cache, imports); kept for errors
                n_comm = int(round(scene.T / h))
                half_T = (n_comm // 2) * h
                pairs = [(_simulate(path, half_T, h), _simulate(path, scene.T, h)) for _ in range(repeats)]
                e2e = [b for _, b in pairs]
                slopes = [(b - a) / (n_comm - n_comm // 2) for a, b in pairs]        # [s] per doStep
                per_step = _median(slopes)
                e2e_m = _median(e2e)
                err = None
                if j == 0:
                    if sph_probes is None:                          # one SPH run serves every model
                        sph_probes = sph_at_probes(scene, problem, summary.probes, h)
                    err = probe_error(kept[0], sph_probes[0], sph_probes[1], scene)
                rows.append({"model": model, "step_s": h, "doSteps": n_comm, "internal_steps": n_internal,
                             "fmu_e2e_s": e2e_m, "fmu_e2e_min_s": min(e2e),
                             "fixed_s": _median([b - n_comm * d for (_, b), d in zip(pairs, slopes)]),
                             "core_s": core_time, "us_per_doStep_fmpy": per_step * 1e6,
                             "us_per_doStep_core": (core_time / n_comm * 1e6) if not spec.linear else float("nan"),
                             "us_per_doStep_bare_call": bare_us, "probe_error_v_vs_sph": err,
                             "k_v": summary.k_v, "k_rho": summary.k_rho})
                if bar is not None:
                    bar.update(1)
    sph_loop, sph_call = [], []
    run_sph(scene, progress=False, problem=problem, sample_steps=[0, n_internal])      # compile/warm
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = run_sph(scene, progress=progress, problem=problem)
        sph_call.append(time.perf_counter() - t0)
        sph_loop.append(result.wall_time)
        if bar is not None:
            bar.update(1)
    sph = {"loop_s": _median(sph_loop), "call_s": _median(sph_call),
           "probe_error_v_vs_exact": None if sph_probes is None else sph_probes[2]}
    for row in rows:
        row["sph_s"] = sph["call_s"]
        row["speedup"] = sph["call_s"] / row["fmu_e2e_s"]
        row["speedup_vs_loop"] = sph["loop_s"] / row["fmu_e2e_s"]
    # the scene facts of the first time-stepped model (its n_freeze applies), else of the first model
    first = next((s for m, s in summaries.items() if get_model(m).uses_n_freeze), next(iter(summaries.values())))
    return {"rows": rows, "sph": sph, "scene": scene.name, "n": scene.sph.n_particles, "T": scene.T,
            "dt": scene.sph.dt, "internal_steps": n_internal, "k_v": first.k_v, "k_rho": first.k_rho,
            "n_freeze": first.n_freeze, "fmpy": fmpy.__version__, "repeats": repeats,
            "probes": list(first.probes)}


# ---------------------------------------------------------------------------
# FMUs built once per process (bench_rows, the lean loop, stress runners)
# ---------------------------------------------------------------------------

_PREPARED = {}
_WORKDIR = []


def _workdir():
    if not _WORKDIR:
        folder = Path(tempfile.mkdtemp(prefix="sphrom-fmu-bench-"))
        atexit.register(shutil.rmtree, folder, True)
        _WORKDIR.append(folder)
    return _WORKDIR[0]


def benched_fmu_models():
    """The FMU models these benchmarks time, per POD mode count k: those on a POD basis (frozen, exact).  The
    balanced model has no POD basis (its order is not k) and its own measurement,
    ``python -m sphrom.bench.balanced_measure``."""
    return tuple(m for m in fmu_model_names() if get_model(m).needs_basis)


def prepared_fmu(scene, k, model="frozen", n_freeze=defaults.N_FREEZE, problem=None, probes=defaults.PROBES):
    """(path, unzipdir, model description, summary) of the FMI 2 FMU of ``scene``: packaged and extracted
    once per process for each (scene text, k, model, n_freeze, probes)."""
    from fmpy import extract, read_model_description

    key = (hashlib.sha256(scene.text.encode()).hexdigest() if getattr(scene, "text", None) else scene.name,
           int(k), model, int(n_freeze), tuple(probes))
    if key not in _PREPARED:
        folder = _workdir() / f"{scene.name}-{model}-k{k}-nf{n_freeze}-{len(_PREPARED)}"
        folder.mkdir()
        path = folder / "model.fmu"
        summary = package_fmu(scene, path, k=k, n_freeze=n_freeze, probes=probes, fmi=2, progress=False,
                              binaries=ensure_binaries(), problem=problem, model=model, bounds=False)
        unzipdir = extract(str(path), unzipdir=str(folder / "unzipped"))
        _PREPARED[key] = (path, unzipdir, read_model_description(str(path)), summary)
    return _PREPARED[key]


def start(fmu, n_freeze=None, dt=None, initial_state_scale=1.0):
    """fmi2Reset and initialization of an instantiated FMU (:class:`sphrom.fmu.run.driver.FMU`):
    initial_state_scale 1 (the scene's initial state, as the training run and the Python models have it), and
    the internal step ``dt`` and ``n_freeze`` where given."""
    fmu.reset()
    fmu.initialize(initial_state_scale=initial_state_scale, dt=dt, n_freeze=n_freeze)


def lean_loop(fmu, h, n_steps, f=None):
    """n_steps communication steps of h through the driver: the input f[i] held (when given), doStep, every
    output read."""
    times = np.arange(n_steps + 1) * h
    inputs = {} if f is None else {"f": np.append(np.asarray(f[:n_steps], float), 0.0)}
    return fmu.simulate(times, inputs, steps=np.full(n_steps, h))


def _fmu_states(unzipdir, md, summary, ops, steps, dt, force, n_freeze, h):
    """The FMU's fields at the error steps, from one untimed run on the timed configuration: communication
    points on the grid of h plus the error-step times, input held over each step at its start value."""
    t_samples = np.asarray(steps) * dt
    grid = np.arange(int(round(t_samples[-1] / h)) + 1) * h
    points = np.unique(np.concatenate([grid[grid < t_samples[-1]], t_samples]))
    wanted = set(np.searchsorted(points, t_samples).tolist())
    k = summary.k_v + summary.k_rho
    zs = []

    def keep_state(j, t):
        if j in wanted:
            zs.append(fmu.reduced_state(k))
    with FMU(unzipdir, name="lean") as fmu:
        start(fmu, n_freeze=n_freeze)
        keep_state(0, points[0])
        inputs = {} if force is None else {"f": np.array([float(force(p)) for p in points])}
        fmu.simulate(points, inputs, outputs=[], on_step=keep_state)
    return ops.fields(np.array(zs))           # the operators' own reconstruction


def bench_rows(context):
    """The FMU rows of ``sphrom bench`` (sphrom.bench.lib.methods.bench_python's ``extra``).

    For each k of the study and each model that can be packaged as an FMU: the FMU through the FMU driver's
    loop at a 10 ms communication step (n_freeze 10 and 1 for the frozen model, the one refreshed every
    n_freeze steps), and for that model the C core loop alone (rom_advance through ctypes, no fmpy); once
    the C full SPH (fmu_src/sph.c).  Errors against the full SPH (context v_sph/rho_sph at the
    context steps) and the reference; times are medians of context["repeats"].
    """
    scene, run = context["scene"], context["run"]
    problem = run.problem
    T = scene.T
    forced = bool(problem.terms["force_profile"]) and bool(np.any(scene.force(np.linspace(0, T, 1025)) != 0))
    h = min(defaults.STEP, T / 10)
    n_comm = int(round(T / h))
    steps = np.asarray(context["steps"])
    t = steps * scene.sph.dt
    v_sph, rho_sph, ref = context["v_sph"], context["rho_sph"], context["reference"]

    def errors(v, rho):
        e_s = error_table(v, rho, v_sph, rho_sph, t, problem.rho0)
        e_r = None if ref is None else error_table(v, rho, ref[0], ref[1], t, problem.rho0)
        return e_s, e_r

    bench = dict(scene=scene, problem=problem, steps=steps, repeats=max(1, int(context.get("repeats", 3))),
                 n=step_count(T, scene.sph.dt), h=h, n_comm=n_comm, force=scene.force if forced else None,
                 f_comm=np.asarray(scene.force(np.arange(n_comm) * h), float) if forced else None, errors=errors,
                 core=Core(ensure_binaries().core))
    rows = []
    for k in context["ks"]:
        for model in benched_fmu_models():
            rows += _fmu_rows(k, model, **bench)
    if scene.sph.integrator in ("euler", "symplectic"):
        rows.append(_c_sph_row(forced=forced, **bench))
    return rows


def _fmu_rows(k, model, *, scene, problem, steps, repeats, n, h, n_comm, force, f_comm, errors, core):
    """bench_rows for one k and model: the FMU through the driver (n_freeze 10 and 1 where it has one), and the C
    core alone for a time-stepped model."""
    spec = get_model(model)
    # the time-stepped FMU is "FMU (fmpy)", the product's default; the others are named
    method = "FMU (fmpy)" if spec.uses_n_freeze else f"FMU {model} (fmpy)"
    try:
        path, unzipdir, md, summary = prepared_fmu(scene, k, model, problem=problem)
    except Exception as exc:                    # e.g. no energy basis: say so, keep the others
        return [bench_row(scene, f"FMU {model} (fmpy)", k, None, float("nan"), 0.0, None, None, f"not built: {exc}")]
    # the FMU's numbers and operators (the resources of its model_kind), as packaged, at n_freeze 10
    _, ops, blob = RESOURCES[spec.fmu_kind](scene, model, k, 10, summary.probes, summary.integrator,
                                           False, problem, bounds=False)
    rows = []
    for nf in ((10, 1) if spec.uses_n_freeze else (None,)):
        times = []
        with FMU(unzipdir, name="lean") as slave:
            for r in range(repeats + 1):
                start(slave, n_freeze=nf)
                t0 = time.perf_counter()
                lean_loop(slave, h, n_comm, f_comm)
                if r:
                    times.append(time.perf_counter() - t0)
        e_s, e_r = errors(*_fmu_states(unzipdir, md, summary, ops, steps, scene.sph.dt, force, nf, h))
        rows.append(bench_row(scene, method, k, nf, _median(times), summary.timings.get("model", 0.0), e_s, e_r,
                              f"FMU driver loop, {h * 1e3:g} ms comm. step ({n_comm} doSteps, input + doStep + "
                              f"all outputs), instantiate {slave.instantiate_s * 1e3:.1f} ms not included; "
                              f"errors from the FMU's serialized state (input held over each step)"))
    if spec.uses_n_freeze:                      # the C core's internal steps, refreshed every 10
        rows.append(bench_row(scene, "FMU core (C)", k, 10, _core_time(core, blob, repeats, n, h, n_comm, f_comm),
                              0.0, None, None,
                              (f"rom_advance over {n} internal steps in one ctypes call, no fmpy" if f_comm is None
                               else f"rom_set_input + rom_do_step per {h * 1e3:g} ms step through ctypes, no fmpy")
                              + "; same arithmetic as the FMU"))
    return rows


def _core_time(core, blob, repeats, n, h, n_comm, f_comm):
    """Median time [s] of the C core alone (n_freeze 10): n internal steps in one call, or the forced
    communication steps of h through rom_set_input and rom_do_step."""
    cm = core.load(blob)
    try:
        cm.set_n_freeze(10)
        times = []
        for r in range(repeats + 1):
            cm.reset()
            cm.set_n_freeze(10)
            t0 = time.perf_counter()
            if f_comm is None:
                cm.advance(n)
            else:
                for i in range(n_comm):
                    cm.set_input(float(f_comm[i]))
                    cm.do_step(i * h, h)
            if r:
                times.append(time.perf_counter() - t0)
    finally:
        cm.close()
    return _median(times)


def _c_sph_row(*, scene, problem, steps, repeats, n, errors, core, forced, **_):
    """The C full SPH (fmu_src/sph.c), same scene and integrator: the bench row with its errors."""
    dt = scene.sph.dt
    runner = core.sph.runner(problem, scene.sph.integrator)
    g = force_values(scene, problem, 0, n, dt, 0)[:, 0] if forced else None
    times = []
    for r in range(repeats + 1):
        v, rho = problem.v0.copy(), problem.rho0.copy()
        vs, rs = [v.copy()], [rho.copy()]
        wall = 0.0
        for a, b in zip(steps[:-1], steps[1:]):
            wall += runner.advance(v, rho, int(b - a), dt, g=None if g is None else g[a:b])
            if r == 0:
                vs.append(v.copy())
                rs.append(rho.copy())
        if r == 0:
            e_s, e_r = errors(np.array(vs), np.array(rs))
        else:
            times.append(wall)
    return bench_row(scene, "C full SPH", problem.n, None, _median(times), 0.0, e_s, e_r,
                     f"fmu_src/sph.c, {scene.sph.integrator}, N = {problem.n} (time in the C calls)")


def sph_step_rows(base="tenmode", n=400, k=BENCH_K, n_freeze=BENCH_FREEZE, n_steps=20_000, repeats=5, core=None):
    """The same-language ratio at N = n: ns per step of the C frozen core and of the C full SPH (sph.c)."""
    core = core or Core(ensure_binaries().core)
    frozen = core_rows(base, [n], k=k, n_freeze=n_freeze, n_steps=max(n_steps, 100_000), repeats=repeats,
                       core=core)[0]
    scene = bench_scene(base, n)
    problem = build_problem(scene)
    runner = core.sph.runner(problem, "euler")
    v, rho = problem.v0.copy(), problem.rho0.copy()
    runner.advance(v, rho, 100, scene.sph.dt)
    times = []
    for _ in range(repeats):
        v, rho = problem.v0.copy(), problem.rho0.copy()
        times.append(runner.advance(v, rho, n_steps, scene.sph.dt) / n_steps * 1e9)
    sph_ns = _median(times)
    return {"n": n, "k": k, "n_freeze": n_freeze, "frozen_ns": frozen["ns_per_step"], "sph_ns": sph_ns,
            "ratio": sph_ns / frozen["ns_per_step"], "k_v": frozen["k_v"], "k_rho": frozen["k_rho"]}


def fmu_measurements(scene_name="tenmode", repeats=5, sizes=(100, 400, 1600), steps=(0.01, 0.001),
                     progress=True, with_end_to_end=True, with_same=True):
    """The FMU section of ``sphrom bench`` (and ``sphrom bench fmu``): the C core against N, end to end through the
    FMU driver (``with_end_to_end``), and the same-language ratio at N = 400 (``with_same``).

    Returns a dict: ``core`` (:func:`core_rows`), ``e2e`` (:func:`end_to_end`, or None), ``same``
    (:func:`sph_step_rows`, or None), ``repeats``.
    """
    total = len(sizes) + (len(steps) * len(benched_fmu_models()) + repeats if with_end_to_end else 0) + 1
    with progress_bar(total=total, desc="FMU", enabled=progress) as bar:
        e2e = end_to_end(scene_name, steps=steps, repeats=repeats, bar=bar) if with_end_to_end else None
        core = core_rows(scene_name, list(sizes), repeats=repeats, bar=bar)
        same = sph_step_rows(scene_name, n=400, repeats=repeats) if with_same else None
        bar.update(1)
    return {"core": core, "e2e": e2e, "same": same, "repeats": repeats}


def write_fmu_csv(out, core, e2e, prefix="bench_fmu_"):
    """``out``/<prefix>core.csv and, with ``e2e``, <prefix>e2e.csv (written atomically); returns the paths."""
    paths = [out / f"{prefix}core.csv"]
    write_csv(paths[0], core)
    if e2e is not None:
        paths.append(out / f"{prefix}e2e.csv")
        write_csv(paths[1], e2e["rows"])
    return paths
