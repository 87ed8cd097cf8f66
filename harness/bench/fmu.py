"""``sphrom bench fmu`` (alias ``sphrom bench fmu-speed``, also the command ``sphrom bench-fmu``): the FMU's speed.

(1) ns per internal step of the C model core at k = 12, n_freeze = 10 for several particle counts N (scenes
derived from SCENE), showing that the cost does not depend on N; (2) the end-to-end time of SCENE's FMU through
sphrom's FMU driver beside the Python full SPH of the same scene in the same run, as ratios, with the time split
into the fixed cost, the driver's per-doStep cost and the core's; (3) with a report, the same-language ratio (the C
frozen step against the C full-SPH step at N = 400) and BENCHMARKS.md's sections "Headline" and "The FMU"
replaced (the figures of the rest of ``sphrom bench`` do not depend on the FMU).  The measurements are the
library's (:mod:`sphrom.bench.lib.fmu`, which the whole report ``sphrom bench --report`` shares); medians of
``--repeats``.

Its two names keep the defaults and the files of what each was (:data:`NAMES`): ``fmu`` writes fmu_core.csv and
fmu_e2e.csv into validation/benchmarks and the two sections of BENCHMARKS.md; ``fmu-speed`` (the command
``sphrom bench-fmu``) prints the tables, and with ``--out DIR`` writes bench_fmu_core.csv, bench_fmu_e2e.csv and
bench_fmu.md.
"""

from __future__ import annotations

import platform
import time

from ..errors import FieldError, exact
from ..markdown import write_text
from ..options import MAX_REPEATS, add_quiet, add_scene, float_list, int_in, int_list, max_particles
from . import program_main
from .lib.document import update_report
from .lib.fmu_sections import fmu_section, fmu_tables, headline_section
from .lib.timing import cpu_model, load_average

# The measuring modules (numpy, numba, fmpy) are imported inside the functions: `sphrom --help` builds this
# program's options (the command sphrom bench-fmu), which must not load them (tests/test_cli_imports.py).

# name -> its defaults: where the CSV files go (None: only with --out), the report whose sections are replaced
# (None: only with --report), the CSV files' prefix, and whether the Markdown tables go beside them (bench_fmu.md)
NAMES = {"fmu": {"out": "validation/benchmarks", "report": "BENCHMARKS.md", "prefix": "fmu_", "tables": False},
         "fmu-speed": {"out": None, "report": None, "prefix": "bench_fmu_", "tables": True}}
HELP = "time the FMU: C core ns/step against N, end to end through fmpy vs full SPH"
DESCRIPTION = ("(1) ns per internal step of the C model core at k = 12, n_freeze = 10 for several particle counts N "
               "(scenes derived from SCENE), showing the cost does not depend on N; (2) the end-to-end time of "
               "SCENE's FMU through sphrom's FMU driver with 10 ms and 1 ms communication steps beside the Python "
               "full SPH of the same scene in the same run, as ratios, with the time split into the fixed cost, the "
               "driver's per-doStep cost and the core's; (3) with --report, the same-language ratio (the C frozen "
               "step against the C full SPH step) and the report's sections Headline and The FMU. Medians of "
               "--repeats.")


def _min_particles():
    """Enough particles for the benchmark's k modes: 4 k."""
    from .lib.fmu import BENCH_K
    return 4 * BENCH_K


def add_arguments(p, name="fmu"):
    """The program's options on the parser ``p``, with the defaults of ``name`` (a key of :data:`NAMES`)."""
    defaults = NAMES[name]
    add_scene(p, default="tenmode", option_alias=True)
    p.add_argument("--n-particles", "--sizes", dest="n_particles", metavar="N,...", default="100,400,1600",
                   type=int_list(lo=_min_particles, hi=max_particles),
                   help="particle counts for the core benchmark, enough for 12 modes (default %(default)s)")
    p.add_argument("--repeats", type=int_in(5, MAX_REPEATS), default=5, help="repeats per figure, >= 5 (median)")
    p.add_argument("--step", "--steps", dest="step", type=float_list(lo=0, lo_open=True), metavar="H,...",
                   default="0.01,0.001", help="communication steps [s] for the end-to-end runs (default %(default)s)")
    p.add_argument("--core-only", action="store_true", help="only the core benchmark (no report)")
    p.add_argument("--out", metavar="DIR", default=defaults["out"],
                   help=f"folder for {defaults['prefix']}core.csv, {defaults['prefix']}e2e.csv"
                        + (", bench_fmu.md" if defaults["tables"] else "") + " (default %(default)s)")
    p.add_argument("--report", metavar="FILE.md", default=defaults["report"],
                   help="replace the sections Headline and The FMU of this Markdown report (default %(default)s)")
    add_quiet(p)
    p.set_defaults(called_as=name)


def _print_tables(scene, core, e2e, repeats):
    """The console's account of the measurements: the core table, the end-to-end runs and the targets."""
    from ..rom.registry import get_model
    print(f"C core (libsphrom_core, no FMI), k = 12, n_freeze = 10, scenes like {scene.name} at several N; "
          f"median of {repeats}")
    print(f"{'N':>7} {'k_v':>4} {'k_rho':>5} {'ns/step':>9} {'min':>7} {'max':>7} {'CPU ns':>7}  "
          "(slopes M -> 2M steps)")
    for r in core:
        print(f"{r['n']:>7} {r['k_v']:>4} {r['k_rho']:>5} {r['ns_per_step']:>9.1f} {r['ns_min']:>7.1f} "
              f"{r['ns_max']:>7.1f} {r['ns_per_step_cpu']:>7.1f}")
    target = "meets" if max(r["ns_per_step"] for r in core) <= 150 else "misses"
    print(f"  target <= 150 ns/step: {target} it")
    if e2e is None:
        return
    print(f"\nend to end: {e2e['scene']} (N = {e2e['n']}, T = {e2e['T']:g} s, {e2e['internal_steps']} internal "
          f"steps of {e2e['dt']:g} s), fmpy {e2e['fmpy']}")
    sph_err = e2e["sph"]["probe_error_v_vs_exact"]
    print(f"  full SPH (run_sph, numba): {e2e['sph']['call_s']:.3f} s per run "
          f"({e2e['sph']['loop_s']:.3f} s in its time loop); probe v error against exact: "
          + ("—" if sph_err is None else f"{sph_err:.3e}"))
    for r in e2e["rows"]:
        err = r["probe_error_v_vs_sph"]
        print(f"  FMU {r['model']} (k_v = {r['k_v']}, k_rho = {r['k_rho']}), {r['step_s'] * 1e3:g} ms steps "
              f"({r['doSteps']} doSteps): {r['fmu_e2e_s']:.4f} s -> {r['speedup']:.1f}x faster than the full SPH "
              f"({r['speedup_vs_loop']:.1f}x vs its loop alone)"
              + ("" if err is None else f"; probe v error against the full SPH {err:.3e}"))
        if not get_model(r["model"]).linear:        # a time-stepped model: the core's internal steps
            print(f"    where the time goes (slopes between two step counts): fixed cost (extract, load, "
                  f"instantiate, free) {r['fixed_s']:.4f} s, {r['us_per_doStep_fmpy']:.1f} us per doStep through "
                  f"the driver, of which the core's internal steps {r['us_per_doStep_core']:.1f} us; a bare doStep "
                  f"call of one internal step {r['us_per_doStep_bare_call']:.1f} us")
    for model in dict.fromkeys(r["model"] for r in e2e["rows"]):
        first = next(r for r in e2e["rows"] if r["model"] == model)
        verdict = "meets" if first["speedup"] >= 50 else "misses"
        accuracy = ""
        if first["probe_error_v_vs_sph"] is not None and sph_err is not None:
            below = first["probe_error_v_vs_sph"] < sph_err
            accuracy = f", at a probe v error {'below' if below else 'above'} the SPH's"
        print(f"  target >= 50x at {first['step_s'] * 1e3:g} ms, FMU {model}: {verdict} it "
              f"({first['speedup']:.1f}x{accuracy})")


def run(args):
    """Run the program with the parsed options ``args`` (``args.called_as``: the name it was called by, a key of
    :data:`NAMES`); its exit status."""
    from ..fmu.run.cosim import MAX_COMM_STEPS
    from ..runio import check_output_dir, check_output_path, output_dir
    from ..scene import load_scene
    from .lib.fmu import fmu_measurements, write_fmu_csv

    defaults = NAMES[args.called_as]
    scene = load_scene(args.scene)
    if args.core_only and args.report:
        raise FieldError("core_only", f"the sections of the report {args.report} need the end-to-end runs")
    if not args.core_only:
        for h in args.step:             # each step runs the scene's horizon T through fmpy
            if h > scene.T or scene.T / h > MAX_COMM_STEPS:
                raise FieldError("step", f"{exact(h)} is out of range (allowed: T / 1e8 = "
                                         f"{scene.T / MAX_COMM_STEPS:g} s <= step <= T = {scene.T:g} s, at most 1e8 "
                                         "communication steps)")
    out = check_output_dir(args.out) if args.out else None
    if args.report:
        check_output_path(args.report, field="report")
    load_start = load_average()
    t0 = time.perf_counter()
    fmu = fmu_measurements(args.scene, repeats=args.repeats, sizes=args.n_particles, steps=args.step,
                           progress=not args.quiet, with_end_to_end=not args.core_only, with_same=bool(args.report))
    wall = time.perf_counter() - t0
    _print_tables(scene, fmu["core"], fmu["e2e"], args.repeats)
    if out is not None:
        with output_dir(out):
            written = write_fmu_csv(out, fmu["core"], fmu["e2e"], prefix=defaults["prefix"])
            if defaults["tables"]:
                written.append(out / "bench_fmu.md")
                write_text(written[-1], fmu_tables(fmu["core"], fmu["e2e"]))
        print("wrote " + ", ".join(str(p) for p in written))
    if args.report:
        command = (f"sphrom bench {args.called_as} {args.scene} --n-particles {','.join(map(str, args.n_particles))} "
                   f"--step {','.join(f'{h:g}' for h in args.step)} --repeats {args.repeats}"
                   + (f" --out {args.out}" if args.out else "") + f" --report {args.report}")
        note = (f"Re-measured alone by `{command}` on {cpu_model()}, Python {platform.python_version()}, "
                f"{wall:.0f} s wall, load average (1 / 5 / 15 min) {' / '.join(map(str, load_start or ()))} at the "
                f"start, {' / '.join(map(str, load_average() or ()))} at the end; medians of {args.repeats}), after "
                "the rest of this report.")
        section = fmu_section(fmu)
        section[1:1] = ["", note]
        path = update_report(args.report, {"## Headline": headline_section(fmu), "## The FMU": section})
        print(f"wrote the sections Headline and The FMU of {path}")
    return 0


def main(argv=None, name="fmu"):
    """``sphrom bench fmu [SCENE] [options]`` (``python -m sphrom.bench.fmu``), or under its alias ``name``
    (``fmu-speed``, with that name's defaults); its exit status."""
    return program_main(name, DESCRIPTION, lambda p: add_arguments(p, name), run, argv)


if __name__ == "__main__":
    raise SystemExit(main())
