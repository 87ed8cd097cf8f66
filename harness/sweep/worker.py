"""The task of a study, as run on a dask worker: one entry, FMU and optional full SPH.

Worker-local FMU cache
----------------------
Each worker keeps one instantiated :class:`~sphrom.fmu.run.driver.FMU` per FMU in
the module-level dict ``_SLAVES`` and resets it between runs (fmi2Reset /
fmi3Reset, then initialization with the run's n_freeze), so an FMU is loaded
(extracted, its library opened, instantiated) once per worker, not once per
task.  A module-level dict lives in the worker's process and survives from
task to task; dask's workers are one process each (the LocalCluster of
``sphrom sweep`` has one thread per worker), and the dict is keyed by
(FMU, thread) as well, because a worker of another cluster may run several
tasks at once in threads and one FMU instance must never be stepped by two
threads.  The same code runs outside dask (tests, a direct call).
``cache_stats`` reports the instantiations and calls (``client.run``).

The FMU arrives as bytes (scattered once per FMU by the client) and is
extracted once per machine to ``$SPHROM_CACHE/sweep/unzipped/<key>/``, so a
remote cluster needs no shared file system, and nothing is left in /tmp.

A run that fails (an FMU error such as a runaway, a non-finite force, a full
SPH blow-up) returns status ``failed`` with the error on one line; it never
raises, so the study goes on.
"""

from __future__ import annotations

import collections
import dataclasses
import datetime as _dt
import os
import shutil
import threading
import time
import zipfile
from pathlib import Path

import numpy as np

from ..expr import Expr
from ..fmu.run.driver import FMU
from ..norms import relative_l2
from ..rom.operators import probe_rows
from ..scene import parse_scene
from ..sph.solver import build_problem, run_sph
from .fmus import sweep_dir
from .spec import force_at

_SLAVES = {}                        # (fmu key, thread id) -> FMU
_LOADS = collections.Counter()      # (fmu key, thread id) -> instantiations in this process
_CALLS = collections.Counter()      # "runs", "sph" -> calls in this process
_PROBLEMS = {}                      # fmu key -> (scene, SPHProblem), for the full SPH comparison
MAX_ERROR = 600                     # characters of an error message kept


def worker_name():
    """The dask worker's name (its address when unnamed), else ``local-<pid>``."""
    try:
        from distributed import get_worker
        w = get_worker()
        return str(w.name) if w.name is not None else str(w.address)
    except (ImportError, ValueError):
        return f"local-{os.getpid()}"


def extracted(bundle):
    """The FMU of ``bundle`` extracted once per machine (atomic rename); its folder."""
    root = sweep_dir() / "unzipped"
    folder = root / bundle["key"]
    if (folder / "modelDescription.xml").is_file():
        return folder
    root.mkdir(parents=True, exist_ok=True)
    tmp = root / f".{bundle['key']}.tmp-{os.getpid()}-{threading.get_ident()}"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir()
    archive = tmp / "fmu.zip"
    archive.write_bytes(bundle["fmu"])
    with zipfile.ZipFile(archive) as zf:
        for info in zf.infolist():
            zf.extract(info, tmp / "x")
            mode = info.external_attr >> 16
            if mode:
                os.chmod(tmp / "x" / info.filename, mode)
    try:
        os.rename(tmp / "x", folder)
    except OSError:                  # another worker got there first
        pass
    shutil.rmtree(tmp, ignore_errors=True)
    return folder


def slave_for(bundle):
    """(FMU, load time [s]) of ``bundle``'s FMU for this thread: cached, instantiated on first use."""
    key = (bundle["key"], threading.get_ident())
    slave = _SLAVES.get(key)
    if slave is not None:
        return slave, 0.0
    t0 = time.perf_counter()
    slave = FMU(extracted(bundle), name=f"sweep-{worker_name()}")
    _SLAVES[key] = slave
    _LOADS[key] += 1
    return slave, time.perf_counter() - t0


def drop_slave(bundle):
    """Forget (and free) this thread's instance of ``bundle``'s FMU."""
    slave = _SLAVES.pop((bundle["key"], threading.get_ident()), None)
    if slave is not None:
        try:
            slave.close()
        except Exception:            # pragma: no cover - freeing a broken instance
            pass


def cache_stats():
    """This process's FMU instantiations {fmu key: count} and calls {"runs": n, "sph": n}."""
    loads = collections.Counter()
    for (key, _), n in _LOADS.items():
        loads[key] += n
    return {"loads": dict(loads), "calls": dict(_CALLS), "instances": len(_SLAVES), "pid": os.getpid()}


def probe_stats(times, v, window):
    """Statistics of probe velocities over ``window`` [s].

    Parameters
    ----------
    times : ndarray (M+1,)
        Communication points [s].
    v : ndarray (M+1, P)
        Probe velocities [m s^-1].
    window : (t0, t1)
        Points with t0 <= t <= t1 count (1e-9 relative slack).

    Returns
    -------
    dict of ndarray (P,)
        ``v_max`` max |v|, ``v_rms`` sqrt(mean v^2) (points equally weighted),
        ``v_final`` v at the last point [m s^-1].
    """
    slack = 1e-9 * abs(float(times[-1]))            # relative: a bar's times may be microseconds
    inside = (times >= window[0] - slack) & (times <= window[1] + slack)
    w = v[inside]
    return {"v_max": np.max(np.abs(w), axis=0), "v_rms": np.sqrt(np.mean(w**2, axis=0)), "v_final": v[-1]}


def held_force(entry):
    """The FMU's input as a scene force: f(t_j) held over [t_j, t_j + step) (an Expr in t).

    The full SPH is driven by exactly the values the FMU receives, so its
    comparison measures the reduced model, not the sampling of the input.
    (For rk4 the stage at the step's end takes the next point's value.)
    """
    h = entry.step

    def held(env):
        j = np.floor(np.asarray(env["t"], dtype=float) / h + 1e-9)
        return force_at(entry, j * h)
    return Expr(text=f"{entry.shape} held over steps of {h:g} s", names=frozenset({"t"}), _fn=held)


def sph_run(bundle, entry):
    """The full SPH of the variant with the entry's held force to t_end.

    Returns (times [s], v (M+1, P) [m s^-1], rho (M+1, P) [kg m^-3], rho0 (P,), wall [s]):
    v and rho interpolated linearly at the probes (as the FMU's outputs are).
    """
    key = (bundle["key"], entry.c, entry.d) if entry.parametric else bundle["key"]
    if key not in _PROBLEMS:
        scene = parse_scene(bundle["scene_text"], f"<{entry.scene} variant>")
        if entry.parametric:         # the FMU's scene has the base c, d: the run's are the entry's
            from .spec import variant_scene
            scene = variant_scene(scene, **entry.parameter_values(scene))
        _PROBLEMS.clear()            # keep one: a worker mostly meets the variants in turn
        _PROBLEMS[key] = (scene, build_problem(scene))
    scene, problem = _PROBLEMS[key]
    run_scene = dataclasses.replace(scene.with_T(entry.t_end), f=held_force(entry))
    if not _CALLS["sph_warm"]:       # load the compiled loop (numba's cache) once, untimed
        run_sph(run_scene.with_T(scene.sph.dt), sample_steps=[0, 1], progress=False, problem=problem)
        _CALLS["sph_warm"] = 1
    t0 = time.perf_counter()
    m = int(round(entry.step / scene.sph.dt))
    steps = np.arange(int(round(entry.t_end / entry.step)) + 1, dtype=np.int64) * m
    res = run_sph(run_scene, sample_steps=steps, progress=False, problem=problem)
    rows = probe_rows(np.eye(problem.n), problem.x, scene.L, entry.probes)
    v, rho = res.v @ rows.T, res.rho @ rows.T
    wall = time.perf_counter() - t0
    return res.t, v, rho, rows @ problem.rho0, wall


def _one_line(exc, slave=None):
    text = f"{type(exc).__name__}: {exc}"
    if slave is not None and slave.errors():
        text += " | FMU: " + "; ".join(slave.errors())
    text = " ".join(text.split())
    return text if len(text) <= MAX_ERROR else text[:MAX_ERROR - 3] + "..."


def run_entry(bundle, entry):
    """Run one entry; never raises.

    Parameters
    ----------
    bundle : dict
        ``key``, ``fmu`` (bytes), ``scene_text`` of the entry's variant.
    entry : sphrom.sweep.spec.Entry

    Returns
    -------
    dict
        The entry's outputs: ``status`` (ok | failed), ``error``, per probe
        j = 1..P ``v_max_j``, ``v_rms_j``, ``v_final_j`` [m s^-1]; with
        compare_sph ``sph_err_v``, ``sph_err_rho`` (relative L2 of eq. 3.4
        over probes and communication points; rho as rho - rho0) and
        ``sph_wall_s``; ``fmu_wall_s`` (reset, initialization and the
        co-simulation loop), ``load_s`` (instantiation, 0 when cached),
        ``task_wall_s``, ``worker``, ``fmu_loads`` (instantiations of this FMU
        by this worker thread so far), ``started_utc``.
    """
    _CALLS["runs"] += 1
    t_task = time.perf_counter()
    started = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="microseconds")
    out = {"status": "failed", "error": "", "worker": worker_name(), "started_utc": started, "fmu_loads": 0,
           "fmu_wall_s": float("nan"), "load_s": float("nan"), "sph_wall_s": float("nan"),
           "sph_err_v": float("nan"), "sph_err_rho": float("nan")}
    P = len(entry.probes)
    slave = None
    try:
        m = int(round(entry.t_end / entry.step))
        times = np.arange(m + 1) * entry.step
        f = force_at(entry, times[:-1])
        bad = ~np.isfinite(f)
        if np.any(bad):
            raise ValueError(f"force shape {entry.shape!r} is not finite at t = {times[:-1][bad][0]:g} s")
        slave, load = slave_for(bundle)
        out["load_s"] = load
        out["fmu_loads"] = _LOADS[(bundle["key"], threading.get_ident())]
        t0 = time.perf_counter()
        slave.messages.clear()
        try:
            slave.reset()
        except Exception:            # an instance reset cannot recover: load it afresh
            drop_slave(bundle)
            slave, load = slave_for(bundle)
            out["load_s"] += load
            out["fmu_loads"] = _LOADS[(bundle["key"], threading.get_ident())]
            t0 = time.perf_counter()
        if entry.parametric:         # c, d of this run on the one parametric FMU (fixed: before initialization)
            from ..fmu.variables import vr
            from ..scene import parse_scene
            params = entry.parameter_values(parse_scene(bundle["scene_text"], f"<{entry.scene} variant>"))
            slave.set_real([vr(name) for name in params], list(params.values()))
        # the scene's v0, as its full SPH; n_freeze where the FMU has it (a linear model has no internal step)
        slave.initialize(n_freeze=entry.n_freeze if "n_freeze" in slave.vr else None, initial_state_scale=1)
        values = slave.run(np.full(m, entry.step), f)
        out["fmu_wall_s"] = time.perf_counter() - t0
        v, rho = values[:, :P], values[:, P:2 * P]
        if not np.all(np.isfinite(values)):
            raise FloatingPointError("the FMU returned non-finite outputs")
        stats = probe_stats(times, v, entry.window)
        for name, arr in stats.items():
            for j in range(P):
                out[f"{name}_{j + 1}"] = float(arr[j])
        if entry.compare_sph:
            slave_done = slave
            slave = None             # an SPH failure is not the FMU's
            _CALLS["sph"] += 1
            t_s, v_s, rho_s, rho0, wall = sph_run(bundle, entry)
            out["sph_wall_s"] = wall
            out["sph_err_v"] = relative_l2(v, v_s, times)
            out["sph_err_rho"] = relative_l2(rho, rho_s, times, baseline=rho0)
            slave = slave_done
        out["status"] = "ok"
    except Exception as exc:         # recorded, never raised: the study goes on
        out["error"] = _one_line(exc, slave)
    out["task_wall_s"] = time.perf_counter() - t_task
    return out
