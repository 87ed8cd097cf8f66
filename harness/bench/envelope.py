"""Where the frozen model leaves its envelope: probe error against the full SPH as the amplitude grows.

The scene's initial velocity is scaled by s (the density starts at ρ0, as the FMU's
``initial_state_scale``); the full SPH runs the scaled scene, the reduced models start from the
scaled coordinates on the x1 basis (the FMU's basis: what it was trained on).  Per s it records the
relative L² error of the probe velocities against the full SPH (frozen: n_freeze = 10, the scene's
FMU's integrator (``sphrom fmu``'s default: :func:`sphrom.fmu.kinds.frozen.open_ended_integrator`) and the
scene's Δt; exact: the exact linear model, scale invariant, whose error moves only with the
full SPH's departure from linearity in J, its time stepping of ρ), the peak strain |ρ0/ρ - 1| of the full SPH at the particles and at the
probes, and the frozen run's largest coordinate excess beyond the trained ranges in units of its
block's largest half-width (the quantity the FMU's coordinate check compares with margin - 1,
:mod:`sphrom.fmu.training.envelope`).  Run as::

    python -m sphrom.bench.envelope [SCENE ...] [--scales 1,1.5,...] [--out validation/benchmarks/envelope.csv]
                                     [--report BENCHMARKS.md]

It writes the CSV and a PNG of error against peak probe strain beside it, and its section of
BENCHMARKS.md (``sphrom bench --report`` carries it over).  It
also measures the headroom of every built-in scene's frozen model on its own training run (the FMU's
settings: k = the scene's largest rom.accel_modes, n_freeze = 10, the scene's force): the largest
coordinate excess (the check allows margin - 1) and the largest probe strain over the trained one (the
check allows the margin), in ``envelope_training.csv`` beside the CSV.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from .. import defaults
from ..fmu.resources import probe_pairs
from ..markdown import write_text
from ..norms import relative_l2
from ..progress import progress_bar
from ..runio import atomic_path
from ..scene import builtin_names, derive_scene, load_scene
from . import program_parser
from .lib.document import replace_section
from .lib.tables import write_csv

# The measuring modules (numba through the model code, scipy, fmpy, matplotlib) are imported inside the functions:
# `sphrom bench NAME --help` answers before they load (tests/test_bench_programs.py).

# Imported inside the functions: the modules that load numba, scipy or matplotlib (--help answers before they
# load: tests/test_bench_programs.py).

SCALES = (1.0, 1.25, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0)
PROBES = defaults.PROBES
N_FREEZE = defaults.N_FREEZE
FAILURE_ERROR = 0.5      # the frozen model has failed where its probe error reaches this


def _probe(field, x, L):
    i0, i1, w = probe_pairs(x, L, PROBES)
    return (1.0 - w) * field[..., i0] + w * field[..., i1]


def fmu_integrator(ops, scene):
    """The integrator ``sphrom fmu`` gives the frozen FMU of ``scene`` when no integrator is named: the scene's,
    or symplectic Euler where the scene's explicit Euler grows a reduced mode
    (:func:`sphrom.fmu.kinds.frozen.open_ended_integrator`)."""
    from ..fmu.kinds.frozen import default_integrator, open_ended_integrator
    return open_ended_integrator(ops, scene.sph.dt, default_integrator(scene))


def coordinate_excess(env, z, k_v):
    """max over samples and coordinates of (|a_i - c_i| - h_i) / H_block (the FMU's coordinate check)."""
    out = -np.inf
    for block in (slice(0, k_v), slice(k_v, None)):
        lo, hi = env.lo[block], env.hi[block]
        c, h = 0.5 * (lo + hi), 0.5 * (hi - lo)
        out = max(out, float(np.max((np.abs(z[:, block] - c) - h) / h.max())))
    return out


def measure(scene_name, scales=SCALES, progress=True):
    """Rows (dicts) of the amplitude sweep of one scene (a name, a path or a Scene; module docstring)."""
    from ..fmu.training import envelope as E
    from ..pod.pipeline import accel_modes, basis_for_scene
    from ..rom.registry import get_model
    from ..sph.solver import build_problem, run_sph, step_count
    scene = load_scene(scene_name) if isinstance(scene_name, str) else scene_name
    problem = build_problem(scene)
    basis, run = basis_for_scene(scene, progress=False, problem=problem)
    k = min(int(max(accel_modes(scene, basis))), *basis.max_modes)
    frozen, exact = get_model("frozen"), get_model("exact")
    ops = frozen.build(problem, basis, k, k, input_direction=frozen.fmu_input_direction,
                       tensor="always")            # the FMU's frozen model (the registry's: b about rest)
    lin = exact.build(problem, basis, k, k, input_direction=exact.fmu_input_direction)
    env = E.measure(scene, ops, problem, run, PROBES, linear=False)
    integrator = fmu_integrator(ops, scene)
    n = step_count(scene.T, scene.sph.dt)
    steps = np.arange(0, n + 1, scene.sph.every)
    rho0 = np.asarray(problem.rho0, float)
    rows = []
    with progress_bar(len(scales), f"envelope {scene.name}", unit="scale", enabled=progress) as bar:
        for s in scales:
            amp = derive_scene(scene, {"fields": {"v0": f"{s!r}*({scene.fields['v0'].text})"}})
            ref = run_sph(amp, sample_steps=steps, progress=False)
            v_ref = _probe(ref.v, problem.x, scene.L)
            strain = np.abs(rho0[None, :] / ref.rho - 1.0)
            probe_strain = np.abs(_probe(rho0, problem.x, scene.L) / _probe(ref.rho, problem.x, scene.L) - 1.0)
            row = {"scene": scene.name, "scale": s, "integrator": integrator, "peak_strain": float(strain.max()),
                   "peak_probe_strain": float(probe_strain.max())}
            fr = frozen.run(ops, problem, dt=scene.sph.dt, n_steps=n, sample_steps=steps,
                            options=frozen.options(n_freeze=N_FREEZE, integrator=integrator),
                            state=ops.initial_state(s))
            row["frozen_v_error"] = relative_l2(_probe(fr.v, problem.x, scene.L), v_ref, fr.t)
            fr_rho = _probe(fr.rho, problem.x, scene.L)
            row["frozen_peak_probe_strain"] = float(np.max(np.abs(_probe(rho0, problem.x, scene.L) / fr_rho - 1)))
            row["frozen_coordinate_excess"] = coordinate_excess(env, fr.z, ops.sizes["velocity"])
            ex = exact.run(lin, problem, dt=scene.sph.dt, n_steps=n, sample_steps=steps,
                           state=lin.initial_state(s),
                           options=exact.options(step=scene.sph.dt * scene.sph.every))
            row["exact_v_error"] = relative_l2(_probe(ex.v, problem.x, scene.L), v_ref, ex.t)
            rows.append(row)
            bar.update()
    return rows


def training_headroom(scene_name):
    """One row: the frozen model's run of its own training scene against its recorded envelope."""
    from ..fmu.training import envelope as E
    from ..pod.pipeline import accel_modes, basis_for_scene
    from ..rom.registry import get_model
    from ..sph.solver import build_problem, step_count
    scene = load_scene(scene_name)
    problem = build_problem(scene)
    basis, run = basis_for_scene(scene, progress=False, problem=problem)
    k = int(max(accel_modes(scene, basis)))
    frozen = get_model("frozen")
    ops = frozen.build(problem, basis, k, k, input_direction=frozen.fmu_input_direction,
                       tensor="always")            # the FMU's frozen model (the registry's: b about rest)
    env = E.measure(scene, ops, problem, run, PROBES, linear=False)
    integrator = fmu_integrator(ops, scene)
    n = step_count(scene.T, scene.sph.dt)
    fr = frozen.run(ops, problem, dt=scene.sph.dt, n_steps=n, every=scene.sph.every,
                    options=frozen.options(n_freeze=N_FREEZE, integrator=integrator))
    rho0 = _probe(np.asarray(problem.rho0, float), problem.x, scene.L)
    strain = float(np.max(np.abs(rho0 / _probe(fr.rho, problem.x, scene.L) - 1.0)))
    return {"scene": scene.name, "integrator": integrator, "k_v": ops.sizes["velocity"],
            "coordinate_excess": coordinate_excess(env, fr.z, ops.sizes["velocity"]),
            "probe_strain_ratio": strain / env.max_probe_strain, "max_probe_strain": env.max_probe_strain,
            "allowed_excess": env.margin - 1.0, "allowed_ratio": env.margin}


def failure_strain(rows, scene, error=None):
    """The full SPH's peak probe strain at which the frozen probe error reaches ``error`` (default
    :data:`FAILURE_ERROR`), interpolated linearly between the scales measured; nan when never reached."""
    error = FAILURE_ERROR if error is None else error
    rs = sorted((r for r in rows if r["scene"] == scene), key=lambda r: r["scale"])
    for a, b in zip(rs, rs[1:]):
        if a["frozen_v_error"] < error <= b["frozen_v_error"]:
            w = (error - a["frozen_v_error"]) / (b["frozen_v_error"] - a["frozen_v_error"])
            return a["peak_probe_strain"] + w * (b["peak_probe_strain"] - a["peak_probe_strain"])
    return float("nan")


def plot(rows, path):
    """Probe velocity error against the full SPH's peak probe strain, one line per scene and model."""
    from ..fmu.training.envelope import FAILURE_STRAIN
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for scene in dict.fromkeys(r["scene"] for r in rows):
        rs = [r for r in rows if r["scene"] == scene]
        x = [r["peak_probe_strain"] for r in rs]
        ax.loglog(x, [r["frozen_v_error"] for r in rs], "o-", label=f"{scene}: frozen")
        ax.loglog(x, [r["exact_v_error"] for r in rs], "s--", label=f"{scene}: exact")
        for r in rs:
            ax.annotate(f"{r['scale']:g}x", (r["peak_probe_strain"], r["frozen_v_error"]), fontsize=7,
                        textcoords="offset points", xytext=(3, -9))
    ax.axvline(FAILURE_STRAIN, color="k", lw=0.8, ls=":", label=f"failure strain {FAILURE_STRAIN:g}")
    ax.set_xlabel("peak probe strain |ρ0/ρ - 1| of the full SPH")
    ax.set_ylabel("relative L² error of the probe velocities")
    ax.set_title("Initial state scaled by s: reduced models (x1 basis) against the full SPH", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120, format="png")
    plt.close(fig)


SCENES = ("tenmode", "multimode", "damped")


def run(out, scenes=SCENES, scales=SCALES, progress=True):
    """The sweep of ``scenes`` and the training headroom of every built-in scene: rows written to ``out``
    (envelope.csv), envelope.png and envelope_training.csv beside it; returns
    {"rows", "training", "command"} for the report (:func:`envelope_section`)."""
    out = Path(out)
    rows = [r for s in scenes for r in measure(s, scales, progress=progress)]
    write_csv(out, rows)
    with atomic_path(out.with_suffix(".png")) as tmp:
        plot(rows, tmp)
    training = [training_headroom(name) for name in builtin_names()]
    write_csv(out.with_name("envelope_training.csv"), training)
    command = "python -m sphrom.bench.envelope " + " ".join(scenes)
    if tuple(scales) != SCALES:
        command += " --scales " + ",".join(f"{s:g}" for s in scales)
    failure = {s: failure_strain(rows, s) for s in dict.fromkeys(r["scene"] for r in rows)}
    return {"rows": rows, "training": training, "command": command, "failure": failure,
            "failure_error": FAILURE_ERROR}


def _within_margin(rows, scenes, margin):
    """", at s = margin the frozen error is r × its value at s = 1 (scene, ...)" from the rows that have both."""
    ratios = []
    for s in scenes:
        at = {r["scale"]: r["frozen_v_error"] for r in rows if r["scene"] == s}
        if 1.0 in at and margin in at and at[1.0] > 0:
            ratios.append(f"{at[margin] / at[1.0]:.2g}× ({s})")
    return f": at s = {margin:g} the frozen error is {', '.join(ratios)} its value at s = 1" if ratios else ""


def _integrators(rows):
    """"symplectic (tenmode, multimode), euler (damped)" from the rows' integrator column."""
    by = {}
    for r in rows:
        by.setdefault(r.get("integrator", "the scene's"), []).append(r["scene"])
    return ", ".join(f"{k} ({', '.join(dict.fromkeys(v))})" for k, v in by.items())


def envelope_section(envelope, image_dir=""):
    """The frozen FMU's training envelope (:func:`run`: rows, training, command, and
    failure, the probe strain per scene where the frozen error reaches failure_error): error against
    amplitude and strain, the margin's headroom on the training runs; [] without it."""
    from ..fmu.training.envelope import FAILURE_STRAIN, MARGIN
    if not envelope:
        return []
    rows, d = envelope["rows"], image_dir.rstrip("/") + "/" if image_dir else ""
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    lines = ["## The training envelope of the frozen FMU", "",
             f"`{envelope['command']}` (`{d}envelope.csv`): the initial velocity scaled by s, the density at ρ0; "
             "the full SPH runs the scaled scene, the reduced models start from the scaled coordinates on the x1 "
             "basis (the FMU's: k = the scene's largest `rom.accel_modes`, n_freeze = 10), the frozen model stepped "
             f"with the FMU's own integrator (`sphrom fmu`'s default: {_integrators(rows)}). Relative L² error of "
             "the probe velocities (x/L = 0.25, 0.5, 0.66) against the full SPH; peak strain |ρ0/ρ − 1| of the "
             "full SPH over the particles and at the probes; the frozen run's largest coordinate excess beyond "
             "its trained ranges in units of its block's largest half-width (the FMU warns above margin − 1 = "
             f"{MARGIN - 1:g}).", "",
             f"![error against strain]({d}envelope.png)", "",
             "| scene | s | peak strain | peak probe strain | frozen v error | coordinate excess | exact v error |",
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in rows:
        lines.append(f"| {r['scene']} | {r['scale']:g} | {r['peak_strain']:.3g} | {r['peak_probe_strain']:.3g} | "
                     f"{r['frozen_v_error']:.3g} | {r['frozen_coordinate_excess']:.3g} | {r['exact_v_error']:.3g} |")
    reached = envelope["failure"]              # scene -> probe strain at the failure error (nan: not reached)
    where = ", ".join(f"{v:.3g} ({s})" for s, v in reached.items() if not math.isnan(v)) or "never in this range"
    exact = "; ".join(f"{s} {min(r['exact_v_error'] for r in rows if r['scene'] == s):.4g} to "
                      f"{max(r['exact_v_error'] for r in rows if r['scene'] == s):.4g}" for s in scenes)
    lines += ["", "The full SPH is linear in J = ρ0/ρ (up to its time stepping of ρ), so a scaled initial state "
              f"scales its solution and the exact model's error hardly moves with s ({exact}); the frozen "
              "model's error grows about linearly with the strain (the density linearization of eq. 2.17 and the "
              f"ρ² coefficient): it reaches {envelope['failure_error']:.0%} at a probe strain of {where}. The FMU's failure "
              f"strain is {FAILURE_STRAIN:g}, its margin {MARGIN:g}{_within_margin(rows, scenes, MARGIN)}.", "",
              "Headroom on the training runs (every built-in scene's frozen model on its own scene, "
              f"`{d}envelope_training.csv`): the FMU warns above a coordinate excess of {MARGIN - 1:g} or a probe "
              f"strain of {MARGIN:g}× the trained one.", "",
              "| scene | largest coordinate excess | probe strain / trained |", "| --- | ---: | ---: |"]
    for r in envelope["training"]:
        lines.append(f"| {r['scene']} | {r['coordinate_excess']:.3g} | {r['probe_strain_ratio']:.3g} |")
    return lines + [""]


def _scales(text):
    try:
        scales = [float(s) for s in text.split(",")]
    except ValueError:
        scales = []
    if not scales or not all(np.isfinite(s) and s > 0 for s in scales):
        raise argparse.ArgumentTypeError(f"{text!r} is not a comma-separated list of numbers > 0")
    return scales


def main(argv=None):
    p = program_parser("envelope", description=__doc__.split("\n\n")[0])
    p.add_argument("scenes", nargs="*", default=list(SCENES), metavar="SCENE")
    p.add_argument("--scales", type=_scales, default=list(SCALES), metavar="S1,S2,...")
    p.add_argument("--out", default="validation/benchmarks/envelope.csv", metavar="FILE.csv")
    p.add_argument("--report", default="BENCHMARKS.md", metavar="FILE.md")
    p.add_argument("--quiet", action="store_true")
    args = p.parse_args(argv)
    result = run(args.out, args.scenes, args.scales, progress=not args.quiet)
    lines = envelope_section(result, image_dir=str(Path(args.out).parent))
    print("\n".join(lines))
    report = Path(args.report)
    text = report.read_text() if report.exists() else "# Benchmarks\n"
    write_text(report, replace_section(text, lines[0], lines))
    for scene in args.scenes:
        print(f"{scene}: probe strain at {FAILURE_ERROR:.0%} frozen probe error: "
              f"{failure_strain(result['rows'], scene):.3g} (nan: not reached)")
    print(f"wrote {args.out}, its .png, envelope_training.csv beside it and the section of {report}")


if __name__ == "__main__":
    main()
