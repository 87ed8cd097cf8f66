"""Benchmarks of the FMU (``sphrom bench-fmu``).

1. The C core alone (``libsphrom_core`` through ctypes, no FMI, no Python in
   the loop): ns per internal step at k = 12, n_freeze = 10 for several
   particle counts N.  The step costs O(k^2) plus the refresh's
   O(k^3 (k+1)/2) every n_freeze steps; N appears nowhere, which the rows show.
2. End to end through fmpy: ``fmpy.simulate_fmu`` of the scene's FMU over its
   horizon with 10 ms and 1 ms communication steps (extraction, loading,
   instantiation, the loop, recording), beside the full SPH of the same scene
   timed in the same run (:func:`harness.sph.solver.run_sph`), as ratios.
3. Where the time goes: the fixed cost of simulate_fmu (a one-step run:
   extraction, loading, instantiation, freeing), the core's own time for the
   same internal steps, the rest per doStep (fmpy's loop: input, doStep,
   recording), and of that the bare ``fmi2DoStep`` call through fmpy/ctypes
   (doSteps of one internal step on FMU2Slave, minus the core's time).

Every figure is the median of ``repeats`` runs.
"""

from __future__ import annotations

import statistics
import tempfile
import time
from pathlib import Path

BENCH_K = 12
BENCH_FREEZE = 10


def _median(values):
    return float(statistics.median(values))


def bench_scene(base, n):
    """A scene like ``base`` with N = n particles for the core benchmark.

    The horizon is cut to the snapshot window's end (the POD needs no more) and
    the full SPH uses symplectic Euler, which stays stable at every N (explicit
    Euler amplifies the fastest SPH mode without bound at large N); neither
    changes the cost of a reduced step, which depends on k only.
    """
    from ..scene import derive_scene, load_scene
    scene = load_scene(base)
    window = scene.snapshots.get("window")
    T = float(window[1]) if window else scene.T
    every = max(1, min(scene.sph.every, int(round(T / scene.sph.dt / 10))))
    return derive_scene(scene, {"domain": {"T": T}, "sph": {"n_particles": int(n), "integrator": "symplectic",
                                                               "every": every}})


def core_rows(base, sizes, k=BENCH_K, n_freeze=BENCH_FREEZE, n_steps=200_000, repeats=5, core=None, progress=False,
              bar=None):
    """ns per internal step of the C core for each N in ``sizes`` (list of dicts)."""
    from .build import ensure_binaries
    from .core import Core
    from .package import reduced_model
    from .resources import pack

    core = core or Core(ensure_binaries().core)
    rows = []
    for n in sizes:
        scene = bench_scene(base, n)
        data, ops, problem, basis = reduced_model(scene, k, n_freeze, [0.5], "euler", progress=progress)
        model = core.load(pack(data))
        model.set_n_freeze(n_freeze)
        model.advance(1000)                      # warm up
        times = []
        for _ in range(repeats):
            model.reset()
            model.set_n_freeze(n_freeze)
            t0 = time.perf_counter()
            model.advance(n_steps)
            times.append((time.perf_counter() - t0) / n_steps * 1e9)
        model.close()
        rows.append({"n": int(n), "k": k, "k_v": data.k_v, "k_rho": data.k_rho, "n_freeze": n_freeze,
                     "steps": n_steps, "ns_per_step": _median(times), "ns_min": min(times), "ns_max": max(times)})
        if bar is not None:
            bar.update(1)
    return rows


def _simulate(path, stop_time, step):
    import fmpy
    t0 = time.perf_counter()
    fmpy.simulate_fmu(str(path), stop_time=stop_time, output_interval=step)
    return time.perf_counter() - t0


def _bare_calls(unzipdir, md, n_calls, h):
    """n_calls fmi2DoStep of length h on an extracted FMU, nothing else: the call cost through fmpy/ctypes."""
    from fmpy.fmi2 import FMU2Slave
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier="sphrom", instanceName="bench")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    t = 0.0
    t0 = time.perf_counter()
    for i in range(n_calls):
        fmu.doStep(t, h)
        t = (i + 1) * h
    wall = time.perf_counter() - t0
    fmu.terminate()
    fmu.freeInstance()
    return wall


def end_to_end(scene_name="tenmode", steps=(0.01, 0.001), repeats=5, k=None, progress=False, bar=None, workdir=None):
    """End-to-end FMU time (fmpy.simulate_fmu) beside the full SPH of the same scene.

    Returns a dict with ``rows`` (one per communication step), ``sph`` (full
    SPH medians) and ``scene`` facts.
    """
    import fmpy
    from fmpy import extract, read_model_description

    from ..scene import load_scene
    from ..sph.solver import build_problem, run_sph, step_count
    from .build import ensure_binaries
    from .core import Core
    from .package import package_fmu, reduced_model
    from .resources import pack

    scene = load_scene(scene_name)
    problem = build_problem(scene)
    n_internal = step_count(scene.T, scene.sph.dt)
    binaries = ensure_binaries()
    with tempfile.TemporaryDirectory(dir=workdir) as tmp:
        path = Path(tmp) / f"{scene.name}.fmu"
        summary = package_fmu(scene, path, k=k, fmi=2, progress=progress, binaries=binaries, problem=problem)
        md = read_model_description(str(path))
        unzipdir = extract(str(path), unzipdir=str(Path(tmp) / "unzipped"))
        # the core alone, same model, same internal steps
        data, *_ = reduced_model(scene, summary.k, summary.n_freeze, summary.probes, summary.integrator,
                                 progress=False, problem=problem)
        model = Core(binaries.core).load(pack(data))
        core_times = []
        for _ in range(repeats):
            model.reset()
            t0 = time.perf_counter()
            model.advance(n_internal)
            core_times.append(time.perf_counter() - t0)
        model.close()
        core_time = _median(core_times)
        fixed = _median([_simulate(path, min(steps), min(steps)) for _ in range(repeats)])
        # the bare call: doSteps of one internal step each, minus the core's time for those steps
        n_calls = 20_000
        bare = _median([_bare_calls(unzipdir, md, n_calls, scene.sph.dt) for _ in range(repeats)])
        bare_us = (bare - n_calls * core_time / n_internal) / n_calls * 1e6
        rows = []
        for h in steps:
            _simulate(path, scene.T, h)                          # warm (page cache, imports)
            e2e = [_simulate(path, scene.T, h) for _ in range(repeats)]
            n_comm = int(round(scene.T / h))
            e2e_m = _median(e2e)
            rows.append({"step_s": h, "doSteps": n_comm, "internal_steps": n_internal,
                         "fmu_e2e_s": e2e_m, "fmu_e2e_min_s": min(e2e), "fixed_s": fixed, "core_s": core_time,
                         "us_per_doStep_fmpy": (e2e_m - fixed - core_time) / n_comm * 1e6,
                         "us_per_doStep_bare_call": bare_us})
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
    sph = {"loop_s": _median(sph_loop), "call_s": _median(sph_call)}
    for row in rows:
        row["sph_s"] = sph["call_s"]
        row["speedup"] = sph["call_s"] / row["fmu_e2e_s"]
        row["speedup_vs_loop"] = sph["loop_s"] / row["fmu_e2e_s"]
    return {"rows": rows, "sph": sph, "scene": scene.name, "n": scene.sph.n_particles, "T": scene.T,
            "dt": scene.sph.dt, "internal_steps": n_internal, "k_v": summary.k_v, "k_rho": summary.k_rho,
            "n_freeze": summary.n_freeze, "fmpy": fmpy.__version__, "repeats": repeats}


def markdown(core, e2e):
    """The two tables as Markdown text."""
    lines = ["## C core: ns per internal step (k = %d, n_freeze = %d)" % (core[0]["k"], core[0]["n_freeze"]), "",
             "| N | k_v | k_rho | ns/step (median) | min | max |", "| ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in core:
        lines.append(f"| {r['n']} | {r['k_v']} | {r['k_rho']} | {r['ns_per_step']:.1f} | {r['ns_min']:.1f} | "
                     f"{r['ns_max']:.1f} |")
    if e2e is not None:
        lines += ["", f"## End to end: {e2e['scene']} (N = {e2e['n']}, T = {e2e['T']:g} s, "
                      f"{e2e['internal_steps']} internal steps, k_v = {e2e['k_v']}, k_rho = {e2e['k_rho']})", "",
                  f"Full SPH (run_sph, numba, same run): {e2e['sph']['call_s']:.3f} s per run "
                  f"({e2e['sph']['loop_s']:.3f} s in its time loop).", "",
                  "| comm. step | doSteps | FMU via fmpy.simulate_fmu [s] | speed-up vs full SPH | fixed cost [s] | "
                  "core [s] | fmpy per doStep [µs] | bare doStep call [µs] |",
                  "| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
        for r in e2e["rows"]:
            lines.append(f"| {r['step_s'] * 1e3:g} ms | {r['doSteps']} | {r['fmu_e2e_s']:.4f} | "
                         f"{r['speedup']:.1f}x | {r['fixed_s']:.4f} | {r['core_s']:.4f} | "
                         f"{r['us_per_doStep_fmpy']:.1f} | {r['us_per_doStep_bare_call']:.1f} |")
    return "\n".join(lines) + "\n"
