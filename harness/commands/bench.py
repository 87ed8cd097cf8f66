"""``sphrom bench``: run time against error for every method, cost scaling, skipped terms (BENCHMARKS.md)."""

from .options import int_at_least


def add_parser(sub):
    p = sub.add_parser("bench", help="run time against error of every method (writes BENCHMARKS.md with --report)",
                       description="For each SCENE (default: the paper's acceleration scenes) time the full SPH and "
                                   "every reduced model (original, linearized, frozen for n_freeze in 1,2,5,10,20,50, "
                                   "exact), and the FMU when it can be built, in one run on one machine: medians of "
                                   "--repeats runs, speed-ups as ratios to the full SPH timed in the same run, offline "
                                   "and online time apart. Also the cost per step against N and the saving of the "
                                   "specialised right-hand sides. Writes CSV, PNG plots and a Markdown report.")
    from ..bench.suite import KS_SCALING, SIZES, SPH_SIZES
    p.add_argument("scenes", nargs="*", metavar="SCENE")
    p.add_argument("--repeats", type=int_at_least(1), default=5, help="timed runs per point (median; default 5)")
    p.add_argument("--ks", help="comma-separated mode counts (default: the scene's acceleration-study k)")
    p.add_argument("--sizes", default=",".join(map(str, SIZES)), help="particle counts of the scaling table")
    p.add_argument("--scaling-ks", default=",".join(map(str, KS_SCALING)),
                   help="comma-separated mode counts of the cost-against-k table at N = 400")
    p.add_argument("--sph-sizes", default=",".join(map(str, SPH_SIZES)),
                   help="particle counts of the full-SPH step table (as sphrom bench-sph)")
    p.add_argument("--no-fmu", action="store_true", help="skip the FMU entries")
    p.add_argument("--no-stress", action="store_true", help="leave the stress maps out of the report")
    p.add_argument("--fmu-scene", default="tenmode", metavar="SCENE",
                   help="scene of the FMU end-to-end table (default tenmode, the headline's)")
    p.add_argument("--out", default="validation/benchmarks", metavar="DIR", help="folder for CSV and PNG files")
    p.add_argument("--replot", action="store_true",
                   help="only redraw the time-against-error plots from --out's bench.csv (no timing)")
    p.add_argument("--report", metavar="FILE.md", nargs="?", const="BENCHMARKS.md",
                   help="also write the Markdown report (default BENCHMARKS.md)")
    p.set_defaults(handler=run)


def run(args):
    import os
    from pathlib import Path

    from ..bench.report import report
    from ..bench.suite import DEFAULT_SCENES, replot, run_benchmarks
    from ..errors import UserError
    from ..report.markdown import write_text
    from ..scene import load_scene

    out = Path(args.out)
    if args.replot:
        if not (out / "bench.csv").is_file():
            raise UserError(f"--replot: no {out / 'bench.csv'} (run sphrom bench --out {out} first)")
        replot(out)
        print(f"redrew {out}/*_time_error.png from {out / 'bench.csv'}")
        return 0
    scenes = [load_scene(s) for s in (args.scenes or DEFAULT_SCENES)]
    try:
        ks = [int(k) for k in args.ks.split(",")] if args.ks else None
        sizes = [int(n) for n in args.sizes.split(",")]
        ks_scaling = [int(k) for k in args.scaling_ks.split(",")]
        sph_sizes = [int(n) for n in args.sph_sizes.split(",")]
    except ValueError:
        raise UserError("--ks/--sizes/--scaling-ks/--sph-sizes: comma-separated integers expected") from None
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UserError(f"--out: cannot create '{out}' ({exc})") from None
    r = run_benchmarks(scenes, out, ks=ks, repeats=args.repeats, sizes=sizes, ks_scaling=ks_scaling,
                       sph_sizes=sph_sizes, fmu=not args.no_fmu, fmu_scene=args.fmu_scene,
                       stress=bool(args.report) and not args.no_stress)
    if args.report:
        path = Path(args.report)
        write_text(path, report(r, Path(os.path.relpath(out.resolve(), path.resolve().parent)).as_posix()))
    for name, by_k, paper in r.savings:
        print(f"{name}: frozen (n_freeze = 10) saves " + ", ".join(f"{100 * v:.0f} % (k = {k})" for k, v in
                                                                   by_k.items())
              + " of the full SPH time (paper up to " + ("—" if paper is None else f"{100 * paper:.0f}") + " %)")
    print(f"wrote {out}/bench.csv, scaling.csv, skip.csv and plots" +
          (f"; report {args.report}" if args.report else "") + f" ({r.wall:.0f} s)")
    return 0
