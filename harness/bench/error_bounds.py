"""The certified error bounds of the FMUs' outputs, measured: effectivity (bound / true error), false alarms, cost.

``sphrom bench error_bounds [SCENE ...] [--models frozen,exact,balanced] [--corpus N] [--span S] [--repeats R]
[--out FOLDER] [--report BENCHMARKS.md]`` packages each scene's FMU of each model (FMI 2, the scene's defaults,
without the a priori bounds) and drives it over S x the scene's T (default 20) at 10 ms communication steps, from
rest and from the scene's initial state, under five forces no basis saw (:func:`forces`), held over each step, and
two of them linear over each step (FMI 2 input derivatives).  The scenes: every built-in scene and ``--corpus`` N
generated user scenes (:func:`sphrom.bench.lib.error_corpus.user_scenes`, shared with ``error_bounds_ports
--corpus``: damping that varies along the bar, force profiles that are not uniform, c and ρ0 that vary, rough initial
states; default 4).

The truth is the full SPH of eqs. 2.10-2.11 as the linear system in J (:mod:`sphrom.rom.lti`) integrated exactly in
time: the matrix exponential of the system augmented with the input and its slope, one dense step map applied to
every run at once, independent of every reduced model and of the bounds' shadow.  v at the probes, and ρ = ρ0 /
(1 + e) at the particles, both interpolated linearly at the probes as the FMU does.

Per run and output (v_probe_j, rho_probe_j): the effectivity is the largest bound over the run / the largest true
error over the run, counted where that error is above :data:`FLOOR` of the output's signal (|v| or |ρ|);
violations: communication points where a bound is below the true error (must be 0); a false alarm: a run that
warned (a velocity bound above error_tolerance) while its true velocity error stayed below a tenth of
error_tolerance.  Cost: the C core's doStep (``rom_do_step`` through ctypes, no FMI or Python in the loop) on the
same model with and without the bounds' sections, median of ``repeats`` runs of 1000 steps, timed in turn.

Writes ``error_bounds.csv`` (one row per run and output), ``error_bounds.png`` (bound and true error against time
of a few runs) into FOLDER, and the section "Certified error bounds" of the report.

``--parametric`` measures the parametric FMUs instead (frozen and exact, ``--vary`` c over [c/2, 2c] and d over
[d/2, 3d/2], [0, 5] s⁻¹ for an undamped scene, about the scene's c and d; :data:`PARAMETRIC_SPAN`): the same runs at
``--points`` held-out (c, d) of the box (:func:`sphrom.rom.parametric.held_out_points`), the truth the full linear
SPH with that c and d; writes ``error_bounds_parametric.csv`` and the section "Certified error bounds of parametric
FMUs".
"""

from __future__ import annotations

import contextlib
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from ..options import int_at_least, int_list, positive_float
from .lib.error_corpus import CORPUS_MENU, user_scenes  # noqa: F401 (the corpus: shared with error_bounds_ports)
from .lib.stopped import RunStopped, reason
from .lib.native_cost import (COUNT_STEPS, NATIVE_BUDGET, NATIVE_ROUNDS, NATIVE_STEPS, NO_COST, PAST_STEPS,
                               cost_lines, native_cost)

SECTION_HEADING = "## Certified error bounds"
PARAMETRIC_HEADING = "## Certified error bounds of parametric FMUs"
PARAMETRIC_SPAN = {"c": (0.5, 2.0), "d": (0.5, 1.5)}   # the trained box: these x the scene's c and d
UNDAMPED_D_RANGE = (0.0, 5.0)                           # [s^-1] d's range of an undamped scene
STEP = 0.01             # [s] communication step
SPAN = 20.0             # runs over this x the scene's T
STARTS = (("rest", 0.0), ("initial state", 1.0))
LINEAR = ("slow sine", "chirp")                         # the forces also run linear over each step
FLOOR = 1e-9            # effectivity counted where the run's largest error exceeds this x its output's signal
CHUNK = 20              # doStep calls timed together (the cost's medians are over such chunks)
COST_STEPS = 1000


def forces(t, T_run):
    """Five forces no basis saw [m s^-2] over a run of T_run [s]: a constant, a slow sine, a step at a third, a chirp
    from 0.5 to 5 Hz, two tones."""
    return {"constant 2e-3": 2e-3 * np.ones_like(t),
            "slow sine": 1e-2 * np.sin(2 * np.pi * 0.3 * t),
            "step at a third": 3e-3 * (t > T_run / 3),
            "chirp": 5e-3 * np.sin(2 * np.pi * (0.5 * t + 4.5 / (2 * T_run) * t * t)),
            "two tones": 4e-3 * (np.sin(2 * np.pi * 1.3 * t) + 0.5 * np.sin(2 * np.pi * 4.1 * t + 1.0))}


def scene_note(scene, problem):
    """The scene's fields in a few words (the report's scene column)."""
    d = problem.d
    return (f"N {problem.n}, T {scene.T:g} s, d {'uniform ' + format(d[0], 'g') if np.all(d == d[0]) else 'varies'}"
            f", profile {'uniform' if np.all(problem.profile == problem.profile[0]) else 'varies'}")


def exact_truth(problem, probes, t, cases):
    """{case: (v (M, P), ρ (M, P))} of the full linear SPH at the times ``t`` (uniform steps), exact in time: every
    case (scale, f (M,), linear) at once, x(0) = scale x0, f held over each step or linear between the samples."""
    import scipy.linalg as sla

    from ..rom.lti import full_linear_system, probe_matrix
    lti = full_linear_system(problem, probes)
    n = problem.rho0.size
    h = float(t[1] - t[0])
    A = lti.A.toarray()
    names = list(cases)
    if n > DENSE_TRUTH:
        return modal_truth(problem, probes, t, cases, lti)
    M = np.zeros((2 * n + 2, 2 * n + 2))
    M[:2 * n, :2 * n] = A * h
    M[:2 * n, 2 * n] = lti.B[:, 0] * h
    M[2 * n, 2 * n + 1] = 1.0
    E = sla.expm(M)
    Phi, g0, g1 = E[:2 * n, :2 * n], E[:2 * n, 2 * n], E[:2 * n, 2 * n + 1]
    U = np.column_stack([cases[c][1] for c in names])                 # (M, R)
    lin = np.array([cases[c][2] for c in names], float)
    X = np.column_stack([cases[c][0] * lti.x0 for c in names])       # (2N, R)
    rows = probe_matrix(problem.x, problem.scene.L, probes, np.ones(n))
    Rv = rows / np.sqrt(problem.rho0)[None, :]
    v = np.empty((t.size, len(names), len(probes)))
    e = np.empty((t.size, len(names), 2 * len(probes)))
    # e at the two particles of each probe (the density is interpolated from them as the FMU does)
    L = problem.scene.L
    s = np.mod(np.asarray(probes) * L - problem.x[0], L) / (L / n)
    i0 = np.floor(s).astype(np.int64) % n
    i1 = (i0 + 1) % n
    wt = s - np.floor(s)
    parts = np.concatenate([i0, i1])
    for k in range(t.size):
        v[k] = (Rv @ X[:n]).T
        e[k] = (X[n + parts] / np.sqrt(problem.c)[parts][:, None]).T
        if k + 1 < t.size:
            X = Phi @ X + np.outer(g0, U[k]) + np.outer(g1, lin * (U[k + 1] - U[k]))
    P = len(probes)
    rho = ((1 - wt) * problem.rho0[i0] / (1 + e[:, :, :P]) + wt * problem.rho0[i1] / (1 + e[:, :, P:]))
    return {c: (v[:, r], rho[:, r]) for r, c in enumerate(names)}


DENSE_TRUTH = 400        # particles: the truth's dense step map up to here, A's eigenvectors above


def probe_parts(problem, probes):
    """(i0, i1, w): the particles around each probe and the weight of i1 (the FMU's interpolation)."""
    from ..fmu.resources import probe_pairs
    return probe_pairs(problem.x, problem.scene.L, probes)


def modal_truth(problem, probes, t, cases, lti):
    """:func:`exact_truth` through A's eigenvectors (A = V Λ V^-1, LAPACK's geev, not the bounds' planes): each
    step multiplies the modal coordinates by e^{λ h} and adds the held input's (e^{λh} - 1)/λ and the slope's
    (e^{λh} - 1 - λh)/(λ² h) times V^-1 b (their limits h and h/2 at λ = 0): O(N) per step and run."""
    import scipy.linalg as sla
    n = problem.rho0.size
    h = float(t[1] - t[0])
    lam, V = sla.eig(lti.A.toarray())
    Vi = np.linalg.inv(V)
    bz = Vi @ lti.B[:, 0]
    x = lam * h
    small = np.abs(x) < 1e-8
    e = np.exp(x)
    g0 = np.where(small, h * (1 + x / 2), (e - 1) / np.where(small, 1, lam)) * bz
    g1 = np.where(small, h / 2 * (1 + x / 3), (e - 1 - x) / np.where(small, 1, lam * x)) * bz
    i0, i1, w = probe_parts(problem, probes)
    P = len(probes)
    Cv = ((1 - w)[:, None] * V[i0] / lti.w_v[i0][:, None] + w[:, None] * V[i1] / lti.w_v[i1][:, None])
    Ce = np.vstack([V[n + i0] / lti.w_e[i0][:, None], V[n + i1] / lti.w_e[i1][:, None]])
    names = list(cases)
    U = np.column_stack([cases[c][1] for c in names])
    lin = np.array([cases[c][2] for c in names], float)
    Z = Vi @ np.column_stack([cases[c][0] * lti.x0 for c in names])
    v = np.empty((t.size, len(names), P))
    ee = np.empty((t.size, len(names), 2 * P))
    for k in range(t.size):
        v[k] = np.real(Cv @ Z).T
        ee[k] = np.real(Ce @ Z).T
        if k + 1 < t.size:
            Z = e[:, None] * Z + np.outer(g0, U[k]) + np.outer(g1, lin * (U[k + 1] - U[k]))
    rho = ((1 - w) * problem.rho0[i0] / (1 + ee[:, :, :P]) + w * problem.rho0[i1] / (1 + ee[:, :, P:]))
    return {c: (v[:, r], rho[:, r]) for r, c in enumerate(names)}


def run_fmu(path, t, scale, f, linear, parameters=None):
    """(outputs (M, n), names, warnings, error_tolerance) of the FMU driven over ``t``.  Raises
    :class:`~sphrom.bench.lib.stopped.RunStopped` (with the FMU's logged reason) when the FMU returns an error
    status: the run is recorded as stopped, not counted, and the bench goes on."""
    from fmpy.fmi1 import FMICallException

    from ..fmu.run.driver import FMU
    messages = []
    try:
        with FMU(path, messages=messages) as fmu:
            fmu.initialize(parameters={"initial_state_scale": scale, **(parameters or {})},
                           inputs={"f": float(f[0])})
            y = fmu.simulate(t, {"f": f}, rates=linear)
            tol = fmu.get_real([fmu.vr["error_tolerance"]])[0]
            return y, fmu.outputs, fmu.warnings(), tol
    except FMICallException as exc:               # the FMU stopped the run (an error status): say why
        raise RunStopped(reason(messages, exc)) from None


def run_metrics(y, names, v_t, rho_t, rho0_probe, warned, tol):
    """Per output (name, effectivity or nan, largest error, largest bound), the run's violations, its false alarm."""
    from ..fmu.variables import members
    out, bad = [], np.zeros(y.shape[0], bool)
    max_v_err = 0.0
    for kind, truth, signal in (("v_probe_j", v_t, np.abs(v_t)), ("rho_probe_j", rho_t, np.abs(rho_t))):
        value = y[:, members(names, kind)]
        bound = y[:, members(names, kind.replace("_j", "_j_error_bound"))]
        err = np.abs(value - truth)
        bad |= np.any(bound < err, axis=1)
        for j in range(err.shape[1]):
            e_max, b_max, s_max = float(err[:, j].max()), float(bound[:, j].max()), float(signal[:, j].max())
            eff = b_max / e_max if e_max > FLOOR * s_max and e_max > 0 else float("nan")
            out.append((kind.replace("_j", f"_{j + 1}"), eff, e_max, b_max))
        if kind == "v_probe_j":
            max_v_err = float(err.max())
    false_alarm = bool(warned) and max_v_err < 0.1 * tol
    return out, int(bad.sum()), false_alarm


def step_cost(path, repeats, n_steps=COST_STEPS):
    """(ns per doStep with the bounds, without, the loop's own ns per step) of the FMU's model in the C core:
    ``repeats`` runs of ``n_steps`` steps of STEP at f = 1e-3, timed in chunks of CHUNK steps, the models' chunks
    in turn; medians over the chunks (a chunk the OS descheduled is an outlier, not the cost)."""
    import statistics
    import zipfile

    from ..fmu.make.build import ensure_binaries
    from ..fmu.resources import pack, unpack
    from ..fmu.run.core import Core
    blob = zipfile.ZipFile(path).read("resources/model.bin")
    data = unpack(blob)
    data.sections = {k: v for k, v in data.sections.items() if not k.startswith("SH")}
    bare = pack(data)                                # any model kind
    core = Core(ensure_binaries(quiet=True).core)
    models = [core.load(blob), core.load(bare)]
    times = [[], [], []]
    for _ in range(repeats):
        for m in models:
            m.reset(0.0)
            m.set_input(1e-3)
        for start in range(0, n_steps - CHUNK + 1, CHUNK):   # chunks in turn: a descheduled chunk is an outlier
            for i, m in enumerate(models):
                t0 = time.perf_counter()
                for j in range(start, start + CHUNK):
                    m.do_step(j * STEP, STEP)
                times[i].append((time.perf_counter() - t0) / CHUNK * 1e9)
            t0 = time.perf_counter()                 # the loop's own cost: one trivial core call per step
            for j in range(CHUNK):
                models[1].set_input(1e-3)
            times[2].append((time.perf_counter() - t0) / CHUNK * 1e9)
    for m in models:
        m.close()
    return tuple(statistics.median(x) for x in times)


def run_cases(t, T_run):
    """{case: (start name, scale, force name, f, linear)} of one scene: every force held from each start, the
    :data:`LINEAR` ones linear too."""
    fs = forces(t, T_run)
    out = {}
    for start, scale in STARTS:
        for name, f in fs.items():
            out[f"{name}, held, {start}"] = (start, scale, name, f, False)
            if name in LINEAR:
                out[f"{name}, linear, {start}"] = (start, scale, name, f, True)
    return out


def measure_fmu(path, problem, probes, t, cases, truths, parameters=None):
    """Rows (one per run and output) of the FMU at ``path`` over ``cases``."""
    from ..rom.lti import probe_matrix
    rho0_probe = probe_matrix(problem.x, problem.scene.L, probes, np.ones(problem.n)) @ problem.rho0
    rows, kept = [], {}
    for case, (start, scale, fname, f, linear) in cases.items():
        try:
            y, names, warned, tol = run_fmu(path, t, scale, f, linear, parameters)
        except RunStopped as exc:
            rows.append({"case": case, "start": start, "force": fname, "hold": "linear" if linear else "held",
                         "stopped": str(exc)})
            continue
        v_t, rho_t = truths[case]
        outputs, bad, alarm = run_metrics(y, names, v_t, rho_t, rho0_probe[None, :], warned, tol)
        for name, eff, e_max, b_max in outputs:
            rows.append({"case": case, "start": start, "force": fname, "hold": "linear" if linear else "held",
                         "output": name, "effectivity": eff, "max_err": e_max, "max_bound": b_max,
                         "violations": bad, "points": t.size, "false_alarm": alarm, "warned": bool(warned),
                         "tolerance": tol})
        kept[case] = (y, names, v_t)
    return rows, kept


def measure_scene(scene, models, repeats, folder, probes, span, progress=True):
    """Rows (one per model, run and output) of ``scene`` and the runs kept for the plot."""
    from ..fmu.make.build import ensure_binaries
    from ..fmu.make.package import package_fmu
    from ..sph.solver import build_problem
    problem = build_problem(scene)
    T_run = span * scene.T
    t = np.arange(int(round(T_run / STEP)) + 1) * STEP
    cases = run_cases(t, T_run)
    truths = exact_truth(problem, probes, t, {c: (v[1], v[3], v[4]) for c, v in cases.items()})
    binaries = ensure_binaries(quiet=True)
    out, kept = [], {}
    note = scene_note(scene, problem)
    for model in models:
        path = Path(folder) / f"{scene.name}-{model}.fmu"
        t0 = time.perf_counter()
        try:
            s = package_fmu(scene, path, model=model, fmi=2, progress=progress, binaries=binaries,
                            problem=problem, bounds=False)
        except Exception as exc:                     # a model that does not build on this scene: say so
            out.append({"scene": scene.name, "model": model, "note": str(exc).splitlines()[0], "about": note})
            continue
        seconds = time.perf_counter() - t0
        with_ns, without_ns, loop_ns = step_cost(path, repeats)
        native = native_cost(path, repeats) or NO_COST
        rows, runs = measure_fmu(path, problem, probes, t, cases, truths)
        for r in rows:
            r.update({"scene": scene.name, "model": model, "about": note, "N": problem.n, "k_v": s.k_v,
                      "k_rho": s.k_rho, "shadow_order": s.shadow_order, "package_s": seconds,
                      "step_ns_bounds": with_ns, "step_ns_plain": without_ns, "loop_ns": loop_ns,
                      "cost_ratio": with_ns / without_ns, **native.row(), "note": _stopped(r)})
        out += rows
        kept.update({(scene.name, model, c): v for c, v in runs.items()})
    return out, kept


def summarise(rows, keys):
    """Aggregate rows by ``keys``: runs, violations, points, effectivity median and max (of the counted ones),
    the largest error and bound, false alarms."""
    groups = {}
    for r in rows:
        if r.get("note"):
            continue
        groups.setdefault(tuple(r[k] for k in keys), []).append(r)
    out = []
    for key, rs in groups.items():
        eff = np.array([r["effectivity"] for r in rs], float)
        counted = eff[np.isfinite(eff)]
        # a run is a case of one scene and model (case names repeat across scenes and models)
        per_run = {(r.get("scene"), r.get("model"), r.get("point"), r["case"]):
                   (r["violations"], r["points"], r["false_alarm"]) for r in rs}
        out.append({**dict(zip(keys, key)), "runs": len(per_run),
                    "violations": sum(v[0] for v in per_run.values()), "points": sum(v[1] for v in per_run.values()),
                    "false_alarms": sum(v[2] for v in per_run.values()), "counted": int(counted.size),
                    "outputs": int(eff.size),
                    "eff_median": float(np.median(counted)) if counted.size else float("nan"),
                    "eff_max": float(counted.max()) if counted.size else float("nan"),
                    "max_err": max(r["max_err"] for r in rs if r["output"].startswith("v_")),
                    "max_bound": max(r["max_bound"] for r in rs if r["output"].startswith("v_")),
                    **{k: rs[0][k] for k in ("N", "k_v", "k_rho", "shadow_order", "step_ns_bounds", "step_ns_plain",
                                             "cost_ratio", "native_ratio", "native_read_ratio", "instr_ratio",
                                             "instr_past_ratio", "about",
                                             "package_s") if k in rs[0]}})
    return out


def plot(kept, keys, path):
    """Bound (dashed) and true error (solid) of v_probe_1 against time for the runs ``keys``."""
    from matplotlib.figure import Figure

    from ..fmu.variables import members
    fig = Figure(figsize=(8, 4.5))
    ax = fig.add_subplot(1, 1, 1)
    for key, color in zip(keys, ("C0", "C1", "C2", "C3", "C4", "C5")):
        y, names, v_t = kept[key]
        t = np.arange(y.shape[0]) * STEP
        v, vb = y[:, members(names, "v_probe_j")][:, 0], y[:, members(names, "v_probe_j_error_bound")][:, 0]
        ax.semilogy(t, np.maximum(np.abs(v - v_t[:, 0]), 1e-18), color=color, lw=0.8, label=f"{key[0]} {key[1]}: "
                    f"{key[2]}")
        ax.semilogy(t, vb, color=color, lw=0.8, ls="--")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("v_probe_1: |error| (solid), certified bound (dashed) [m/s]")
    ax.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def _g(x, spec=".3g"):
    return "—" if x is None or (isinstance(x, float) and not np.isfinite(x)) else format(x, spec)


def section(rows, notes, *, command, wall, machine, image, span):
    per_model = summarise(rows, ("model",))
    table = summarise(rows, ("scene", "model", "hold", "start"))
    lines = [SECTION_HEADING, "",
             f"Produced by `{command}` ({machine}, {wall:.0f} s wall; every run and output in "
             "`validation/benchmarks/error_bounds.csv`). Each scene's FMU (FMI 2, the scene's defaults) over "
             f"{span:g} x its T at {STEP * 1e3:g} ms steps, from rest and from the scene's initial state, under five "
             "forces no basis saw (a constant, a slow sine, a step, a chirp from 0.5 to 5 Hz, two tones; "
             "harness/bench/error_bounds.py `forces`), held over each step, and the slow sine and the chirp also "
             "linear over each step (input derivatives). Scenes: the built-in ones and generated user scenes "
             "(`user_*`: damping that varies, profiles that are not uniform, c and ρ0 that vary). **Truth: the full "
             "SPH of eqs. 2.10-2.11, linear in J, integrated exactly in time** with the same inputs (independent of "
             "every reduced model and of the bounds). Effectivity: per run and output (v_probe_j, rho_probe_j), the "
             "largest bound over the run / the largest true error over the run, where that error exceeds "
             f"{FLOOR:g} of the output's signal (|v|, |ρ|). Violations: communication points where a bound is "
             "below the true error. False alarms: runs that warned (a velocity bound above error_tolerance) while "
             "their true velocity error stayed below a tenth of error_tolerance. doStep cost: the C core's "
             "rom_do_step through ctypes on the same model with and without the bounds' sections (ns per step, "
             f"medians over chunks of {CHUNK} steps timed in turn; no FMI). Native: the FMU in the native FMI 2 "
             "master (fmu_src/tests/step_cost.c, `sphrom_step_cost`: per step fmi2SetReal of f, fmi2DoStep, "
             "fmi2GetReal of the outputs) against the same FMU without the bounds' sections, thread CPU time per "
             f"step of runs of {NATIVE_STEPS} steps, the three back to back in each round: the median of the rounds' "
             f"ratios (at least --repeats, up to {NATIVE_ROUNDS} while they take less than {NATIVE_BUDGET:g} s) with the "
             "outputs alone read, and with their bounds read too. Instruction ratio: the same master's "
             "instructions per step with the outputs read (callgrind, the difference of runs of "
             f"{COUNT_STEPS[1]} and {COUNT_STEPS[0]} steps), "
             "with the bounds' sections against without: a count the load of a shared machine does not move; "
             "past-table instruction ratio: the same count over as many steps from "
             f"{PAST_STEPS} steps past the free response table's end (20 x T, or where the complement has decayed), "
             "where the complement's modes that matter are continued by a recurrence, on the FMUs with a table.", "",
             "All scenes together, per model:", "",
             "| model | runs | outputs counted / all | effectivity median | max | violations | false alarms |",
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in sorted(per_model, key=lambda r: r["model"]):
        lines.append(f"| {r['model']} | {r['runs']} | {r['counted']} / {r['outputs']} | {_g(r['eff_median'])} | "
                     f"{_g(r['eff_max'])} | {r['violations']} / {r['points']} | {r['false_alarms']} |")
    lines += cost_lines(rows)
    lines += ["", f"![bound and error]({image})", "",
              "| scene | model | N, k_v, k_ρ, shadow | inputs | start | runs | effectivity median | max | "
              "violations | false alarms | max v error [m/s] | max v bound [m/s] | doStep ns with / without | "
              "ratio | native ratio: outputs / with bounds read | instruction ratio |",
              "| --- | --- | --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in table:
        lines.append(f"| {r['scene']} | {r['model']} | {r['N']}, {r['k_v']}, {r['k_rho']}, {r['shadow_order']} | "
                     f"{r['hold']} | {r['start']} | {r['runs']} | {_g(r['eff_median'])} | {_g(r['eff_max'])} | "
                     f"{r['violations']} / {r['points']} | {r['false_alarms']} | {_g(r['max_err'], '.2e')} | "
                     f"{_g(r['max_bound'], '.2e')} | {r['step_ns_bounds']:.0f} / {r['step_ns_plain']:.0f} | "
                     f"{r['cost_ratio']:.2f} | {_g(r.get('native_ratio', float('nan')), '.2f')} / "
                     f"{_g(r.get('native_read_ratio', float('nan')), '.2f')} | "
                     f"{_g(r.get('instr_ratio', float('nan')), '.2f')} |")
    for n in notes:
        lines.append(_note_row(n, before=6, after=7))
    scenes = {}
    for r in rows:
        scenes.setdefault(r["scene"], r.get("about", ""))
    lines += ["", "Scenes: " + "; ".join(f"{k} ({v})" for k, v in scenes.items()) + ".", ""]
    return lines


def parametric_ranges(problem):
    """The trained box of a parametric FMU about the scene's uniform c and d (:data:`PARAMETRIC_SPAN`)."""
    from ..rom.parametric import Range
    c, d = float(problem.c[0]), float(problem.d[0])
    lo, hi = PARAMETRIC_SPAN["c"]
    out = [Range("c", lo * c, hi * c)]
    lo, hi = PARAMETRIC_SPAN["d"]
    out.append(Range("d", lo * d, hi * d) if d > 0 else Range("d", *UNDAMPED_D_RANGE))
    return out


def measure_parametric(scene, models, points, folder, probes, span, repeats=3, progress=True):
    """Rows (one per model, held-out point, run and output) of the parametric FMUs of ``scene``: against the full
    linear SPH with the point's c and d, exact in time."""
    from ..fmu.make.build import ensure_binaries
    from ..fmu.make.package import package_fmu
    from ..rom import parametric as par
    from ..scene import derive_scene
    from ..sph.solver import build_problem
    problem = build_problem(scene)
    T_run = span * scene.T
    t = np.arange(int(round(T_run / STEP)) + 1) * STEP
    cases = run_cases(t, T_run)
    ranges = parametric_ranges(problem)
    try:
        held = par.held_out_points(par.parameter_space(problem, ranges), points)
    except Exception as exc:                         # a scene that cannot be parametric (c not uniform): say so
        return [{"scene": scene.name, "model": ", ".join(models), "note": str(exc).splitlines()[0]}]
    at = {}
    for c, d in held:
        problem_cd = build_problem(derive_scene(scene, {"fields": {"c": repr(float(c)), "d": repr(float(d))}}))
        at[(c, d)] = (problem_cd, exact_truth(problem_cd, probes, t, {k: (v[1], v[3], v[4]) for k, v in
                                                                        cases.items()}))
    binaries = ensure_binaries(quiet=True)
    out = []
    for model in models:
        path = Path(folder) / f"{scene.name}-{model}-parametric.fmu"
        try:
            s = package_fmu(scene, path, model=model, fmi=2, progress=progress, binaries=binaries, vary=ranges)
        except Exception as exc:                     # a model that does not build on this scene: say so
            out.append({"scene": scene.name, "model": model, "note": str(exc).splitlines()[0]})
            continue
        native = native_cost(path, repeats) or NO_COST    # at the FMU's default c and d
        for (c, d), (problem_cd, truths) in at.items():
            rows, _ = measure_fmu(path, problem_cd, probes, t, cases, truths, parameters={"c": c, "d": d})
            for r in rows:
                r.update(native.row())
                r.update({"scene": scene.name, "model": model, "N": problem.n, "k_v": s.k_v, "k_rho": s.k_rho,
                          "shadow_order": s.shadow_order, "c": float(c), "d": float(d), "point": f"{c:.4g}, {d:.4g}",
                          "c_range": f"{ranges[0].lo:g}:{ranges[0].hi:g}",
                          "d_range": f"{ranges[1].lo:g}:{ranges[1].hi:g}", "note": _stopped(r)})
            out += rows
    return out


def parametric_section(rows, notes, *, command, wall, machine, span):
    per_model = summarise(rows, ("model",))
    table = summarise(rows, ("scene", "model", "point", "start"))
    lines = [PARAMETRIC_HEADING, "",
             f"Produced by `{command}` ({machine}, {wall:.0f} s wall; `validation/benchmarks/"
             "error_bounds_parametric.csv`). Each scene's parametric FMU (FMI 2, `--vary c=c/2:2c --vary d=d/2:3d/2`, "
             "d in [0, 5] s⁻¹ for an undamped scene) at held-out (c, d) of its box (Halton points, neither the scene's "
             "nor a training point), under the runs of the section above (over "
             f"{span:g} x T). **Truth: the full linear SPH (eqs. 2.10-2.11 in J) with that c and d, integrated "
             "exactly in time.** The complement's terms are computed by the FMU at its (c, d) (decaying at the "
             "planes' own rates); its initial state is bounded by decaying Hölder sums (no table).", "",
             "| model | runs | outputs counted / all | effectivity median | max | violations | false alarms |",
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in sorted(per_model, key=lambda r: r["model"]):
        lines.append(f"| {r['model']} | {r['runs']} | {r['counted']} / {r['outputs']} | {_g(r['eff_median'])} | "
                     f"{_g(r['eff_max'])} | {r['violations']} / {r['points']} | {r['false_alarms']} |")
    lines += cost_lines(rows)
    lines += ["", "| scene | model | N, k_v, k_ρ, shadow | c, d | start | runs | effectivity median | max | "
              "violations | false alarms | max v error [m/s] | max v bound [m/s] | native doStep ratio | instruction ratio |",
              "| --- | --- | --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in table:
        lines.append(f"| {r['scene']} | {r['model']} | {r['N']}, {r['k_v']}, {r['k_rho']}, {r['shadow_order']} | "
                     f"{r['point']} | {r['start']} | {r['runs']} | {_g(r['eff_median'])} | {_g(r['eff_max'])} | "
                     f"{r['violations']} / {r['points']} | {r['false_alarms']} | {_g(r['max_err'], '.2e')} | "
                     f"{_g(r['max_bound'], '.2e')} | {_g(r.get('native_ratio', float('nan')), '.2f')} | "
                     f"{_g(r.get('instr_ratio', float('nan')), '.2f')} |")
    for n in notes:
        lines.append(_note_row(n, before=6, after=5))
    return lines + [""]


LARGE_HEADING = "## Certified error bounds at large N"
LARGE_T = 0.5            # [s] the large scenes' horizon (their training run)
LARGE_STEPS = 30         # communication steps of the certification run at large N


def large_scene(n):
    """damped_forced with ``n`` particles over LARGE_T, the symplectic integrator at a quarter of its stability
    limit 2 / ω_max (ω_max = π c^½ n / L estimated from the scene: the largest σ of K)."""
    from ..scene import derive_scene, load_scene
    base = load_scene("damped_forced")
    omega = np.pi * np.sqrt(0.1) * n / base.L * 1.2
    dt = 0.5 / omega
    steps = int(round(LARGE_T / dt))
    return derive_scene(base, {"name": f"damped_forced_n{n}", "domain": {"T": LARGE_T},
                               "sph": {"n_particles": n, "dt": LARGE_T / steps, "integrator": "symplectic",
                                       "every": max(1, steps // 50)},
                               "snapshots": {"count": 20, "window": [0.0, 0.8 * LARGE_T]}})


@contextlib.contextmanager
def _empty_cache(path):
    """SPHROM_CACHE set to the empty folder ``path`` inside the block (restored after)."""
    import os
    before = os.environ.get("SPHROM_CACHE")
    os.environ["SPHROM_CACHE"] = str(path)
    try:
        yield
    finally:
        if before is None:
            os.environ.pop("SPHROM_CACHE", None)
        else:
            os.environ["SPHROM_CACHE"] = before


def measure_large(sizes, folder, probes, repeats, progress=True, package_limit=None):
    """Rows (one per N) of the exact FMU of :func:`large_scene`: its packaging time (all of it, and the shadow's
    own: :func:`sphrom.rom.bounds.build_shadow` timed apart), the shadow's size and how many planes were computed,
    the doStep cost with and without the bounds, and a certification run (LARGE_STEPS steps of STEP from the
    initial state under the chirp, held) against :func:`sphrom.rom.reference.exact_probe_reference` (one case of
    :mod:`sphrom.rom.truth`: a Taylor series of the sparse operator above 500 particles): violations and
    effectivities.  Above ``package_limit`` particles (default the FMU's own limit,
    :data:`sphrom.rom.bounds.FMU_MAX_PARTICLES`: no shadow above it) no FMU (:func:`shadow_row`)."""
    if package_limit is None:
        from ..rom.bounds import FMU_MAX_PARTICLES as package_limit
    from ..fmu.make.build import ensure_binaries, fmu_binaries
    from ..fmu.make.package import package_fmu
    from ..rom.bounds import build_shadow
    from ..rom.reference import exact_probe_reference
    from ..sph.solver import build_problem
    out = []
    for n in sizes:
        scene = large_scene(n)
        problem = build_problem(scene)
        t0 = time.perf_counter()
        shadow = build_shadow(problem, probes)
        shadow_s = time.perf_counter() - t0
        if n > package_limit:
            out.append(shadow_row(problem, shadow, shadow_s, probes))
            print(f"N {n}: shadow {shadow_s:.1f} s (no FMU), violations {out[-1]['violations']}, certificate's "
                  f"effectivity max {out[-1]['eff_max']:.3g}", flush=True)
            continue
        path = Path(folder) / f"large-{n}.fmu"
        binaries = ensure_binaries(quiet=True)      # (built once per cache: not the packaging's time)
        with _empty_cache(Path(folder) / f"cache-{n}"):   # the SPH training run is part of the time, never cached
            fmu_binaries(binaries, quiet=True)      # ... the cross-compiled ones neither (win64: built per cache)
            t0 = time.perf_counter()
            s = package_fmu(scene, path, model="exact", fmi=2, progress=progress, binaries=binaries,
                            problem=problem, bounds=False)
            package_s = time.perf_counter() - t0
        with_ns, without_ns, _ = step_cost(path, repeats)
        t = np.arange(LARGE_STEPS + 1) * STEP
        f = forces(t, t[-1])["chirp"]
        t0 = time.perf_counter()
        v_t, rho_t = exact_probe_reference(problem, probes, t, f, 1.0)
        truth_s = time.perf_counter() - t0
        y, names, warned, tol = run_fmu(path, t, 1.0, f, False)
        metrics, bad, alarm = run_metrics(y, names, v_t, rho_t, None, warned, tol)
        eff = np.array([m[1] for m in metrics])
        eff = eff[np.isfinite(eff)]
        out.append({"N": n, "dt": scene.sph.dt, "package_s": package_s, "shadow_s": shadow_s,
                    "planes_s": shadow.info["timings"]["planes"], "method": shadow.info["method"],
                    **tail_columns(shadow),
                    "computed": shadow.info["computed_planes"], "shadow_order": s.shadow_order, "k_v": s.k_v,
                    "k_rho": s.k_rho, "step_ns_bounds": with_ns, "step_ns_plain": without_ns,
                    "cost_ratio": with_ns / without_ns, "violations": bad, "points": t.size, "false_alarm": alarm,
                    "eff_median": float(np.median(eff)) if eff.size else float("nan"),
                    "eff_max": float(eff.max()) if eff.size else float("nan"), "counted": int(eff.size),
                    "outputs": len(metrics), "truth_s": truth_s,
                    "max_err": max(m[2] for m in metrics if m[0].startswith("v_")),
                    "max_bound": max(m[3] for m in metrics if m[0].startswith("v_"))})
        print(f"N {n}: packaging {package_s:.1f} s (shadow {shadow_s:.1f} s), doStep {with_ns:.0f}/{without_ns:.0f} "
              f"ns, violations {bad}, effectivity max {out[-1]['eff_max']:.3g}", flush=True)
    return out


def tail_columns(shadow):
    """{tail_nodes, tail_s}: the uncomputed planes' free response computed (:func:`sphrom.rom.bounds.tail_table`):
    its nodes and seconds (0, 0: bounded by norms)."""
    table = shadow.info.get("tail_table")
    return {"tail_nodes": int(table["nodes"]) if table else 0,
            "tail_s": float(shadow.info["timings"].get("tail_table", 0.0))}


def shadow_row(problem, shadow, shadow_s, probes):
    """The row of N above the packaging limit: no FMU (packaging's SPH training run, the model and doStep are not
    measured), the shadow certified against the truth (the certification run of :func:`measure_large`).

    The model measured: the computed planes' response, the estimate of the same shadow built with the uncomputed
    planes' free response bounded through norms alone (``build_shadow(..., tail_response=False)``: a modal model of
    the lowest planes, exact in time).  Its bound is the FMUs' formula, |model - shadow's estimate| + certificate,
    with the shadow of :func:`sphrom.rom.bounds.build_shadow`; its effectivity per probe the largest bound over the
    run / the model's largest error.  Violations: points where the certificate is below the shadow's own error
    (``violations``) or the model's bound below its error (added).  Beside it (CSV): the norms-only shadow's own
    certificate against the same model's error (``eff_norms_*``: the row's former measure), the certificate and the
    shadow's own error (``cert_max``, ``shadow_err``)."""
    from ..rom.bounds import build_shadow, run_shadow
    from ..rom.reference import exact_probe_reference
    t = np.arange(LARGE_STEPS + 1) * STEP
    f = forces(t, t[-1])["chirp"]
    t0 = time.perf_counter()
    v_t, _ = exact_probe_reference(problem, probes, t, f, 1.0)
    truth_s = time.perf_counter() - t0
    steps, u, rate = np.full(LARGE_STEPS, STEP), f[:LARGE_STEPS, None], np.zeros((LARGE_STEPS, 1))
    y, cert = run_shadow(shadow, steps, u, rate, scale=1.0)
    model = build_shadow(problem, probes, tail_response=False)
    y_m, cert_m = run_shadow(model, steps, u, rate, scale=1.0)
    P = len(probes)
    err_s, cert = np.abs(y[:, :P] - v_t), cert[:, :P]
    err, bound = np.abs(y_m[:, :P] - v_t), np.abs(y_m[:, :P] - y[:, :P]) + cert
    floor = FLOOR * np.abs(v_t).max(axis=0)

    def eff(b, e):
        out = b.max(axis=0) / np.where(e.max(axis=0) > floor, e.max(axis=0), np.nan)
        return out[np.isfinite(out)]
    e_new, e_old = eff(bound, err), eff(cert_m[:, :P], err)
    nan = float("nan")
    return {"N": problem.n, "dt": problem.scene.sph.dt, "package_s": nan, "shadow_s": shadow_s,
            "planes_s": shadow.info["timings"]["planes"], "method": shadow.info["method"], **tail_columns(shadow),
            "computed": shadow.info["computed_planes"], "shadow_order": shadow.order, "k_v": "—", "k_rho": "—",
            "step_ns_bounds": nan, "step_ns_plain": nan, "cost_ratio": nan,
            "violations": int(np.sum(np.any((err_s > cert) | (err > bound), axis=1))),
            "points": t.size, "false_alarm": False, "eff_median": float(np.median(e_new)) if e_new.size else nan,
            "eff_max": float(e_new.max()) if e_new.size else nan, "counted": int(e_new.size), "outputs": P,
            "truth_s": truth_s, "max_err": float(err.max()), "max_bound": float(bound.max()), "shadow_only": True,
            "eff_norms_median": float(np.median(e_old)) if e_old.size else nan,
            "eff_norms_max": float(e_old.max()) if e_old.size else nan,
            "cert_max": float(cert.max()), "shadow_err": float(err_s.max())}


def _e(x):
    """2e8 for 2e+08."""
    mant, exp = f"{x:.0e}".split("e")
    return f"{mant}e{int(exp)}"


def large_section(rows, *, command, wall, machine):
    from ..rom.bounds import CHEBYSHEV_WORK, MAX_TAIL_NODES, TAIL_WORK
    from ..rom.planes import DENSE_LIMIT
    lines = [LARGE_HEADING, "",
             f"Produced by `{command}` ({machine}, {wall:.0f} s wall). The exact FMU of damped_forced with N "
             f"particles over T = {LARGE_T:g} s (symplectic SPH at a quarter of its stability limit; "
             "harness/bench/error_bounds.py `large_scene`). Packaging: `sphrom fmu`'s whole packaging with the "
             "bounds (the full SPH training run, the POD, the model, the shadow), one run; the shadow: "
             f"`build_shadow` timed apart (its planes: the dense SVD up to {DENSE_LIMIT} particles, the sparse "
             "shift-invert Lanczos solver above; the tail: the uncomputed planes' free response from x0 computed, "
             f"`tail_table`, by the full sparse system's Taylor propagation where N x nodes <= {_e(TAIL_WORK)}, else "
             f"by a Chebyshev expansion in K Kᵀ and Kᵀ K where N x its degree <= {_e(CHEBYSHEV_WORK)}, at most "
             f"{MAX_TAIL_NODES} nodes; tail nodes 0: bounded by norms). Certification: {LARGE_STEPS} steps of "
             f"{STEP * 1e3:g} ms from the initial "
             "state under the chirp, held, against the full linear SPH integrated exactly in time "
             "(`sphrom.rom.truth`, the truth packaging measures every FMU against: above 500 particles a "
             "Taylor series of the sparse operator to round-off). doStep: the C core's rom_do_step with and without "
             "the bounds' sections." + (
                 " Rows without packaging (N above `--package-limit`): no FMU (packaging's SPH training run grows "
                 "like N²); the model measured is the computed planes' response (the shadow's estimate with the "
                 "uncomputed planes' free response bounded through norms alone, `build_shadow(..., "
                 "tail_response=False)`: a modal model of the lowest planes, exact in time), its bound the FMUs' "
                 "formula |model − shadow's estimate| + certificate; violations count the certificate against the "
                 "shadow's own error too. " + "; ".join(
                     f"N = {r['N']}: that model's error against its own norms-only certificate, effectivity "
                     f"median {_g(r['eff_norms_median'])}, max {_g(r['eff_norms_max'])} (the row's measure before "
                     f"the tail's response was computed at this N); the certificate {_g(r['cert_max'], '.2e')} m/s "
                     f"against the shadow's own error {_g(r['shadow_err'], '.2e')} m/s"
                     for r in rows if r.get("shadow_only")) + "." if any(r.get("shadow_only") for r in rows) else ""),
             "",
             "| N | dt [s] | packaging [s] | shadow [s] (planes, tail) | planes computed, method | tail nodes | "
             "k_v, k_ρ | shadow order | "
             "doStep ns with / without | ratio | violations | effectivity median | max | max v error [m/s] | "
             "max v bound [m/s] |",
             "| ---: | ---: | ---: | ---: | --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in rows:
        lines.append(f"| {r['N']} | {r['dt']:.3g} | {_g(r['package_s'], '.1f')} | {r['shadow_s']:.1f} "
                     f"({r['planes_s']:.1f}, {r['tail_s']:.1f}) | {r['computed']}, {r['method']} | {r['tail_nodes']} | "
                     f"{r['k_v']}, {r['k_rho']} | "
                     f"{r['shadow_order']} | {_g(r['step_ns_bounds'], '.0f')} / {_g(r['step_ns_plain'], '.0f')} | "
                     f"{_g(r['cost_ratio'], '.2f')} | {r['violations']} / {r['points']} | {_g(r['eff_median'])} | "
                     f"{_g(r['eff_max'])} | {_g(r['max_err'], '.2e')} | {_g(r['max_bound'], '.2e')} |")
    return lines + [""]


def main(argv=None):
    from . import machine_text, program_command, program_parser
    from .lib.document import update_report
    from .lib.tables import write_csv
    from .. import defaults
    from ..parser import fmu_models, positive_int
    from ..scene import builtin_names, load_scene
    p = program_parser("error_bounds", description=__doc__.split("\n\n")[0])
    p.add_argument("scenes", nargs="*", metavar="SCENE",
                   help="a built-in scene or a scene's TOML file (default: every built-in scene)")
    p.add_argument("--models", type=fmu_models, default="frozen,exact,balanced", metavar="M1,M2")
    p.add_argument("--corpus", type=int_at_least(0), default=4, metavar="N", help="generated user scenes (default 4; 0: none)")
    p.add_argument("--span", type=positive_float, default=SPAN, metavar="S", help="runs over S x the scene's T (default 20)")
    p.add_argument("--repeats", type=positive_int, default=5, metavar="R")
    p.add_argument("--out", default="validation/benchmarks", metavar="FOLDER")
    p.add_argument("--report", default="BENCHMARKS.md", metavar="FILE.md")
    p.add_argument("--quiet", action="store_true")
    p.add_argument("--parametric", action="store_true",
                   help="the parametric FMUs (frozen, exact) at held-out (c, d): their own section")
    p.add_argument("--points", type=positive_int, default=2, metavar="P",
                   help="held-out (c, d) per scene with --parametric (default 2)")
    p.add_argument("--sizes", type=int_list(lo=16), default=None, metavar="N1,N2",
                   help="instead: the bounds at large N (e.g. 10000,100000): packaging time, cost, certification")
    p.add_argument("--package-limit", type=positive_int, default=None, metavar="N",
                   help="above N particles (with --sizes) the shadow alone, no FMU (default: the FMU's own limit, "
                        "above which it carries no bounds)")
    args = p.parse_args(argv)
    if args.sizes is not None:
        return main_large(args, list(args.sizes), argv)
    names = args.scenes or builtin_names()
    unknown = [s for s in names if s not in builtin_names() and not Path(s).is_file()]
    if unknown:
        p.error(f"SCENE: {unknown[0]!r} is neither a built-in scene nor a file (built-in: "
                f"{', '.join(builtin_names())})")
    scenes = [load_scene(s) for s in names] + (user_scenes(args.corpus) if not args.parametric else [])
    probes = defaults.PROBES
    t0 = time.perf_counter()
    rows, kept = [], {}
    measure = measure_parametric if args.parametric else measure_scene
    models = args.models
    if args.parametric:
        from ..rom.registry import get_model             # a parametric model is built on a POD basis
        models = [m for m in models if get_model(m).needs_basis]
    with tempfile.TemporaryDirectory(prefix="sphrom-error-bounds-") as folder:
        for scene in scenes:
            if args.parametric:
                got = measure(scene, models, args.points, folder, probes, args.span, repeats=args.repeats,
                              progress=not args.quiet)
            else:
                got, runs = measure(scene, models, args.repeats, folder, probes, args.span, progress=not args.quiet)
                kept.update(runs)
            rows += got
            for r in summarise(got, ("scene", "model")):
                print(f"{r['scene']:20s} {r['model']:9s} effectivity median {_g(r['eff_median'])} max "
                      f"{_g(r['eff_max'])} ({r['counted']} of {r['outputs']} outputs), violations {r['violations']}, "
                      f"false alarms {r['false_alarms']}", flush=True)
            for r in got:
                if r.get("note"):
                    print(f"{r['scene']:20s} {r['model']:9s} {'' if r.get('stopped') else 'not built: '}"
                          f"{r['note']}", flush=True)
    wall = time.perf_counter() - t0
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    notes = [r for r in rows if r.get("note")]
    done = [r for r in rows if not r.get("note")]
    command = program_command("error_bounds", argv)
    if args.parametric:
        write_csv(out / "error_bounds_parametric.csv", done)
        lines = parametric_section(done, notes, command=command, wall=wall, machine=machine_text(), span=args.span)
        update_report(args.report, {PARAMETRIC_HEADING: lines})
        print(f"wrote {out / 'error_bounds_parametric.csv'} and the section of {args.report}")
    else:
        write_csv(out / "error_bounds.csv", done)
        image = out / "error_bounds.png"
        keys = [k for k in kept if k[2] in ("two tones, held, initial state", "chirp, linear, rest")][:6]
        if keys:
            plot(kept, keys, image)
        lines = section(done, notes, command=command, wall=wall, machine=machine_text(), image=str(image),
                        span=args.span)
        update_report(args.report, {SECTION_HEADING: lines})
        print(f"wrote {out / 'error_bounds.csv'}, {image} and the section of {args.report}")
    return 0 if all(r["violations"] == 0 for r in done) else 1


def _stopped(row):
    """The note of a run the FMU stopped (its case and the FMU's reason), "" for a measured one."""
    return f"the run {row['case']} stopped: {row['stopped']}" if row.get("stopped") else ""


def _note_row(note, before, after):
    """A table row for a scene and model not built, or a run the FMU stopped: ``before`` and ``after`` empty cells
    ("—") around its reason."""
    text = note["note"] if note.get("stopped") else f"not built: {note['note']}"
    cells = [note["scene"], note["model"], *["—"] * before, text.replace("|", "/"), *["—"] * after]
    return "| " + " | ".join(cells) + " |"


def main_large(args, sizes, argv):
    """``--sizes``: the rows of :func:`measure_large`, their CSV and section."""
    from . import machine_text, program_command
    from .lib.document import update_report
    from .lib.tables import write_csv
    from .. import defaults
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="sphrom-error-bounds-large-") as folder:
        rows = measure_large(sizes, folder, defaults.PROBES, args.repeats, progress=not args.quiet,
                             package_limit=args.package_limit)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / "error_bounds_large.csv", rows)
    update_report(args.report, {LARGE_HEADING: large_section(rows, command=program_command("error_bounds", argv),
                                                             wall=time.perf_counter() - t0,
                                                             machine=machine_text())})
    print(f"wrote {out / 'error_bounds_large.csv'} and the section of {args.report}")
    return 0 if all(r["violations"] == 0 for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
