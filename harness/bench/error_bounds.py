"""The certified error bounds of the FMUs' outputs, measured: effectivity (bound / true error) and cost.

``sphrom bench error_bounds [SCENE ...] [--models frozen,exact,balanced] [--repeats R] [--out FOLDER]
[--report BENCHMARKS.md]`` packages each scene's FMU of each model (FMI 2, the scene's defaults, without the a
priori bounds) and drives it, its inputs held over 10 ms steps over the scene's T, with five forces no basis saw
(:data:`FORCES`) from initial_state_scale 0, 1 and 3.  The truth is the full SPH of eqs. 2.10-2.11 as the linear
system in J (:mod:`sphrom.rom.lti`), advanced exactly over each step (the matrix exponential of the system
augmented with the held input), independent of every reduced model and of the bounds' shadow: v at the probes,
and ρ = ρ0 / (1 + e) at the particles, both interpolated linearly at the probes as the FMU does.

Per scene, model and scale: the communication points where a bound is below the true error (certification:
must be 0), and the effectivity bound / |error| of v_probe_j over every point where the error exceeds 10⁻³ of
its largest in that run (median, 90th percentile, max over the runs of the five forces), the largest error and
bound.  Cost: the C core's doStep (``rom_do_step`` through ctypes, no FMI or Python in the loop) on the same model
with and without the bounds' sections, median of ``repeats`` runs of the scene's 1000 steps, timed in turn.

Writes ``error_bounds.csv`` and ``error_bounds.png`` (bound and true error against time of one run) into FOLDER,
and the section "Certified error bounds" of the report.

``--parametric`` measures the parametric FMUs instead (frozen and exact, ``--vary`` c over [c/2, 2c] and d over
[d/2, 3d/2], [0, 5] s⁻¹ for an undamped scene, about the scene's c and d; :data:`PARAMETRIC_SPAN`): the same
forces and scales at ``--points`` held-out (c, d) of the box (:func:`sphrom.rom.parametric.held_out_points`),
the truth the full linear SPH with that c and d; writes ``error_bounds_parametric.csv`` and the section
"Certified error bounds of parametric FMUs" (no cost columns: the doStep is the ordinary one's, the planes
assembled once at initialization).
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

SECTION_HEADING = "## Certified error bounds"
PARAMETRIC_HEADING = "## Certified error bounds of parametric FMUs"
PARAMETRIC_SPAN = {"c": (0.5, 2.0), "d": (0.5, 1.5)}   # the trained box: these x the scene's c and d
UNDAMPED_D_RANGE = (0.0, 5.0)                           # [s^-1] d's range of an undamped scene
STEP = 0.01             # [s] communication step
SCALES = (0.0, 1.0, 3.0)
FLOOR = 1e-3            # effectivity where |error| > FLOOR x its largest in the run
CHUNK = 20              # doStep calls timed together (the cost's medians are over such chunks)


def forces(t, T):
    """Five forces no basis saw [m s^-2] (a constant, a slow sine, a step, a chirp, two tones)."""
    return {"constant 2e-3": 2e-3 * np.ones_like(t),
            "slow sine": 1e-2 * np.sin(2 * np.pi * 0.3 * t),
            "step at T/3": 3e-3 * (t > T / 3),
            "chirp": 5e-3 * np.sin(2 * np.pi * (0.5 + 0.2 * t) * t),
            "two tones": 4e-3 * (np.sin(2 * np.pi * 1.3 * t) + 0.5 * np.sin(2 * np.pi * 4.1 * t + 1.0))}


def truth_runs(problem, probes, t, fs):
    """{name: (v (M+1, P), e at the particles (M+1, N))} of the full linear SPH from rest under each force of
    ``fs`` (held over the steps), and "free": the free response from the scene's initial state; exact in time."""
    import scipy.linalg as sla

    from ..rom.lti import full_linear_system, probe_matrix
    lti = full_linear_system(problem, probes)
    n = problem.rho0.size
    A = lti.A.toarray()
    M = np.zeros((2 * n + 1, 2 * n + 1))
    M[:2 * n, :2 * n] = A * STEP
    M[:2 * n, 2 * n] = lti.B[:, 0] * STEP
    E = sla.expm(M)
    Phi, g = E[:2 * n, :2 * n], E[:2 * n, 2 * n]
    rows = probe_matrix(problem.x, problem.scene.L, probes, np.ones(n))
    out = {}
    for name, (x0, f) in {"free": (lti.x0, np.zeros_like(t)), **{k: (0 * lti.x0, f) for k, f in fs.items()}}.items():
        X = np.empty((t.size, 2 * n))
        X[0] = x0
        for j in range(t.size - 1):
            X[j + 1] = Phi @ X[j] + g * f[j]
        out[name] = ((X[:, :n] / np.sqrt(problem.rho0)) @ rows.T, X[:, n:] / np.sqrt(problem.c))
    return out, rows


def effectivities(bound, err):
    mask = err > FLOOR * err.max() if err.max() > 0 else np.zeros(err.shape, bool)
    return bound[mask] / err[mask]


def measure_model(path, problem, scale, fs, truths, rows, t, parameters=None):
    """Per force: (violations, points, effectivities, max error, max bound, the run's v, bound, truth);
    ``parameters``: more start values (a parametric FMU's c and d)."""
    from ..fmu.run.driver import FMU
    from ..fmu.variables import members
    out = []
    v_free, e_free = truths["free"]
    for name, f in fs.items():
        with FMU(path) as fmu:
            fmu.initialize(parameters={"initial_state_scale": scale, **(parameters or {})}, inputs={"f": float(f[0])})
            y = fmu.simulate(t, {"f": f})
            names = fmu.outputs
        v_t = scale * v_free + truths[name][0]
        rho_t = (problem.rho0 / (1.0 + scale * e_free + truths[name][1])) @ rows.T
        v, vb = y[:, members(names, "v_probe_j")], y[:, members(names, "v_probe_j_error_bound")]
        rho, rb = y[:, members(names, "rho_probe_j")], y[:, members(names, "rho_probe_j_error_bound")]
        ev, er = np.abs(v - v_t), np.abs(rho - rho_t)
        bad = int(np.sum(np.any(vb < ev, axis=1) | np.any(rb < er, axis=1)))
        out.append((name, bad, t.size, effectivities(vb, ev), float(ev.max()), float(vb.max()), (v, vb, v_t)))
    return out


def warning_cases(path, problem, t, training, truths, rows):
    """The error signal at the default error_tolerance: the training run (the scene's force from its initial
    state; its largest true v error relative to the largest |v|) and f = 1e-3 from rest: the warnings logged."""
    from ..fmu.run.driver import FMU
    from ..fmu.variables import members
    out = {}
    for case, scale, f in (("training", 1.0, training), ("small", 0.0, np.full_like(t, 1e-3))):
        with FMU(path) as fmu:
            fmu.initialize(parameters={"initial_state_scale": scale}, inputs={"f": float(f[0])})
            y = fmu.simulate(t, {"f": f})
            tolerance = fmu.get_real([fmu.vr["error_tolerance"]])[0]
            warned = fmu.warnings()
            names = fmu.outputs
        v_t = scale * truths["free"][0] + truths[case][0]
        out[f"{case}_rel_err"] = float(np.abs(y[:, members(names, "v_probe_j")] - v_t).max()
                                       / max(np.abs(v_t).max(), 1e-300))
        out[f"{case}_warning"] = warned[0] if warned else ""
        out["tolerance"] = tolerance
    return out


def step_cost(path, repeats, n_steps):
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


def measure_scene(name, models, repeats, folder, progress=True):
    """Rows (one per model and scale) of scene ``name`` and the runs kept for the plot."""
    from ..fmu.make.build import ensure_binaries
    from ..fmu.make.package import package_fmu
    from ..scene import load_scene
    from ..sph.solver import build_problem
    from .. import defaults
    scene = load_scene(name)
    problem = build_problem(scene)
    probes = defaults.PROBES
    t = np.arange(int(round(scene.T / STEP)) + 1) * STEP
    fs = forces(t, scene.T)
    training = np.broadcast_to(np.asarray(scene.force(t), float), t.shape).copy()
    truths, rows = truth_runs(problem, probes, t, {**fs, "training": training, "small": np.full_like(t, 1e-3)})
    binaries = ensure_binaries(quiet=True)
    out, kept = [], {}
    for model in models:
        path = Path(folder) / f"{name}-{model}.fmu"
        try:
            s = package_fmu(scene, path, model=model, fmi=2, progress=progress, binaries=binaries,
                            problem=problem, bounds=False)
        except Exception as exc:                     # a model that does not build on this scene: say so
            out.append({"scene": name, "model": model, "note": str(exc).splitlines()[0]})
            continue
        with_ns, without_ns, loop_ns = step_cost(path, repeats, t.size - 1)
        signal = warning_cases(path, problem, t, training, truths, rows)
        for scale in SCALES:
            runs = measure_model(path, problem, scale, fs, truths, rows, t)
            eff = np.concatenate([r[3] for r in runs])
            out.append({"scene": name, "model": model, "k_v": s.k_v, "k_rho": s.k_rho, "N": problem.rho0.size,
                        "scale": scale, "violations": sum(r[1] for r in runs), "points": sum(r[2] for r in runs),
                        "eff_median": float(np.median(eff)) if eff.size else float("nan"),
                        "eff_p90": float(np.percentile(eff, 90)) if eff.size else float("nan"),
                        "eff_max": float(eff.max()) if eff.size else float("nan"),
                        "max_err": max(r[4] for r in runs), "max_bound": max(r[5] for r in runs),
                        "step_ns_bounds": with_ns, "step_ns_plain": without_ns, "loop_ns": loop_ns,
                        "cost_ratio": with_ns / without_ns,
                        "cost_ratio_core": (with_ns - loop_ns) / max(without_ns - loop_ns, 1e-9), **signal,
                        "note": ""})
            kept[(name, model, scale)] = runs
    return out, kept


def parametric_ranges(problem):
    """The trained box of a parametric FMU about the scene's uniform c and d (:data:`PARAMETRIC_SPAN`)."""
    from ..rom.parametric import Range
    c, d = float(problem.c[0]), float(problem.d[0])
    lo, hi = PARAMETRIC_SPAN["c"]
    out = [Range("c", lo * c, hi * c)]
    lo, hi = PARAMETRIC_SPAN["d"]
    out.append(Range("d", lo * d, hi * d) if d > 0 else Range("d", *UNDAMPED_D_RANGE))
    return out


def measure_parametric(name, models, points, folder, progress=True):
    """Rows (one per model, held-out point and scale) of the parametric FMUs of scene ``name``: certification and
    effectivity against the full linear SPH with the point's c and d."""
    from ..fmu.make.build import ensure_binaries
    from ..fmu.make.package import package_fmu
    from ..rom import parametric as par
    from ..scene import derive_scene, load_scene
    from ..sph.solver import build_problem
    from .. import defaults
    scene = load_scene(name)
    problem = build_problem(scene)
    probes = defaults.PROBES
    t = np.arange(int(round(scene.T / STEP)) + 1) * STEP
    fs = forces(t, scene.T)
    ranges = parametric_ranges(problem)
    try:
        held = par.held_out_points(par.parameter_space(problem, ranges), points)
    except Exception as exc:                         # a scene that cannot be parametric (c not uniform): say so
        return [{"scene": name, "model": ", ".join(models), "note": str(exc).splitlines()[0]}]
    at = {}
    for c, d in held:
        problem_cd = build_problem(derive_scene(scene, {"fields": {"c": repr(float(c)), "d": repr(float(d))}}))
        at[(c, d)] = (problem_cd, *truth_runs(problem_cd, probes, t, fs))
    binaries = ensure_binaries(quiet=True)
    out = []
    for model in models:
        path = Path(folder) / f"{name}-{model}-parametric.fmu"
        try:
            s = package_fmu(scene, path, model=model, fmi=2, progress=progress, binaries=binaries, vary=ranges)
        except Exception as exc:                     # a model that does not build on this scene: say so
            out.append({"scene": name, "model": model, "note": str(exc).splitlines()[0]})
            continue
        for (c, d), (problem_cd, truths, rows) in at.items():
            for scale in SCALES:
                runs = measure_model(path, problem_cd, scale, fs, truths, rows, t, parameters={"c": c, "d": d})
                eff = np.concatenate([r[3] for r in runs])
                out.append({"scene": name, "model": model, "k_v": s.k_v, "k_rho": s.k_rho, "N": problem.rho0.size,
                            "c_range": f"{ranges[0].lo:g}:{ranges[0].hi:g}",
                            "d_range": f"{ranges[1].lo:g}:{ranges[1].hi:g}", "c": float(c), "d": float(d),
                            "scale": scale, "violations": sum(r[1] for r in runs),
                            "points": sum(r[2] for r in runs),
                            "eff_median": float(np.median(eff)) if eff.size else float("nan"),
                            "eff_p90": float(np.percentile(eff, 90)) if eff.size else float("nan"),
                            "eff_max": float(eff.max()) if eff.size else float("nan"),
                            "max_err": max(r[4] for r in runs), "max_bound": max(r[5] for r in runs), "note": ""})
    return out


def parametric_section(rows, *, command, wall, machine):
    lines = [PARAMETRIC_HEADING, "",
             f"Produced by `{command}` ({machine}, {wall:.0f} s wall). Each scene's parametric FMU (FMI 2, "
             "`--vary c=c/2:2c --vary d=d/2:3d/2`, d in [0, 5] s⁻¹ for an undamped scene) at held-out (c, d) of its "
             "box (Halton points, neither the scene's nor a training point), under the five forces and the three "
             "initial_state_scales of the section above. Truth: the full linear SPH (eqs. 2.10-2.11 in J) with that c "
             "and d, exact in time. The parametric bound is looser by construction: the complement's initial state "
             "is bounded for all time (one Hölder value, no decay table) and its forced part by the energy "
             "(no step-response gains), both valid for every (c, d) of the box.", "",
             "| scene | model | N | k_v, k_ρ | c | d | scale | violations | effectivity median | p90 | max | "
             "max error [m/s] | max bound [m/s] |",
             "| --- | --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in rows:
        if r.get("note"):
            lines.append(f"| {r['scene']} | {r['model']} | — | — | — | — | — | not built: "
                         f"{r['note'].replace('|', '/')} | — | — | — | — | — |")
            continue
        lines.append(f"| {r['scene']} | {r['model']} | {r['N']} | {r['k_v']}, {r['k_rho']} | {r['c']:.4g} | "
                     f"{r['d']:.4g} | {r['scale']:g} | {r['violations']} / {r['points']} | {_g(r['eff_median'])} | "
                     f"{_g(r['eff_p90'])} | {_g(r['eff_max'])} | {_g(r['max_err'], '.2e')} | "
                     f"{_g(r['max_bound'], '.2e')} |")
    return lines + [""]


def plot(kept, key, path):
    """Bound and true error of v_probe_1 against time for the runs of ``key`` (scene, model, scale)."""
    from matplotlib.figure import Figure
    runs = kept[key]
    fig = Figure(figsize=(8, 4.5))
    ax = fig.add_subplot(1, 1, 1)
    t = np.arange(runs[0][6][0].shape[0]) * STEP
    for (name, *_, (v, vb, v_t)), color in zip(runs, ("C0", "C1", "C2", "C3", "C4")):
        ax.semilogy(t, np.abs(v[:, 0] - v_t[:, 0]), color=color, lw=1, label=f"|error| {name}")
        ax.semilogy(t, vb[:, 0], color=color, lw=1, ls="--")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("v_probe_1: |error| (solid), certified bound (dashed) [m/s]")
    ax.set_title(f"{key[0]}, {key[1]} FMU, initial_state_scale {key[2]:g}")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def _g(x, spec=".3g"):
    return "—" if x is None or (isinstance(x, float) and not np.isfinite(x)) else format(x, spec)


def section(rows, *, command, wall, machine, image):
    lines = [SECTION_HEADING, "",
             f"Produced by `{command}` ({machine}, {wall:.0f} s wall). Each scene's FMU (FMI 2, the scene's "
             f"defaults) over its T at communication steps of {STEP * 1e3:g} ms, inputs held, under five forces "
             "no basis saw (a constant, a slow sine, a step, a chirp, two tones; harness/bench/error_bounds.py "
             "FORCES) from initial_state_scale 0, 1 and 3. Truth: the full SPH of eqs. 2.10-2.11, linear in J, "
             "advanced exactly in time with the same held inputs (independent of every reduced model and of the "
             "bounds). Violations: communication points where a v or ρ bound is below the true error (of all "
             "points of the five runs). Effectivity: v_probe_j's bound / |error| at the points where the error "
             f"exceeds {FLOOR:g} of its largest in the run (median, 90th percentile, max over the five runs). "
             "doStep cost: the C core's rom_do_step called through ctypes on the same model with and without the "
             f"bounds' sections (ns per step: medians over chunks of {CHUNK} steps, the two models' chunks timed in "
             "turn; no FMI); the ratio, and the ratio with the loop's own cost (a trivial core call per step, "
             "measured in the same run) taken out of both.", "",
             f"![bound and error]({image})", "",
             "| scene | model | N | k_v, k_ρ | scale | violations | effectivity median | p90 | max | max error "
             "[m/s] | max bound [m/s] | doStep ns with / without | cost ratio | without the loop |",
             "| --- | --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in rows:
        if r.get("note"):
            lines.append(f"| {r['scene']} | {r['model']} | | | | not built: {r['note'].replace('|', '/')} "
                         "| | | | | | | | |")
            continue
        lines.append(f"| {r['scene']} | {r['model']} | {r['N']} | {r['k_v']}, {r['k_rho']} | {r['scale']:g} | "
                     f"{r['violations']} / {r['points']} | {_g(r['eff_median'])} | {_g(r['eff_p90'])} | "
                     f"{_g(r['eff_max'])} | {_g(r['max_err'], '.2e')} | {_g(r['max_bound'], '.2e')} | "
                     f"{r['step_ns_bounds']:.0f} / {r['step_ns_plain']:.0f} | {r['cost_ratio']:.2f} | "
                     f"{r['cost_ratio_core']:.2f} |")
    lines += ["", "The error signal at the default `error_tolerance` (5 % of the training run's largest |v_probe|): the "
              "training run (the scene's force from its initial state; its largest true v error relative to the "
              "largest |v|) and f = 1e-3 from rest (the quickstart's `sphrom cosim FMU --force 1e-3`): the warning "
              "logged, or none.", "",
              "| scene | model | error_tolerance [m/s] | training: max error / max abs(v) | training: warning | "
              "f = 1e-3 from rest: max error / max abs(v) | warning |",
              "| --- | --- | ---: | ---: | --- | ---: | --- |"]
    for r in rows:
        if r.get("note") or r.get("scale") != 1.0:
            continue
        lines.append(f"| {r['scene']} | {r['model']} | {r['tolerance']:.3g} | {r['training_rel_err']:.3g} | "
                     f"{_quote(r['training_warning'])} | {r['small_rel_err']:.3g} | {_quote(r['small_warning'])} |")
    return lines + [""]


def _quote(text):
    """A warning in a table cell: its substance after the function name, or 'none'."""
    return text.split(": ", 1)[-1].replace("|", "/") if text else "none"


def main(argv=None):
    from .lib.document import update_report
    from .lib.tables import write_csv
    from ..parser import fmu_models, positive_int
    from ..scene import builtin_names
    from . import machine_text, program_command, program_parser
    p = program_parser("error_bounds", description=__doc__.split("\n\n")[0])
    p.add_argument("scenes", nargs="*", metavar="SCENE", help="default: every built-in scene")
    p.add_argument("--models", type=fmu_models, default="frozen,exact,balanced", metavar="M1,M2")
    p.add_argument("--repeats", type=positive_int, default=5, metavar="R")
    p.add_argument("--out", default="validation/benchmarks", metavar="FOLDER")
    p.add_argument("--report", default="BENCHMARKS.md", metavar="FILE.md")
    p.add_argument("--quiet", action="store_true")
    p.add_argument("--parametric", action="store_true",
                   help="the parametric FMUs (frozen, exact) at held-out (c, d): their own section")
    p.add_argument("--points", type=positive_int, default=2, metavar="P",
                   help="held-out (c, d) per scene with --parametric (default 2)")
    args = p.parse_args(argv)
    scenes = args.scenes or builtin_names()
    unknown = [s for s in scenes if s not in builtin_names()]
    if unknown:
        p.error(f"SCENE: {unknown[0]!r} is not a built-in scene (allowed: {', '.join(builtin_names())})")
    models = args.models
    if args.parametric:
        from ..rom.registry import get_model            # a parametric model is built on a POD basis
        return main_parametric(args, scenes, [m for m in models if get_model(m).needs_basis], argv)
    t0 = time.perf_counter()
    rows, kept = [], {}
    with tempfile.TemporaryDirectory(prefix="sphrom-error-bounds-") as folder:
        for name in scenes:
            got, runs = measure_scene(name, models, args.repeats, folder, progress=not args.quiet)
            rows += got
            kept.update(runs)
            for r in got:
                if r.get("note"):
                    print(f"{r['scene']:20s} {r['model']:9s} not built: {r['note']}", flush=True)
                    continue
                print(f"{r['scene']:20s} {r['model']:9s} scale {r['scale']:g}: violations {r['violations']}, "
                      f"effectivity median {r['eff_median']:.3g} max {r['eff_max']:.3g}, max error "
                      f"{r['max_err']:.2e}, doStep {r['step_ns_bounds']:.0f}/{r['step_ns_plain']:.0f} ns", flush=True)
    wall = time.perf_counter() - t0
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / "error_bounds.csv", rows)
    key = next((k for k in [("tenmode", "frozen", 1.0)] + list(kept) if k in kept), None)
    image = out / "error_bounds.png"
    if key is not None:
        plot(kept, key, image)
    lines = section(rows, command=program_command("error_bounds", argv), wall=wall, machine=machine_text(),
                    image=str(image))
    update_report(args.report, {SECTION_HEADING: lines})
    print(f"wrote {out / 'error_bounds.csv'}, {image} and the section of {args.report}")
    return 0


def main_parametric(args, scenes, models, argv):
    """``--parametric``: the rows of :func:`measure_parametric`, their CSV and section."""
    from . import machine_text, program_command
    from .lib.document import update_report
    from .lib.tables import write_csv
    t0 = time.perf_counter()
    rows = []
    with tempfile.TemporaryDirectory(prefix="sphrom-error-bounds-") as folder:
        for name in scenes:
            got = measure_parametric(name, models, args.points, folder, progress=not args.quiet)
            rows += got
            for r in got:
                if r.get("note"):
                    print(f"{r['scene']:20s} {r['model']:9s} not built: {r['note']}", flush=True)
                    continue
                print(f"{r['scene']:20s} {r['model']:9s} c {r['c']:.4g} d {r['d']:.4g} scale {r['scale']:g}: "
                      f"violations {r['violations']}, effectivity median {r['eff_median']:.3g} max "
                      f"{r['eff_max']:.3g}, max error {r['max_err']:.2e}", flush=True)
    wall = time.perf_counter() - t0
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / "error_bounds_parametric.csv", rows)
    lines = parametric_section(rows, command=program_command("error_bounds", argv), wall=wall,
                               machine=machine_text())
    update_report(args.report, {PARAMETRIC_HEADING: lines})
    print(f"wrote {out / 'error_bounds_parametric.csv'} and the section of {args.report}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
