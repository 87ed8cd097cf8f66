"""``sphrom bench``: every measurement program (``sphrom bench NAME``, ``--list``), and the whole report.

``sphrom bench NAME [options]`` runs the program NAME of :data:`sphrom.bench.PROGRAMS` with its own options;
``sphrom bench [SCENE ...] [options]`` (no program name first) is the program ``suite``: run time against error
of every method, cost scaling, skipped terms (BENCHMARKS.md with ``--report``).  The first word decides: a
program's name is a program (no built-in scene has one: tests/test_bench_programs.py), anything else a scene (a
scene file named like a program is given as a path, ./NAME.toml).
"""

from ..options import MAX_REPEATS, add_quiet, int_in, int_list, min_particles


def add_parser(sub):
    p = sub.add_parser("bench", help="the measurement programs (sphrom bench NAME, --list); without a NAME, run "
                                     "time against error of every method (BENCHMARKS.md with --report)",
                       usage="sphrom bench NAME [options] | sphrom bench --list | sphrom bench [SCENE ...] [options]",
                       description="sphrom bench NAME [options] runs the measurement program NAME (sphrom bench "
                                   "--list: one line each; sphrom bench NAME --help: its options). Without a program "
                                   "name first (the program suite): for each SCENE (default: the paper's "
                                   "acceleration scenes) time the full SPH and "
                                   "every reduced model (original, linearized, frozen for n_freeze in 1,2,5,10,20,50, "
                                   "exact), and the FMU when it can be built, in one run on one machine: medians of "
                                   "--repeats runs, speed-ups as ratios to the full SPH timed in the same run, offline "
                                   "and online time apart. Also the cost per step against N and the saving of the "
                                   "specialised right-hand sides. Writes CSV, PNG plots and a Markdown report.")
    from ..bench.suite import KS_SCALING, SIZES, SPH_SIZES
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
    p.add_argument("--list", action="store_true",
                   help="list the measurement programs (what each measures, how long it takes, what it writes)")
    add_quiet(p)
    p.set_defaults(handler=run)


def program_args(argv, build_parser):
    """``sphrom bench NAME ...`` with NAME a program of :data:`sphrom.bench.PROGRAMS` (module docstring): the
    arguments that run it (command ``bench``, its handler), else None (every other command line).
    ``build_parser``: sphrom's parser builder (:func:`sphrom.cli.build_parser`), for programs that are commands."""
    import argparse

    from ..bench import PROGRAMS, run_program
    if len(argv) < 2 or argv[0] != "bench" or argv[1] not in PROGRAMS:
        return None
    name, rest = argv[1], list(argv[2:])
    return argparse.Namespace(command="bench", handler=lambda args: run_program(name, rest, build_parser))


def run(args):
    import os
    from pathlib import Path

    from ..bench.lib.document import report
    from ..bench.suite import DEFAULT_SCENES, replot, run_benchmarks
    from ..errors import UserError
    from ..markdown import write_text
    from ..runio import check_output_dir, check_output_path, output_dir
    from ..scene import load_scene

    if args.list:
        from ..bench import list_lines
        print("\n".join(list_lines()))
        return 0
    out = Path(args.out)
    if args.replot:
        if not (out / "bench.csv").is_file():
            raise UserError(f"--replot: no {out / 'bench.csv'} (run sphrom bench --out {out} first)")
        replot(out)
        print(f"redrew {out}/*_time_error.png from {out / 'bench.csv'}")
        return 0
    scenes = [load_scene(s) for s in (args.scenes or DEFAULT_SCENES)]
    from ..errors import FieldError
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
