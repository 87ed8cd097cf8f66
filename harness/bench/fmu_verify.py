"""What ``sphrom fmu`` measures, for every built-in scene: the packaged FMU against the full SPH.

``python -m sphrom.bench.fmu_verify [SCENE ...] [--models frozen,exact] [--repeats R] [--out FOLDER]
[--report BENCHMARKS.md]`` packages each scene's FMU of each model (FMI 2, the scene's default settings, as
``sphrom fmu SCENE --model MODEL``), with the verification of :mod:`sphrom.fmu.check.verify` (the training force, a
step and an unseen sine, against the full SPH linear in J integrated exactly in time; errors of eq. 3.4 at the
probes; whether `sphrom fmu` accepts it by default), then times the training run of the
full SPH (its compiled loop) and of every model's FMU (fmpy on an instantiated FMU) in turn, ``repeats``
times (medians; the speed-up is the ratio of the medians taken in the same run).  The tolerance column
compares the FMU's training error with the full SPH's own error against the reference (the paper's figure,
the scene's ``paper.sph_error_v``): below it, the reduced model adds less than the SPH's own error.

Writes ``fmu_verify.csv`` into FOLDER and the section "The packaged FMU against the full SPH, every scene"
of the report (replaced when present, else put before the stress maps or at the end).
"""

from __future__ import annotations

import statistics
import sys
import tempfile
import time
from pathlib import Path

from ..fmu.make.build import ensure_binaries
from ..scene import builtin_names, load_scene
from . import machine_text, program_command, program_parser
from .lib.document import fmt, update_report
from .lib.tables import write_csv
from .lib.timing import median_times_interleaved

# The measuring modules (numba through the model code, scipy, fmpy, matplotlib) are imported inside the functions:
# `sphrom bench NAME --help` answers before they load (tests/test_bench_programs.py).

# Imported inside the functions: the modules that load numba, scipy or matplotlib (--help answers before they
# load: tests/test_bench_programs.py).

SECTION_HEADING = "## The packaged FMU against the full SPH, every scene"


def measure_scene(name, models, repeats, folder, fmi=2, progress=True, bounds=True):
    """Rows (one per model) of scene ``name``: errors of the verification, median times, speed-up.

    ``bounds=False`` packages the linear FMUs without their certified error bounds (``sphrom fmu --no-bounds``:
    they cost the full 2N linear system, minutes at N = 1000; the outputs do not depend on them)."""

    from ..fmu.check.verify import acceptance, fmu_features, fmu_run, sph_reference
    from ..fmu.make.package import package_fmu
    from ..sph.solver import build_problem
    scene = load_scene(name)
    problem = build_problem(scene)
    binaries = ensure_binaries(quiet=True)
    summaries, refs = [], None
    for model in models:
        s = package_fmu(scene, Path(folder) / f"{name}-{model}.fmu", model=model, fmi=fmi, progress=progress,
                        binaries=binaries, problem=problem, verify=True, accept=False, references=refs,
                        bounds=bounds)
        refs = s.verification.refs
        summaries.append(s)
    first = summaries[0].verification
    force, scale, _, (t, *_) = refs["training"]
    values = scene.force(t)
    sph_times, fmu_times = [], {s.model: [] for s in summaries}

    def sph():
        sph_times.append(sph_reference(scene, force, scale, first.step, first.probes, problem=problem)[-1])

    def fmu(summary):
        has_scale = fmu_features(summary.path)[0]
        interpolate = summary.verification.input != "held"
        return lambda: fmu_times[summary.model].append(
            fmu_run(summary.path, values, t, scale=1.0 if has_scale else None, interpolate=interpolate)[-1])

    median_times_interleaved([sph] + [fmu(s) for s in summaries], repeats=repeats, warmup=0)
    sph_s = statistics.median(sph_times)
    tol = scene.paper.get("sph_error_v")
    rows = []
    for s in summaries:
        v = s.verification
        fmu_s = statistics.median(fmu_times[s.model])
        rows.append({"scene": name, "model": s.model, "k": s.k, "k_v": s.k_v, "k_rho": s.k_rho,
                     "N": scene.sph.n_particles, "T": scene.T, "step": v.step, "input": v.input,
                     "train_err_v": v.training.err_v, "train_err_rho": v.training.err_rho,
                     "unseen_force": v.unseen.force, "unseen_start": v.unseen.start,
                     "unseen_err_v": v.unseen.err_v, "unseen_err_rho": v.unseen.err_rho,
                     "unseen_max_drho": v.unseen.max_drho, "step_err_v": v.case("step").err_v,
                     "accepted": acceptance(v, None, s.model) is None,
                     "fmu_s": fmu_s, "sph_s": sph_s, "speedup": sph_s / fmu_s, "repeats": repeats,
                     "tolerance": tol, "meets": None if tol is None else bool(v.training.err_v <= tol),
                     "note": "; ".join(c.note for c in v.cases if c.note)})
    return rows


def packaged_fmu_section(rows, *, command, repeats, wall, machine):
    """The packaged FMU against the full SPH for every scene and model (rows of
    :func:`measure_scene`): what ``sphrom fmu`` measures and stores in each FMU."""
    lines = [SECTION_HEADING, "",
             f"Produced by `{command}` ({machine}, {wall:.0f} s wall). Each scene's FMU (FMI 2, the scene's "
             "default k, n_freeze = 10, probes x/L = 0.25, 0.5, 0.66), as `sphrom fmu SCENE --model MODEL` "
             "builds and measures it: co-simulated through fmpy at its default communication step (f at the "
             "points, held, or linear with df/dt where the FMU declares canInterpolateInputs) against the full "
             "SPH linear in J, integrated exactly in time with the same input (harness/rom/truth.py), "
             "relative L² errors of eq. 3.4 at the probes (v; ρ as ρ − ρ0). Training: the scene's force and "
             "initial state. Step: a constant (the training force's peak, or max|v0|/T) from rest. Unseen: "
             "A sin(2π ν_u t), ν_u = 2.2 ν_1 (A: the training force's peak, or 2π ν_u max|v0| for a free scene), "
             "from the start given in the table. Accepted: v error at most 0.1 on every case, what `sphrom fmu` "
             "requires by default (docs/fmu/index.md). Times: medians of "
             f"{repeats} runs of the training case, timed in turn in one run, setup excluded (the FMU through "
             "fmpy on an instantiated FMU, Python's per-step overhead included; the full SPH's compiled time "
             "loop); speed-up = full SPH / FMU. Tolerance: the full SPH's own v error against the reference "
             "(the paper's, `paper.sph_error_v`): met when the FMU adds less than that. A uniform force from rest "
             "moves the bar rigidly: the full SPH's ρ − ρ0 is then 0 (no relative error, —) and the largest "
             "|ρ − ρ_SPH| at the probes says how much density the FMU makes up.", "",
             "| scene | model | k_v, k_ρ | h [s] | training: v | ρ − ρ0 | step: v | unseen: v | ρ − ρ0 | max abs(ρ − "
             "ρ_true) [kg/m³] | unseen from | accepted | FMU [s] | full SPH [s] | speed-up | tolerance | met |",
             "| --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- | --- | ---: | ---: | ---: | ---: "
             "| --- |"]
    for r in rows:
        met = "—" if r["meets"] is None else ("yes" if r["meets"] else "**no**")
        accepted = "yes" if r.get("accepted") in (True, "True") else "**no**"
        lines.append(f"| {r['scene']} | {r['model']} | {r['k_v']}, {r['k_rho']} | {r['step']:g} | "
                     f"{fmt(r['train_err_v'])} | {fmt(r['train_err_rho'])} | {fmt(r.get('step_err_v'))} | "
                     f"{fmt(r['unseen_err_v'])} | {fmt(r['unseen_err_rho'])} | "
                     f"{fmt(r.get('unseen_max_drho'), '.2e')} | {r['unseen_start']} | {accepted} | {r['fmu_s']:.4f} | "
                     f"{r['sph_s']:.4f} | {r['speedup']:.1f}× | {fmt(r['tolerance'], '.3g')} | {met} |")
    notes = [f"{r['scene']} {r['model']}: {r['note']}" for r in rows if r.get("note")]
    if notes:
        lines += ["", "FMU failures: " + "; ".join(notes) + "."]
    return lines + [""]


def main(argv=None):
    p = program_parser("fmu_verify", description=__doc__.split("\n\n")[0])
    p.add_argument("scenes", nargs="*", metavar="SCENE", help="default: every built-in scene")
    p.add_argument("--models", metavar="M1,M2", help="default: every model with an FMU")
    p.add_argument("--repeats", type=int, default=3, metavar="R")
    p.add_argument("--out", default="validation/benchmarks", metavar="FOLDER")
    p.add_argument("--report", default="BENCHMARKS.md", metavar="FILE.md")
    p.add_argument("--no-bounds", action="store_true",
                   help="package the linear FMUs without their error bounds (as sphrom fmu --no-bounds)")
    p.add_argument("--quiet", action="store_true")
    args = p.parse_args(argv)
    from ..rom.registry import fmu_model_names
    scenes = args.scenes or builtin_names()
    models = [m for m in (args.models or ",".join(fmu_model_names())).split(",") if m]
    t0 = time.perf_counter()
    rows = []
    with tempfile.TemporaryDirectory(prefix="sphrom-fmu-verify-") as folder:
        for name in scenes:
            for r in measure_scene(name, models, args.repeats, folder, progress=not args.quiet,
                                   bounds=not args.no_bounds):
                rows.append(r)
                print(f"{r['scene']:20s} {r['model']:7s} training v {r['train_err_v']:.3e}  unseen v "
                      f"{r['unseen_err_v']:.3e}  FMU {r['fmu_s']:.4f} s  SPH {r['sph_s']:.4f} s  "
                      f"{r['speedup']:.3g}x", flush=True)
    wall = time.perf_counter() - t0
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / "fmu_verify.csv", rows)
    lines = packaged_fmu_section(rows, command=program_command("fmu_verify", argv), repeats=args.repeats, wall=wall,
                                 machine=machine_text())
    report = update_report(args.report, {SECTION_HEADING: lines})
    print(f"wrote {out / 'fmu_verify.csv'} and the section of {report} ({wall:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
