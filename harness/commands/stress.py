"""``sphrom stress``: numerical-stability maps of every method."""

from ..options import add_quiet, float_list, int_list


def add_parser(sub):
    p = sub.add_parser("stress", help="stability maps: time step, amplitude, horizon, modes, random forces",
                       description="For each SCENE (default tenmode, damped_forced, heterogeneous): run every method "
                                   "over dt from 0.1x to 2x the explicit limit (and the paper's dt) against initial "
                                   "amplitudes x1..x1000, over horizons up to T = 1000, with k up to the number of "
                                   "snapshots, and under large random forces; record stable / growing / unphysical / "
                                   "blow-up, the time of blow-up and the energy drift. Writes a heat-map PNG per scene, "
                                   "CSV files and stress.md.")
    from ..bench.lib.stress_settings import AMPLITUDES, HORIZONS, MODE_COUNTS
    p.add_argument("scenes", nargs="*", metavar="SCENE")
    p.add_argument("--amplitudes", type=float_list(lo=0, lo_open=True, integral_as_int=True), metavar="A,...",
                   default=",".join(map(str, AMPLITUDES)), help="initial-amplitude factors (default %(default)s)")
    p.add_argument("--horizons", type=float_list(lo=0, lo_open=True), metavar="T,...",
                   default=",".join(f"{h:g}" for h in HORIZONS), help="horizons T [s] at the paper's dt "
                   "(default %(default)s)")
    p.add_argument("--modes", type=int_list(lo=1), metavar="K,...", default=",".join(map(str, MODE_COUNTS)),
                   help="mode counts of the k sweep (default %(default)s)")
    p.add_argument("--quick", action="store_true", help="a small sweep (a smoke run)")
    p.add_argument("--no-fmu", action="store_true", help="skip the FMU column")
    p.add_argument("--out", default="validation/stress", metavar="DIR")
    add_quiet(p)
    p.set_defaults(handler=run)


def run(args):

    from ..bench.lib.stress_maps import stress_report
    from ..bench.lib.stress_settings import DEFAULT_SCENES, DT_FACTORS, QUICK_DT_FACTORS
    from ..markdown import write_text
    from ..runio import check_output_dir, output_dir
    from ..scene import load_scene

    scenes = [load_scene(s) for s in (args.scenes or DEFAULT_SCENES)]
    amps, horizons, ks, factors = args.amplitudes, args.horizons, args.modes, DT_FACTORS
    if args.quick:
        amps, horizons, ks, factors = amps[:2], horizons[:1], ks[:2], QUICK_DT_FACTORS
    out = check_output_dir(args.out)
    with output_dir(out):
        text, wall = stress_report(scenes, amps, horizons, ks, factors, out, no_fmu=args.no_fmu, quick=args.quick,
                                   progress=not args.quiet)
        write_text(out / "stress.md", text)
    print(f"wrote {out}/stress.md, stress_*.csv and a heat map per scene ({wall:.0f} s)")
    return 0
