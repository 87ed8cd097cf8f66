"""``sphrom bench [SCENE ...]`` (the program ``suite``): every benchmark of BENCHMARKS.md in one run, and the
report.

:func:`run_benchmarks` measures (run time against error per scene, cost against N and k, skipped terms, the
force direction, the full SPH step, the FMU, optionally the stress maps), writes the CSV and PNG files into one
folder and returns a :class:`BenchResults`; :func:`report` turns that into BENCHMARKS.md, with the sections only
this program writes here and the ones it shares with the programs that re-measure one alone (the FMU's, the
full SPH step's, the stress maps') from the library (:mod:`sphrom.bench.lib`).  Times are medians of
``repeats`` runs, ratios are taken within the run.

Also ``sphrom bench suite [SCENE ...]`` and ``python -m sphrom.bench.suite``.
"""

from __future__ import annotations

import csv
import dataclasses
import os
import platform
import time
from pathlib import Path

from .. import __version__
from ..errors import FieldError, UserError
from ..markdown import write_text
from ..options import MAX_REPEATS, add_quiet, int_in, int_list, min_particles
from . import program_main
from .lib.document import fmt, split_sections
from .lib.fmu_sections import fmu_section, headline_section
from .lib.stress_settings import AMPLITUDES, DT_FACTORS, HORIZONS, MODE_COUNTS
from .lib.stress_settings import DEFAULT_SCENES as STRESS_SCENES
from .lib.tables import write_csv

# The measuring modules (numpy, numba, fmpy) are imported inside the functions: `sphrom --help` builds this
# program's options (sphrom bench), which must not load them (tests/test_cli_imports.py).

DEFAULT_SCENES = ("tenmode", "damped", "damped_forced", "heterogeneous", "mild_damped_forced")
SIZES = (100, 400, 1600, 6400, 10000)          # N of the cost-against-N table
KS_SCALING = (4, 8, 12, 20, 40)                # the k sweep of the cost table (N = 400)
SPH_SIZES = (100, 400, 10000, 100000)          # N of the full-SPH step table (as sphrom bench-sph)
SKIP_SCENES = 2                                # the skipped-terms table uses the first scenes only
BENCH_FIELDS = ["scene", "method", "k", "n_freeze", "online_s", "offline_s", "speedup", "err_v_sph", "err_rho_sph",
                "err_v_ref", "err_rho_ref", "note"]
COST_FIELDS = ["method", "n", "k", "us_per_step"]


@dataclasses.dataclass
class BenchResults:
    """What :func:`run_benchmarks` measured (rows are lists of dicts, as in the CSV files)."""

    command: str                  # the command line quoted in the report
    version: str
    python: str
    machine: str
    repeats: int
    scene_names: list
    rows: list                    # run time against error, every scene (bench.csv)
    savings: list                 # (scene, {k: saving of the frozen model}, the paper's saving or None)
    sizes: list
    scaling: list                 # cost against N (scaling.csv)
    ks_scaling: list
    scaling_k: list               # cost against k (scaling_k.csv)
    skips: list                   # skip.csv
    directions: list              # input_direction.csv
    input_tolerance: float
    sph_sizes: list
    sph_steps: list               # sph_scaling.csv
    fmu: dict | None = None       # sphrom.bench.lib.fmu.fmu_measurements, None without the FMU
    stress: object = None         # sphrom.bench.lib.stress_maps.StressMaps, None without the maps
    stress_command: str = ""
    wall: float = 0.0             # [s]


def run_benchmarks(scenes, out, *, ks=None, repeats=5, sizes=SIZES, ks_scaling=KS_SCALING, sph_sizes=SPH_SIZES,
                   fmu=True, fmu_scene="tenmode", stress=False, progress=True):
    """Run every benchmark on ``scenes``; CSV and PNG files into ``out`` (created).

    Parameters
    ----------
    scenes : list of Scene
    out : Path
        Folder for bench.csv, scaling.csv, scaling_k.csv, skip.csv, input_direction.csv, sph_scaling.csv,
        fmu_core.csv, fmu_e2e.csv, the plots and (``stress``) ``stress/``.
    ks : list of int, optional
        Mode counts (default each scene's acceleration-study k).
    repeats : int
        Timed runs per point (median).
    sizes, ks_scaling, sph_sizes : list of int
        N of the cost table, k of the cost table at N = 400, N of the full-SPH step table.
    fmu : bool
        The FMU rows and tables (needs a compiler and CMake).
    fmu_scene : str
        Scene of the FMU's end-to-end table.
    stress : bool
        Also the stress maps of :data:`sphrom.bench.lib.stress_settings.DEFAULT_SCENES`.
    progress : bool
        Progress bars.

    Returns
    -------
    BenchResults
    """
    from ..progress import progress_bar
    from ..rom.operators import INPUT_TOLERANCE
    from ..scene import load_scene
    from .lib.fmu import bench_rows, fmu_measurements, write_fmu_csv
    from .lib.input_direction import input_direction_rows
    from .lib.methods import bench_python, plot_time_error, savings_by_k
    from .lib.scaling import per_step_costs, plot_costs
    from .lib.skip import skip_savings
    from .lib.sph_scaling import INTEGRATORS, scaling_table
    from .lib.stress_maps import stress_maps, stress_section

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    extra = bench_rows if fmu else None
    all_rows, savings = [], []
    total = sum(1 + len(ks or s.rom.get("accel_modes", [1])) * 9 for s in scenes)
    with progress_bar(total=total, desc="bench", enabled=progress) as bar:
        for scene in scenes:
            rows = bench_python(scene, ks=ks, repeats=repeats, progress=bar, extra=extra)
            all_rows += rows
            plot_time_error(rows, out / f"{scene.name}_time_error.png", scene.name)
            savings.append((scene.name, savings_by_k(rows, scene), scene.paper.get("cpu_saving")))
    with progress_bar(total=len(sizes), desc="scaling", enabled=progress) as bar:
        scaling = per_step_costs(sizes=sizes, repeats=repeats, progress=bar)
    plot_costs(scaling, out / "scaling_n.png")
    with progress_bar(total=1, desc="scaling in k", enabled=progress) as bar:
        scaling_k = per_step_costs(sizes=[400], ks=ks_scaling, repeats=repeats, progress=bar)
    plot_costs(scaling_k, out / "scaling_k.png", key="k")
    skips = []
    for scene in scenes[:SKIP_SCENES]:
        skips += skip_savings(scene, repeats=repeats, fmu=fmu)
    directions = []
    for scene in scenes:
        directions += input_direction_rows(scene)
    with progress_bar(total=len(sph_sizes) * len(INTEGRATORS), desc="full SPH step", enabled=progress) as bar:
        sph_steps = scaling_table("tenmode", sph_sizes, INTEGRATORS, repeats, bar)
    write_csv(out / "sph_scaling.csv", sph_steps)
    fmu_results = None
    if fmu:
        fmu_results = fmu_measurements(fmu_scene, repeats=max(5, repeats), progress=progress)
        write_fmu_csv(out, fmu_results["core"], fmu_results["e2e"], prefix="fmu_")
    maps, stress_command = None, ""
    if stress:
        stress_command = "sphrom bench --report (the stress maps of sphrom stress)"
        maps = stress_maps([load_scene(s) for s in STRESS_SCENES], list(AMPLITUDES), list(HORIZONS),
                           list(MODE_COUNTS), DT_FACTORS, out / "stress", fmu=fmu, progress=progress)
        write_text(out / "stress" / "stress.md", "\n".join(stress_section(maps, stress_command, "", level=1)) + "\n")
    wall = time.perf_counter() - started
    write_csv(out / "bench.csv", all_rows, BENCH_FIELDS)
    write_csv(out / "scaling.csv", scaling, COST_FIELDS)
    write_csv(out / "scaling_k.csv", scaling_k, COST_FIELDS)
    write_csv(out / "skip.csv", skips)
    if directions:
        write_csv(out / "input_direction.csv", directions)
    return BenchResults(
        command="sphrom bench " + " ".join(s.name for s in scenes) + f" --repeats {repeats} --report",
        version=__version__, python=platform.python_version(), machine=platform.machine(), repeats=repeats,
        scene_names=[s.name for s in scenes], rows=all_rows, savings=savings, sizes=list(sizes), scaling=scaling,
        ks_scaling=list(ks_scaling), scaling_k=scaling_k, skips=skips, directions=directions,
        input_tolerance=INPUT_TOLERANCE, sph_sizes=list(sph_sizes), sph_steps=sph_steps, fmu=fmu_results,
        stress=maps, stress_command=stress_command, wall=wall)


def read_bench_csv(path):
    """The rows of a bench.csv written by :func:`run_benchmarks` (numbers parsed, NaN for empty)."""
    rows = []
    with open(path) as fh:
        for r in csv.DictReader(fh):
            for key in ("online_s", "offline_s", "speedup", "err_v_sph", "err_rho_sph", "err_v_ref", "err_rho_ref"):
                r[key] = float(r[key]) if r[key] not in ("", "nan") else float("nan")
            r["k"] = int(r["k"]) if r["k"] else None
            r["n_freeze"] = int(r["n_freeze"]) if r["n_freeze"] else None
            rows.append(r)
    return rows


def replot(out):
    """Redraw ``out``/<scene>_time_error.png from ``out``/bench.csv (the measured rows, unchanged).

    Returns the scene names redrawn.
    """
    from .lib.methods import plot_time_error
    out = Path(out)
    rows = read_bench_csv(out / "bench.csv")
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    for scene in scenes:
        plot_time_error([r for r in rows if r["scene"] == scene], out / f"{scene}_time_error.png", scene)
    return scenes


# ---------------------------------------------------------------------------
# BENCHMARKS.md, in document order
# ---------------------------------------------------------------------------

def intro_section(command, version, python, machine, wall, repeats):
    """The title and the paragraph saying how the figures were made."""
    return ["# Benchmarks", "",
            f"Produced by `{command}` (sphrom {version}, Python {python}, {machine}, {wall:.0f} s wall). Times are "
            f"medians of {repeats} runs on a shared 2-core machine; speed-ups are ratios to the full SPH timed in the "
            "same run. Errors: relative L² (square-root form of eq. 3.4); reduced models against the full SPH, the "
            "full SPH against the reference (exact, or a continuum reference for heterogeneous); ρ errors of "
            "ρ − ρ0. Online = the time loop; offline = SPH run for the snapshots, SVD and operators.", ""]


def savings_section(savings):
    """CPU saving of the frozen model per scene and k beside the paper's.

    ``savings``: list of (scene name, {k: saving}, the paper's saving or None).
    """
    lines = ["## CPU saving of the frozen model against the full SPH (n_freeze = 10)", "",
             "| scene | ours, per k | paper (\"up to\") |", "| --- | --- | --- |"]
    for name, by_k, paper in savings:
        lines.append(f"| {name} | " + ", ".join(f"{100 * v:.0f} % (k = {k})" for k, v in by_k.items())
                     + f" | {fmt(None if paper is None else 100 * paper, '.0f')} % |")
    return lines + ["", "Both in Python in our case; the paper's full SPH was slower relative to its reduced models "
                    "than our compiled (numba) one, which is why our savings are smaller: see the per-step costs "
                    "below.", ""]


def scene_section(name, rows, image):
    """Run time against error of every method on one scene: the plot and the table of ``rows``."""
    lines = [f"## {name}", "", f"![time against error]({image})", "",
             "| method | k | n_freeze | online [s] | speed-up | offline [s] | error v | error ρ−ρ0 | vs ref: v | "
             "vs ref: ρ−ρ0 |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        lines.append(f"| {r['method']} | {r['k']} | {r['n_freeze'] or ''} | {r['online_s']:.4f} | "
                     f"{r['speedup']:.1f}× | {r['offline_s']:.3f} | {fmt(r['err_v_sph'])} | "
                     f"{fmt(r['err_rho_sph'])} | {fmt(r['err_v_ref'])} | {fmt(r['err_rho_ref'])} |")
    return lines + [""]


def _cost_rows(rows, key, values, methods):
    from .lib.scaling import growth
    out = []
    for method in methods:
        cells = [next((f"{r['us_per_step']:.3g} µs" for r in rows if r["method"] == method and r[key] == v), "—")
                 for v in values]
        out.append(f"| {method} | " + " | ".join(cells) + f" | {growth(rows, method, key=key):.2f} |")
    return out


def cost_n_section(scaling, sizes, image):
    """Cost per step of every method against the particle count N (rows of ``per_step_costs``)."""
    lines = ["## Cost per step against N (k = 12, tenmode fields, Δt at the scene's CFL number)", "",
             f"![cost against N]({image})", "",
             "| method | " + " | ".join(f"N = {n}" for n in sizes) + " | growth exponent |",
             "| --- |" + " --- |" * (len(sizes) + 1)]
    lines += _cost_rows(scaling, "n", sizes, dict.fromkeys(r["method"] for r in scaling))
    return lines + [""]


def cost_k_section(scaling_k, ks, image):
    """Cost per step of every reduced model against the mode count k at N = 400."""
    lines = [f"## Cost per step against k (N = 400, k = {', '.join(map(str, ks))})", "",
             f"![cost against k]({image})", "",
             "| method | " + " | ".join(f"k = {k}" for k in ks) + " | growth exponent in k |",
             "| --- |" + " --- |" * (len(ks) + 1)]
    lines += _cost_rows(scaling_k, "k", ks, dict.fromkeys(r["method"] for r in scaling_k if r["k"]))
    return lines + ["", "Expected: the original and linearised models cost O(N k) per step (the nonlinear term is "
                    "evaluated on the particles), the frozen model O(k²) per step plus O(k⁴)/n_freeze for the exact "
                    "refresh tensor, the exact model O(k²) per communication step.", ""]


def skip_section(skips):
    """What skipping absent terms saves (rows of :func:`sphrom.bench.lib.skip.skip_savings`)."""
    lines = ["## Skipping what a scene doesn't need", "",
             "The same loop on the same inputs with the scene's own terms (specialised) and with every term forced "
             "on (zero damping and force evaluated, per-particle arrays); the results are identical.", "",
             "| scene | solver | specialised [µs/step] | general [µs/step] | saving |",
             "| --- | --- | --- | --- | --- |"]
    for r in skips:
        lines.append(f"| {r['scene']} | {r['solver']} | {r['specialised_us']:.3f} | {r['general_us']:.3f} | "
                     f"{100 * r['saving']:.0f} % |")
    return lines + [""]


def input_direction_section(directions, scene_names, tolerance):
    """Projected against appended force direction per scene; [] without rows.

    ``tolerance`` is the FMU's rule (``sphrom.rom.operators.INPUT_TOLERANCE``).
    """
    if not directions:
        return []
    lines = ["## How the force direction enters the frozen model", "",
             "The FMU takes any f(t) along the scene's force profile (uniform). Projected as in eq. 2.19, the part "
             "of the profile outside the POD velocity modes is lost; appended, the normalised residual becomes an "
             "extra velocity mode. Frozen model, n_freeze = 10, errors against the full SPH. The FMU appends only "
             f"when the modes miss more than {tolerance:g} of the profile (`INPUT_TOLERANCE`).", "",
             "| scene | k | modes miss | projected: v | ρ − ρ0 | appended (k_v + 1): v | ρ − ρ0 | FMU's rule |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for name in scene_names:
        pr = {r["choice"]: r for r in directions if r["scene"] == name}
        if len(pr) == 2:
            a, b = pr["project"], pr["augment"]
            lines.append(f"| {name} | {a['k']} | {100 * a['input_error']:.2g} % | {fmt(a['err_v'])} | "
                         f"{fmt(a['err_rho'])} | {fmt(b['err_v'])} | {fmt(b['err_rho'])} | {a['fmu_rule']} |")
    return lines + [""]


# Sections that other programs write into BENCHMARKS.md (each names its command; they sit between the FMU's
# section and the stress maps): ``sphrom bench --report`` carries them over from the existing document, in
# its order, so that regenerating the benchmarks never drops them.
CARRIED = ("## The full SPH step: numba against a hand-written C stencil",
           "## The training envelope of the frozen FMU",
           "## The packaged FMU against the full SPH, every scene",
           "## Linear models: time against error",
           "## A component at rest",
           "## Scale: the balanced model and its bounds to N = 10⁴",
           "## Fast end to end: before and after",
           "## Certified error bounds",        # sphrom bench error_bounds
           "## Certified error bounds: ports and coupled components",     # sphrom bench error_bounds_ports
           "## Certified error bounds of parametric FMUs",   # sphrom bench error_bounds --parametric
           "## Certified error bounds at large N",           # sphrom bench error_bounds --sizes
           "## User scenes at the first try",                # sphrom bench scenes
           "## Ports in a sampled master loop",              # sphrom bench port_loop
           "## Ports at their cost floor: the cost per communication step")   # sphrom bench port_cost


def report(results, image_dir, stress_image_dir=None, existing=None):
    """BENCHMARKS.md from :class:`BenchResults` (text ending in a newline).

    ``image_dir`` is the folder of the PNG files as seen from the report; ``stress_image_dir`` that of the
    heat maps (default ``image_dir``/stress); ``existing`` the document being replaced, whose
    :data:`CARRIED` sections are kept.
    """
    from .lib.sph_scaling import sph_step_section
    from .lib.stress_maps import stress_section
    r = results
    d = image_dir.rstrip("/") + "/" if image_dir else ""
    lines = intro_section(r.command, r.version, r.python, r.machine, r.wall, r.repeats)
    lines += headline_section(r.fmu)
    lines += savings_section(r.savings)
    for name in r.scene_names:
        lines += scene_section(name, [row for row in r.rows if row["scene"] == name], f"{d}{name}_time_error.png")
    lines += cost_n_section(r.scaling, r.sizes, f"{d}scaling_n.png")
    lines += cost_k_section(r.scaling_k, r.ks_scaling, f"{d}scaling_k.png")
    lines += skip_section(r.skips)
    lines += input_direction_section(r.directions, r.scene_names, r.input_tolerance)
    lines += sph_step_section(r.sph_steps, r.sph_sizes, r.repeats)
    lines += fmu_section(r.fmu)
    old = split_sections(existing or "")
    carried = {h: body for h, body in old.items() if h in CARRIED}
    for heading in [h for h in old if h in carried] + [h for h in carried if h not in old]:
        body = list(carried[heading])
        while body and not body[-1]:
            body.pop()
        lines += body + [""]
    if r.stress is not None:
        lines += stress_section(r.stress, r.stress_command, f"{d}stress" if stress_image_dir is None
                                else stress_image_dir, level=2)
    while lines and not lines[-1]:
        lines.pop()
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------
# the program: sphrom bench [SCENE ...], sphrom bench suite [SCENE ...]
# ---------------------------------------------------------------------------

DESCRIPTION = ("For each SCENE (default: the paper's acceleration scenes) time the full SPH and every reduced model "
               "(original, linearized, frozen for n_freeze in 1,2,5,10,20,50, exact), and the FMU when it can be "
               "built, in one run on one machine: medians of --repeats runs, speed-ups as ratios to the full SPH timed "
               "in the same run, offline and online time apart. Also the cost per step against N and the saving of "
               "the specialised right-hand sides. Writes CSV, PNG plots and a Markdown report.")


def add_arguments(p):
    """The program's options on the parser ``p`` (``sphrom bench``'s, ``sphrom bench suite``'s)."""
    p.add_argument("scenes", nargs="*", metavar="SCENE")
    p.add_argument("--repeats", type=int_in(1, MAX_REPEATS), default=5, help="timed runs per point (median; default 5)")
    p.add_argument("--modes", "--ks", dest="modes", type=int_list(lo=1), metavar="K,...",
                   help="comma-separated mode counts (default: the scene's acceleration-study k)")
    p.add_argument("--n-particles", "--sizes", dest="n_particles", type=int_list(lo=min_particles),
                   default=",".join(map(str, SIZES)), metavar="N,...",
                   help="particle counts of the cost-against-N table (default %(default)s)")
    p.add_argument("--scaling-modes", "--scaling-ks", dest="scaling_modes", type=int_list(lo=1),
                   default=",".join(map(str, KS_SCALING)), metavar="K,...",
                   help="mode counts of the cost-against-k table at N = 400 (default %(default)s)")
    p.add_argument("--sph-n-particles", "--sph-sizes", dest="sph_n_particles", type=int_list(lo=min_particles),
                   default=",".join(map(str, SPH_SIZES)), metavar="N,...",
                   help="particle counts of the full-SPH step table, as sphrom bench-sph (default %(default)s)")
    p.add_argument("--no-fmu", action="store_true", help="skip the FMU entries")
    p.add_argument("--no-stress", action="store_true", help="leave the stress maps out of the report")
    p.add_argument("--fmu-scene", default="tenmode", metavar="SCENE",
                   help="scene of the FMU end-to-end table (default tenmode, the headline's)")
    p.add_argument("--out", default="validation/benchmarks", metavar="DIR", help="folder for CSV and PNG files")
    p.add_argument("--replot", action="store_true",
                   help="only redraw the time-against-error plots from --out's bench.csv (no timing)")
    p.add_argument("--report", metavar="FILE.md", nargs="?", const="BENCHMARKS.md",
                   help="also write the Markdown report (default BENCHMARKS.md)")
    add_quiet(p)


def run(args):
    """Run the program with the parsed options ``args``; its exit status."""
    from ..runio import check_output_dir, check_output_path, output_dir
    from ..scene import load_scene

    out = Path(args.out)
    if args.replot:
        if not (out / "bench.csv").is_file():
            raise FieldError("replot", f"no {out / 'bench.csv'}: nothing was measured into {out} yet")
        replot(out)
        print(f"redrew {out}/*_time_error.png from {out / 'bench.csv'}")
        return 0
    scenes = [load_scene(s) for s in (args.scenes or DEFAULT_SCENES)]
    try:
        load_scene(args.fmu_scene)              # every option checked before the long benchmark starts
    except UserError as exc:
        raise FieldError("fmu_scene", str(exc)) from None
    if args.report:
        check_output_path(args.report, field="report")
    check_output_dir(out)
    with output_dir(out):
        r = run_benchmarks(scenes, out, ks=args.modes, repeats=args.repeats, sizes=args.n_particles,
                           ks_scaling=args.scaling_modes, sph_sizes=args.sph_n_particles, fmu=not args.no_fmu,
                           fmu_scene=args.fmu_scene, stress=bool(args.report) and not args.no_stress,
                           progress=not args.quiet)
        if args.report:
            path = Path(args.report)
            existing = path.read_text() if path.is_file() else None
            write_text(path, report(r, Path(os.path.relpath(out.resolve(), path.resolve().parent)).as_posix(),
                                    existing=existing))
    for name, by_k, paper in r.savings:
        print(f"{name}: frozen (n_freeze = 10) saves " + ", ".join(f"{100 * v:.0f} % (k = {k})" for k, v in
                                                                   by_k.items())
              + " of the full SPH time (paper up to " + ("—" if paper is None else f"{100 * paper:.0f}") + " %)")
    print(f"wrote {out}/bench.csv, scaling.csv, skip.csv and plots" +
          (f"; report {args.report}" if args.report else "") + f" ({r.wall:.0f} s)")
    return 0


def main(argv=None):
    """``sphrom bench suite [SCENE ...] [options]`` (``python -m sphrom.bench.suite``); its exit status."""
    return program_main("suite", DESCRIPTION, add_arguments, run, argv)


if __name__ == "__main__":
    raise SystemExit(main())
