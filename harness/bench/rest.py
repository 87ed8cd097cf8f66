"""A component at rest: does the packaged FMU stay at rest, and what does the rest-consistent b cost?

The frozen FMU takes b about the projected rest density (b = K a^ρ_rest, the frozen model's build option
``b="rest"``, :func:`sphrom.rom.operators.rest_b`) instead of eq. 2.22's b = U^vᵀ ρ0⁻¹ G c (``b="paper"``),
which leaves the constant force of ρ0's projection error in every run.  For every built-in scene this packages
the FMUs as ``sphrom fmu SCENE --model frozen|exact`` does (FMI 2, the scene's default k, n_freeze = 10, probes
x/L = 0.25, 0.5, 0.66) and, for comparison, the frozen FMU of the paper's variant (``package_fmu`` with
``build_options={"b": "paper"}``: the same model and packaging with eq. 2.22's b, its training envelope measured
on it), and measures through fmpy:

* **rest**: ``initial_state_scale`` = 0 and f = 0 for T = 100 s at the FMU's default communication step:
  the largest |v_probe| over the run, relative to the largest |v_probe| of the scene's own full SPH training
  run, and the largest change of ρ_probe from its start, relative to ρ0;
* **training** and **unseen**: the verification of ``sphrom fmu`` (:mod:`sphrom.fmu.check.verify`): the relative
  L² errors (eq. 3.4) of the probe velocities against the full SPH linear in J, integrated exactly in time
  (packaging's truth, :mod:`sphrom.fmu.check.truth`), on the scene's force and initial state, and on
  A sin(2π·0.7 t) from rest.

Run as::

    python -m sphrom.bench.rest [SCENE ...] [--out validation/benchmarks/rest.csv] [--report BENCHMARKS.md]

It writes the CSV, ``rest.png`` beside it (|v_probe|(t) at rest, multimode, every model) and the section
"A component at rest" of the report.
"""

from __future__ import annotations

import csv
import platform
import re
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from .. import defaults
from ..fmu.make.build import ensure_binaries
from ..runio import atomic_path
from ..scene import builtin_names, load_scene
from . import program_parser
from .lib.document import split_sections, update_report
from .lib.tables import write_csv

# The measuring modules (numba through the model code, scipy, fmpy, matplotlib) are imported inside the functions:
# `sphrom bench NAME --help` answers before they load (tests/test_bench_programs.py).

# Imported inside the functions: the modules that load numba, scipy or matplotlib (--help answers before they
# load: tests/test_bench_programs.py).

SECTION_HEADING = "## A component at rest"
PROBES = defaults.PROBES
REST_T = 100.0            # [s] the rest run's length
PLOT_SCENE = "multimode"
EQ222 = "frozen, eq. 2.22's b"      # the row label of the comparison FMU


def rest_run(path, step, T=REST_T):
    """(t, v (M, P), rho (M, P)) of the FMU at ``path`` left at rest (initial_state_scale 0), f = 0."""
    from ..fmu.check.verify import fmu_run
    t = np.arange(int(round(T / step)) + 1) * step
    v, rho, _ = fmu_run(path, np.zeros_like(t), t, scale=0.0)
    return t, v, rho


def measure_scene(name, folder, progress=True):
    """Rows (frozen with eq. 2.22's b, frozen, exact) of scene ``name`` and the rest runs {model: (t, v)}."""
    from ..fmu.check.verify import fmu_features
    from ..fmu.make.package import package_fmu
    from ..sph.solver import build_problem
    scene = load_scene(name)
    problem = build_problem(scene)
    binaries = ensure_binaries(quiet=True)
    folder = Path(folder)
    summaries, refs = {}, None
    # (label, model, build options): the frozen model's two variants through its build option b, and the exact
    for label, model, options in ((EQ222, "frozen", {"b": "paper"}), ("frozen", "frozen", None),
                                  ("exact", "exact", None)):
        summaries[label] = package_fmu(scene, folder / f"{name}-{len(summaries)}.fmu",
                                       model=model, fmi=2, probes=PROBES, progress=progress, binaries=binaries,
                                       problem=problem, verify=True, accept=False, references=refs,
                                       build_options=options)
        refs = summaries[label].verification.refs
    paths = {label: (s.path, s.verification) for label, s in summaries.items()}
    _, _, _, (t_train, sph_v, _, rho0, _) = refs["training"]
    v_scale = float(np.max(np.abs(sph_v)))
    rows, traces = [], {}
    for label, (path, verification) in paths.items():
        step = fmu_features(path)[2]
        t, v, rho = rest_run(path, step)
        traces[label] = (t, np.max(np.abs(v), axis=1) / v_scale)
        rows.append({"scene": name, "model": label, "N": scene.sph.n_particles, "step": step, "T_rest": REST_T,
                     "rest_v": float(np.max(np.abs(v))) / v_scale,
                     "rest_drho": float(np.max(np.abs(rho - rho[0]) / rho0)),
                     "rest_rho_offset": float(np.max(np.abs(rho[0] - rho0) / rho0)),
                     "train_err_v": verification.training.err_v, "train_err_rho": verification.training.err_rho,
                     "unseen_err_v": verification.unseen.err_v, "v_scale": v_scale,
                     "baseline": EQ222 if path == summaries["frozen"].path else ""})
    return rows, traces


def plot(traces, path, scene):
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    for label, (t, v) in traces.items():
        ax.semilogy(t[1:], np.maximum(v[1:], 1e-20), label=label)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("max |v_probe| / largest |v_probe| of the scene")
    ax.set_title(f"{scene}: FMU left at rest (initial_state_scale = 0), f = 0", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120, format="png")
    plt.close(fig)


def section(rows, command, wall, machine, out="validation/benchmarks/rest.csv"):
    """The report's lines."""
    def e(x):
        x = float(x)
        return "—" if not np.isfinite(x) else f"{x:.2e}"
    lines = [SECTION_HEADING, "",
             f"Produced by `{command}` ({machine}, {wall:.0f} s wall; `{out}`, "
             f"`{Path(out).with_suffix('.png').name}`). Each scene's FMU (FMI 2, the scene's default k, n_freeze = 10, probes x/L = 0.25, 0.5, "
             "0.66) as `sphrom fmu SCENE --model MODEL` builds it; *frozen, eq. 2.22's b*: the same frozen FMU with "
             "only b replaced by eq. 2.22's U^vᵀ ρ0⁻¹ G c (what the frozen FMU used before it took b about the "
             "projected rest density, b = K a^ρ_rest). *At rest*: `initial_state_scale` = 0, f = 0, "
             f"T = {REST_T:g} s at the FMU's default step: the largest |v_probe| relative to the largest |v_probe| "
             "of the scene's full SPH training run, and the largest change of ρ_probe from its start relative to "
             "ρ0. *Training* / *unseen*: relative L² errors (eq. 3.4) of the probe velocities against the full SPH "
             "linear in J, integrated exactly in time (packaging's truth; the scene's force and initial state; A sin(2π·0.7 t) from rest), as `sphrom fmu` measures them.",
             "",
             "*Change*: the frozen FMU's error relative to the same FMU with eq. 2.22's b.",
             "",
             "| scene | model | at rest: max v | at rest: ρ change | training v error | change | unseen v error "
             "| change |",
             "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |"]

    base = {(r["scene"], r["model"]): r for r in rows}

    def change(r, key):           # the row's error relative to its baseline row's (the FMU with eq. 2.22's b)
        b = base.get((r["scene"], r.get("baseline") or None))
        return "" if b is None else f"{100 * (float(r[key]) / float(b[key]) - 1):+.1f} %"
    for r in rows:
        lines.append(f"| {r['scene']} | {r['model']} | {e(r['rest_v'])} | {e(r['rest_drho'])} | "
                     f"{e(r['train_err_v'])} | {change(r, 'train_err_v')} | {e(r['unseen_err_v'])} | "
                     f"{change(r, 'unseen_err_v')} |")
    return lines


def rerender(csv_path, report):
    """Rewrite the section of ``report`` from the rows of ``csv_path``, keeping its "Produced by" command and
    wall time (the measurement is the CSV's; only the table's layout changes)."""

    with open(csv_path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    old = "\n".join(split_sections(report.read_text()).get(SECTION_HEADING, []))
    m = re.search(r"Produced by `([^`]*)` \(([^,]*, Python [^,]*), ([0-9.]+) s wall", old)
    if not m:
        raise SystemExit(f"{report}: no section {SECTION_HEADING!r} with its command to keep")
    update_report(report, {SECTION_HEADING: section(rows, m.group(1), float(m.group(3)), m.group(2), str(csv_path))})
    print(f"re-rendered the section of {report} from {csv_path}")
    return 0


def main(argv=None):
    p = program_parser("rest", description=__doc__.split("\n\n")[0])
    p.add_argument("scenes", nargs="*", metavar="SCENE", help="default: every built-in scene")
    p.add_argument("--out", default="validation/benchmarks/rest.csv", metavar="FILE.csv")
    p.add_argument("--report", default="BENCHMARKS.md", metavar="FILE.md")
    p.add_argument("--quiet", action="store_true")
    p.add_argument("--from-csv", metavar="FILE.csv",
                   help="re-render the report's section from a CSV this command wrote (no runs); the command and "
                        "wall time of that run are read from the report's section")
    args = p.parse_args(argv)
    if args.from_csv:
        return rerender(Path(args.from_csv), Path(args.report))
    scenes = args.scenes or builtin_names()
    t0 = time.perf_counter()
    rows, traces = [], None
    with tempfile.TemporaryDirectory(prefix="sphrom-rest-") as folder:
        for name in scenes:
            r, tr = measure_scene(name, folder, progress=not args.quiet)
            rows += r
            if name == PLOT_SCENE or traces is None:
                traces = (name, tr)
            for x in r:
                print(f"{x['scene']:20s} {x['model']:22s} rest v {x['rest_v']:.2e}  rest drho {x['rest_drho']:.2e}  "
                      f"training v {x['train_err_v']:.3e}  unseen v {x['unseen_err_v']:.3e}", flush=True)
    wall = time.perf_counter() - t0
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_csv(out, rows)
    with atomic_path(out.with_suffix(".png")) as tmp:
        plot(traces[1], tmp, traces[0])
    given = argv if argv is not None else sys.argv[1:]
    command = "python -m sphrom.bench.rest" + (" " + " ".join(given) if given else "")
    lines = section(rows, command, wall, f"{platform.machine()}, Python {platform.python_version()}", args.out)
    report = update_report(args.report, {SECTION_HEADING: lines})
    print(f"wrote {out}, {out.with_suffix('.png')} and the section of {report} ({wall:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
